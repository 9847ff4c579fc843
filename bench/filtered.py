"""Filtered ground motion (Kanai-Tajimi): how far white noise overstates the friction work,
and what an accuracy costs, crandall against a fine-step Euler peer written the way users
write it (bench/peers/numba_kt.py; numba is a dependency of the benchmarks only).

The scene of issue 35: zeta = 0.6, mu g = 1 (g = 1, mu = 1), h = 1, t0 = 10 s, static =
kinetic friction, the shaking ending at t0; the body's time scale t* = 2 h^2 / (mu g)^2 = 2 s.

1. The ratio of the mean distance at the stop to the white-noise value h^2 t0 / (2 mu g) = 5
   (the energy law), over omega t* = 1 ... 64: crandall, --paths paths each, with its
   standard error and estimated bias. White noise overstates the friction work by the
   inverse of this ratio; it tends to 1 as omega grows.
2. Time to a relative error eps (1e-2, 1e-3) in the mean distance at the stop and in its
   variance, at omega t* = 1, 4, 16, one thread each, as ratios measured in one run:
   - crandall: a pilot run (--pilot paths) at each step of STEP_FACTORS times the default
     step and each event depth of DEPTHS (the bisections of a step where a stop or an onset
     may happen, ``simulate(event_depth=...)``; 8 is the default) gives the per-path spread,
     the estimated bias (``Result.bias``: its coupled grids each bisect to the same depth
     below their own step, so it sees the depth's and the step's error) and the time per path
     (the fastest of --repeats runs, alternating the pilots; the same seed gives the same
     numbers, only the time differs). Per (statistic, eps) the pilot chosen is the fastest of
     those whose own estimated bias is at most eps |value| / 2 (a longer step with one more
     bisection reaches the same finest substep with fewer skeleton steps), its time the paths
     needed for a standard error of eps |value| / 2 times its time per path. No outside
     reference enters the choice. Every pilot is also taken with the ground-motion control
     variates (controls_run: what a run to an accuracy applies on its base level), whose
     spread is measured on half the pilot's paths after a fit on the other half, at the
     plain pilot's time times the measured cost of forming them. The default step and
     depth's time and ratio (without controls) are kept beside it (the script says when even
     that bias is above eps |value| / 2);
   - Euler: its step bias from the same paths at dt and 2 dt (dt = 4, 2, 1 ms; their paired
     difference is c dt for a first-order bias), c fitted where resolved; the dt that brings
     it to eps |value| / 2, the paths for the standard error, and its measured time per path
     step.
   Both times are extrapolated from measured rates (a run of 1e-3 would take hours for the
   peer); the JSON holds every input, the pilots of every depth included.
3. With --direct, what a user runs is timed too: ``simulate(scene, error=EPS)`` (its own
   levels, event depth and control variates) for the pairs of DIRECT, EPS = eps |value| /
   sqrt 2 (the root-mean-square of the peer's two halves), against the same Euler time.

Writes bench/out/filtered.{json,png} (bench/results/ with --publish).

    .venv/bin/python bench/filtered.py [--paths 20000] [--pilot 20000] [--repeats 2] [--direct]
        [--publish]
"""

from __future__ import annotations

import argparse
import math
import platform
import sys
import time
import warnings
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
from _publish import write  # noqa: E402

import crandall  # noqa: E402
from crandall import _core, engine  # noqa: E402
from crandall.spec import RunSpec  # noqa: E402
from peers import numba_kt  # noqa: E402

ZETA, MU_G, H, T0 = 0.6, 1.0, 1.0, 10.0
T_STAR = 2 * H ** 2 / MU_G ** 2
WHITE = H ** 2 * T0 / (2 * MU_G)
RATIOS = (1.0, 2.0, 4.0, 8.0, 16.0, 32.0, 64.0)
COST_AT = (1.0, 4.0, 16.0)
EULER_DT = (4e-3, 2e-3, 1e-3)
EPS = (1e-2, 1e-3)
#: The event depths the time to eps chooses from (8: the default, kDefaultEventDepth).
DEPTHS = (8, 6, 5, 4, 3)
DEFAULT_DEPTH = 8
#: The steps it chooses from, as multiples of the default step (1: the default).
STEP_FACTORS = (1, 2)


def scene(wt: float) -> crandall.Scene:
    kt = crandall.KanaiTajimi(omega=wt / T_STAR, zeta=ZETA, h=H)
    return crandall.Scene(mu=MU_G, g=1.0, excitation=kt, t0=T0, times=[T0],
                          observe=["distance", "stop"])


