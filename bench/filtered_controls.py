"""How much a control variate from the ground motion could save a filtered run: the share of
the per-path variance of the distance at the stop S (and of (S - E S)^2, the variance's
per-path term) that a linear regression on features of the ground acceleration explains.

A measurement made for the design of such controls, before crandall's runs to an accuracy
had them (they now use the core's own ground features: docs/filtered.md, "Control
variates"). With --estimator-check it checks those instead: on the base level of the
friction calibration's scene (bench/filtered_error.py's friction_omega_tstar_4), BLOCKS
independent blocks of a pilot of 4096 paths (the coefficients, by least squares) and 16384
more (the estimate, minus the controls' multiples, and its standard error from their
residuals), the estimator of a run to an accuracy's base level: the spread of the blocks'
estimates over the mean reported standard error should be 1 (writes
filtered_controls_check.{json,png}). The features are functions of the ground acceleration a_g at the skeleton's grid
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

With --shares, what the core's controls themselves explain on a run to an accuracy's base level
(its step, depth and plan), fitted as the run fits them (pilots of 4096 paths), measured on a
held-out half of --paths paths: the first 15 controls (ground features and body sums), 18 (and
the products), all 22 (and the second-order sums); writes filtered_controls_shares.{json,png}.

    .venv/bin/python bench/filtered_controls.py [--paths 4000] [--publish]
    .venv/bin/python bench/filtered_controls.py --estimator-check [--blocks 200] [--publish]
    .venv/bin/python bench/filtered_controls.py --shares --paths 100000 [--pilots 40] [--publish]
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


PILOT, BLOCK = 4096, 16384


def estimator_check(blocks: int, publish: bool):
    """The base level's control-variate estimator over independent blocks (module doc)."""
    from crandall.adaptive.levels import FILTER_BASE_DT_FACTOR, _Level
    from crandall.spec import default_dt
    sc = crandall.Scene(mu=1.0, g=1.0, excitation=crandall.KanaiTajimi(omega=2.0, zeta=0.6,
                                                                        h=1.0),
                        t0=10.0, times=[5.0], observe=["distance", "velocity", "stop"])
    lev = _Level(sc, 0, 7, FILTER_BASE_DT_FACTOR * default_dt(sc), 2, True)
    size = PILOT + BLOCK
    values, ctl = _core.run_samples(lev.plan, 0, blocks * size, 2, True)
    rows = {}
    for name, y_all, slot in (("distance_at_stop", values[:, 1, 0, 2], 1),
                              ("distance@5", values[:, 0, 0, 2], 0)):
        est, se, plain = [], [], []
        for b in range(blocks):
            y = y_all[b * size:(b + 1) * size]
            c = ctl[b * size:(b + 1) * size, slot, :]
            x = np.column_stack([np.ones(size), c])
            beta, *_ = np.linalg.lstsq(x[:PILOT], y[:PILOT], rcond=None)
            r = y[PILOT:] - c[PILOT:] @ beta[1:]
            est.append(float(r.mean()))
            se.append(float(r.std(ddof=1) / np.sqrt(BLOCK)))
            plain.append(float(y[PILOT:].std(ddof=1) / np.sqrt(BLOCK)))
        est = np.array(est)
        ratio = float(est.std(ddof=1) / np.mean(se))
        rows[name] = {"spread_of_estimates": float(est.std(ddof=1)),
                      "mean_reported_stderr": float(np.mean(se)),
                      "ratio": ratio, "ratio_stderr": ratio / np.sqrt(2 * (blocks - 1)),
                      "mean_plain_stderr": float(np.mean(plain)), "estimates": est.tolist()}
        print(f"{name}: spread {est.std(ddof=1):.5f}, mean reported stderr {np.mean(se):.5f}: "
              f"ratio {ratio:.3f} +- {rows[name]['ratio_stderr']:.3f} (without controls "
              f"{np.mean(plain):.5f})", flush=True)
    data = {"machine": platform.machine(), "crandall": crandall.__version__,
            "command": " ".join(["bench/filtered_controls.py"] + sys.argv[1:]),
            "blocks": blocks, "pilot": PILOT, "block": BLOCK,
            "base_dt": lev.plan.options.dt, "rows": rows}

    def plot_check(data, path):
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
        fig, ax = plt.subplots(figsize=(6, 3.5))
        names = list(data["rows"])
        r = [data["rows"][n]["ratio"] for n in names]
        e = [1.96 * data["rows"][n]["ratio_stderr"] for n in names]
        ax.errorbar(range(len(names)), r, yerr=e, fmt="o", capsize=3)
        ax.axhline(1.0, color="k", lw=0.8, ls="--")
        ax.set_xticks(range(len(names)))
        ax.set_xticklabels(names)
        ax.set_ylabel("spread of estimates / reported stderr")
        fig.tight_layout()
        fig.savefig(path, dpi=110)

    print(write("filtered_controls_check", data, plot_check, publish=publish))


