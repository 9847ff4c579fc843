"""Coverage of importance sampling's runs flagged reliable: crandall.tail(method="importance")
on tails of the stop time, the velocity and the speed with exact references, many seeds.

For each case and seed the run reports an estimate, its standard error, the 95 % interval and
whether it calls itself reliable (crandall.tail's Pareto, effective-sample and largest-share
checks). Over the reliable runs: the share whose interval holds the exact value (with its
binomial standard error) and the mean ratio of the estimate to the exact value (with its
standard error). ``reliable=True`` has to mean that the interval can be trusted: the coverage
should be near 95 % and the mean ratio near 1.

The references: the closed-form stop-time law (crandall.analytic.stop_time_sf) for the paper's
scene, and for a start in motion with two pieces the law of V at the switch-off by numerical
integration of the transition density (crandall.analytic.schedule.stop_time_sf); the paper's
law of the velocity (crandall.analytic.velocity_sf, any time, also after the switch-off) for
the velocity while the noise acts and the speed |V| after it.

Writes bench/out/tails_is_coverage.json and .png; --publish copies both to bench/results/.

    .venv/bin/python bench/tails_is_coverage.py [--seeds 150] [--cases NAME ...] [--publish]
"""

from __future__ import annotations

import argparse
import math
import os
import sys
import time
import warnings
from collections import Counter
from pathlib import Path

import numpy as np
from scipy.optimize import brentq

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
from _publish import write  # noqa: E402


