"""What a filtered run to an accuracy leaves out, measured: on the friction calibration's scene
(bench/filtered_error.py's friction_omega_tstar_4: Kanai-Tajimi omega = 2, zeta = 0.6, h = 1,
mu g = 1, t0 = 10 s), for the mean distance at the stop,

1. the base level's mean without control variates, on --paths paths far beyond any run's, and
   the 22 controls' sample means over their standard errors there (each must be 0 in
   expectation: docs/filtered.md, "Control variates"), with beta . mean(controls) for the
   coefficients fitted on the same paths (the shift the controls would put into an estimate
   if their means were not 0);
2. the means of the level differences Y_l (fine minus coarse on the coupled grids, event
   depth 4), levels 1 to --levels, on --level-paths paths each;

so that the base mean plus every level mean (the last ones' tail summed geometrically at
their measured ratio) is the limit the levels converge to, to be set beside the controlled
Euler reference (docs/methods/adaptive.md, "The controlled reference"), and the tail after
level 2, what the calibration's runs at rel_error 0.02 and 0.01 leave out, beside the bias
they report.

Writes bench/out/filtered_truncation.{json,png} (bench/results/ with --publish).

    .venv/bin/python bench/filtered_truncation.py [--paths 39321600] [--levels 5]
        [--level-paths 1048576] [--threads 2] [--publish]
"""

from __future__ import annotations

import argparse
import sys

import numpy as np

from _publish import write

import crandall
from crandall import KanaiTajimi, Scene
from crandall.adaptive.estimator import _Engine
from crandall.adaptive.levels import _check_statistics

STATISTICS = ["distance_at_stop:var", "distance_at_stop:mean", "distance:mean", "velocity:var"]
#: Paths beyond any run's (a run's levels start at path 0).
FIRST = 1 << 36


def engine(threads: int):
    sc = Scene(mu=1.0, g=1.0, excitation=KanaiTajimi(omega=2.0, zeta=0.6, h=1.0), t0=10.0,
               times=[5.0], observe=["distance", "velocity", "stop"])
    eng = _Engine(sc, eps=None, rel=0.02, seed=1, threads=threads,
                  statistics=_check_statistics(sc, STATISTICS))
    i = [k for k, t in enumerate(eng.targets)
         if t.name == "distance_at_stop" and t.stat == "mean"][0]
    return eng, i, eng.targets[i].slot


def base(eng, i, slot, paths: int):
    lev = eng._level(0)
    k = 22
    s1, s2, n, b = np.zeros(k + 1), np.zeros((k + 1, k + 1)), 0, 0
    while n < paths:
        count = min(eng.batch, paths - n)
        block, controls = lev.samples(FIRST + n, count)
        x = np.empty((count, k + 1))
        x[:, 0] = eng._values(block)[:, i]
        x[:, 1:] = controls[:, eng.control_of[slot], :k]
        s1 += x.sum(0)
        s2 += x.T @ x
        n += count
        b += 1
        if b % 100 == 0:
            print(f"base: {n} paths", flush=True)
    m = s1 / n
    cov = (s2 - n * np.outer(m, m)) / (n - 1)
    se = np.sqrt(np.diag(cov) / n)
    beta = np.linalg.solve(cov[1:, 1:], cov[1:, 0])
    return {"paths": n, "mean": float(m[0]), "stderr": float(se[0]),
            "control_mean_over_stderr": [float(x) for x in m[1:] / se[1:]],
            "beta_dot_control_means": float(beta @ m[1:]),
            "beta_dot_control_means_stderr": float(np.sqrt(beta @ cov[1:, 1:] @ beta / n)),
            "share_explained": float(cov[1:, 0] @ beta / cov[0, 0])}


def level_means(eng, slot, levels: int, paths: int):
    # The sample's S column (V, U, S per slot and grid: fine first, coarse second).
    out = []
    for level in range(1, levels + 1):
        lev = eng._level(level)
        n, s1, s2 = 0, 0.0, 0.0
        while n < paths:
            count = min(8192, paths - n)
            block, _ = lev.samples(FIRST + n, count)
            d = block[:, slot, 0, 2] - block[:, slot, 1, 2]
            s1, s2, n = s1 + d.sum(), s2 + (d * d).sum(), n + count
        m = s1 / n
        out.append({"level": level, "paths": n, "mean": m,
                    "stderr": ((s2 / n - m * m) / n) ** 0.5})
        print(f"level {level}: {m:.4e} +- {out[-1]['stderr']:.1e} ({n} paths)", flush=True)
    return out


def plot(data, path):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(5.5, 4))
    lv = data["levels"]
    ax.errorbar([r["level"] for r in lv], [r["mean"] for r in lv],
                yerr=[1.96 * r["stderr"] for r in lv], fmt="o-", capsize=3)
    ax.set_yscale("log")
    ax.set_xlabel("level l (the base step / 2^l)")
    ax.set_ylabel("mean of Y_l, the distance at the stop")
    ax.set_title(f"limit {data['limit']:.5f} +- {data['limit_stderr']:.5f}; "
                 f"tail after level 2 {data['tail_after_2']:.2e}", fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=110)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--paths", type=int, default=600 * 65536)
    ap.add_argument("--levels", type=int, default=5)
    ap.add_argument("--level-paths", type=int, default=1 << 20)
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--publish", action="store_true")
    a = ap.parse_args()
    eng, i, slot = engine(a.threads)
    levels = level_means(eng, slot, a.levels, a.level_paths)
    b = base(eng, i, slot, a.paths)
    # The levels beyond the last, summed at the last two levels' measured ratio.
    ratio = levels[-2]["mean"] / levels[-1]["mean"]
    rest = levels[-1]["mean"] / (ratio - 1.0)
    total = sum(r["mean"] for r in levels) + rest
    data = {"base": b, "levels": levels, "ratio_last": ratio, "rest_after_last": rest,
            "limit": b["mean"] + total,
            "limit_stderr": float(np.sqrt(b["stderr"] ** 2
                                          + sum(r["stderr"] ** 2 for r in levels))),
            "tail_after_2": total - levels[0]["mean"] - levels[1]["mean"],
            "command": " ".join(["bench/filtered_truncation.py"] + sys.argv[1:]),
            "crandall": crandall.__version__}
    print(f"base {b['mean']:.5f} +- {b['stderr']:.5f}, limit {data['limit']:.5f} +- "
          f"{data['limit_stderr']:.5f}, tail after level 2 {data['tail_after_2']:.3e}, "
          f"beta . mean(controls) {b['beta_dot_control_means']:.2e} +- "
          f"{b['beta_dot_control_means_stderr']:.1e}")
    print(write("filtered_truncation", data, plot, publish=a.publish))


if __name__ == "__main__":
    main()
