"""How many splitting runs end above their target relative error, for each confidence level of
the bound on the pilot's variance that sizes their second stage (docs/methods/tails.md, "How
many samples: two stages").

A splitting replica's estimate is skewed, so the sample variance of a small pilot is low more
often than a normal sample's, and a run sized from it falls short of its target. This script
draws many replicas of two runs of the paper's scene (scaled, tau0 = 5, 200 particles, the
default step; one level each, so the distance's replicas rank by the normalised score): the
distance at the stop at P about 1e-9 (level 51) and the stop time at
P = 1e-6 (the level of bench/tails_coverage.py). Then, for each confidence level, it replays
crandall.tail's two stages on them: a pilot of 20 replicas drawn from the pool, the second
stage as many replicas as max(1.3, (n - 1) / chi2_(1-conf)(n - 1)) times the pilot's variance
asks for a 10 % relative error (at least the pilot's 20), drawn from the pool too, and the
relative error that run would report (its replicas' standard error over their mean). Reported
per level: the share of runs above the target, the mean replicas (pilot included) over
those the pool's own variance needs, and how often the run's 95 % interval covers the pool's
mean (the mean of the law the replay draws from). The replicas are crandall.tail's own (read back from a
checkpoint of one long run).

Writes bench/out/tails_pilot.{json,png} (bench/results/ with --publish).

    .venv/bin/python bench/tails_pilot.py [--replicas 800] [--runs 4000] [--publish]
"""

from __future__ import annotations

import argparse
import json
import math
import os
import sys
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np
from scipy.optimize import brentq
from scipy.stats import chi2
from scipy.stats import norm, t as student

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
from _publish import write  # noqa: E402

TAU0 = 5.0
PILOT = 20
SAFETY = 1.3
REL = 0.1
CONFIDENCE = (0.9, 0.95, 0.975, 0.99)


def replicas(scene, quantity, level, n, seed):
    """About n splitting replicas of crandall.tail at one level: a run whose pilot and second
    stage are n / 2 each (min_samples = max_samples = n / 2), all read back from its
    checkpoint (every replica is an independent sample of the same job)."""
    import crandall

    half = (n + 1) // 2
    with tempfile.TemporaryDirectory() as tmp:
        path = os.path.join(tmp, "run.ckpt")
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            crandall.tail(scene, quantity, [level], method="splitting", rel_error=0.9,
                          min_samples=half, max_samples=half, seed=seed, threads=1,
                          checkpoint=path)
        with np.load(path) as data:
            state = json.loads(str(data["state"]))
    return np.array([s["estimates"][0] for s in state["samples"]])


def replay(pool, runs, rng):
    need = (pool.std(ddof=1) / pool.mean() / REL) ** 2
    rows = []
    for conf in CONFIDENCE:
        factor = max(SAFETY, (PILOT - 1) / chi2.ppf(1 - conf, PILOT - 1))
        above, cost, covered = 0, 0.0, 0
        for _ in range(runs):
            pilot = rng.choice(pool, PILOT)
            n = max(PILOT, math.ceil(factor * pilot.var(ddof=1) / (REL * pilot.mean()) ** 2))
            s = rng.choice(pool, n)
            se = s.std(ddof=1) / math.sqrt(n)
            above += se / s.mean() > REL
            cost += n + PILOT
            # The run's 95 % interval (TailResult.interval's: Student's t below 200 samples,
            # normal above) against the mean of the law the replay draws from, the pool's.
            q = student.ppf(0.975, n - 1) if n < 200 else norm.ppf(0.975)
            covered += abs(s.mean() - pool.mean()) <= q * se
        rows.append({"confidence": conf, "factor": factor, "share_above_target": above / runs,
                     "replicas_over_needed": cost / runs / need,
                     "coverage_95": covered / runs})
    return need, rows


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--replicas", type=int, default=800)
    ap.add_argument("--runs", type=int, default=4000)
    ap.add_argument("--publish", action="store_true")
    args = ap.parse_args()
    import crandall
    from crandall import analytic

    scene = crandall.Scene.scaled(tau0=TAU0, times=[TAU0])
    stop_level = brentq(lambda t: math.log(analytic.stop_time_sf(t, TAU0)) - math.log(1e-6),
                        TAU0, 40.0, xtol=1e-12)
    rng = np.random.default_rng(20261126)
    out = {"script": "bench/tails_pilot.py",
           "command": "python bench/tails_pilot.py " + " ".join(sys.argv[1:]),
           "crandall_version": crandall.__version__, "pilot": PILOT, "safety": SAFETY,
           "target_rel_error": REL, "runs": args.runs, "cases": {}}
    start = time.perf_counter()
    for name, quantity, level in (("distance_at_stop 1e-9", "distance_at_stop", 51.0),
                                  ("stop_time 1e-6", "stop_time", stop_level)):
        pool = replicas(scene, quantity, level, args.replicas, seed=777)
        c = pool - pool.mean()
        need, rows = replay(pool, args.runs, rng)
        out["cases"][name] = {
            "quantity": quantity, "level": level, "replicas": len(pool),
            "mean": float(pool.mean()), "relative_spread": float(pool.std(ddof=1) / pool.mean()),
            "skewness": float(np.mean(c ** 3) / np.std(pool) ** 3),
            "zero_replicas": int(np.sum(pool == 0)), "replicas_needed": need, "rows": rows}
        print(f"{name}: {len(pool)} replicas, mean {pool.mean():.4g}, relative spread "
              f"{out['cases'][name]['relative_spread']:.3g}, skewness "
              f"{out['cases'][name]['skewness']:.3g}; {need:.0f} replicas needed")
        for r in rows:
            print(f"  {100 * r['confidence']:.1f} % bound (x{r['factor']:.2f}): "
                  f"{100 * r['share_above_target']:.1f} % of runs above the target, "
                  f"{r['replicas_over_needed']:.2f} x the replicas needed, the 95 % interval "
                  f"covers in {100 * r['coverage_95']:.1f} %", flush=True)
    out["seconds"] = time.perf_counter() - start
    write("tails_pilot", out, plot, publish=args.publish)


def plot(data, path: Path) -> None:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(10, 4))
    for name, case in data["cases"].items():
        conf = [100 * r["confidence"] for r in case["rows"]]
        axes[0].plot(conf, [100 * r["share_above_target"] for r in case["rows"]], "o-",
                     label=f"{name} (spread {case['relative_spread']:.2f})")
        axes[1].plot(conf, [r["replicas_over_needed"] for r in case["rows"]], "o-", label=name)
    axes[0].set_ylabel(f"runs above the target ({100 * data['target_rel_error']:g} %), %")
    axes[1].set_ylabel("replicas run / replicas needed")
    for ax in axes:
        ax.set_xlabel(f"confidence of the bound on a {data['pilot']}-replica pilot's variance, %")
        ax.grid(True, alpha=0.3)
        ax.legend(fontsize=8)
    fig.suptitle("splitting's second stage, replayed on crandall.tail's replicas", fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


if __name__ == "__main__":
    main()
