"""Work-precision: bias against the analytic layer versus wall time per path, per method.

For each crandall method and the two peers (NumPy and Numba Euler-Maruyama, bench/peers/), over
a ladder of steps dt, simulates the paper's scene (scaled units, tau0 = 5, outputs at tau = 1
and 5, observing velocity, displacement, distance and the stop) and records, for the paper's
four curves at tau = 1 and 5 (mean distance; variances of velocity, displacement, distance)
and for the stop quantities (E tau_s, Var U3(tau_s)):

- the bias simulated - analytic and its standard error (paths scaled so that every run costs
  about the same number of path-steps; a bias is "resolved" when it exceeds 3 standard errors,
  otherwise the point is an upper bound |bias| + 2 SE);
- the wall time per path on one thread (a separate timing run, all observables).

Then, for an error of 1e-3 in each curve at tau = 5, the time per path each family needs
(power-law fit |bias| = C dt^p through its resolved points; an unresolved point whose upper
bound is below 1e-3 certifies the cheapest such run) and the ratio best peer / best crandall.

Writes bench/out/work_precision.json and bench/out/work_precision.png; with --publish also
copies both to bench/results/ (the README quotes that copy through bench/report.py).

    .venv/bin/python bench/work_precision.py [--quick] [--publish]

Needs matplotlib and, for the Numba peer, numba (bench-only dependencies).
"""

from __future__ import annotations

import argparse
import json
import math
import os
import platform
import sys
import time
from pathlib import Path

import numpy as np

import crandall
from crandall import analytic
from crandall.paper import CURVES

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
from _publish import write  # noqa: E402
from peers import numpy_em  # noqa: E402

try:
    from peers import numba_em  # noqa: E402
except ImportError:  # pragma: no cover - optional
    numba_em = None

TAU0 = 5.0
TIMES = [1.0, 5.0]
TARGET = 1e-3
OBSERVE = ["velocity", "displacement", "distance", "stop"]

# name -> (quantity, statistic, time index or None for the stop)
OBSERVABLES = {
    **{f"{c.name}@{tau:g}": (c.quantity, c.statistic, i)
       for c in CURVES for i, tau in enumerate(TIMES)},
    "stop_time_mean": ("stop_time", "mean", None),
    "distance_at_stop_var": ("distance_at_stop", "var", None),
}
CURVES_AT_5 = [f"{c.name}@5" for c in CURVES]


def reference() -> dict:
    t = np.array(TIMES)
    ref = {}
    for c in CURVES:
        values = c.analytic(t, TAU0)
        for i, tau in enumerate(TIMES):
            ref[f"{c.name}@{tau:g}"] = float(values[i])
    ref["stop_time_mean"] = float(analytic.stop_time_mean(TAU0))
    ref["distance_at_stop_var"] = float(analytic.distance_at_stop_var(TAU0))
    return ref


def stats_from_result(r) -> dict:
    out = {}
    for name, (q, stat, i) in OBSERVABLES.items():
        if stat == "mean":
            v, se = r.mean(q), r.stderr(q)
        else:
            v, se = r.var(q), r.var_stderr(q)
        if i is not None:
            v, se = v[i], se[i]
        out[name] = (float(v), float(se))
    return out


def stats_from_samples(s: dict) -> dict:
    out = {}
    for name, (q, stat, i) in OBSERVABLES.items():
        x = s[q] if i is None else s[q][i]
        n = x.size
        if stat == "mean":
            out[name] = (float(x.mean()), float(x.std(ddof=1) / math.sqrt(n)))
        else:
            c = x - x.mean()
            m2 = float(np.mean(c * c))
            m4 = float(np.mean(c ** 4))
            out[name] = (float(c @ c / (n - 1)), math.sqrt(max(m4 - m2 * m2, 0.0) / n))
    return out


def crandall_runner(method: str):
    scene = crandall.Scene.scaled(tau0=TAU0, times=TIMES, observe=OBSERVE)

    def run(paths, dt, seed, threads):
        r = crandall.simulate(scene, paths=paths, seed=seed, dt=dt, method=method, threads=threads)
        return stats_from_result(r), r.steps_per_path

    return run


def peer_runner(module):
    def run(paths, dt, seed, threads):  # peers are single-threaded, as users write them
        return stats_from_samples(module.simulate(paths, dt, TIMES, TAU0, seed)), round(TAU0 / dt)

    return run