def crandall_run(wt: float, paths: int, seed: int, depth: int = DEFAULT_DEPTH,
                 repeats: int = 1, factor: int = 1):
    """A run's statistics, bias estimates and time (the fastest of ``repeats`` runs, which
    give the same numbers), at ``factor`` times the default step. The default depth runs as
    ``event_depth=None``, the default step as ``dt=None``."""
    sc = scene(wt)
    dt = None if factor == 1 else factor * crandall.simulate(sc, paths=1, seed=seed).dt
    seconds = []
    for _ in range(repeats):
        start = time.perf_counter()
        r = crandall.simulate(sc, paths=paths, seed=seed, threads=1, dt=dt,
                              event_depth=None if depth == DEFAULT_DEPTH else depth)
        seconds.append(time.perf_counter() - start)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", crandall.StatisticsWarning)
        out = {"dt": r.dt, "step_factor": factor, "paths": paths, "seconds": min(seconds),
               "all_seconds": seconds, "event_depth": depth,
               "steps_per_path": int(r.steps_per_path)}
        for stat in ("mean", "var"):
            value = r.mean("distance_at_stop") if stat == "mean" else r.var("distance_at_stop")
            se = (r.stderr("distance_at_stop") if stat == "mean"
                  else r.var_stderr("distance_at_stop"))
            out[stat] = {"value": float(value), "stderr": float(se),
                         "bias": float(r.bias("distance_at_stop", stat)),
                         "bias_is_bound": bool(r.bias_is_bound("distance_at_stop", stat))}
    return out


def euler_run(wt: float, dt: float, paths: int, seed: int):
    """Euler at dt and 2 dt on the same noise: the paired difference of the two is its step
    bias's growth c dt (first order: bias(2 dt) - bias(dt) = c dt = bias(dt)), resolved with
    far fewer paths than a comparison with crandall's value would need."""
    start = time.perf_counter()
    fine, coarse = numba_kt.coupled(paths, dt, t0=T0, omega=wt / T_STAR, zeta=ZETA, h=H,
                                    mu_g=MU_G, seed=seed)
    seconds = time.perf_counter() - start
    n = fine.size
    out = {"dt": dt, "paths": paths, "seconds": seconds,
           "path_steps": paths * 1.5 * T0 / dt}  # dt and 2 dt (the slide to rest adds a few)
    for stat in ("mean", "var"):
        if stat == "mean":
            phi = coarse - fine
            value, spread = fine.mean(), fine.std(ddof=1)
        else:
            a, b = coarse - coarse.mean(), fine - fine.mean()
            phi = a * a - b * b
            value = fine.var(ddof=1)
            m2, m4 = np.mean(b * b), np.mean(b ** 4)
            spread = math.sqrt(max(m4 - m2 * m2, 0.0))
        out[stat] = {"value": float(value), "spread": float(spread),
                     "difference": float(phi.mean()),
                     "stderr": float(phi.std(ddof=1) / math.sqrt(n))}
    return out


def controls_run(wt: float, paths: int, seed: int, depth: int, factor: int, plain,
                 repeats: int = 1):
    """The same pilot's paths with the ground-motion control variates (docs/filtered.md,
    "Control variates"; what a run to an accuracy applies on its base level): the per-path
    spread of S and of (S - mean S)^2 after subtracting the controls' multiples, the
    coefficients fitted by least squares on the first half of the paths and the spread
    measured on the second (so no fit to the same paths shrinks it). Its time is the plain
    pilot's times the ratio of ``_core.run_samples``' time with the controls to without (the
    fastest of ``repeats`` each, alternated): the cost of forming them, on top of the plain
    run's whole cost (its bias estimate included). The bias is the plain pilot's (the controls
    leave every path's value as it is)."""
    sc = scene(wt)
    spec = RunSpec.create(sc, paths=paths, seed=seed, dt=plain["dt"] if factor != 1 else None,
                          event_depth=None if depth == DEFAULT_DEPTH else depth)
    plan = _core.Plan(engine.plan_options(spec))
    with_ctl, without = [], []
    for _ in range(repeats):
        start = time.perf_counter()
        values, ctl = _core.run_samples(plan, 0, paths, 1, True)
        with_ctl.append(time.perf_counter() - start)
        start = time.perf_counter()
        _core.run_samples(plan, 0, paths, 1, False)
        without.append(time.perf_counter() - start)
    s = values[:, -1, 0, 2]  # the stop's slot: (time, U, S)
    x = np.column_stack([np.ones(paths), ctl[:, -1, :]])
    half = paths // 2
    factor_time = min(with_ctl) / min(without)
    out = {"dt": plain["dt"], "step_factor": factor, "paths": paths, "event_depth": depth,
           "controls": True, "seconds": plain["seconds"] * factor_time,
           "controls_time_factor": factor_time, "run_samples_seconds": [with_ctl, without]}
    for stat in ("mean", "var"):
        y = s if stat == "mean" else (s - s.mean()) ** 2
        beta, *_ = np.linalg.lstsq(x[:half], y[:half], rcond=None)
        rest = y[half:] - x[half:] @ beta
        spread = float(rest.std(ddof=1))
        out[stat] = {"value": plain[stat]["value"], "stderr": spread / math.sqrt(paths),
                     "explained": float(1.0 - rest.var() / y[half:].var()),
                     "bias": plain[stat]["bias"], "bias_is_bound": plain[stat]["bias_is_bound"]}
    return out


