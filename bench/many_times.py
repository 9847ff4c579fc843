"""What a run to an accuracy costs with many output times, against a fixed-step run of as many
paths as its base level drew.

Scene: scaled units, tau0 = 5, output times evenly on [0.01, 5] (10, 100, 1000, 10000 of
them), velocity, displacement and distance observed, error = 0.05, two threads (one with
--threads). For each count: the wall time of ``simulate(scene, error=0.05)``, the paths of its
base level, and the wall time of ``simulate(scene, paths=<those paths>)`` (the default fixed
step) in the same process. At 1000 output times the run to an accuracy is also timed with
control sums at every output slot (``adaptive.CONTROL_SLOTS`` raised above the slots, how
runs were made before the control sums were limited to CONTROL_SLOTS slots), so the two are
a ratio measured in one run. The 10000-time run of that kind is not made (minutes).

Writes bench/out/many_times.json and bench/out/many_times.png; --publish copies both to
bench/results/.

    .venv/bin/python bench/many_times.py [--counts 10 100 1000 10000] [--threads 2] [--publish]
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
from _publish import write  # noqa: E402

TAU0 = 5.0
ERROR = 0.05
SEED = 11


def _scene(count: int):
    import crandall
    return crandall.Scene.scaled(tau0=TAU0, times=np.linspace(0.01, TAU0, count),
                                 observe=["velocity", "displacement", "distance"])


def _accuracy_run(count: int, threads: int, control_slots=None):
    import crandall
    from crandall.adaptive import features  # the module that reads CONTROL_SLOTS
    keep = features.CONTROL_SLOTS
    if control_slots is not None:
        features.CONTROL_SLOTS = control_slots
    try:
        t = time.perf_counter()
        r = crandall.simulate(_scene(count), error=ERROR, seed=SEED, threads=threads)
        wall = time.perf_counter() - t
    finally:
        features.CONTROL_SLOTS = keep
    worst = max(float(np.nanmax(np.atleast_1d(r.error(n, s)) / ERROR))
                for n in r.names for s in ("mean", "var"))
    return {"wall_s": wall, "paths": r.cost["paths"], "path_steps": r.cost["path_steps"],
            "worst_error_over_target": worst}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--counts", type=int, nargs="+", default=[10, 100, 1000, 10000])
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--publish", action="store_true")
    args = ap.parse_args()
    import crandall
    from crandall import adaptive

    rows = []
    for count in args.counts:
        acc = _accuracy_run(count, args.threads)
        t = time.perf_counter()
        crandall.simulate(_scene(count), paths=acc["paths"][0], seed=SEED, threads=args.threads)
        fixed = time.perf_counter() - t
        row = {"output_times": count, "accuracy_run": acc, "fixed_step_wall_s": fixed}
        if count == 1000:
            row["accuracy_run_controls_at_every_slot"] = _accuracy_run(
                count, args.threads, control_slots=count + 2)
        rows.append(row)
        print(f"{count:6d} output times: error={ERROR} {acc['wall_s']:.2f} s "
              f"(base paths {acc['paths'][0]}), fixed step of those paths {fixed:.2f} s"
              + (f", controls at every slot {row['accuracy_run_controls_at_every_slot']['wall_s']:.2f} s"
                 if count == 1000 else ""), flush=True)
    data = {"scene": {"units": "scaled", "tau0": TAU0, "times": "linspace(0.01, tau0, count)",
                      "observe": ["velocity", "displacement", "distance"]},
            "error": ERROR, "seed": SEED, "threads": args.threads,
            "control_slots": adaptive.CONTROL_SLOTS, "rows": rows,
            "build": crandall._core.build_info()}

    def plot(d, path):
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
        fig, ax = plt.subplots(figsize=(5.5, 3.8))
        n = [r["output_times"] for r in d["rows"]]
        ax.loglog(n, [r["accuracy_run"]["wall_s"] for r in d["rows"]], "o-",
                  label=f"error={ERROR} (controls at <= {d['control_slots']} slots)")
        ax.loglog(n, [r["fixed_step_wall_s"] for r in d["rows"]], "s-",
                  label="fixed step, the base level's paths")
        every = [(r["output_times"], r["accuracy_run_controls_at_every_slot"]["wall_s"])
                 for r in d["rows"] if "accuracy_run_controls_at_every_slot" in r]
        if every:
            ax.loglog(*zip(*every), "x", ms=9, label="controls at every slot")
        ax.set_xlabel("output times")
        ax.set_ylabel("wall time (s)")
        ax.set_title(f"Many output times ({d['threads']} threads)")
        ax.legend(fontsize=8)
        fig.tight_layout()
        fig.savefig(path, dpi=110)
        plt.close(fig)

    print(write("many_times", data, plot, publish=args.publish))


if __name__ == "__main__":
    main()
