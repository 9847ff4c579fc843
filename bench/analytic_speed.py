"""Time the four paper curves (eq10r, eq10s, eq10t, eq10u) of crandall.analytic, 10^4 points each.

Writes bench/out/analytic_speed.json. Run: python bench/analytic_speed.py
Target (issue 3): all four curves under 50 ms in total.
"""

import json
import pathlib
import platform
import time

import numpy as np

import crandall.analytic as A

N = 10_000
REPEAT = 20


def main():
    tau = np.logspace(-8, 6, N)
    funcs = [A.velocity_var, A.displacement_var, A.distance_mean, A.distance_var]
    for f in funcs:  # warm-up: builds the series tables once
        f(tau)
    per = {}
    totals = []
    for _ in range(REPEAT):
        tot = 0.0
        for f in funcs:
            t0 = time.perf_counter()
            f(tau)
            dt = time.perf_counter() - t0
            per[f.__name__] = min(per.get(f.__name__, np.inf), dt)
            tot += dt
        totals.append(tot)
    out = {
        "points_per_curve": N,
        "tau_range": [1e-8, 1e6],
        "best_total_seconds": min(totals),
        "median_total_seconds": float(np.median(totals)),
        "best_seconds_per_curve": per,
        "target_seconds": 0.050,
        "python": platform.python_version(),
        "numpy": np.__version__,
        "machine": platform.machine(),
        "command": "python bench/analytic_speed.py",
    }
    path = pathlib.Path(__file__).parent / "out" / "analytic_speed.json"
    path.parent.mkdir(exist_ok=True)
    path.write_text(json.dumps(out, indent=2) + "\n")
    print(json.dumps(out, indent=2))


if __name__ == "__main__":
    main()
