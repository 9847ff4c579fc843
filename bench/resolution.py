"""Relative bias at a time T reached in N steps: the measurement behind DEFAULT_MIN_STEPS.

The default grid is graded (``crandall.methods.DEFAULT_MIN_STEPS``): every output time and
the switch-off T is reached in at least N steps. This script measures, for the "exact" and
"richardson" methods, the relative bias of the mean and variance of the distance and of the
variance of the displacement at T after N equal steps, where it is worst: small T, where the
path is a Brownian motion (the drift's effect is O(sqrt(T))) and the relative bias depends on
N only.

Two measurements, which must agree:

1. Noise-free, in the Brownian limit. The exact skeleton gives the velocity exactly in law at
   the grid points, so the trapezoid sums' expectations are exactly the trapezoid (and product
   trapezoid) rules applied to E|X(t)|, E[|X(s)||X(t)|] and E[X(s)X(t)], which for a Brownian
   motion are closed forms (bivariate normal). The richardson moments are the same linear
   combination of the grids N, N/2, N/4 as in the kernel (weights of
   ``docs/methods/richardson.md``); its variance is its second moment less its mean squared,
   as in ``combine``. The exact values are the integrals of the same functions.
2. Monte Carlo: ``crandall.simulate`` at scaled T (noise on throughout), dt = T / N, against
   ``crandall.analytic`` (which includes the drift), with standard errors.

Writes bench/results/resolution.json.

    .venv/bin/python bench/resolution.py [--paths N] [--quick]
"""

from __future__ import annotations

import argparse
import json
import math
import os
import platform
import time
from pathlib import Path

import numpy as np

import crandall
from crandall import analytic
from crandall.methods import DEFAULT_MIN_STEPS

HERE = Path(__file__).resolve().parent
STEPS = [4, 8, 16, 32, 64, 128, 256]
MC_STEPS = [4, 8, 16, 64]
MC_TIMES = [1e-4, 0.1, 0.5]


# -- 1. the Brownian limit, without noise ----------------------------------------------------

def _abs_product(s, t):
    """E|W(s)||W(t)| for a standard Brownian motion W."""
    lo, hi = np.minimum(s, t), np.maximum(s, t)
    rho = np.sqrt(np.divide(lo, hi, out=np.zeros_like(hi), where=hi > 0))
    return (2 / np.pi) * np.sqrt(s * t) * (np.sqrt(1 - rho**2) + rho * np.arcsin(rho))


def _trapezoid_moments(n):
    """E S, E S^2, E U^2 of the trapezoid sums on n steps of [0, 1] (standard W)."""
    t = np.linspace(0.0, 1.0, n + 1)
    w = np.full(n + 1, 1.0 / n)
    w[0] = w[-1] = 0.5 / n
    s, u = np.meshgrid(t, t)
    return (float(w @ np.sqrt(2 * t / np.pi)), float(w @ _abs_product(s, u) @ w),
            float(w @ np.minimum(s, u) @ w))


def _richardson_weights():
    # sum w_j = 1, sum w_j 2^(j p) = 0 for p = 3/2, 2 (docs/methods/richardson.md).
    a = np.array([[1.0, 1.0, 1.0], [1.0, 2**1.5, 4**1.5], [1.0, 4.0, 16.0]])
    return np.linalg.solve(a, [1.0, 0.0, 0.0])