def families(quick: bool) -> dict:
    # (runner, dt ladder, path-steps per statistics run, threads for the statistics run, most
    # paths per run). crandall's own methods get a larger budget than the peers: they are
    # several times faster per path-step, and the variances' biases near 1e-3 are only resolved
    # with 10^7-10^8 paths (the standard error of a variance ~ Var sqrt(2 / paths)).
    budget = 3e7 if quick else 4e8
    big = 3e7 if quick else 3e9
    cap, big_cap = 2e7, (2e7 if quick else 2e8)
    coarse = [0.8, 0.4, 0.2, 0.1, 0.05]
    fams = {
        "crandall exact": (crandall_runner("exact"), coarse, big, 2, big_cap),
        "crandall richardson": (crandall_runner("richardson"), coarse, big, 2, big_cap),
        "crandall richardson2": (crandall_runner("richardson2"), coarse[:-1], big, 2, big_cap),
        "crandall refine": (crandall_runner("refine"), [0.8, 0.4, 0.2], budget / 4, 2, cap),
        "crandall euler": (crandall_runner("euler"), [0.1, 0.05, 0.02, 0.01], big / 2, 2, big_cap),
        "NumPy Euler-Maruyama": (peer_runner(numpy_em), [0.1, 0.05, 0.02, 0.01], budget / 4, 1,
                                 cap),
    }
    if numba_em is not None:
        numba_em.warm_up()
        fams["Numba Euler-Maruyama"] = (peer_runner(numba_em), [0.1, 0.05, 0.02, 0.01],
                                        budget / 2, 1, cap)
    if quick:
        fams = {k: (r, l[:3], b, t, c) for k, (r, l, b, t, c) in fams.items()}
    return fams


def time_per_path(run, dt, threads=1, target_seconds=0.5) -> float:
    """Wall time per path on one thread, all observables: repeat until target_seconds."""
    paths = 2000
    while True:
        t0 = time.perf_counter()
        run(paths, dt, 12345, threads)
        elapsed = time.perf_counter() - t0
        if elapsed >= target_seconds or paths >= 10**7:
            return elapsed / paths
        paths = int(paths * min(10.0, 1.5 * target_seconds / max(elapsed, 1e-4)))


def cost_at_target(points: list, target: float = TARGET):
    """Time per path to reach |bias| = target for one family and one observable, or None.

    Resolved points (|bias| > 3 SE) are fitted by |bias| = C dt^p (log-log least squares, at
    least two points); the time per path is fitted as a + b / dt over the ladder. An unresolved
    point whose upper bound |bias| + 2 SE is below the target certifies that run's time (the
    cheapest such run is taken when no fit gives a cheaper answer)."""
    dts = np.array([p["dt"] for p in points])
    tpp = np.array([p["time_per_path_s"] for p in points])
    a, b = np.polyfit(1.0 / dts, tpp, 1)[::-1] if len(points) > 1 else (0.0, tpp[0] * dts[0])
    certified = [p["time_per_path_s"] for p in points
                 if not p["resolved"] and abs(p["bias"]) + 2 * p["stderr"] <= target]
    certified += [p["time_per_path_s"] for p in points if p["resolved"] and abs(p["bias"]) <= target]
    res = [p for p in points if p["resolved"]]
    fit = None
    if len(res) >= 2:
        x = np.log([p["dt"] for p in res])
        y = np.log([abs(p["bias"]) for p in res])
        slope, icpt = np.polyfit(x, y, 1)
        if slope > 0.2:
            dt_star = math.exp((math.log(target) - icpt) / slope)
            fit = {"order": float(slope), "dt": dt_star, "time_per_path_s": float(a + b / dt_star)}
    options = certified + ([fit["time_per_path_s"]] if fit else [])
    if not options:
        return None
    how = "certified" if certified and min(certified) <= (fit or {"time_per_path_s": math.inf})[
        "time_per_path_s"] else "fit"
    return {"time_per_path_s": float(min(options)), "how": how, "fit": fit}


