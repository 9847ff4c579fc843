"""Calibration of the error bars of runs to a requested accuracy (``simulate(error=EPS)``).

Over many independent seeds, counts how often the analytic value (``crandall.analytic``) lies
in the reported 95 % interval (estimate +- 1.96 x ``Result.error``) for the statistics of the
paper's scene (scaled units, tau0 = 5): the mean distance and the variances of velocity,
displacement and distance at tau = 1 and 5, and the stop time's mean and variance, the
distance at the stop's mean and variance and the displacement at the stop's variance.
Target: 93-97 % for each. Also records each run's cost and the reported errors against the
target. Writes bench/out/calibration.{json,png} (bench/results/ with --publish).

    .venv/bin/python bench/calibration.py [--seeds 200] [--error 1e-2] [--publish]
"""

from __future__ import annotations

import argparse
import math
import sys
import time

import numpy as np

import crandall
from crandall import analytic
from _publish import write

TAU0 = 5.0
TIMES = (1.0, 5.0)


def references():
    """(quantity, stat, time index or None) -> analytic value."""
    out = {}
    for i, t in enumerate(TIMES):
        out[("distance", "mean", i)] = float(analytic.distance_mean(t, TAU0))
        out[("velocity", "var", i)] = float(analytic.velocity_var(t, TAU0))
        out[("displacement", "var", i)] = float(analytic.displacement_var(t, TAU0))
        out[("distance", "var", i)] = float(analytic.distance_var(t, TAU0))
    out[("stop_time", "mean", None)] = float(analytic.stop_time_mean(TAU0))
    out[("stop_time", "var", None)] = float(analytic.stop_time_var(TAU0))
    out[("distance_at_stop", "mean", None)] = float(analytic.distance_at_stop_mean(TAU0))
    out[("distance_at_stop", "var", None)] = float(analytic.distance_at_stop_var(TAU0))
    out[("displacement_at_stop", "var", None)] = float(analytic.displacement_at_stop_var(TAU0))
    return out


def key_name(key) -> str:
    name, stat, i = key
    return f"{name}_{stat}" + ("" if i is None else f"@{TIMES[i]:g}")


def run(seeds: int, eps: float, first_seed: int = 1000, threads: int = 1):
    scene = crandall.Scene.scaled(tau0=TAU0, times=list(TIMES),
                                  observe=["velocity", "displacement", "distance", "stop"])
    refs = references()
    rows = {key_name(k): {"inside": 0, "z": [], "error": []} for k in refs}
    costs = []
    for s in range(first_seed, first_seed + seeds):
        r = crandall.simulate(scene, error=eps, seed=s, threads=threads)
        costs.append(r.cost)
        for key, ref in refs.items():
            name, stat, i = key
            value = r.mean(name) if stat == "mean" else r.var(name)
            err = r.error(name, stat)
            if i is not None:
                value, err = value[i], err[i]
            row = rows[key_name(key)]
            # An estimator without variance or bias (the mean distance at the stop, through the
            # Ito identity) reports error 0: it must then equal the analytic value to rounding.
            half = max(1.959963984540054 * err, 4e-16 * abs(ref))
            row["inside"] += int(abs(value - ref) <= half)
            row["z"].append((value - ref) / err if err > 0 else 0.0)
            row["error"].append(float(err))
    for row in rows.values():
        row["coverage"] = row["inside"] / seeds
        row["max_error"] = max(row["error"])
        row["rms_z"] = float(np.sqrt(np.mean(np.square(row["z"]))))
    return {"seeds": seeds, "error": eps, "first_seed": first_seed, "statistics": rows,
            "wall_time_mean": float(np.mean([c["wall_time"] for c in costs])),
            "path_steps_mean": float(np.mean([c["path_steps"] for c in costs])),
            "binomial_sd_of_coverage": math.sqrt(0.95 * 0.05 / seeds)}


def plot(data, path):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    names = list(data["statistics"])
    cov = [data["statistics"][n]["coverage"] for n in names]
    fig, ax = plt.subplots(figsize=(7, 4))
    ax.barh(names, cov)
    ax.axvspan(0.93, 0.97, color="g", alpha=0.2, label="target 93-97 %")
    ax.set_xlim(0.8, 1.0)
    ax.set_xlabel(f"coverage of the 95 % interval, {data['seeds']} seeds, error = {data['error']:g}")
    ax.legend(loc="lower left")
    fig.tight_layout()
    fig.savefig(path, dpi=110)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=200)
    ap.add_argument("--error", type=float, default=1e-2)
    ap.add_argument("--threads", type=int, default=1)
    ap.add_argument("--publish", action="store_true")
    a = ap.parse_args()
    t = time.perf_counter()
    data = run(a.seeds, a.error, threads=a.threads)
    data["wall_time_total"] = time.perf_counter() - t
    data["command"] = " ".join(["bench/calibration.py"] + sys.argv[1:])
    data["crandall"] = crandall.__version__
    for n, row in data["statistics"].items():
        print(f"{n:28s} coverage {row['coverage']:.3f}  rms z {row['rms_z']:.2f}  "
              f"max error {row['max_error']:.2g}")
    for row in data["statistics"].values():
        del row["z"], row["error"]
    write("calibration", data, plot, publish=a.publish)


if __name__ == "__main__":
    main()