def brownian_limit():
    mean_true = (2 / 3) * math.sqrt(2 / math.pi)       # E int_0^1 |W|
    # E (int_0^1 |W|)^2 = 2 int_0^1 t^2 dt int_0^1 sqrt(u) k(sqrt u) du with
    # k(r) = (2/pi)(sqrt(1 - r^2) + r arcsin r); u = sin^2 q turns the inner integral into
    # (4/pi) int_0^(pi/2) sin^2 q cos q (cos q + q sin q) dq = (4/pi)(pi/16 + 5 pi/64) = 9/16.
    second_true = (2 / 3) * (9 / 16)
    var_true = second_true - mean_true**2
    disp_true = 1 / 3                                  # Var int_0^1 W
    w = _richardson_weights()
    rows = []
    for n in STEPS:
        grids = [_trapezoid_moments(n // 2**j) for j in range(3)]
        m1, m2, u2 = grids[0]
        row = {"steps": n, "exact": {
            "distance_mean": m1 / mean_true - 1,
            "distance_var": (m2 - m1**2) / var_true - 1,
            "displacement_var": u2 / disp_true - 1}}
        if n % 4 == 0:
            r1 = sum(wj * g[0] for wj, g in zip(w, grids))
            r2 = sum(wj * g[1] for wj, g in zip(w, grids))
            ru = sum(wj * g[2] for wj, g in zip(w, grids))
            row["richardson"] = {"distance_mean": r1 / mean_true - 1,
                                 "distance_var": (r2 - r1**2) / var_true - 1,
                                 "displacement_var": ru / disp_true - 1}
        rows.append(row)
    return rows


# -- 2. Monte Carlo against the analytic layer -----------------------------------------------

def monte_carlo(paths, seed, steps, times):
    rows = []
    for tau in times:
        ref = {"distance_mean": float(analytic.distance_mean(tau)),
               "distance_var": float(analytic.distance_var(tau)),
               "displacement_var": float(analytic.displacement_var(tau))}
        scene = crandall.Scene.scaled(tau0=math.inf, times=[tau],
                                      observe=["displacement", "distance"])
        for method in ("exact", "richardson"):
            for n in steps:
                t = time.perf_counter()
                r = crandall.simulate(scene, paths=paths, seed=seed, dt=tau / n, method=method)
                sim = {"distance_mean": (r.mean("distance")[0], r.stderr("distance")[0]),
                       "distance_var": (r.var("distance")[0], r.var_stderr("distance")[0]),
                       "displacement_var": (r.var("displacement")[0],
                                            r.var_stderr("displacement")[0])}
                rows.append({"tau": tau, "method": method, "steps": n,
                             "steps_per_path": r.steps_per_path, "paths": paths,
                             "seconds": round(time.perf_counter() - t, 2),
                             "relative_bias": {k: float(v / ref[k] - 1) for k, (v, _) in sim.items()},
                             "relative_stderr": {k: float(se / ref[k]) for k, (_, se) in sim.items()}})
                print(f"tau={tau:g} {method:<10} N={n:<4} " + "  ".join(
                    f"{k} {rows[-1]['relative_bias'][k]:+.2e}±{rows[-1]['relative_stderr'][k]:.1e}"
                    for k in sim), flush=True)
    return rows


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--paths", type=int, default=4_000_000)
    ap.add_argument("--seed", type=int, default=20261121)
    ap.add_argument("--quick", action="store_true", help="100k paths, not written to results/")
    args = ap.parse_args()
    paths = 100_000 if args.quick else args.paths
    start = time.perf_counter()
    limit = brownian_limit()
    for row in limit:
        print(row, flush=True)
    mc = monte_carlo(paths, args.seed, MC_STEPS, MC_TIMES)
    out = {
        "what": "relative bias (simulated / exact - 1) at a time T reached in N equal steps",
        "default_min_steps": DEFAULT_MIN_STEPS,
        "brownian_limit": limit,
        "monte_carlo": mc,
        "crandall": crandall.__version__,
        "build": crandall._core.build_info(),
        "machine": platform.machine(),
        "cpus": os.cpu_count(),
        "seconds": round(time.perf_counter() - start, 1),
    }
    if not args.quick:
        (HERE / "results").mkdir(exist_ok=True)
        (HERE / "results" / "resolution.json").write_text(json.dumps(out, indent=1) + "\n")
        print("wrote", HERE / "results" / "resolution.json")


if __name__ == "__main__":
    main()