def plot(data: dict, path: Path) -> None:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    names = list(OBSERVABLES)
    fig, axes = plt.subplots(2, 5, figsize=(20, 8), constrained_layout=True)
    styles = {}
    markers = "osD^v<>p"
    for j, fam in enumerate(data["families"]):
        styles[fam] = markers[j % len(markers)]
    for ax, name in zip(axes.flat, names):
        for fam, fd in data["families"].items():
            pts = fd["points"]
            t = np.array([p["time_per_path_s"] for p in pts])
            e = np.array([p["observables"][name]["bias"] for p in pts])
            se = np.array([p["observables"][name]["stderr"] for p in pts])
            res = np.array([p["observables"][name]["resolved"] for p in pts])
            shown = np.where(res, np.abs(e), np.abs(e) + 2 * se)
            line, = ax.plot(t, shown, "-", lw=1, alpha=0.6, label=fam)
            ax.plot(t[res], shown[res], styles[fam], color=line.get_color())
            ax.plot(t[~res], shown[~res], styles[fam], color=line.get_color(), mfc="none")
        ax.axhline(TARGET, color="grey", ls=":", lw=1)
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_title(name.replace("@", " at tau="))
        ax.set_xlabel("wall time per path, 1 thread [s]")
        ax.set_ylabel("|bias| (hollow: bound |bias| + 2 SE)")
    axes.flat[0].legend(fontsize=7)
    fig.suptitle(f"Work-precision, tau0 = {TAU0:g} (scaled units); load {data['load']}")
    fig.savefig(path, dpi=90)
    plt.close(fig)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="small budget, 3 steps per ladder")
    ap.add_argument("--publish", action="store_true", help="copy JSON and PNG to bench/results/")
    args = ap.parse_args()
    started = time.perf_counter()
    load_before = os.getloadavg()
    ref = reference()
    data = {"script": "bench/work_precision.py", "command": "python bench/work_precision.py"
            + (" --quick" if args.quick else "") + (" --publish" if args.publish else ""),
            "crandall_version": crandall.__version__, "machine": platform.processor() or platform.machine(),
            "cpus": os.cpu_count(), "build": crandall._core.build_info(), "tau0": TAU0, "times": TIMES, "target_error": TARGET,
            "reference": ref, "families": {}}
    for fam, (run, ladder, budget, threads, most) in families(args.quick).items():
        points = []
        for dt in ladder:
            steps = math.ceil(TAU0 / dt)
            paths = int(max(20_000, min(most, budget / steps)))
            t0 = time.perf_counter()
            stats, steps_per_path = run(paths, dt, 1, threads)
            wall = time.perf_counter() - t0
            tpp = time_per_path(run, dt)
            obs = {}
            for name, (v, se) in stats.items():
                bias = v - ref[name]
                obs[name] = {"value": v, "bias": bias, "stderr": se, "resolved": abs(bias) > 3 * se}
            points.append({"dt": dt, "paths": paths, "steps_per_path": int(steps_per_path),
                           "stat_run_threads": threads, "stat_run_wall_s": wall,
                           "time_per_path_s": tpp, "observables": obs})
            print(f"{fam:24s} dt={dt:<6g} paths={paths:>9d} {tpp * 1e6:9.2f} us/path  "
                  + "  ".join(f"{n}:{o['bias']:+.1e}±{o['stderr']:.0e}" for n, o in obs.items()
                              if n in CURVES_AT_5), flush=True)
        data["families"][fam] = {"points": points}
        (HERE / "out").mkdir(exist_ok=True)
        (HERE / "out" / "work_precision.partial.json").write_text(json.dumps(data, indent=1))
    # Cost of an error of 1e-3 in each curve at tau = 5.
    ratios = {}
    for name in CURVES_AT_5:
        costs = {}
        for fam, fd in data["families"].items():
            pts = [{"dt": p["dt"], "time_per_path_s": p["time_per_path_s"], **p["observables"][name]}
                   for p in fd["points"]]
            costs[fam] = cost_at_target(pts)
        ours = {k: v for k, v in costs.items() if k.startswith("crandall") and v}
        peers = {k: v for k, v in costs.items() if not k.startswith("crandall") and v}
        best_ours = min(ours.items(), key=lambda kv: kv[1]["time_per_path_s"]) if ours else None
        best_peer = min(peers.items(), key=lambda kv: kv[1]["time_per_path_s"]) if peers else None
        ratios[name] = {
            "costs": costs,
            "best_crandall": best_ours[0] if best_ours else None,
            "best_peer": best_peer[0] if best_peer else None,
            "ratio_peer_over_crandall": (best_peer[1]["time_per_path_s"] / best_ours[1]["time_per_path_s"]
                                         if best_ours and best_peer else None),
        }
    data["at_target"] = ratios
    data["load"] = [round(x, 2) for x in load_before]
    data["load_after"] = [round(x, 2) for x in os.getloadavg()]
    data["total_seconds"] = time.perf_counter() - started
    write("work_precision", data, plot, publish=args.publish)
    for name, r in ratios.items():
        print(f"{name}: best crandall {r['best_crandall']}, best peer {r['best_peer']}, "
              f"ratio {r['ratio_peer_over_crandall']}")
    print(f"done in {data['total_seconds']:.0f} s; load {data['load']} -> {data['load_after']}")


if __name__ == "__main__":
    main()
