"""What a tail probability costs: crandall.tail at p = 1e-9 against plain Monte Carlo, and a
tail curve of an engineering scene.

Measured, one thread, in one run:

1. The paper's scene (scaled units, tau0 = 5, the default step 0.01): the stop time and the
   distance at the stop at levels where P is about 1e-9 (the stop time's level from the
   closed form; the distance's from a splitting run), by splitting (and the stop time also by
   importance sampling) to a 10 % relative error: wall time, achieved relative error, and the
   stop time's estimate against the closed form (z with the reported standard error).
2. Plain Monte Carlo of the same quantities (crandall.simulate, method exact, the same step):
   its measured time per path; its time to 10 % at p is 100 / p paths times that. Its
   path-steps per second (the fixed-step kernel's rate) against splitting's (the steps its
   particles take over the seconds of its run): ``rate_against_kernel``.
3. The residual displacement |U(t_s)| of the shipped scene crate (SI), from 1 down to 1e-9 in one
   splitting run, with its 95 % band, joined to plain Monte Carlo where that is informative;
   and its last level by importance sampling (the excursions' signs re-drawn) and by
   splitting of that level alone (the score normalised towards it), to the same relative
   error.

Writes bench/out/tails.json and bench/out/tails.png; --publish copies both to bench/results/.

    .venv/bin/python bench/tails.py [--quick] [--publish]
"""

from __future__ import annotations

import argparse
import math
import os
import sys
import time
import warnings
from pathlib import Path

import numpy as np
from scipy.optimize import brentq

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
from _publish import write  # noqa: E402

