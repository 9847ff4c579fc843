"""Fragility curves of the shipped crate (mu = 0.3, shaken for 2 s): P(S(t_s) > d) over the
intensity h, at d = 0.5, 1 and 2 m, each grid point a splitting run to a 10 % relative error
(crandall.fragility, one thread), the lognormal fit per threshold, and the annual rate of
exceeding each d under an illustrative hazard curve of h (a power law, lambda(h) = 1e-2
(h / 0.5)^-3 per year: not a site's), through the fit and through the grid's estimates (with
the most the shaking outside the grid could add). Writes bench/out/fragility.{json,png} (with --publish
also bench/results/, the figure the README shows).

    python bench/fragility.py [--publish] [--seed N]
"""

from __future__ import annotations

import argparse
import time

import numpy as np

import crandall
from crandall import plots

from _publish import write

INTENSITIES = [0.7, 0.85, 1.0, 1.2, 1.4, 1.7, 2.0]
THRESHOLDS = [0.5, 1.0, 2.0]
HAZARD_H = np.geomspace(0.05, 20.0, 40)
HAZARD_RATE = 1e-2 * (HAZARD_H / 0.5) ** -3.0


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--publish", action="store_true")
    ap.add_argument("--seed", type=int, default=1)
    args = ap.parse_args()
    crate = crandall.Scene.from_toml("crate")
    start = time.perf_counter()
    result = crandall.fragility(crate, "distance_at_stop", THRESHOLDS, intensities=INTENSITIES,
                                seed=args.seed, threads=1, progress=False)
    seconds = time.perf_counter() - start
    fit = result.fit_lognormal()
    hazard = result.hazard((HAZARD_H, HAZARD_RATE), fit=fit)
    grid = result.hazard((HAZARD_H, HAZARD_RATE), use="estimates")
    print(result)
    print(fit)
    print(hazard)
    print(grid)
    data = {
        "scene": "crate", "quantity": "distance_at_stop", "seed": args.seed,
        "seconds": seconds, "intensities": INTENSITIES, "thresholds": THRESHOLDS,
        "probability": result.probability.tolist(), "stderr": result.stderr.tolist(),
        "low": result.low.tolist(), "high": result.high.tolist(),
        "reliable": result.reliable.tolist(),
        "fit": {"median": fit.median.tolist(), "median_low": fit.median_low.tolist(),
                "median_high": fit.median_high.tolist(), "beta": fit.beta.tolist(),
                "beta_low": fit.beta_low.tolist(), "beta_high": fit.beta_high.tolist(),
                "chi2": fit.chi2.tolist(), "dof": fit.dof.tolist()},
        "hazard_curve": "1e-2 (h / 0.5)^-3 per year (illustrative)",
        "hazard": {"rate": hazard.rate.tolist(), "stderr": hazard.stderr.tolist()},
        "hazard_estimates": {"rate": grid.rate.tolist(), "stderr": grid.stderr.tolist(),
                             "outside": grid.outside.tolist()},
    }

    def plot(_, path):
        fig = plots.fragility(result, hazard=(HAZARD_H, HAZARD_RATE))
        fig.suptitle("crate: P(distance at the stop > d | h), splitting runs with 95 % bands, "
                     "lognormal fits; the rate under an illustrative hazard curve", fontsize=9)
        fig.savefig(path, dpi=110)

    print(write("fragility", data, plot, publish=args.publish))


if __name__ == "__main__":
    main()