PLAIN_PILOTS = [(f, d) for f in STEP_FACTORS for d in DEPTHS]
#: Every pilot without and with the control variates.
PILOTS = [(f, d, c) for c in (False, True) for f, d in PLAIN_PILOTS]
DEFAULT_PILOT = (1, DEFAULT_DEPTH, False)


def pilots(wt: float, paths: int, seed: int, repeats: int):
    """One pilot per (step factor, depth) of PILOTS (the same seed), each timed as the
    fastest of ``repeats`` runs taken in turn over the pilots (so the machine's load falls
    alike on them); the statistics and bias estimates are those of one run."""
    runs = {p + (False,): crandall_run(wt, paths, seed, p[1], factor=p[0])
            for p in PLAIN_PILOTS}
    for _ in range(repeats - 1):
        for p in PLAIN_PILOTS:
            again = crandall_run(wt, paths, seed, p[1], factor=p[0])
            run = runs[p + (False,)]
            run["all_seconds"] += again["all_seconds"]
            run["seconds"] = min(run["all_seconds"])
    for f, d in PLAIN_PILOTS:
        runs[(f, d, True)] = controls_run(wt, paths, seed, d, f, runs[(f, d, False)], repeats)
    return runs


def crandall_time(pilot, stat: str, half: float):
    """Paths and seconds to a standard error of ``half`` at a pilot's spread and rate."""
    ref = pilot[stat]
    spread = ref["stderr"] * math.sqrt(pilot["paths"])  # NaN: too few carrying paths
    paths = math.ceil((spread / half) ** 2) if math.isfinite(spread) else math.nan
    return {"event_depth": pilot["event_depth"], "dt": pilot["dt"],
            "step_factor": pilot["step_factor"], "controls": pilot.get("controls", False),
            "controls_time_factor": pilot.get("controls_time_factor"),
            "paths": paths,
            "seconds": paths * pilot["seconds"] / pilot["paths"], "bias": ref["bias"],
            "bias_is_bound": ref["bias_is_bound"], "bias_within": ref["bias"] <= half}


