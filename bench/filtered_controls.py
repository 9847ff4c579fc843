"""How much a control variate from the ground motion could save a filtered run: the share of
the per-path variance of the distance at the stop S (and of (S - E S)^2, the variance's
per-path term) that a linear regression on features of the ground acceleration explains.

A measurement for the design of such controls, not a feature: crandall's filtered runs use
none today. The features are functions of the ground acceleration a_g at the skeleton's grid
points up to the switch-off t0 alone, a Gaussian vector whose law the plan knows (the filter's
transitions and Van Loan covariances), so each feature's mean is computable exactly and a
regression on them estimates E S without bias (with coefficients fitted on other paths).
With a share R^2 explained, the paths needed for a standard error fall by 1 / (1 - R^2).

Features (w_k the trapezoid weights of the grid up to t0; v_k = sum of w-weighted a_g up to
grid point k, the trapezoid ground velocity):
  arias    sum_k w_k a_k^2          velocity2  sum_k w_k v_k^2        final2  v_K^2
  abs_acc  sum_k w_k |a_k|          abs_vel    sum_k w_k |v_k|
and, for "quadratic", their squares and the product of the first two.

bench/filtered.py's scene (Kanai-Tajimi, zeta = 0.6, h = 1, mu g = 1, t0 = 10 s, the default
step and event depth) at omega t* = 1, 4, 16; --paths paths each from
``_core.filtered_trajectory`` (one path per call: slow, but it exposes a_g at every point).
The regression is fitted on one half of the paths and R^2 measured on the other, so an
overfit cannot inflate it.

Writes bench/out/filtered_controls.{json,png} (bench/results/ with --publish).

    .venv/bin/python bench/filtered_controls.py [--paths 4000] [--publish]
"""

from __future__ import annotations

import argparse
import platform
import sys
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
from _publish import write  # noqa: E402

import crandall  # noqa: E402
from crandall import _core, engine  # noqa: E402
from crandall.spec import RunSpec  # noqa: E402
from filtered import T0, scene  # noqa: E402

CASES = (1.0, 4.0, 16.0)
NAMES = ("arias", "velocity2", "final2", "abs_acc", "abs_vel")


def features(wt: float, paths: int, seed: int):
    """Per path: S at the stop and the features of the skeleton's a_g up to t0."""
    plan = _core.Plan(engine.plan_options(RunSpec.create(scene(wt), paths=paths, seed=seed)))
    lengths, _, _ = _core.filtered_grid(plan)
    grid = np.concatenate([[0.0], np.cumsum(lengths)])
    grid = grid[grid <= T0 * (1 + 1e-12)]
    steps = np.diff(grid)
    w = np.zeros(grid.size)
    w[:-1] += steps / 2
    w[1:] += steps / 2
    s = np.empty(paths)
    f = np.empty((paths, len(NAMES)))
    for i in range(paths):
        tr = _core.filtered_trajectory(plan, i)
        t = tr["t"]
        # The skeleton's points: the trajectory's first point at each grid time.
        a = tr["a_g"][np.minimum(np.searchsorted(t, grid * (1 - 1e-12)), t.size - 1)]
        v = np.concatenate([[0.0], np.cumsum(steps * (a[1:] + a[:-1]) / 2)])
        s[i] = tr["S"][-1]
        f[i] = (np.sum(w * a * a), np.sum(w * v * v), v[-1] ** 2, np.sum(w * np.abs(a)),
                np.sum(w * np.abs(v)))
    return s, f


def explained(y: np.ndarray, x: np.ndarray) -> float:
    """R^2 of y on [1, x]: fitted on the first half, measured on the second."""
    half = y.size // 2
    design = np.column_stack([np.ones(y.size), x])
    beta, *_ = np.linalg.lstsq(design[:half], y[:half], rcond=None)
    rest = y[half:] - design[half:] @ beta
    return float(1.0 - rest.var() / y[half:].var())


def plot(data, path):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7, 4))
    rows = data["cases"]
    labels = ["arias", "linear", "quadratic"]
    x = np.arange(len(rows))
    for j, key in enumerate(labels):
        ax.bar(x + (j - 1) * 0.13, [r["mean"][key] for r in rows], width=0.13,
               label=f"S: {key}")
        ax.bar(x + (j + 2) * 0.13, [r["variance"][key] for r in rows], width=0.13,
               label=f"(S - E S)^2: {key}", alpha=0.6)
    ax.set_xticks(x + 0.2)
    ax.set_xticklabels([f"omega t* = {r['omega_t_star']:g}" for r in rows])
    ax.set_ylabel("R^2 (held-out half)")
    ax.set_ylim(0, 1)
    ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=110)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--paths", type=int, default=4000)
    ap.add_argument("--publish", action="store_true")
    args = ap.parse_args()
    cases = []
    for i, wt in enumerate(CASES):
        s, f = features(wt, args.paths, 500 + i)
        quad = np.column_stack([f, f * f, f[:, 0] * f[:, 1]])
        row = {"omega_t_star": wt, "paths": args.paths, "mean_S": float(s.mean()),
               "var_S": float(s.var(ddof=1)),
               "correlation": {n: float(np.corrcoef(s, f[:, j])[0, 1])
                               for j, n in enumerate(NAMES)}}
        centred = (s - s.mean()) ** 2
        for label, y in (("mean", s), ("variance", centred)):
            r = {"arias": explained(y, f[:, :1]), "linear": explained(y, f),
                 "quadratic": explained(y, quad)}
            r["paths_saved_linear"] = 1.0 / max(1.0 - r["linear"], 1e-12)
            r["paths_saved_quadratic"] = 1.0 / max(1.0 - r["quadratic"], 1e-12)
            row[label] = r
        cases.append(row)
        print(f"omega t* = {wt:4g}: R^2 of S on arias {row['mean']['arias']:.3f}, linear "
              f"{row['mean']['linear']:.3f}, quadratic {row['mean']['quadratic']:.3f}; of "
              f"(S - E S)^2: {row['variance']['arias']:.3f}, {row['variance']['linear']:.3f}, "
              f"{row['variance']['quadratic']:.3f}", flush=True)
    data = {"machine": platform.machine(), "crandall": crandall.__version__,
            "command": " ".join(["bench/filtered_controls.py"] + sys.argv[1:]),
            "features": list(NAMES), "cases": cases}
    print(write("filtered_controls", data, plot, publish=args.publish))


if __name__ == "__main__":
    main()
