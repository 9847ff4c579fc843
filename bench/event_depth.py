"""A filtered excitation's event depth (``simulate(event_depth=...)``): what a shallower event
search saves per path, what it moves, and whether the run's own bias estimate sees it.

bench/filtered.py's scene (Kanai-Tajimi, zeta = 0.6, h = 1, mu g = 1, t0 = 10 s, t* = 2 s) at
omega t* = 1, 4, 16, the default step, one thread. Per depth of DEPTHS:

- time: ``crandall.simulate`` of --paths paths, the fastest of --repeats runs taken in turn
  over the depths (the same seed gives the same numbers: only the time differs), as a ratio
  to depth 8's in the same process (the machine's load falls alike on all);
- shift: the paired per-path difference against depth 8 on the same seed
  (``_core.run_samples``; a node's random numbers depend on its place in the bisection tree
  only, and every depth builds the same roots, so both depths walk the same skeleton and the
  same bridges, docs/filtered.md) of the distance at the stop (its mean and
  variance) and of the stop time, with standard errors;
- bias: the run's ``Result.bias`` at that depth (its coupled grids each bisect to the same
  depth below their own step), for the same statistics.

Writes bench/out/event_depth.{json,png} (bench/results/ with --publish).

    .venv/bin/python bench/event_depth.py [--paths 10000] [--repeats 3] [--publish]
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
from filtered import scene  # noqa: E402

WT = (1.0, 4.0, 16.0)
DEPTHS = (8, 6, 5, 4, 3)
DEFAULT_DEPTH = 8
# Per path values of the stop slot (times = [t0]: slot 1): the stop time minus t0 in the
# velocity's column, the distance in the third.
STOP_SLOT, STOP_TIME, DISTANCE = 1, 0, 2


def _event_depth(depth):
    return None if depth == DEFAULT_DEPTH else depth


def samples(sc, paths: int, seed: int, depth: int) -> np.ndarray:
    spec = RunSpec.create(sc, paths=paths, seed=seed, event_depth=_event_depth(depth))
    plan = _core.Plan(engine.plan_options(spec, histograms=False))
    return np.asarray(_core.run_samples(plan, 0, paths, 1))[:, STOP_SLOT, 0, :]


def paired(a: np.ndarray, b: np.ndarray):
    """Mean and variance of a minus those of b, paired per path, with standard errors."""
    n = a.size
    d = a - b
    ca, cb = a - a.mean(), b - b.mean()
    phi = ca * ca - cb * cb
    return {"mean": float(d.mean()), "mean_stderr": float(d.std(ddof=1) / math.sqrt(n)),
            "var": float(a.var(ddof=1) - b.var(ddof=1)),
            "var_stderr": float(phi.std(ddof=1) / math.sqrt(n))}


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--paths", type=int, default=10000)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--seed", type=int, default=11)
    ap.add_argument("--publish", action="store_true")
    args = ap.parse_args()
    rows = []
    for i, wt in enumerate(WT):
        sc = scene(wt)
        seed = args.seed + i
        seconds = {d: [] for d in DEPTHS}
        results = {}
        for _ in range(args.repeats):
            for d in DEPTHS:
                start = time.perf_counter()
                r = crandall.simulate(sc, paths=args.paths, seed=seed, threads=1,
                                      event_depth=_event_depth(d))
                seconds[d].append(time.perf_counter() - start)
                results[d] = r
        base = samples(sc, args.paths, seed, DEFAULT_DEPTH)
        for d in DEPTHS:
            r = results[d]
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", crandall.StatisticsWarning)
                bias = {"distance_mean": float(r.bias("distance_at_stop", "mean")),
                        "distance_var": float(r.bias("distance_at_stop", "var")),
                        "stop_time_mean": float(r.bias("stop_time", "mean"))}
                bound = {"distance_mean": bool(r.bias_is_bound("distance_at_stop", "mean")),
                         "distance_var": bool(r.bias_is_bound("distance_at_stop", "var")),
                         "stop_time_mean": bool(r.bias_is_bound("stop_time", "mean"))}
            s = base if d == DEFAULT_DEPTH else samples(sc, args.paths, seed, d)
            row = {"omega_t_star": wt, "event_depth": d, "dt": r.dt, "paths": args.paths,
                   "seed": seed, "seconds": min(seconds[d]), "all_seconds": seconds[d],
                   "time_ratio": min(seconds[d]) / min(seconds[DEFAULT_DEPTH]),
                   "us_per_path": min(seconds[d]) / args.paths * 1e6,
                   "distance_mean": float(r.mean("distance_at_stop")),
                   "distance_var": float(r.var("distance_at_stop")),
                   "stop_time_mean": float(r.mean("stop_time")),
                   "distance_shift": paired(s[:, DISTANCE], base[:, DISTANCE]),
                   "stop_time_shift": paired(s[:, STOP_TIME], base[:, STOP_TIME]),
                   "bias": bias, "bias_is_bound": bound}
            rows.append(row)
            sh, st = row["distance_shift"], row["stop_time_shift"]
            print(f"omega t* = {wt:4g} depth {d}: time {row['time_ratio']:.2f} "
                  f"({row['us_per_path']:.0f} us/path); distance mean {sh['mean']:+.2e} "
                  f"+- {sh['mean_stderr']:.1e} (bias {bias['distance_mean']:.1e}), var "
                  f"{sh['var']:+.2e} +- {sh['var_stderr']:.1e} (bias {bias['distance_var']:.1e});"
                  f" stop time {st['mean']:+.2e} +- {st['mean_stderr']:.1e} "
                  f"(bias {bias['stop_time_mean']:.1e})", flush=True)
    data = {"machine": platform.machine(), "python": platform.python_version(),
            "crandall": crandall.__version__, "depths": list(DEPTHS),
            "command": " ".join(["bench/event_depth.py"] + sys.argv[1:]), "rows": rows}
    print(write("event_depth", data, plot, publish=args.publish))


def plot(data, path):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (a, b) = plt.subplots(1, 2, figsize=(10, 4))
    for wt in WT:
        rows = [r for r in data["rows"] if r["omega_t_star"] == wt and
                r["event_depth"] != DEFAULT_DEPTH]
        d = [r["event_depth"] for r in rows]
        rel = [abs(r["distance_shift"]["mean"]) / r["distance_mean"] for r in rows]
        est = [r["bias"]["distance_mean"] / r["distance_mean"] for r in rows]
        line, = a.semilogy(d, rel, "o-", label=f"shift, omega t* = {wt:g}")
        a.semilogy(d, est, "x--", color=line.get_color(), label="its Result.bias")
        b.plot(d, [r["time_ratio"] for r in rows], "o-", label=f"omega t* = {wt:g}")
    a.set_xlabel("event depth")
    a.set_ylabel("|mean distance at stop shift| / mean (vs depth 8)")
    a.legend(fontsize=7)
    b.set_xlabel("event depth")
    b.set_ylabel("time per path / depth 8's")
    b.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=110)


if __name__ == "__main__":
    main()