def cost(wt, runs, euler_runs):
    """Per (statistic, eps): crandall at the fastest pilot whose own estimated bias is
    within eps |value| / 2 (the default step and depth's numbers beside it), against Euler."""
    rows = []
    rate = sum(e["seconds"] for e in euler_runs) / sum(e["path_steps"] for e in euler_runs)
    default = runs[DEFAULT_PILOT]
    for stat in ("mean", "var"):
        value = abs(default[stat]["value"])
        points = [{"dt": e["dt"], "bias": e[stat]["difference"], "stderr": e[stat]["stderr"],
                   "resolved": abs(e[stat]["difference"]) > 2 * e[stat]["stderr"]}
                  for e in euler_runs]
        resolved = [p for p in points if p["resolved"]]
        c = (sum(p["bias"] * p["dt"] for p in resolved) / sum(p["dt"] ** 2 for p in resolved)
             if resolved else math.nan)
        e_spread = euler_runs[-1][stat]["spread"]
        for eps in EPS:
            half = eps * value / 2
            each = [crandall_time(runs[p], stat, half) for p in PILOTS]
            within = [x for x in each if x["bias_within"] and math.isfinite(x["seconds"])]
            # The fastest within, by the fastest of each pilot's alternated runs (a step and
            # a depth trade against each other, so no order of the pilots is known to be
            # that of their cost). None within: the default, flagged
            # (crandall_bias_within False).
            chosen = min(within, key=lambda x: x["seconds"]) if within else each[0]
            base = each[0]
            dt_e = min(half / abs(c), EULER_DT[0]) if resolved else math.nan
            n_e = math.ceil((e_spread / half) ** 2)
            t_e = n_e * (T0 / dt_e) * rate if resolved else math.nan
            rows.append({"omega_t_star": wt, "stat": stat, "eps": eps,
                         "value": default[stat]["value"], "crandall_dt": default["dt"],
                         "crandall_depth": chosen["event_depth"],
                         "crandall_chosen_dt": chosen["dt"],
                         "crandall_step_factor": chosen["step_factor"],
                         "crandall_controls": chosen["controls"],
                         "crandall_paths": chosen["paths"],
                         "crandall_seconds": chosen["seconds"],
                         "crandall_bias": chosen["bias"],
                         "crandall_bias_within": chosen["bias_within"],
                         "default_depth": {"event_depth": DEFAULT_DEPTH,
                                           "crandall_paths": base["paths"],
                                           "crandall_seconds": base["seconds"],
                                           "crandall_bias": base["bias"],
                                           "crandall_bias_within": base["bias_within"],
                                           "ratio": t_e / base["seconds"] if resolved
                                           else math.nan},
                         "depths": each,
                         "euler_bias_per_dt": c, "euler_dt": dt_e, "euler_paths": n_e,
                         "euler_seconds": t_e, "euler_seconds_per_step": rate,
                         "ratio": t_e / chosen["seconds"] if resolved else math.nan,
                         "euler_points": points})
    return rows


#: The runs to an accuracy timed directly (--direct): (statistic, eps) pairs (the variance to
#: 1e-3 takes about 20 minutes at omega t* = 1, a few elsewhere).
DIRECT = (("mean", 1e-2), ("mean", 1e-3), ("var", 1e-2), ("var", 1e-3))


def direct_run(wt: float, stat: str, eps: float, value: float, seed: int):
    """What a user runs for eps: ``simulate(scene, error=EPS)`` with EPS = eps |value| /
    sqrt 2, the root-mean-square error of a bias and a standard error of eps |value| / 2 each
    (the peer's criterion), one thread, its control variates and levels as it chooses them."""
    target = eps * abs(value) / math.sqrt(2.0)
    start = time.perf_counter()
    r = crandall.simulate(scene(wt), error=target, seed=seed, threads=1,
                          statistics=[f"distance_at_stop:{stat}"])
    seconds = time.perf_counter() - start
    got = r.mean("distance_at_stop") if stat == "mean" else r.var("distance_at_stop")
    return {"stat": stat, "eps": eps, "error_target": target, "seconds": seconds,
            "value": float(got), "error": float(r.error("distance_at_stop", stat)),
            "levels": r.levels}


