"""How often the interval of a weighted record fraction holds the true probability
(crandall.suites.weighted_interval: Clopper-Pearson on Kish's effective sample size).

The model behind it: each record i of a suite exceeds a threshold independently with the same
probability p (the records stand for the population of ground motions at a site); the weighted
fraction sum(w_i I_i) / sum(w_i) estimates p, and its 95 % interval should hold p in at least
95 % of suites. With equal weights this is the Clopper-Pearson interval, whose coverage is at
least 95 % for every p; with unequal weights the count is not binomial, and the effective
sample size is an approximation. Measured here, for suites of n = 6, 18 and 40 records and
weights
- equal;
- lognormal with log-standard deviation 0.5 and 1 (fixed per suite size: seed 1);
- one record with a tenth of the total weight and the rest equal, and one with half;
- both polarities of each record (what crandall.record_fragility does by default): a record
  counts the fraction of its two polarities above the threshold (0, 1/2 or 1), each polarity
  exceeding with probability p, the second the same as the first with probability rho and
  independent of it otherwise (rho = 0 and 0.5; rho = 1 is one polarity), with equal and
  with lognormal(1) weights; n_eff is the records' (the polarities are not counted twice);
over p from 0.01 to 0.9, by --suites simulated suites per case (binomial standard error of a
coverage of 0.95: 0.0022 at 10,000).

Writes bench/out/records_coverage.{json,png} (bench/results/ with --publish).

    .venv/bin/python bench/records_coverage.py [--suites 10000] [--publish]
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
from _publish import write  # noqa: E402

PROBABILITIES = [0.01, 0.03, 0.1, 0.2, 0.3, 0.5, 0.7, 0.9]
SIZES = [6, 18, 40]


def weight_patterns(n: int):
    rng = np.random.default_rng(1)
    yield "equal", np.ones(n), None
    yield "lognormal 0.5", rng.lognormal(0.0, 0.5, n), None
    spread = rng.lognormal(0.0, 1.0, n)
    yield "lognormal 1", spread, None
    w = np.ones(n)
    w[0] = (n - 1) / 9.0  # a tenth of the total
    yield "one record 10 %", w, None
    w = np.ones(n)
    w[0] = n - 1.0  # half of the total
    yield "one record 50 %", w, None
    yield "polarities rho 0", np.ones(n), 0.0
    yield "polarities rho 0.5", np.ones(n), 0.5
    yield "lognormal 1, polarities rho 0", spread, 0.0


def coverage(weights: np.ndarray, rho, p: float, suites: int, rng) -> float:
    """The fraction of simulated suites whose interval holds p; ``rho`` None: one outcome per
    record, else two polarities with that correlation."""
    from crandall.suites import effective_size, weighted_interval

    n = len(weights)
    y = (rng.random((suites, n)) < p).astype(float)
    if rho is not None:
        same = rng.random((suites, n)) < rho
        second = np.where(same, y, rng.random((suites, n)) < p)
        y = (y + second) / 2
    fraction = np.clip(y @ (weights / weights.sum()), 0.0, 1.0)
    low, high = weighted_interval(fraction, effective_size(weights))
    return float(np.mean((low <= p) & (p <= high)))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--suites", type=int, default=10_000)
    ap.add_argument("--publish", action="store_true")
    args = ap.parse_args()
    import crandall
    from crandall.suites import effective_size

    rng = np.random.default_rng(20261127)
    start = time.perf_counter()
    cases = []
    for n in SIZES:
        for name, w, rho in weight_patterns(n):
            row = {"records": n, "weights": name, "effective_size": effective_size(w),
                   "coverage": [coverage(w, rho, p, args.suites, rng) for p in PROBABILITIES]}
            cases.append(row)
            print(f"n = {n:2d} {name:30s} n_eff = {row['effective_size']:5.1f}: "
                  + " ".join(f"{c:.3f}" for c in row["coverage"]), flush=True)
    se = math.sqrt(0.95 * 0.05 / args.suites)
    low = min(min(c["coverage"]) for c in cases)
    print(f"lowest coverage {low:.3f} (binomial standard error at 0.95: {se:.4f})")
    out = {"script": "bench/records_coverage.py",
           "command": "python bench/records_coverage.py" + (f" --suites {args.suites}"
                                                            if args.suites != 10_000 else "")
           + (" --publish" if args.publish else ""),
           "crandall_version": crandall.__version__, "suites": args.suites,
           "probabilities": PROBABILITIES, "cases": cases, "lowest": low,
           "coverage_standard_error": se, "seconds": time.perf_counter() - start}
    write("records_coverage", out, plot, publish=args.publish)


def plot(data, path: Path) -> None:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, len(SIZES), figsize=(13, 4), sharey=True)
    for ax, n in zip(axes, SIZES):
        for c in data["cases"]:
            if c["records"] == n:
                ax.plot(data["probabilities"], c["coverage"], "o-",
                        label=f"{c['weights']} (n_eff {c['effective_size']:.1f})")
        ax.axhline(0.95, color="k", lw=0.8)
        ax.set_xscale("log")
        ax.set_xlabel("true probability p")
        ax.set_title(f"{n} records")
        ax.legend(fontsize=7)
    axes[0].set_ylabel("coverage of the 95 % interval")
    fig.suptitle("Weighted record fractions: Clopper-Pearson on Kish's effective sample size")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


if __name__ == "__main__":
    main()