TAU0 = 5.0
#: The distance at the stop where P is about 1e-9 at the default step (from a splitting run
#: and its slope: 2.9e-9 at 47.5, 8.8e-9 at 44, so 1e-9 near 51).
DISTANCE_1E9 = 51.0


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="p = 1e-6 and 30 %% error: a smoke test")
    ap.add_argument("--publish", action="store_true")
    args = ap.parse_args()
    import crandall
    from crandall import analytic

    warnings.simplefilter("default")
    p_target = 1e-6 if args.quick else 1e-9
    rel = 0.3 if args.quick else 0.1
    scene = crandall.Scene.scaled(tau0=TAU0, times=[TAU0])
    stop_level = brentq(lambda t: math.log(analytic.stop_time_sf(t, TAU0)) - math.log(p_target),
                        TAU0, 60.0, xtol=1e-12)
    distance_level = DISTANCE_1E9 if not args.quick else 30.5
    runs = {}
    start = time.perf_counter()
    for name, quantity, level, method in (
            ("stop_time splitting", "stop_time", stop_level, "splitting"),
            ("stop_time importance", "stop_time", stop_level, "importance"),
            ("distance_at_stop splitting", "distance_at_stop", distance_level, "splitting")):
        t = time.perf_counter()
        r = crandall.tail(scene, quantity, [level], rel_error=rel, method=method, seed=20261125,
                          threads=1)
        entry = {"quantity": quantity, "method": method, "level": level,
                 "probability": float(r.probability[0]), "stderr": float(r.stderr[0]),
                 "rel_error": float(r.rel_error[0]), "seconds": time.perf_counter() - t,
                 "steps": r.steps, "samples": r.samples, "reliable": bool(r.reliable[0])}
        if quantity == "stop_time":
            exact = float(analytic.stop_time_sf(level, TAU0))
            entry.update(exact=exact, z=(entry["probability"] - exact) / entry["stderr"])
        if method == "importance":
            entry["proposal"] = r.diagnostics["proposal"]
            entry["pareto_shape"] = r.diagnostics["pareto_shape"][0]
        runs[name] = entry
        print(f"{name}: P = {entry['probability']:.4g} +- {entry['stderr']:.2g} "
              f"(rel. {entry['rel_error']:.3f}) in {entry['seconds']:.1f} s"
              + (f", exact {entry['exact']:.4g}, z = {entry['z']:.2f}" if "exact" in entry else ""),
              flush=True)
    # Plain Monte Carlo's cost per path on the same grid and thread count.
    mc_paths = 20_000 if args.quick else 200_000
    mc_scene = crandall.Scene.scaled(tau0=TAU0, times=[TAU0], observe=["distance", "stop"])
    t = time.perf_counter()
    crandall.simulate(mc_scene, paths=mc_paths, seed=1, method="exact", threads=1)
    per_path = (time.perf_counter() - t) / mc_paths
    # The fixed-step kernel's path-step rate on the grid splitting stores its paths on (the
    # same step; the coast after the excitation is closed-form in both): what the rate of
    # splitting's own path-steps (its particles' steps, clones from their branch point) is
    # compared with.
    from crandall.tail.problem import _Problem
    grid_steps = _Problem(scene, "stop_time", None, None).steps
    kernel_rate = grid_steps / per_path
    mc = {"paths": mc_paths, "seconds_per_path": per_path, "steps_per_path": grid_steps,
          "path_steps_per_second": kernel_rate}
    print(f"plain Monte Carlo: {kernel_rate / 1e6:.0f} M path-steps/s")
    for name, e in runs.items():
        if e["method"] == "splitting":
            e["path_steps_per_second"] = e["steps"] / e["seconds"]
            e["rate_against_kernel"] = e["path_steps_per_second"] / kernel_rate
            print(f"  {name}: {e['path_steps_per_second'] / 1e6:.1f} M path-steps/s, "
                  f"{e['rate_against_kernel']:.3f} of the kernel's")
        mc_seconds = 100.0 / e["probability"] * per_path
        e["plain_monte_carlo_seconds"] = mc_seconds
        e["speedup"] = mc_seconds / e["seconds"]
        print(f"  {name}: plain Monte Carlo would take {mc_seconds:.3g} s "
              f"({e['speedup']:.3g} times longer)")
    # The crate's residual displacement, 1 down to 1e-9 (or 1e-6 quick): one splitting run.
    crate = crandall.Scene.from_toml("crate")
    crate = crandall.Scene.from_dict({**crate.to_dict(), "observe": ["displacement", "distance", "stop", "residual"],
                                      "distributions": ["residual_displacement"]})
    t = time.perf_counter()
    reference = crandall.simulate(crate, paths=100_000, seed=3, method="exact", threads=1)
    top = 5.3 if not args.quick else 2.9  # about 1e-9 and 1e-6
    levels = np.linspace(0.02, top, 28)
    curve = crandall.tail(crate, "residual_displacement", levels, rel_error=rel, seed=4,
                          threads=1)
    lo, hi = curve.interval()
    grid = np.linspace(levels[0], levels[-1], 60)
    mc_p = [reference.exceedance("residual_displacement", float(x)).value for x in grid]
    crate_entry = {"levels": levels.tolist(), "probability": curve.probability.tolist(),
                   "stderr": curve.stderr.tolist(), "lower_95": lo.tolist(), "upper_95": hi.tolist(),
                   "seconds": time.perf_counter() - t, "mc_paths": 100_000, "mc_levels": grid.tolist(),
                   "mc_probability": mc_p, "units": "m"}
    print(f"crate residual displacement: P(> {levels[-1]:.2f} m) = {curve.probability[-1]:.3g} "
          f"(rel. {curve.rel_error[-1]:.3f}), {crate_entry['seconds']:.1f} s")
    t = time.perf_counter()
    m = crandall.tail(crate, "residual_displacement", [top], method="importance",
                      rel_error=rel, seed=1, threads=1)
    crate_entry["importance"] = {
        "level": top, "probability": float(m.probability[0]), "stderr": float(m.stderr[0]),
        "rel_error": float(m.rel_error[0]), "reliable": bool(m.reliable[0]),
        "pareto_shape": m.diagnostics["pareto_shape"][0], "proposal": m.diagnostics["proposal"],
        "seconds": time.perf_counter() - t,
        "z_against_splitting": (float(m.probability[0]) - float(curve.probability[-1]))
        / math.hypot(float(m.stderr[0]), float(curve.stderr[-1]))}
    print(f"  by importance sampling: {m.probability[0]:.3g} (rel. {m.rel_error[0]:.3f}, "
          f"reliable {bool(m.reliable[0])}), {crate_entry['importance']['seconds']:.1f} s")
    # The top level alone: splitting ranks by the score normalised towards it.
    t = time.perf_counter()
    one = crandall.tail(crate, "residual_displacement", [top], rel_error=rel, seed=5, threads=1)
    crate_entry["splitting_one_level"] = {
        "level": top, "probability": float(one.probability[0]), "stderr": float(one.stderr[0]),
        "rel_error": float(one.rel_error[0]), "samples": one.samples,
        "seconds": time.perf_counter() - t,
        "z_against_importance": (float(one.probability[0]) - float(m.probability[0]))
        / math.hypot(float(one.stderr[0]), float(m.stderr[0]))}
    print(f"  by splitting of that level alone: {one.probability[0]:.3g} (rel. "
          f"{one.rel_error[0]:.3f}), {crate_entry['splitting_one_level']['seconds']:.1f} s")
    out = {"script": "bench/tails.py",
           "command": "python bench/tails.py" + (" --quick" if args.quick else "")
           + (" --publish" if args.publish else ""),
           "crandall_version": crandall.__version__, "threads": 1, "tau0": TAU0,
           "target_probability": p_target, "target_rel_error": rel,
           "seconds": time.perf_counter() - start, "load": [round(x, 2) for x in os.getloadavg()],
           "runs": runs, "plain_monte_carlo": mc, "crate_residual": crate_entry}
    write("tails", out, plot, publish=args.publish)