def cases():
    """name -> (scene, quantity, time, level, exact P, what)."""
    import crandall
    from crandall import analytic
    from crandall.analytic import schedule

    out = {}
    out["tau0=20, level 25"] = (crandall.Scene.scaled(tau0=20, times=[20]), "stop_time", None, 25.0,
                                float(analytic.stop_time_sf(25.0, 20.0)), "closed form")
    level = brentq(lambda t: math.log(analytic.stop_time_sf(t, 5.0)) - math.log(1e-9), 5.0, 40.0,
                   xtol=1e-12)
    out["tau0=5, P=1e-9"] = (crandall.Scene.scaled(tau0=5, times=[5]), "stop_time", None, level, 1e-9,
                             "closed form")
    out["tau0=100, level 105"] = (crandall.Scene.scaled(tau0=100, times=[100]), "stop_time", None,
                                  105.0,
                                  float(analytic.stop_time_sf(105.0, 100.0)), "closed form")
    # A start in motion (U1 = 6) and two pieces (h = 1.5 then 0.7).
    scene = crandall.Scene.scaled(tau0=[4.0, 8.0], h=[1.5, 0.7], v0=6.0, times=[8.0])
    pieces = [(float(e), float(n)) for e, n in scene.pieces]

    def sf(t):
        return schedule.stop_time_sf(pieces, scene.drift, t, scene.v0)

    level = brentq(lambda t: math.log(sf(t)) - math.log(1e-8), 8.5, 30.0, xtol=1e-10)
    out["v0=6, two pieces, P=1e-8"] = (scene, "stop_time", None, level, float(sf(level)),
                                       "transition density, quadrature")
    # The velocity at the switch-off (tau0 = 5) above a level of P = 1e-8, and the speed |V|
    # one unit of time after it above a level of P = 1e-7 (symmetric: twice the velocity's).
    level = brentq(lambda y: math.log(analytic.velocity_sf(y, 5.0, 5.0)) - math.log(1e-8),
                   0.5, 40.0, xtol=1e-12)
    out["velocity at tau0=5, P=1e-8"] = (crandall.Scene.scaled(tau0=5, times=[5]), "velocity",
                                         5.0, level, float(analytic.velocity_sf(level, 5.0, 5.0)),
                                         "closed form")
    level = brentq(lambda y: math.log(2 * analytic.velocity_sf(y, 6.0, 5.0)) - math.log(1e-7),
                   0.1, 40.0, xtol=1e-12)
    out["speed at tau=6 (tau0=5), P=1e-7"] = (crandall.Scene.scaled(tau0=5, times=[6]), "speed",
                                              6.0, level,
                                              float(2 * analytic.velocity_sf(level, 6.0, 5.0)),
                                              "closed form")
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=150)
    ap.add_argument("--cases", nargs="*", default=None, help="names (default: all)")
    ap.add_argument("--rel-error", type=float, default=0.1)
    ap.add_argument("--publish", action="store_true")
    args = ap.parse_args()
    import crandall

    warnings.simplefilter("ignore")  # unreliable runs warn: they are counted below
    rows = []
    start = time.perf_counter()
    for name, (scene, quantity, at, level, exact, what) in cases().items():
        if args.cases and name not in args.cases:
            continue
        runs = []
        for seed in range(args.seeds):
            t = time.perf_counter()
            r = crandall.tail(scene, quantity, [level], time=at, method="importance",
                              seed=70_000 + seed, rel_error=args.rel_error, threads=1)
            lo, hi = r.interval()
            d = r.diagnostics
            runs.append({"ratio": float(r.probability[0] / exact),
                         "rel_error": float(r.rel_error[0]),
                         "reliable": bool(r.reliable[0]),
                         "covered": bool(lo[0] <= exact <= hi[0]),
                         "proposal": d["proposal"], "pareto_shape": d["pareto_shape"][0],
                         "effective_samples": d["effective_samples"][0],
                         "largest_weight_share": d["largest_weight_share"][0],
                         "paths": int(r.samples), "seconds": time.perf_counter() - t})
        rel = [x for x in runs if x["reliable"]]
        n = len(rel)
        cov = float(np.mean([x["covered"] for x in rel])) if n else math.nan
        ratios = np.array([x["ratio"] for x in rel])
        props = Counter(f"w{x['proposal']['window']:g} d{x['proposal']['drift']:g}"
                        + ("" if x["proposal"].get("full") is None
                           else f" + full d{x['proposal']['full']:g}") for x in runs)
        row = {"case": name, "quantity": quantity, "time": at, "level": level, "exact": exact, "reference": what,
               "seeds": len(runs), "reliable": n, "covered": int(sum(x["covered"] for x in rel)),
               "coverage": cov,
               "coverage_stderr": math.sqrt(cov * (1 - cov) / n) if n else math.nan,
               "mean_ratio": float(ratios.mean()) if n else math.nan,
               "mean_ratio_stderr": float(ratios.std(ddof=1) / math.sqrt(n)) if n > 1 else math.nan,
               "covered_all": float(np.mean([x["covered"] for x in runs])),
               "mean_ratio_all": float(np.mean([x["ratio"] for x in runs])),
               "mean_reported_rel_error": float(np.mean([x["rel_error"] for x in rel])) if n else math.nan,
               "seconds_mean": float(np.mean([x["seconds"] for x in runs])),
               "proposals": dict(props.most_common()), "runs": runs}
        rows.append(row)
        print(f"{name}: P = {exact:.3g}; {len(runs)} seeds, {n} reliable, {row['covered']} of them "
              f"covered ({cov:.1%} +- {row['coverage_stderr']:.1%}); mean ratio "
              f"{row['mean_ratio']:.3f} +- {row['mean_ratio_stderr']:.3f}; all runs: covered "
              f"{row['covered_all']:.1%}, mean ratio {row['mean_ratio_all']:.3f}; "
              f"{row['seconds_mean']:.2f} s per run; proposals {dict(props.most_common(4))}",
              flush=True)
    out = {"script": "bench/tails_is_coverage.py",
           "command": "python bench/tails_is_coverage.py " + " ".join(sys.argv[1:]),
           "crandall_version": crandall.__version__, "target_rel_error": args.rel_error,
           "seconds": time.perf_counter() - start,
           "load": [round(x, 2) for x in os.getloadavg()], "cases": rows}
    write("tails_is_coverage", out, plot, publish=args.publish)


def plot(data, path: Path) -> None:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    rows = data["cases"]
    fig, (a1, a2) = plt.subplots(1, 2, figsize=(10, 4))
    y = np.arange(len(rows))
    a1.errorbar([r["coverage"] for r in rows], y, xerr=[2 * r["coverage_stderr"] for r in rows],
                fmt="o")
    a1.axvline(0.95, color="k", ls=":")
    a1.set_xlabel("coverage of the 95 % interval, reliable runs (+- 2 se)")
    a2.errorbar([r["mean_ratio"] for r in rows], y,
                xerr=[2 * r["mean_ratio_stderr"] for r in rows], fmt="o")
    a2.axvline(1.0, color="k", ls=":")
    a2.set_xlabel("mean estimate / exact, reliable runs (+- 2 se)")
    for ax in (a1, a2):
        ax.set_yticks(y)
        ax.set_yticklabels([f"{r['case']}\n({r['reliable']}/{r['seeds']} reliable)" for r in rows],
                           fontsize=7)
    a2.set_yticklabels([])
    fig.suptitle("importance sampling: tails of the stop time, velocity and speed, runs flagged "
                 "reliable", fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


if __name__ == "__main__":
    main()