def plot(data, path):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (a, b) = plt.subplots(1, 2, figsize=(11, 4.2))
    wt = [r["omega_t_star"] for r in data["ratio"]]
    m = [r["ratio"] for r in data["ratio"]]
    e = [1.96 * r["error"] for r in data["ratio"]]
    a.errorbar(wt, m, yerr=e, fmt="o-", capsize=3, label="Kanai-Tajimi (crandall)")
    a.axhline(1.0, color="k", lw=0.8, ls="--", label="white noise (energy law)")
    a.set_xscale("log")
    a.set_xlabel("omega t*  (t* = 2 h^2 / (mu g)^2)")
    a.set_ylabel("E S(t_s) / (h^2 t0 / (2 mu g))")
    a.set_title(f"zeta = {ZETA}, t0 = {T0:g} s = {T0 / T_STAR:g} t*")
    a.legend()
    rows = data["cost"]
    labels, ratios, defaults = [], [], []
    for r in rows:
        labels.append(f"{r['stat']} eps={r['eps']:g}\nwt*={r['omega_t_star']:g} "
                      f"d={r.get('crandall_depth', DEFAULT_DEPTH)} "
                      f"dt x{r.get('crandall_step_factor', 1)}"
                      f"{' cv' if r.get('crandall_controls') else ''}")
        ratios.append(r["ratio"])
        defaults.append(r.get("default_depth", {}).get("ratio", r["ratio"]))
    x = np.arange(len(rows))
    direct = [r.get("direct", {}).get("ratio", np.nan) for r in rows]
    b.bar(x - 0.27, defaults, width=0.27, label=f"default step, event depth {DEFAULT_DEPTH}")
    b.bar(x, ratios, width=0.27, label="chosen step, depth (d) and controls (cv)")
    b.bar(x + 0.27, direct, width=0.27, label="simulate(error=) itself (--direct)")
    b.legend(fontsize=7)
    b.set_yscale("log")
    b.set_xticks(x)
    b.set_xticklabels(labels, fontsize=6, rotation=90)
    b.set_ylabel("Euler time / crandall time (one thread)")
    b.axhline(10.0, color="r", lw=0.8, ls="--")
    fig.tight_layout()
    fig.savefig(path, dpi=110)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--paths", type=int, default=20000)
    ap.add_argument("--pilot", type=int, default=20000)
    ap.add_argument("--euler-paths", type=int, default=20000)
    ap.add_argument("--repeats", type=int, default=2,
                    help="timed runs per pilot depth (the fastest counts)")
    ap.add_argument("--direct", action="store_true",
                    help="also time simulate(error=...) itself for DIRECT (about half an hour)")
    ap.add_argument("--publish", action="store_true")
    args = ap.parse_args()
    numba_kt.warm_up()
    ratio = []
    for i, wt in enumerate(RATIOS):
        r = crandall_run(wt, args.paths, 100 + i)
        ratio.append({"omega_t_star": wt, "ratio": r["mean"]["value"] / WHITE,
                      "error": math.hypot(r["mean"]["stderr"], r["mean"]["bias"]) / WHITE,
                      "run": r})
        print(f"omega t* = {wt:5g}: E S / white = {ratio[-1]['ratio']:.4f} "
              f"+- {r['mean']['stderr'] / WHITE:.4f} (bias {r['mean']['bias'] / WHITE:.1e}), "
              f"{r['seconds']:.1f} s", flush=True)
    rows = []
    for i, wt in enumerate(COST_AT):
        runs = pilots(wt, args.pilot, 200 + i, args.repeats)
        for (f, d, c), run in runs.items():
            print(f"omega t* = {wt:4g} dt {run['dt']:.3g} depth {d}"
                  f"{' controls' if c else ''}: "
                  f"{run['seconds'] / run['paths'] * 1e6:.1f} us "
                  f"per path, mean {run['mean']['value']:.5f} (bias {run['mean']['bias']:.2e}), "
                  f"var {run['var']['value']:.4f} (bias {run['var']['bias']:.2e})", flush=True)
        euler = [euler_run(wt, dt, args.euler_paths, 300 + 10 * i + j)
                 for j, dt in enumerate(EULER_DT)]
        for row in cost(wt, runs, euler):
            if args.direct and (row["stat"], row["eps"]) in DIRECT:
                d = direct_run(wt, row["stat"], row["eps"], row["value"], 400 + i)
                d["ratio"] = row["euler_seconds"] / d["seconds"]
                row["direct"] = d
                print(f"omega t* = {wt:4g} {row['stat']:4s} eps {row['eps']:g}: "
                      f"simulate(error={d['error_target']:.3g}) {d['seconds']:.3g} s "
                      f"(value {d['value']:.5g} +- {d['error']:.2g}): ratio {d['ratio']:.3g}",
                      flush=True)
            rows.append(row)
            base = row["default_depth"]
            print(f"omega t* = {wt:4g} {row['stat']:4s} eps {row['eps']:g}: crandall "
                  f"{row['crandall_seconds']:.3g} s at dt {row['crandall_chosen_dt']:.3g}, "
                  f"depth {row['crandall_depth']}"
                  f"{', controls' if row['crandall_controls'] else ''} "
                  f"({row['crandall_paths']} paths"
                  f"{'' if row['crandall_bias_within'] else ', bias above eps/2'}; depth "
                  f"{DEFAULT_DEPTH} {base['crandall_seconds']:.3g} s), Euler "
                  f"{row['euler_seconds']:.3g} s (dt {row['euler_dt']:.2g}, "
                  f"{row['euler_paths']} paths): ratio {row['ratio']:.3g} (depth "
                  f"{DEFAULT_DEPTH}: {base['ratio']:.3g})", flush=True)
    data = {"machine": platform.machine(), "python": platform.python_version(),
            "crandall": crandall.__version__, "zeta": ZETA, "mu_g": MU_G, "h": H, "t0": T0,
            "t_star": T_STAR, "white": WHITE, "depths": list(DEPTHS),
            "step_factors": list(STEP_FACTORS),
            "command": " ".join(["bench/filtered.py"] + sys.argv[1:]),
            "ratio": ratio, "cost": rows}
    print(write("filtered", data, plot, publish=args.publish))


if __name__ == "__main__":
    main()
