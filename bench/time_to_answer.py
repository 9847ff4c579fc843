"""Time to an answer: wall time to reach a total error EPS (bias and statistical error
together) for each statistic of the paper's scene, by three routes, in one run:

- "crandall error=EPS": ``crandall.simulate(scene, error=EPS, statistics=[stat])``, the
  multilevel run (docs/methods/adaptive.md), run for real;
- "crandall fixed step": today's fixed-step default (richardson on the default graded grid,
  ``simulate(scene, paths=N)``) with the paths N its statistical error needs
  (N = V / EPS^2, V the per-path variance of the statistic's estimator measured on a pilot;
  its discretisation bias is ignored, to its advantage);
- "Numba Euler-Maruyama" (bench/peers/numba_em.py, one thread as users write it) with the
  step and paths chosen from its measured bias (bench/results/bias.json, the "euler" rows: a
  power law c dt^p fitted through the resolved points of each statistic), choosing the step
  that minimises the cost under bias^2 + V/N <= EPS^2: the peer gets the benefit of the
  doubt.

The two fixed-step routes are timed on a run of TIMED_SECONDS and scaled linearly to the
paths they need (their time is linear in the paths); the multilevel route is run in full
whenever its predicted time is below --budget seconds, and predicted from its EPS^-2 law
otherwise. Every point records whether it was run or predicted.
Writes bench/out/time_to_answer.{json,png} (bench/results/ with --publish).

    .venv/bin/python bench/time_to_answer.py [--budget 120] [--threads 1] [--publish]
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
from _publish import write

try:
    from peers import numba_em
except ImportError:  # numba missing: the peer's column is left out
    numba_em = None

HERE = Path(__file__).resolve().parent
TAU0 = 5.0
EPS = (1e-2, 1e-3, 1e-4)
#: (label, quantity, stat, time or None, key in bias.json and its time index)
STATISTICS = [
    ("distance_mean@1", "distance", "mean", 1.0, ("distance_mean", 2)),
    ("distance_mean@5", "distance", "mean", 5.0, ("distance_mean", 3)),
    ("velocity_var@1", "velocity", "var", 1.0, ("velocity_var", 2)),
    ("velocity_var@5", "velocity", "var", 5.0, ("velocity_var", 3)),
    ("displacement_var@1", "displacement", "var", 1.0, ("displacement_var", 2)),
    ("displacement_var@5", "displacement", "var", 5.0, ("displacement_var", 3)),
    ("distance_var@1", "distance", "var", 1.0, ("distance_var", 2)),
    ("distance_var@5", "distance", "var", 5.0, ("distance_var", 3)),
    ("stop_time_mean", "stop_time", "mean", None, ("stop_time_mean", 0)),
    ("distance_at_stop_var", "distance_at_stop", "var", None, ("distance_at_stop_var", 0)),
]
TIMED_SECONDS = 1.0


def scene_for(quantity: str, when):
    if when is None:
        if quantity == "stop_time":
            return crandall.Scene.scaled(tau0=TAU0, times=[], observe=["stop"])
        # A stop value needs its quantity observed over time too (one output time).
        return crandall.Scene.scaled(tau0=TAU0, times=[TAU0],
                                     observe=["stop", quantity.replace("_at_stop", "")])
    return crandall.Scene.scaled(tau0=TAU0, times=[when], observe=[quantity])


def per_path_variance(result, quantity, stat):
    """V: paths x (standard error)^2 of the statistic's estimator on a fixed-step run."""
    if stat == "mean":
        se = result.stderr(quantity)
    else:
        se = result.var_stderr(quantity)
    return float(np.atleast_1d(se)[0]) ** 2 * result.paths


def fixed_step(quantity, stat, when, threads, seed=1):
    """Today's default: time per path and per-path variance of the estimator."""
    sc = scene_for(quantity, when)
    n = 20000
    while True:
        t = time.perf_counter()
        r = crandall.simulate(sc, paths=n, seed=seed, threads=threads)
        wall = time.perf_counter() - t
        if wall >= TIMED_SECONDS or n >= 1 << 24:
            break
        n *= 4
    return {"seconds_per_path": wall / n, "V": per_path_variance(r, quantity, stat),
            "steps_per_path": r.steps_per_path, "pilot_paths": n}


def euler_bias_law(key):
    """c, p of |bias| = c dt^p for the Euler peer, through the resolved points of bias.json."""
    data = json.loads((HERE / "results" / "bias.json").read_text())
    name, idx = key
    pts = []
    for run in data["runs"]:
        if run["method"] != "euler" or name not in run["quantities"]:
            continue
        b = run["quantities"][name]["bias"][idx]
        se = run["quantities"][name]["stderr"][idx]
        if abs(b) > 3 * se:
            pts.append((run["dt"], abs(b)))
    pts.sort()
    if len(pts) < 2:
        return None
    x = np.log([p[0] for p in pts])
    y = np.log([p[1] for p in pts])
    p, logc = np.polyfit(x, y, 1)
    return float(math.exp(logc)), float(p)


def euler_seconds_per_path_step():
    if numba_em is None:
        return None
    numba_em.warm_up()
    paths, dt = 20000, 0.01
    t = time.perf_counter()
    numba_em.simulate(paths, dt, [1.0, 5.0], TAU0, 0)
    return (time.perf_counter() - t) / (paths * round(TAU0 / dt))


