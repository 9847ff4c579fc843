"""Measured bias of the simulated statistics against the analytic layer, per method and step.

For each method and internal step dt, simulates the paper's scene (scaled units, tau0 = 5)
and records, for the four curves of the paper (mean distance; variances of velocity,
displacement and distance) at tau in {0.1, 0.5, 1, 5} and for the stop quantities, the
difference simulated - analytic and its standard error. Writes bench/results/bias.json (the
tests quote its figures) and bench/results/bias.png.

    .venv/bin/python bench/bias.py [--paths N] [--quick]
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import time
from pathlib import Path

import numpy as np

import crandall
from crandall import analytic
from crandall.paper import CURVES

HERE = Path(__file__).resolve().parent
TAU0 = 5.0
TIMES = [0.1, 0.5, 1.0, 5.0]


def reference():
    t = np.array(TIMES)
    return {
        **{c.name: c.analytic(t, TAU0) for c in CURVES},
        "stop_time_mean": np.array([analytic.stop_time_mean(TAU0)]),
        "distance_at_stop_var": np.array([analytic.distance_at_stop_var(TAU0)]),
        "distance_at_stop_mean": np.array([TAU0 / 2]),
    }


def measure(result):
    return {
        **{c.name: c.simulated(result) for c in CURVES},
        "stop_time_mean": (np.array([result.mean("stop_time")]),
                           np.array([result.stderr("stop_time")])),
        "distance_at_stop_var": (np.array([result.var("distance_at_stop")]),
                                 np.array([result.var_stderr("distance_at_stop")])),
        "distance_at_stop_mean": (np.array([result.mean("distance_at_stop")]),
                                  np.array([result.stderr("distance_at_stop")])),
    }


def render_only() -> None:
    out = json.loads((HERE / "results" / "bias.json").read_text())
    (HERE / "results" / "bias.md").write_text(table(out))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--paths", type=int, default=4_000_000)
    ap.add_argument("--quick", action="store_true", help="fewer paths and steps (smoke run)")
    ap.add_argument("--methods", nargs="*", default=["exact", "euler"])
    ap.add_argument("--render", action="store_true", help="only rewrite bias.md from bias.json")
    args = ap.parse_args()
    if args.render:
        return render_only()
    paths = 100_000 if args.quick else args.paths
    ladder = [0.1, 0.05, 0.02, 0.01]
    scene = crandall.Scene.scaled(tau0=TAU0, times=TIMES)
    ref = reference()
    runs = []
    for method in args.methods:
        for dt in ladder:
            start = time.perf_counter()
            r = crandall.simulate(scene, paths=paths, seed=20261121, dt=dt, method=method)
            wall = time.perf_counter() - start
            entry = {"method": method, "dt": dt, "paths": paths, "wall_s": wall, "quantities": {}}
            for name, (sim, se) in measure(r).items():
                entry["quantities"][name] = {
                    "tau": TIMES if sim.size == len(TIMES) else ["stop"],
                    "bias": (sim - ref[name]).tolist(),
                    "stderr": se.tolist(),
                }
            runs.append(entry)
            d = entry["quantities"]["distance_mean"]
            print(f"{method:>8} dt={dt:<6} E U3 bias at tau={TIMES}: "
                  + ", ".join(f"{b:+.2e}±{s:.1e}" for b, s in zip(d["bias"], d["stderr"]))
                  + f"   ({wall:.1f} s)", flush=True)
    out = {
        "script": "bench/bias.py",
        "command": ".venv/bin/python bench/bias.py"
                   + (" --quick" if args.quick else f" --paths {paths}"),
        "crandall": crandall.__version__,
        "machine": {"cpus": os.cpu_count(), "platform": platform.platform(),
                    "load_before": os.getloadavg()[0]},
        "tau0": TAU0,
        "runs": runs,
    }
    (HERE / "results").mkdir(exist_ok=True)
    (HERE / "results" / "bias.json").write_text(json.dumps(out, indent=1))
    (HERE / "results" / "bias.md").write_text(table(out))
    plot(runs)


def table(out) -> str:
    """Markdown table of the bias of E U3 (mean distance) per method and dt, with stderr."""
    lines = [f"Bias of the mean scaled distance E U3(tau) against eq10r (tau0 = {out['tau0']:g}), "
             f"simulated - analytic ± standard error; `{out['command']}`:", "",
             "| method | dt | " + " | ".join(f"tau = {t:g}" for t in TIMES) + " | wall s |",
             "|---|---|" + "---|" * len(TIMES) + "---|"]
    for r in out["runs"]:
        q = r["quantities"]["distance_mean"]
        cells = " | ".join(f"{b:+.1e} ± {s:.0e}" for b, s in zip(q["bias"], q["stderr"]))
        lines.append(f"| {r['method']} | {r['dt']:g} | {cells} | {r['wall_s']:.1f} |")
    return "\n".join(lines) + "\n"


def plot(runs) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    names = ["distance_mean", "velocity_var", "displacement_var", "distance_var"]
    fig, axes = plt.subplots(1, 4, figsize=(16, 4), constrained_layout=True)
    for ax, name in zip(axes, names):
        for method in sorted({r["method"] for r in runs}):
            rs = [r for r in runs if r["method"] == method]
            dts = np.array([r["dt"] for r in rs])
            for i, tau in enumerate(TIMES):
                b = np.array([abs(r["quantities"][name]["bias"][i]) for r in rs])
                s = np.array([r["quantities"][name]["stderr"][i] for r in rs])
                ax.errorbar(dts, b, yerr=s, marker="o", capsize=2,
                            label=f"{method}, tau={tau:g}")
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel("dt (scaled)")
        ax.set_ylabel("|simulated - analytic|")
        ax.set_title(name)
    axes[0].legend(fontsize=7)
    fig.savefig(HERE / "results" / "bias.png", dpi=90)


if __name__ == "__main__":
    main()
