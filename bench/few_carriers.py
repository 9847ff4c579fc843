"""When is the standard error of a variance trustworthy? Coverage against the number of paths
that carry the spread (Result.carriers), the rule behind results.MIN_CARRIERS.

The standard error of a sample variance, sqrt((m4 - m2^2) / n), rests on the fourth moment.
Where a few paths far from the mean carry the spread (the velocity long after the
switch-off, when almost every path is at rest), those few paths decide m4, and the interval
+- 1.96 standard errors covers far less than 95 %. The number that says so is the effective
number of carrying paths, k = (sum d^2)^2 / sum d^4 (d the deviations from the mean), which
the stored central sums give.

Measured here, for the 95 % interval of the variance:

1. Laws (NumPy, no simulation): sparse samples of 10^6 paths of which Poisson(lambda) are
   nonzero, exponential with a random sign (the velocity of the moving paths after the
   switch-off); normal and Laplace samples of a few paths. Coverage of the law's variance,
   binned by k; and of the law's mean by the mean's interval (whose error is not withheld),
   for sparse values of both signs and of one sign.
2. The simulator: the scaled scene tau0 = 1 at tau = 1, 1.5, 2, 2.5, 3, 3.5 (about
   20 000 exp(-4 (tau - 1)) paths still move), 20 000 paths, method "exact" (exact in law at
   any step), many seeds; coverage of crandall.analytic.velocity_var by the interval the
   result used to give, binned by k; and how many intervals the rule withholds.

Writes bench/out/few_carriers.json and bench/out/few_carriers.png; --publish copies both to
bench/results/.

    .venv/bin/python bench/few_carriers.py [--quick] [--publish]
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
from _publish import write  # noqa: E402

#: Bins of the carrying paths k.
EDGES = [0, 2, 5, 10, 20, 30, 50, 100, 300, 1e300]
Z = 1.959963984540054


def binned(k, covered):
    k, covered = np.asarray(k, dtype=float), np.asarray(covered, dtype=bool)
    rows = []
    for lo, hi in zip(EDGES[:-1], EDGES[1:]):
        sel = (k >= lo) & (k < hi)
        n = int(sel.sum())
        p = float(covered[sel].mean()) if n else float("nan")
        rows.append({"k_low": lo, "k_high": None if hi > 1e299 else hi, "intervals": n,
                     "coverage": p,
                     "coverage_stderr": float(np.sqrt(p * (1 - p) / n)) if n else float("nan")})
    return rows


def _interval(s1, s2, s3, s4, n):
    """(variance, its old standard error, k) from power sums of n values."""
    m = s1 / n
    c2 = s2 - n * m * m
    c4 = s4 - 4 * m * s3 + 6 * m * m * s2 - 3 * n * m ** 4
    var = c2 / (n - 1)
    se = np.sqrt(np.maximum(c4 / n - (c2 / n) ** 2, 0.0) / n)
    with np.errstate(divide="ignore", invalid="ignore"):
        k = np.where(c4 > 0, c2 * c2 / c4, 0.0)
    return var, se, k


def laws(reps: int, rng) -> dict:
    out = {}
    n = 10 ** 6
    ks, cov = [], []
    for lam in (1, 2, 3, 5, 8, 12, 20, 30, 50, 80, 120, 200, 400):
        for _ in range(reps):
            m = rng.poisson(lam)
            v = rng.exponential(1.0, m) * rng.choice([-1.0, 1.0], m)
            var, se, k = _interval(v.sum(), (v ** 2).sum(), (v ** 3).sum(), (v ** 4).sum(), n)
            ks.append(float(k))
            cov.append(abs(var - 2.0 * lam / n) <= Z * se)
    out["sparse_exponential"] = binned(ks, cov)
    # The mean's interval (its standard error sqrt(var / n) is not withheld): sparse values of
    # both signs (the velocity from rest) and of one sign.
    for name, signed in (("mean_sparse_both_signs", True), ("mean_sparse_one_sign", False)):
        ks, cov = [], []
        for lam in (1, 2, 3, 5, 8, 12, 20, 30, 50, 80, 120, 200, 400):
            for _ in range(reps):
                m = rng.poisson(lam)
                v = rng.exponential(1.0, m) * (rng.choice([-1.0, 1.0], m) if signed else 1.0)
                var, _, k = _interval(v.sum(), (v ** 2).sum(), (v ** 3).sum(),
                                      (v ** 4).sum(), n)
                ks.append(float(k))
                cov.append(abs(v.sum() / n - (0.0 if signed else lam / n))
                           <= Z * np.sqrt(var / n))
        out[name] = binned(ks, cov)
    for name, draw, true in (("normal", rng.standard_normal, 1.0),
                             ("laplace", lambda shape: rng.laplace(size=shape), 2.0)):
        ks, cov = [], []
        for size in (5, 10, 20, 30, 60, 100, 300, 1000):
            x = draw((reps, size))
            var, se, k = _interval(x.sum(1), (x ** 2).sum(1), (x ** 3).sum(1),
                                   (x ** 4).sum(1), size)
            ks += k.tolist()
            cov += (np.abs(var - true) <= Z * se).tolist()
        out[name] = binned(ks, cov)
    return out


def simulator(seeds: int) -> dict:
    import crandall
    from crandall import analytic
    from crandall.results import MIN_CARRIERS, MONOMIALS

    times = [1.0, 1.5, 2.0, 2.5, 3.0, 3.5]
    scene = crandall.Scene.scaled(tau0=1.0, times=times, observe=["velocity"])
    ref = np.asarray(analytic.velocity_var(np.array(times), 1.0), dtype=float)
    i2, i4 = MONOMIALS.index((2, 0, 0)), MONOMIALS.index((4, 0, 0))
    ks, cov, withheld, z = [], [], [], []
    for seed in range(seeds):
        r = crandall.simulate(scene, paths=20_000, seed=seed, method="exact", dt=0.25,
                              threads=1)
        acc = r.accumulators.times
        n, c2, c4 = acc.counts, acc.central[:, i2], acc.central[:, i4]
        var = c2 / (n - 1)
        se = np.sqrt(np.maximum(c4 / n - (c2 / n) ** 2, 0.0) / n)
        k = r.carriers("velocity")
        ks.append(k)
        with np.errstate(divide="ignore", invalid="ignore"):
            cov.append(np.abs(var - ref) <= Z * se)
            z.append((var - ref) / se)
        withheld.append(k < MIN_CARRIERS)
    ks, cov, withheld, z = map(np.array, (ks, cov, withheld, z))
    per_time = []
    for j, t in enumerate(times):
        kept = ~withheld[:, j]
        per_time.append({
            "tau": t, "analytic_var": float(ref[j]), "median_carriers": float(np.median(ks[:, j])),
            "old_coverage": float(cov[:, j].mean()),
            "old_min_z": float(np.nanmin(np.where(np.isfinite(z[:, j]), z[:, j], np.nan)))
            if np.isfinite(z[:, j]).any() else None,
            "runs_with_zero_standard_error": int((~np.isfinite(z[:, j])).sum()),
            "withheld": int(withheld[:, j].sum()),
            "coverage_of_the_kept": float(cov[kept, j].mean()) if kept.any() else None})
    return {"seeds": seeds, "paths": 20_000, "tau0": 1.0, "min_carriers": MIN_CARRIERS,
            "per_time": per_time, "by_carriers": binned(ks.ravel(), cov.ravel()),
            "kept_coverage": float(cov[~withheld].mean()),
            "kept_intervals": int((~withheld).sum())}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--publish", action="store_true")
    args = ap.parse_args()
    import crandall

    start = time.perf_counter()
    rng = np.random.default_rng(20261126)
    out = {"script": "bench/few_carriers.py",
           "command": "python bench/few_carriers.py" + (" --quick" if args.quick else "")
           + (" --publish" if args.publish else ""),
           "crandall_version": crandall.__version__,
           "laws": laws(2000 if args.quick else 20000, rng),
           "simulator": simulator(40 if args.quick else 400)}
    out["seconds"] = time.perf_counter() - start
    out["load"] = [round(x, 2) for x in os.getloadavg()]
    for name, rows in list(out["laws"].items()) + [("simulator", out["simulator"]["by_carriers"])]:
        print(name + ": " + ", ".join(
            f"k in [{r['k_low']:g}, {r['k_high'] or 'inf'}): {r['coverage']:.3f} ({r['intervals']})"
            for r in rows if r["intervals"]))
    for row in out["simulator"]["per_time"]:
        print(row)
    write("few_carriers", out, plot, publish=args.publish)


def plot(out: dict, path: Path) -> None:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7.0, 4.4), constrained_layout=True)
    series = [(k, v) for k, v in out["laws"].items() if not k.startswith("mean")] + [
        ("crandall, velocity after the switch-off", out["simulator"]["by_carriers"])]
    for i, (name, rows) in enumerate(series):
        rows = [r for r in rows if r["intervals"] >= 50]
        mid = [np.sqrt(max(r["k_low"], 0.5) * (r["k_high"] or 3 * r["k_low"])) for r in rows]
        ax.errorbar(mid, [r["coverage"] for r in rows],
                    yerr=[1.96 * r["coverage_stderr"] for r in rows], fmt="o-", ms=4,
                    color=f"C{i}", label=name.replace("_", " "))
    ax.axhline(0.95, color="0.4", ls="--", lw=1)
    ax.axvline(out["simulator"]["min_carriers"], color="C3", ls=":", lw=1.2,
               label=f"MIN_CARRIERS = {out['simulator']['min_carriers']}")
    ax.set_xscale("log")
    ax.set_xlabel("paths carrying the spread, k = (sum d^2)^2 / sum d^4")
    ax.set_ylabel("coverage of the 95 % interval of the variance")
    ax.set_title("The variance's standard error against the paths that carry it", fontsize=10)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7)
    fig.savefig(path, dpi=90)
    plt.close(fig)


if __name__ == "__main__":
    main()