def euler_cost(eps, law, V, rate):
    """Least peer time: the step dt with bias c dt^p < eps minimising N(dt) steps(dt)."""
    c, p = law
    best = None
    dt_max = (eps / c) ** (1.0 / p)
    for f in np.linspace(0.05, 0.995, 190):
        dt = f * dt_max
        bias = c * dt ** p
        n = V / (eps ** 2 - bias ** 2)
        seconds = n * (TAU0 / dt) * rate
        if best is None or seconds < best["seconds"]:
            best = {"seconds": seconds, "dt": dt, "paths": n, "bias": bias}
    return best


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--budget", type=float, default=120.0,
                    help="longest multilevel run to do for real (s); longer ones are predicted")
    ap.add_argument("--threads", type=int, default=1)
    ap.add_argument("--publish", action="store_true")
    ap.add_argument("--quick", action="store_true", help="EPS 1e-2 and 1e-3 only, budget 10 s")
    a = ap.parse_args()
    eps_list = EPS[:2] if a.quick else EPS
    budget = 10.0 if a.quick else a.budget
    rate = euler_seconds_per_path_step()
    out = {"script": "bench/time_to_answer.py",
           "command": " ".join(["bench/time_to_answer.py"] + sys.argv[1:]),
           "crandall": crandall.__version__, "build": crandall._core.build_info(),
           "machine": {"cpus": os.cpu_count(), "platform": platform.platform(),
                       "load_before": os.getloadavg()[0]},
           "threads": a.threads, "eps": list(eps_list), "budget_s": budget,
           "euler_seconds_per_path_step": rate, "statistics": {}}
    for label, quantity, stat, when, key in STATISTICS:
        fixed = fixed_step(quantity, stat, when, a.threads)
        law = euler_bias_law(key)
        rows = []
        last = None
        for eps in eps_list:
            row = {"eps": eps}
            predicted_mlmc = None if last is None else last * (last_eps / eps) ** 2
            if predicted_mlmc is None or predicted_mlmc <= budget:
                sc = scene_for(quantity, when)
                r = crandall.simulate(sc, error=eps, seed=7, threads=a.threads,
                                      statistics=[(quantity, stat)])
                err = float(np.atleast_1d(r.error(quantity, stat))[0])
                row["mlmc"] = {"seconds": r.cost["wall_time"], "run": True,
                               "path_steps": r.cost["path_steps"], "levels": len(r.cost["paths"]),
                               "paths": r.cost["paths"], "reported_error": err}
                last, last_eps = r.cost["wall_time"], eps
            else:
                row["mlmc"] = {"seconds": predicted_mlmc, "run": False}
            paths = fixed["V"] / eps ** 2
            row["fixed_step"] = {"seconds": paths * fixed["seconds_per_path"], "run": False,
                                 "paths": paths, "steps_per_path": fixed["steps_per_path"],
                                 "bias_ignored": True}
            if law is not None and rate is not None:
                e = euler_cost(eps, law, fixed["V"], rate)
                row["euler"] = {**e, "run": False}
            rows.append(row)
            print(f"{label:24s} eps {eps:.0e}: mlmc {row['mlmc']['seconds']:.3g} s"
                  f"{'' if row['mlmc']['run'] else ' (predicted)'}, fixed step "
                  f"{row['fixed_step']['seconds']:.3g} s, euler "
                  f"{row.get('euler', {}).get('seconds', math.nan):.3g} s", flush=True)
        slope = finest = None
        ran = [r for r in rows if r["mlmc"]["run"]]
        if len(ran) >= 2:
            x = np.log([r["eps"] for r in ran])
            y = np.log([r["mlmc"]["seconds"] for r in ran])
            slope = float(np.polyfit(x, y, 1)[0])
            # Between the two smallest EPS run: the asymptotic rate, without the fixed cost
            # of the pilot that dominates the largest EPS.
            finest = float((y[-1] - y[-2]) / (x[-1] - x[-2]))
        out["statistics"][label] = {"rows": rows, "fixed_step": fixed, "euler_bias_law": law,
                                    "mlmc_slope_measured": slope,
                                    "mlmc_slope_finest_two": finest}
    write("time_to_answer", out, plot, publish=a.publish)


def plot(data, path):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    stats = list(data["statistics"])
    cols = 5
    rows = math.ceil(len(stats) / cols)
    fig, axes = plt.subplots(rows, cols, figsize=(3.2 * cols, 3.0 * rows), squeeze=False)
    for ax, label in zip(axes.flat, stats):
        rs = data["statistics"][label]["rows"]
        eps = [r["eps"] for r in rs]
        for key, name, style in (("mlmc", "crandall error=EPS", "o-"),
                                 ("fixed_step", "crandall fixed step", "s--"),
                                 ("euler", "Numba Euler-Maruyama", "^:")):
            pts = [(r["eps"], r[key]["seconds"], r[key]["run"]) for r in rs if key in r]
            if not pts:
                continue
            line, = ax.loglog([p[0] for p in pts], [p[1] for p in pts], style, label=name,
                              mfc="none")
            ran = [p for p in pts if p[2]]
            if ran:
                ax.loglog([p[0] for p in ran], [p[1] for p in ran], style[0],
                          color=line.get_color())
        ax.set_title(label, fontsize=9)
        ax.invert_xaxis()
        ax.grid(True, which="both", alpha=0.3)
    for ax in axes.flat[len(stats):]:
        ax.axis("off")
    axes.flat[0].legend(fontsize=7)
    fig.supxlabel("requested error EPS (filled: run; open: predicted)")
    fig.supylabel("wall time (s)")
    fig.tight_layout()
    fig.savefig(path, dpi=100)


if __name__ == "__main__":
    main()
