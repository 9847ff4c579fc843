"""Coverage of crandall.tail's 95 % interval: the stop time of the paper's scene at a level
where P = 1e-6 (closed form), estimated to a 10 % relative error with many seeds.

For each seed the run reports an estimate, its standard error and the 95 % interval; the
coverage is the fraction of intervals that hold the exact value (its binomial standard error
is given). Also the mean of the estimates over the seeds against the exact value (the bias)
and the mean reported relative error.

Writes bench/out/tails_coverage.json and .png; --publish copies both to bench/results/.

    .venv/bin/python bench/tails_coverage.py [--seeds 1000] [--method splitting]
        [--particles 200] [--dt DT] [--publish]
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
P = 1e-6


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=1000)
    ap.add_argument("--method", default="splitting")
    ap.add_argument("--particles", type=int, default=200)
    ap.add_argument("--dt", type=float, default=None, help="grid step (default: the scene's)")
    ap.add_argument("--rel-error", type=float, default=0.1)
    ap.add_argument("--publish", action="store_true")
    args = ap.parse_args()
    import crandall
    from crandall import analytic

    warnings.simplefilter("ignore")  # a run's relative-error warning is counted below
    scene = crandall.Scene.scaled(tau0=TAU0, times=[TAU0])
    level = brentq(lambda t: math.log(analytic.stop_time_sf(t, TAU0)) - math.log(P), TAU0, 40.0,
                   xtol=1e-12)
    est, se, rel, covered, secs = [], [], [], [], []
    start = time.perf_counter()
    for seed in range(args.seeds):
        t = time.perf_counter()
        r = crandall.tail(scene, "stop_time", [level], method=args.method, seed=50_000 + seed,
                          dt=args.dt, particles=args.particles, rel_error=args.rel_error,
                          threads=1)
        secs.append(time.perf_counter() - t)
        lo, hi = r.interval()
        est.append(float(r.probability[0]))
        se.append(float(r.stderr[0]))
        rel.append(float(r.rel_error[0]))
        covered.append(bool(lo[0] <= P <= hi[0]))
    n = args.seeds
    cov = float(np.mean(covered))
    est_a = np.array(est)
    out = {"script": "bench/tails_coverage.py",
           "command": "python bench/tails_coverage.py " + " ".join(sys.argv[1:]),
           "crandall_version": crandall.__version__, "probability": P, "level": level,
           "method": args.method, "particles": args.particles, "dt": args.dt,
           "target_rel_error": args.rel_error, "seeds": n, "coverage": cov,
           "coverage_stderr": math.sqrt(cov * (1 - cov) / n),
           "mean_estimate_over_exact": float(est_a.mean() / P),
           "mean_estimate_stderr": float(est_a.std(ddof=1) / math.sqrt(n) / P),
           "mean_reported_rel_error": float(np.mean(rel)),
           "share_above_target": float(np.mean(np.array(rel) > args.rel_error)),
           "seconds_mean": float(np.mean(secs)), "seconds": time.perf_counter() - start,
           "load": [round(x, 2) for x in os.getloadavg()],
           "estimates": est, "stderrs": se}
    print(f"{args.method}, {n} seeds: coverage {cov:.3f} +- {out['coverage_stderr']:.3f}; "
          f"mean estimate / exact {out['mean_estimate_over_exact']:.4f} +- "
          f"{out['mean_estimate_stderr']:.4f}; mean reported rel. error "
          f"{out['mean_reported_rel_error']:.3f} ({out['share_above_target']:.0%} above the "
          f"target); {out['seconds_mean']:.2f} s per run")
    write(f"tails_coverage_{args.method}", out, plot, publish=args.publish)


def plot(data, path: Path) -> None:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    z = (np.array(data["estimates"]) - data["probability"]) / np.array(data["stderrs"])
    fig, ax = plt.subplots(figsize=(5.5, 4))
    ax.hist(z, bins=40, density=True, alpha=0.6, label="(estimate - exact) / stderr")
    x = np.linspace(-5, 5, 200)
    ax.plot(x, np.exp(-x * x / 2) / math.sqrt(2 * math.pi), "k-", label="standard normal")
    ax.set_title(f"{data['method']}: coverage {data['coverage']:.3f} over {data['seeds']} seeds "
                 f"(P = {data['probability']:g})", fontsize=9)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


if __name__ == "__main__":
    main()
