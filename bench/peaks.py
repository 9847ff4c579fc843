"""The discretisation error of the peaks: the largest speed and |displacement| over the grid
points fall short of the path's own maxima. How much, at the default step?

The peak speed max |U1| is the maximum of a diffusion sampled on a grid: its shortfall falls
like sqrt(dt) (Asmussen, Glynn & Pitman, Ann. Appl. Probab. 5 (1995) 875-896: for a Brownian
motion of volatility sigma, E[max] - E[grid max] ~ -zeta(1/2)/sqrt(2 pi) sigma sqrt(dt),
0.5826 sigma sqrt(dt)). The peak displacement max |U2| is the maximum of a C1 path: at its
maximum U2' = U1 = 0, so its shortfall is of higher order.

Measured here: the mean peak speed and peak displacement at tau = 1 and tau = tau0 = 5 (scaled
units, exact method, uniform grid) at dt = 0.08, 0.04, ..., 0.0025, and at the default grid
(dt = None: 0.01, graded); each mean fitted by M(dt) = M0 - c dt^p (weighted least squares
over the uniform grids), the bias at the default grid is M(default) - M0 with its standard
error, and the sqrt(dt) correction's residual: M(dt) + 0.5826 sqrt(2) sqrt(dt) - M0 (the
velocity's volatility is sqrt(2)).

Writes bench/out/peaks.json and bench/out/peaks.png; --publish copies both to bench/results/.

    .venv/bin/python bench/peaks.py [--quick] [--publish]
"""

from __future__ import annotations

import argparse
import math
import os
import sys
import time
from pathlib import Path

import numpy as np
from scipy.optimize import curve_fit

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
from _publish import write  # noqa: E402

TAU0 = 5.0
TIMES = [1.0, TAU0]
DTS = [0.08, 0.04, 0.02, 0.01, 0.005, 0.0025]
#: -zeta(1/2) / sqrt(2 pi): the Brownian grid maximum's shortfall over sigma sqrt(dt).
AGP = 0.5825971579390106
SIGMA = math.sqrt(2.0)


def model(dt, m0, c, p):
    return m0 - c * dt ** p


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--publish", action="store_true")
    args = ap.parse_args()
    import crandall

    paths = 20_000 if args.quick else 400_000
    scene = crandall.Scene.scaled(tau0=TAU0, times=TIMES,
                                  observe=["velocity", "displacement", "peaks"])
    runs = {}
    start = time.perf_counter()
    for dt in DTS + [None]:
        r = crandall.simulate(scene, paths=paths, seed=20261121, dt=dt, method="exact",
                              threads=2)
        key = "default" if dt is None else f"{dt:g}"
        runs[key] = {"dt": r.dt, "min_steps": r.min_steps, "steps_per_path": r.steps_per_path,
                     **{n: {"mean": r.mean(n).tolist(), "stderr": r.stderr(n).tolist()}
                        for n in ("peak_speed", "peak_displacement")}}
        print(f"dt={key}: peak speed {r.mean('peak_speed')}, peak displacement "
              f"{r.mean('peak_displacement')}", flush=True)
    out = {"script": "bench/peaks.py",
           "command": "python bench/peaks.py" + (" --quick" if args.quick else "")
           + (" --publish" if args.publish else ""),
           "crandall_version": crandall.__version__, "paths": paths, "tau0": TAU0,
           "times": TIMES, "method": "exact", "seconds": time.perf_counter() - start,
           "load": [round(x, 2) for x in os.getloadavg()], "runs": runs, "fits": {}}
    dts = np.array(DTS)
    for name in ("peak_speed", "peak_displacement"):
        for i, tau in enumerate(TIMES):
            m = np.array([runs[f"{d:g}"][name]["mean"][i] for d in DTS])
            se = np.array([runs[f"{d:g}"][name]["stderr"][i] for d in DTS])
            try:
                (m0, c, p), cov = curve_fit(model, dts, m, p0=(m[-1], 1.0, 0.5), sigma=se,
                                            absolute_sigma=True, maxfev=20000)
                m0_se, p_se = float(math.sqrt(cov[0, 0])), float(math.sqrt(cov[2, 2]))
            except RuntimeError:
                m0 = c = p = m0_se = p_se = math.nan
            d = runs["default"][name]
            bias = d["mean"][i] - m0
            entry = {"M0": m0, "M0_stderr": m0_se, "c": c, "p": p, "p_stderr": p_se,
                     "default_mean": d["mean"][i], "default_stderr": d["stderr"][i],
                     "default_bias": bias,
                     "default_bias_stderr": math.hypot(d["stderr"][i], m0_se),
                     "default_relative_bias": bias / m0}
            if name == "peak_speed":
                corrected = m + AGP * SIGMA * np.sqrt(dts)
                entry["sqrt_dt_correction_residual"] = (corrected - m0).tolist()
                entry["default_corrected_residual"] = (
                    d["mean"][i] + AGP * SIGMA * math.sqrt(runs["default"]["dt"]) - m0)
            out["fits"][f"{name}@tau={tau:g}"] = entry
            print(f"{name} at tau={tau:g}: M0 {m0:.5f} ± {m0_se:.5f}, p {p:.3f} ± {p_se:.3f}, "
                  f"bias at the default grid {bias:+.5f} ({100 * bias / m0:+.2f} %)", flush=True)
    write("peaks", out, plot, publish=args.publish)


def plot(out: dict, path: Path) -> None:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import matplotlib.ticker

    fig, axes = plt.subplots(1, 2, figsize=(11, 4.2), constrained_layout=True)
    dts = np.array(DTS)
    for ax, name in zip(axes, ("peak_speed", "peak_displacement")):
        for i, tau in enumerate(out["times"]):
            f = out["fits"][f"{name}@tau={tau:g}"]
            m = np.array([out["runs"][f"{d:g}"][name]["mean"][i] for d in DTS])
            se = np.array([out["runs"][f"{d:g}"][name]["stderr"][i] for d in DTS])
            short = f["M0"] - m
            ax.errorbar(dts, short, yerr=1.96 * se, fmt="o", color=f"C{i}",
                        label=f"tau = {tau:g}: M0 - M(dt)")
            grid = np.geomspace(dts.min(), dts.max(), 50)
            ax.plot(grid, f["c"] * grid ** f["p"], color=f"C{i}",
                    label=f"fit c dt^p, p = {f['p']:.2f} ± {f['p_stderr']:.2f}")
        if name == "peak_speed":
            ax.plot(grid, AGP * SIGMA * np.sqrt(grid), "k--", lw=1,
                    label="0.5826 sqrt(2) sqrt(dt) (Brownian)")
        ax.set_xscale("log")
        ax.xaxis.set_minor_formatter(matplotlib.ticker.NullFormatter())
        ax.set_yscale("symlog", linthresh=1e-4)
        ax.set_xlabel("dt (scaled)")
        ax.set_ylabel("shortfall of the mean grid maximum")
        ax.set_title(name.replace("_", " "))
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7)
    fig.suptitle(f"Discretisation error of the peaks ({out['paths']:,} paths per dt, exact "
                 "method, tau0 = 5)")
    fig.savefig(path, dpi=90)
    plt.close(fig)


if __name__ == "__main__":
    main()