#: The control groups of --shares: the row's first 15 (ground features and body sums), 18
#: (and the three products), 22 (and the four second-order sums): _core.CONTROLS.
GROUPS = (15, 18, 22)


def shares(paths: int, pilots: int, publish: bool):
    """How much of S at the stop and of (S - E S)^2 the core's controls explain on the base
    level of a run to an accuracy (its step and event depth, its plan: adaptive.levels._Level),
    as the run uses them: coefficients fitted on a pilot of 4096 paths. `pilots` such pilots
    drawn from the first half of `paths` paths, each share measured on the second half (heavy
    tails make a small held-out sample too noisy to tell the groups apart): mean, min and max
    over the pilots, per group of GROUPS."""
    from crandall.adaptive.levels import FILTER_BASE_DT_FACTOR, _Level
    from crandall.spec import default_dt

    assert _core.CONTROLS == GROUPS[-1]
    rng = np.random.default_rng(2026)
    cases = []
    for i, wt in enumerate(CASES):
        sc = scene(wt)
        base_dt = FILTER_BASE_DT_FACTOR * default_dt(sc)
        lev = _Level(sc, 0, 700 + i, base_dt, 2, True)
        slot = len(sc.times)  # the stop's
        lev.controls, lev.control_slots = True, [slot]
        lev.batch = paths
        values, ctl = lev.samples(0, paths)
        s = values[:, slot, 0, 2].copy()
        x = ctl[:, 0, :].copy()
        half = paths // 2
        row = {"omega_t_star": wt, "paths": paths, "pilots": pilots, "pilot_paths": PILOT,
               "base_dt": base_dt}
        for label, y in (("mean", s), ("variance", (s - s.mean()) ** 2)):
            out = {}
            for k in GROUPS:
                design = np.column_stack([np.ones(paths), x[:, :k]])
                got = []
                for _ in range(pilots):
                    fit = rng.choice(half, PILOT, replace=False)
                    beta, *_ = np.linalg.lstsq(design[fit], y[fit], rcond=None)
                    rest = y[half:] - design[half:] @ beta
                    got.append(1.0 - rest.var() / y[half:].var())
                got = np.array(got)
                out[str(k)] = {"mean": float(got.mean()), "min": float(got.min()),
                               "max": float(got.max())}
            row[label] = out
        cases.append(row)
        print(f"omega t* = {wt:4g}: S " + ", ".join(
            f"{k}: {row['mean'][str(k)]['mean']:.3f}" for k in GROUPS) + "; (S - E S)^2 " +
            ", ".join(f"{k}: {row['variance'][str(k)]['mean']:.3f}" for k in GROUPS), flush=True)
    data = {"machine": platform.machine(), "crandall": crandall.__version__,
            "command": "bench/filtered_controls.py --shares" + (" --publish" if publish else ""),
            "groups": list(GROUPS), "cases": cases}

    def plot_shares(data, path):
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        fig, ax = plt.subplots(figsize=(7, 4))
        rows = data["cases"]
        x = np.arange(len(rows))
        for j, k in enumerate(GROUPS):
            for lab, off, alpha in (("mean", 0, 1.0), ("variance", 3, 0.6)):
                r = [c[lab][str(k)] for c in rows]
                ax.bar(x + (j + off - 2.5) * 0.13, [v["mean"] for v in r], width=0.13,
                       yerr=[[v["mean"] - v["min"] for v in r], [v["max"] - v["mean"] for v in r]],
                       alpha=alpha, label=f"{'S' if lab == 'mean' else '(S - E S)^2'}: first {k}")
        ax.set_xticks(x)
        ax.set_xticklabels([f"omega t* = {c['omega_t_star']:g}" for c in rows])
        ax.set_ylabel("share explained (held-out half; pilots of 4096)")
        ax.set_ylim(0, 1.25)
        ax.legend(fontsize=7, ncol=3, loc="upper center")
        fig.tight_layout()
        fig.savefig(path, dpi=110)

    print(write("filtered_controls_shares", data, plot_shares, publish=publish))


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--paths", type=int, default=4000)
    ap.add_argument("--shares", action="store_true")
    ap.add_argument("--pilots", type=int, default=40)
    ap.add_argument("--estimator-check", action="store_true")
    ap.add_argument("--blocks", type=int, default=200)
    ap.add_argument("--publish", action="store_true")
    args = ap.parse_args()
    if args.estimator_check:
        estimator_check(args.blocks, args.publish)
        return
    if args.shares:
        shares(args.paths, args.pilots, args.publish)
        return
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
