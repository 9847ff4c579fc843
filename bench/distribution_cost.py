"""What asking for distributions and peaks costs: the same scene with and without them.

Rows of the observable-cost table (bench/throughput.py: tau0 = 5, outputs at tau = 1 and 5,
dt = 0.01, exact method, 1 thread) and the paper's scene as ``crandall run`` simulates it
(13 output times, the default method and grid), each timed with and without
``distributions=True`` and the "peaks" observable. The target: at most 25 % more time than
the same scene without them.

The two runs of a pair alternate (A B A B ...) and each is the best of --repeat, so that a
load on the shared machine falls on both alike; the load average is recorded.

Writes bench/out/distribution_cost.json and .png; --publish copies both to bench/results/.

    .venv/bin/python bench/distribution_cost.py [--quick] [--publish] [--repeat N]
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
from _publish import write  # noqa: E402

TAU0 = 5.0
DT = 0.01
TARGET = 1.25
ALL = ["velocity", "displacement", "distance", "stop"]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--publish", action="store_true")
    ap.add_argument("--repeat", type=int, default=5)
    args = ap.parse_args()
    import crandall
    from crandall import paper

    scale = 0.1 if args.quick else 1.0

    def table_scene(observe, distributions=None):
        return crandall.Scene.scaled(tau0=TAU0, times=[1.0, TAU0], observe=observe,
                                     distributions=distributions)

    paper_times = paper.default_scene().times
    pairs = {
        "velocity + stop: + distributions": (
            table_scene(["velocity", "stop"]), table_scene(["velocity", "stop"], True),
            int(2_000_000 * scale), dict(dt=DT, method="exact")),
        "all: + distributions": (table_scene(ALL), table_scene(ALL, True),
                                 int(100_000 * scale), dict(dt=DT, method="exact")),
        "all: + peaks": (table_scene(ALL), table_scene(ALL + ["peaks"]),
                         int(100_000 * scale), dict(dt=DT, method="exact")),
        "all: + distributions + peaks": (table_scene(ALL), table_scene(ALL + ["peaks"], True),
                                         int(100_000 * scale), dict(dt=DT, method="exact")),
        "paper scene (crandall run): + distributions": (
            crandall.Scene.scaled(tau0=TAU0, times=paper_times),
            crandall.Scene.scaled(tau0=TAU0, times=paper_times, distributions=True),
            int(100_000 * scale), {}),
    }
    load = [round(x, 2) for x in os.getloadavg()]
    rows = {}
    for name, (base, asked, paths, kw) in pairs.items():
        best = [float("inf"), float("inf")]
        for _ in range(args.repeat):
            for i, scene in enumerate((base, asked)):
                t = time.process_time()
                crandall.simulate(scene, paths=paths, seed=1, threads=1, **kw)
                best[i] = min(best[i], time.process_time() - t)
        rows[name] = {"paths": paths, "base_seconds_per_million": best[0] / paths * 1e6,
                      "with_seconds_per_million": best[1] / paths * 1e6,
                      "ratio": best[1] / best[0], **{k: v for k, v in kw.items()}}
        print(f"{name}: {best[0] / paths * 1e6:.4g} -> {best[1] / paths * 1e6:.4g} s per 10^6 "
              f"paths, x{best[1] / best[0]:.3f}", flush=True)
    out = {"script": "bench/distribution_cost.py",
           "command": "python bench/distribution_cost.py" + (" --quick" if args.quick else "")
           + (" --publish" if args.publish else "")
           + (f" --repeat {args.repeat}" if args.repeat != 5 else ""),
           "crandall_version": crandall.__version__, "tau0": TAU0, "dt": DT,
           "timing": "CPU seconds of this process, best of --repeat, pairs alternating",
           "repeat": args.repeat, "target_ratio": TARGET, "rows": rows, "load": load,
           "load_after": [round(x, 2) for x in os.getloadavg()]}
    write("distribution_cost", out, plot, publish=args.publish)


def plot(out: dict, path: Path) -> None:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    rows = out["rows"]
    fig, ax = plt.subplots(figsize=(8, 3.6), constrained_layout=True)
    names = list(rows)
    ax.barh(names, [rows[n]["ratio"] for n in names], color="tab:green")
    ax.axvline(out["target_ratio"], color="tab:red", ls="--", label="target")
    ax.axvline(1.0, color="0.5", lw=0.8)
    ax.set_xlabel("time with / time without (CPU, 1 thread)")
    ax.set_title(f"cost of distributions and peaks (load {out['load']})", fontsize=10)
    ax.legend(fontsize=8)
    fig.savefig(path, dpi=90)
    plt.close(fig)


if __name__ == "__main__":
    main()
