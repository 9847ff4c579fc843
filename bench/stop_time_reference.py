"""A reference for the mean and the variance of the stop time of a body sliding with Coulomb
friction on a foundation shaken by Kanai-Tajimi filtered white noise, independent of crandall
(it does not import it):

    x'' + 2 zeta omega x' + omega^2 x = -h xi(t)  (t < t0; no noise after),
    a_g = -(2 zeta omega x' + omega^2 x)  (a_g = 0 from t0 on),
    V' = -a_g - mu g sign(V) while sliding; at rest while |a_g| <= mu_s g,

zeta = 0.6, h = 1, mu g = mu_s g = 1, t0 = 10 s, from rest with the filter at 0, for omega = 2
and omega = 0.5. The stop time is the last time the body came to rest (a body at rest from
before t0 on stops when it came to rest).

How: the Euler-Maruyama peer bench/peers/numba_kt.py (``coupled_stop_at``: the same paths at
dt and 2 dt on the same Brownian increments) with a touch correction on both grids. a_g's noise
moves like a Brownian motion of variance rate r = (2 zeta omega h)^2, so over a step at whose
ends the body is at rest and |a_g| < K = mu_s g, a_g touches +-K inside the step with about the
Brownian bridge's probability p = exp(-2 (K - a0)(K - a1) / (r dt)) + exp(-2 (K + a0)(K + a1)
/ (r dt)); each touch is a micro-slide, so with probability p (a uniform from a generator of
its own) the last rest time moves to the middle of the step. Plain Euler misses these and its
stop time is biased by about C sqrt(dt); with them the bias is first order and is extrapolated
per path, X = 2 T(dt) - T(2 dt) (for the variance 2 Var(dt) - Var(2 dt), its standard error
from the influence function 2 (T - mean)^2 - (T' - mean')^2, T at dt and T' at 2 dt), at three
fine steps (independent paths per step): their extrapolated values must agree within their
errors (the ``agreement`` block: pairwise z-scores and a chi^2 of constancy), the finest is
the reference. Also per step: the plain means and variances on each grid and the paired step
difference T(dt) - T(2 dt) (halving with dt for a first-order bias); and plain Euler (no
touches) on the very same increments at one step, whose paired difference to the touch run
is the correction's size. Fixed seeds: 10000 case + 1000 step index + chunk (numpy's
default_rng; the touch uniforms from that seed's first SeedSequence child).

Writes bench/results/stop_time_reference.json and prints a table. One core, about 15 minutes:

    OMP_NUM_THREADS=1 NUMBA_NUM_THREADS=1 .venv/bin/python bench/stop_time_reference.py
        [--cases 2.0,0.5] [--paths 2.0:200000,0.5:1000000] [--chunk 100000]
    OMP_NUM_THREADS=1 NUMBA_NUM_THREADS=1 .venv/bin/python bench/stop_time_reference.py
        --more 0.5:2000000   (that many more paths at a case's finest step, pooled into its
        reference)
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
OUT = HERE / "results" / "stop_time_reference.json"

PARAMS = dict(zeta=0.6, h=1.0, mu_g=1.0, mus_g=1.0, t0=10.0)
#: Per omega: the fine steps (coarse 2 dt), the default paths per step, the plain-Euler step.
CASES = {
    2.0: dict(dts=(2e-3, 1e-3, 5e-4), paths=200_000, plain_dt=1e-3),
    0.5: dict(dts=(4e-3, 2e-3, 1e-3), paths=1_000_000, plain_dt=2e-3),
}
CASE_INDEX = {2.0: 1, 0.5: 2}

DESCRIPTION = (
    "Euler-Maruyama for the Kanai-Tajimi filter and Euler for the body (bench/peers/numba_kt.py "
    "coupled_stop_at), each path walked at dt and at 2 dt on the same Brownian increments (the "
    "coarse increment the sum of two fine ones). On both grids, a step with the body at rest at "
    "both ends and |a_g| < K = mu_s g at both ends counts a touch of +-K inside the step with the "
    "Brownian-bridge probability p = exp(-2 (K - a0)(K - a1) / (r dt)) + exp(-2 (K + a0)(K + a1) / "
    "(r dt)), r = (2 zeta omega h)^2 the variance rate of a_g's noise (a uniform from a separate "
    "generator; only steps before t0); a touch is a micro-slide, so the last rest time moves to "
    "the step's middle, the body's state unchanged. This removes plain Euler's ~sqrt(dt) bias of "
    "the stop time (last time at rest; a body sliding at t0 slides to rest at deceleration mu g), "
    "leaving a first-order bias, extrapolated per path as X = 2 T(dt) - T(2 dt) (mean +- its "
    "standard error) and for the variance 2 Var(dt) - Var(2 dt) with the standard error of the "
    "influence function 2 (T - m)^2 - (T' - m')^2. Three fine steps with independent paths check "
    "the extrapolation (their extrapolated values should agree); the finest is the reference.")


def mean_se(a: np.ndarray) -> tuple[float, float]:
    return float(a.mean()), float(a.std(ddof=1) / math.sqrt(len(a)))


def var_se(a: np.ndarray) -> tuple[float, float]:
    d2 = (a - a.mean()) ** 2
    return float(a.var(ddof=1)), float(d2.std(ddof=1) / math.sqrt(len(a)))


def summarise(fine: np.ndarray, coarse: np.ndarray) -> dict:
    """Plain and extrapolated mean and variance of the stop times fine (dt) and coarse (2 dt)."""
    n = len(fine)
    mf, mc = fine.mean(), coarse.mean()
    infl = 2.0 * (fine - mf) ** 2 - (coarse - mc) ** 2
    out = {"mean_fine": mean_se(fine), "mean_coarse": mean_se(coarse),
           "var_fine": var_se(fine), "var_coarse": var_se(coarse),
           "step_difference_mean": mean_se(fine - coarse),
           "extrapolated_mean": mean_se(2.0 * fine - coarse),
           "extrapolated_var": (float(2.0 * fine.var(ddof=1) - coarse.var(ddof=1)),
                                float(infl.std(ddof=1) / math.sqrt(n)))}
    return out


def agreement(values: list[tuple[float, float]]) -> dict:
    """Pairwise z-scores of independent estimates (value, se) and the chi^2 of a constant."""
    v = np.array([x[0] for x in values])
    s = np.array([x[1] for x in values])
    w = 1.0 / s ** 2
    m = float((w * v).sum() / w.sum())
    chi2 = float((w * (v - m) ** 2).sum())
    pairs = {f"{i}-{j}": round(float((v[i] - v[j]) / math.hypot(s[i], s[j])), 3)
             for i in range(len(v)) for j in range(i + 1, len(v))}
    return {"z_pairs": pairs, "chi2": chi2, "dof": len(v) - 1, "weighted_mean": m,
            "weighted_se": float(1.0 / math.sqrt(w.sum()))}


def run(kt, omega: float, dt: float, paths: int, chunk: int, step_index: int, touch: bool):
    """``paths`` coupled paths in chunks of ``chunk``: (fine, coarse) stop times, seeds, s."""
    fines, coarses, seeds = [], [], []
    t = time.perf_counter()
    done, c = 0, 0
    while done < paths:
        n = min(chunk, paths - done)
        seed = 10_000 * CASE_INDEX[omega] + 1_000 * step_index + c
        f, g = kt.coupled_stop_at(n, dt, omega, seed, t0=PARAMS["t0"], zeta=PARAMS["zeta"],
                                  h=PARAMS["h"], mu_g=PARAMS["mu_g"], mus_g=PARAMS["mus_g"],
                                  touch=touch)
        fines.append(f[:, 0])
        coarses.append(g[:, 0])
        seeds.append(seed)
        done += n
        c += 1
    return np.concatenate(fines), np.concatenate(coarses), seeds, time.perf_counter() - t


#: The step index of --more's seeds (the cases' own steps are 0, 1, 2).
MORE_INDEX = 9


def pooled(a, b):
    """The inverse-variance weighted mean of two independent estimates (value, se)."""
    wa, wb = 1.0 / a[1] ** 2, 1.0 / b[1] ** 2
    return [(wa * a[0] + wb * b[0]) / (wa + wb), 1.0 / math.sqrt(wa + wb)]


def more(kt, data, omega: float, paths: int, chunk: int) -> None:
    """--more: paths more at the finest step of a case already run, on seeds 10000 case + 1000
    MORE_INDEX + chunk, summarised as the case's rows are; the reference becomes the pool of the
    finest row and these (both the same estimator at the same step, independent)."""
    case = data["cases"][f"omega_{omega}"]
    fin = case["per_dt"][-1]
    fine, coarse, seeds, sec = run(kt, omega, fin["dt"], paths, chunk, MORE_INDEX, True)
    row = {"dt": fin["dt"], "coarse_dt": 2 * fin["dt"], "paths": paths, "seeds": seeds,
           "seconds": round(sec, 1), **summarise(fine, coarse)}
    case["finest_more"] = row
    case["reference"] = {"dt": fin["dt"], "paths": fin["paths"] + paths,
                         "mean": pooled(fin["extrapolated_mean"], row["extrapolated_mean"]),
                         "var": pooled(fin["extrapolated_var"], row["extrapolated_var"]),
                         "note": "the finest row pooled with finest_more (--more)"}
    print(f"omega {omega} dt {fin['dt']:g}, {paths} more paths ({sec:.0f} s): extrapolated mean "
          f"{fmt(row['extrapolated_mean'])}, var {fmt(row['extrapolated_var'])}; pooled "
          f"{fmt(case['reference']['mean'])}, {fmt(case['reference']['var'])}", flush=True)


def fmt(x: tuple[float, float]) -> str:
    return f"{x[0]:.5f} +- {x[1]:.5f}"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--cases", default="2.0,0.5")
    ap.add_argument("--paths", default="", help="omega:paths,... overriding the defaults")
    ap.add_argument("--chunk", type=int, default=100_000)
    ap.add_argument("--more", default="",
                    help="omega:paths: that many more paths at the case's finest step, on seeds "
                         "of their own, pooled into its reference (the cases already run)")
    args = ap.parse_args()
    sys.path.insert(0, str(HERE))
    from peers import numba_kt as kt
    kt.coupled_stop_at(10, 0.1, 1.0, 0, t0=1.0)  # compile outside the timings
    paths_over = {float(k): int(v) for k, v in
                  (p.split(":") for p in args.paths.split(",") if p)}

    data = json.loads(OUT.read_text()) if OUT.exists() else {}
    data.update({"what": "mean and variance of the stop time (last time at rest), Kanai-Tajimi "
                         "filtered white noise, Coulomb friction; reference independent of "
                         "crandall",
                 "method": DESCRIPTION, "parameters": PARAMS,
                 "script": "bench/stop_time_reference.py",
                 "peer": "bench/peers/numba_kt.py coupled_stop_at"})
    data.setdefault("cases", {})
    if args.more:
        omega, paths = float(args.more.split(":")[0]), int(args.more.split(":")[1])
        more(kt, data, omega, paths, args.chunk)
        OUT.write_text(json.dumps(data, indent=1))
        print(f"wrote {OUT}")
        return
    for omega in (float(c) for c in args.cases.split(",")):
        spec = CASES[omega]
        paths = paths_over.get(omega, spec["paths"])
        case = {"omega": omega, "paths_per_dt": paths, "dts": list(spec["dts"]),
                "per_dt": [], "seconds": 0.0}
        keep = {}
        for i, dt in enumerate(spec["dts"]):
            fine, coarse, seeds, sec = run(kt, omega, dt, paths, args.chunk, i, True)
            row = {"dt": dt, "coarse_dt": 2 * dt, "paths": paths, "seeds": seeds,
                   "seconds": round(sec, 1), **summarise(fine, coarse)}
            case["per_dt"].append(row)
            case["seconds"] += sec
            if dt == spec["plain_dt"]:
                keep = {"fine": fine, "coarse": coarse, "seeds": seeds, "i": i}
            print(f"omega {omega} dt {dt:g}: extrapolated mean {fmt(row['extrapolated_mean'])}"
                  f", var {fmt(row['extrapolated_var'])} ({sec:.0f} s)", flush=True)
        # Plain Euler (no touches) on the same Brownian increments as the touch run at plain_dt.
        dt = spec["plain_dt"]
        fine, coarse, seeds, sec = run(kt, omega, dt, paths, args.chunk, keep["i"], False)
        assert seeds == keep["seeds"]
        case["plain_euler"] = {
            "dt": dt, "coarse_dt": 2 * dt, "paths": paths, "seeds": seeds,
            "seconds": round(sec, 1), "note": "no touch correction, the same Brownian "
            "increments as the touch run at this dt; correction = touch - plain, paired",
            **summarise(fine, coarse),
            "correction_mean_fine": mean_se(keep["fine"] - fine),
            "correction_mean_coarse": mean_se(keep["coarse"] - coarse),
            "correction_var_fine": float(keep["fine"].var(ddof=1) - fine.var(ddof=1)),
            "correction_var_coarse": float(keep["coarse"].var(ddof=1) - coarse.var(ddof=1))}
        case["seconds"] = round(case["seconds"] + sec, 1)
        case["agreement_extrapolated_mean"] = agreement(
            [r["extrapolated_mean"] for r in case["per_dt"]])
        case["agreement_extrapolated_var"] = agreement(
            [r["extrapolated_var"] for r in case["per_dt"]])
        fin = case["per_dt"][-1]
        case["reference"] = {"dt": fin["dt"], "mean": fin["extrapolated_mean"],
                             "var": fin["extrapolated_var"]}
        data["cases"][f"omega_{omega}"] = case
        OUT.parent.mkdir(exist_ok=True)
        OUT.write_text(json.dumps(data, indent=1))

        print(f"\nomega = {omega}, {paths} paths per dt, {case['seconds']:.0f} s")
        print(f"{'dt':>7} {'mean T(dt)':>22} {'extrap. mean':>22} {'var T(dt)':>20} "
              f"{'extrap. var':>20} {'T(dt)-T(2dt)':>22}")
        for r in case["per_dt"]:
            print(f"{r['dt']:7.0e} {fmt(r['mean_fine']):>22} {fmt(r['extrapolated_mean']):>22} "
                  f"{fmt(r['var_fine']):>20} {fmt(r['extrapolated_var']):>20} "
                  f"{fmt(r['step_difference_mean']):>22}")
        pe = case["plain_euler"]
        print(f"plain Euler dt {pe['dt']:g}: mean {fmt(pe['mean_fine'])}, var "
              f"{fmt(pe['var_fine'])}, extrap. mean {fmt(pe['extrapolated_mean'])}; touch "
              f"correction of the mean {fmt(pe['correction_mean_fine'])} (2 dt: "
              f"{fmt(pe['correction_mean_coarse'])}), of the var "
              f"{pe['correction_var_fine']:.4f}")
        for k in ("agreement_extrapolated_mean", "agreement_extrapolated_var"):
            a = case[k]
            print(f"{k}: z {a['z_pairs']}, chi2 {a['chi2']:.2f} ({a['dof']} dof)")
        print(flush=True)
    print(f"wrote {OUT}")


if __name__ == "__main__":
    main()