def plot(data, path: Path) -> None:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (a, b) = plt.subplots(1, 2, figsize=(11, 4.2))
    names = list(data["runs"])
    secs = [data["runs"][n]["seconds"] for n in names]
    mc = [data["runs"][n]["plain_monte_carlo_seconds"] for n in names]
    x = np.arange(len(names))
    a.bar(x - 0.2, secs, 0.4, label="crandall.tail")
    a.bar(x + 0.2, mc, 0.4, label="plain Monte Carlo (100/p paths, measured s/path)")
    a.set_yscale("log")
    a.set_xticks(x, [n.replace(" ", "\n") for n in names], fontsize=8)
    a.set_ylabel("seconds, 1 thread (target: 10 % relative error)")
    a.set_title(f"P = {data['target_probability']:g}, paper's scene")
    a.legend(fontsize=8)
    c = data["crate_residual"]
    lv, p = np.array(c["levels"]), np.array(c["probability"])
    ok = p > 0
    b.fill_between(lv[ok], np.maximum(np.array(c["lower_95"])[ok], 1e-300),
                   np.array(c["upper_95"])[ok], alpha=0.3, label="95 % interval")
    b.plot(lv[ok], p[ok], "o-", ms=3, label="splitting")
    imp = c.get("importance")
    if imp is not None:
        b.errorbar([imp["level"]], [imp["probability"]], yerr=[1.96 * imp["stderr"]], fmt="s",
                   color="C3", ms=5, label="importance sampling (one level)")
    one = c.get("splitting_one_level")
    if one is not None:
        b.errorbar([one["level"] - 0.08], [one["probability"]], yerr=[1.96 * one["stderr"]],
                   fmt="D", color="C2", ms=5, label="splitting, that level alone")
    mp = np.array(c["mc_probability"])
    keep = mp >= 100.0 / c["mc_paths"]
    b.plot(np.array(c["mc_levels"])[keep], mp[keep], "k--",
           label=f"plain Monte Carlo ({c['mc_paths']:.0e} paths)")
    b.set_yscale("log")
    b.set_xlabel("residual displacement |U(t_s)| [m]")
    b.set_ylabel("P(|U(t_s)| > level)")
    b.set_title("100 kg crate, mu = 0.3, h = 1 m s^-3/2 for 2 s")
    b.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


if __name__ == "__main__":
    main()
