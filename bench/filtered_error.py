"""Calibration of runs to an accuracy of a filtered excitation (``simulate(scene, error=EPS)``
on a Kanai-Tajimi scene: crandall.model.FILTERED_LEVELS, docs/methods/adaptive.md).

Over many independent seeds, per case and target: how often the reported 95 % interval
(estimate +- 1.96 x ``Result.error``) holds the reference, and how often the estimate is within
the target itself (the target bounds the root-mean-square error, so this is a one-standard-
error claim: about 68 % or more, not 95 %), each with its Clopper-Pearson 95 % interval.

References, none from the code under test:

- ``frictionless``: mu = 0, so the body's velocity is minus the ground velocity, V = -G with
  G the integral of a_g, and its displacement -D with D the integral of G: their variances
  are the filter's augmented covariance, Van Loan's integral computed here with SciPy's
  expm; the mean distance int_0^t E|V| ds = sqrt(2 / pi) int_0^t sd V(s) ds (V Gaussian) by
  SciPy's quad.
- ``frictionless_peaks``: the same scene with the peaks observed. V = -G and U = -D, a
  Gaussian process, so the peak speed and the peak displacement up to t are the maxima over
  [0, t] of |G| and |D|: simulated here in NumPy from the filter's exact discretisation (SciPy's
  expm of Van Loan's block matrix) on a fine grid (PEAK_REF_STEP), whose every 2nd and 4th point
  give two coarser grids on the same paths; the mean and variance of each maximum are
  extrapolated to dt -> 0 from the three grids (the measured ratio of the paired differences),
  and the reference's standard error is its statistical one plus the whole extrapolation
  correction (as if it were all wrong), added in quadrature.
- ``euler_omega_tstar_4`` and ``_1``: the mean distance at the stop against the Euler anchors
  measured outside the project (32,000 paths at dt = 2.5e-4 s, zeta = 0.6, mu g = 1, h = 1,
  t0 = 10 s, static = kinetic friction): 0.776 +- 0.003 and 0.168 +- 0.002 of the white-noise
  value h^2 t0 / (2 mu g) = 5 at omega t* = 4 and 1 (tests/test_filtered.py). Their standard
  errors (0.015 and 0.01) are of the order of the runs' errors, so the interval is also
  counted with them added in quadrature ("coverage_with_reference_se").
- ``frictionless_envelope``: mu = 0 under a smooth envelope sin(pi t / 4)^2 on [0, 4] s given
  as 4 pieces (the run chooses finer pieces and adds their error to the bias,
  crandall.pieces): the variances of V and of the displacement from the covariance ODE
  dP/dt = A P + P A^T + e(t)^2 b b^T of the same augmented state (SciPy's solve_ivp, DOP853,
  rtol 1e-11), which knows nothing of pieces; the mean distance sqrt(2 / pi) int sd V by
  SciPy's quad on the ODE's dense output.
- ``friction_omega_tstar_4``: mu g = 1, omega = 2 (omega t* = 4), t0 = 10 s, output at 5 s:
  the variance and the mean of the distance at the stop, the mean distance and the variance
  of the velocity at 5 s against the Euler peer bench/peers/numba_kt.py (``coupled_at``: the
  same paths at dt and 2 dt on the same noise), extrapolated to dt -> 0 at first order per
  path (2 X(dt) - X(2 dt); for a variance 2 Var(dt) - Var(2 dt), its standard error from the
  influence function 2 (X - mean)^2 - (X' - mean')^2) at dt = 2e-3, 1e-3 and 5e-4 s; the
  finest is the reference, its standard error counted as above, the coarser two check the
  first-order extrapolation. Cached in bench/results/filtered_error_friction_reference.json
  (--recompute-reference to redo it). Where bench/results/filtered_error_friction_controlled.json
  exists (--controlled-euler K: the same peer with control variates of its own,
  numba_kt.coupled_at_controls, cross-fitted; --controlled-dt for its step), its pooled
  blocks at the finest step are the reference instead (controlled_reference: standard errors
  3-7x smaller, plus a third of the difference to the blocks at twice that step, the
  extrapolation's second-order rest); ``friction_omega_tstar_4_means_error_0.004`` runs the
  two means alone against it.
- ``stop_time_omega_tstar_4_*`` and ``stop_time_omega_tstar_1_*``: the friction scene at
  omega = 2 and 0.5 with the stop observed: the mean and the variance of the stop time (the
  last time at rest) against bench/stop_time_reference.py (bench/results/
  stop_time_reference.json): the Euler peer with the touches of a body at rest counted by the
  Brownian bridge's probability, so that its bias is first order, extrapolated per path at
  three steps (which agree); its finest (pooled with more paths there at omega = 0.5) is the
  reference, with its standard error (also counted in quadrature,
  "coverage_with_reference_se").

Writes bench/out/filtered_error.{json,png} (bench/results/ with --publish).

    OMP_NUM_THREADS=1 .venv/bin/python bench/filtered_error.py [--seeds 200] [--threads 2] [--cases a,b]
        [--stem filtered_error] [--deadline HH:MM] [--recompute-reference] [--publish]
    .venv/bin/python bench/filtered_error.py --check-reference K   (K more Euler blocks)
    .venv/bin/python bench/filtered_error.py --recount STEM [--against controlled] [--publish]
        (STEM's stored per-seed values against the pooled Euler reference, or the controlled one)
    .venv/bin/python bench/filtered_error.py --controlled-euler K [--controlled-paths N]
        [--controlled-dt DT]   (K more controlled Euler blocks)
    OMP_NUM_THREADS=1 .venv/bin/python bench/filtered_error.py --refit 16384,0.25 ...
        (the base level's refit forced onto the cases' shorter runs, its count in "refit")
"""

from __future__ import annotations

import argparse
import datetime
import json
import math
import sys
import time
from pathlib import Path

import numpy as np
import scipy.integrate
import scipy.linalg
import scipy.stats

import crandall
from crandall import KanaiTajimi, Scene, envelopes
from _publish import HERE, write

Z95 = 1.959963984540054
ZETA = 0.6
T0 = 10.0
WHITE = T0 / 2.0  # h^2 t0 / (2 mu g) with h = mu g = 1
TIMES = (1.0, 5.0)
ENVELOPE_TIMES = (1.0, 2.0, 4.0)
ENVELOPE_DURATION = 4.0
FRICTION_TIME = 5.0
EULER_DT = (2e-3, 1e-3, 5e-4)
EULER_PATHS = 1_000_000
REFERENCE_CACHE = Path(__file__).resolve().parent / "results" / \
    "filtered_error_friction_reference.json"


def augmented_cov(omega: float, zeta: float, h: float, t: float) -> np.ndarray:
    """Cov of (x, x', G, D) at t from rest: Kanai-Tajimi's state, G = int a_g, D = int G,
    a_g = -omega^2 x - 2 zeta omega x', driven by -h dW (Van Loan's block exponential)."""
    w = omega
    a = np.array([[0.0, 1.0, 0.0, 0.0], [-w * w, -2 * zeta * w, 0.0, 0.0],
                  [-w * w, -2 * zeta * w, 0.0, 0.0], [0.0, 0.0, 1.0, 0.0]])
    b = np.array([0.0, -1.0, 0.0, 0.0])
    n = 4
    m = np.zeros((2 * n, 2 * n))
    m[:n, :n] = -a
    m[:n, n:] = np.outer(b, b) * h * h
    m[n:, n:] = a.T
    e = scipy.linalg.expm(m * t)
    return e[n:, n:].T @ e[:n, n:]


def frictionless_references(omega: float = 2.0):
    out = {}
    for i, t in enumerate(TIMES):
        c = augmented_cov(omega, ZETA, 1.0, t)
        out[("velocity", "var", i)] = (float(c[2, 2]), 0.0)
        out[("displacement", "var", i)] = (float(c[3, 3]), 0.0)
        sd_integral = scipy.integrate.quad(
            lambda s: math.sqrt(max(augmented_cov(omega, ZETA, 1.0, s)[2, 2], 0.0)), 0.0, t,
            limit=200, epsabs=1e-12, epsrel=1e-10)[0]
        out[("distance", "mean", i)] = (math.sqrt(2.0 / math.pi) * sd_integral, 0.0)
    return out


#: The NumPy reference of the peaks: its fine step, paths (in chunks) and generator seed.
PEAK_REF_STEP = 0.01
PEAK_REF_PATHS = 2_000_000
PEAK_REF_CHUNK = 200_000
PEAK_REF_SEED = 20261127
#: What the peaks' reference measured (the grids' statistics, the ratios, the corrections),
#: written into the JSON when it was computed.
PEAK_REFERENCE_INFO = {}


def _transition(omega: float, zeta: float, h: float, step: float):
    """(Phi, a square root of Q) of (x, x', G, D) over ``step`` (Van Loan's block exponential,
    as augmented_cov)."""
    w = omega
    a = np.array([[0.0, 1.0, 0.0, 0.0], [-w * w, -2 * zeta * w, 0.0, 0.0],
                  [-w * w, -2 * zeta * w, 0.0, 0.0], [0.0, 0.0, 1.0, 0.0]])
    b = np.array([0.0, -h, 0.0, 0.0])
    m = np.zeros((8, 8))
    m[:4, :4], m[:4, 4:], m[4:, 4:] = -a, np.outer(b, b), a.T
    e = scipy.linalg.expm(m * step)
    phi = e[4:, 4:].T
    q = phi @ e[:4, 4:]
    ev, v = np.linalg.eigh(0.5 * (q + q.T))
    return phi, v * np.sqrt(np.clip(ev, 0.0, None))


def frictionless_peak_references(omega: float = 2.0):
    """(name, stat, time index) -> (value, se): the mean and variance of max_[0,t] |G| (the
    peak speed) and max_[0,t] |D| (the peak displacement) at TIMES, extrapolated to dt -> 0 from
    the maxima over the NumPy paths' points on the grids PEAK_REF_STEP x 1, 2, 4."""
    if "references" in PEAK_REFERENCE_INFO:
        return PEAK_REFERENCE_INFO["references"]
    # Kept in bench/out between invocations with the same parameters (a few minutes' work).
    params = {"omega": omega, "zeta": ZETA, "times": list(TIMES), "step": PEAK_REF_STEP,
              "paths": PEAK_REF_PATHS, "chunk": PEAK_REF_CHUNK, "seed": PEAK_REF_SEED}
    cache = HERE / "out" / "filtered_error_peak_reference.json"
    if cache.exists():
        kept = json.loads(cache.read_text())
        if kept["params"] == params:
            PEAK_REFERENCE_INFO.update(kept["info"])
            PEAK_REFERENCE_INFO["references"] = {
                tuple(k.split("|")[:2]) + (int(k.split("|")[2]),): tuple(v)
                for k, v in kept["references"].items()}
            return PEAK_REFERENCE_INFO["references"]
    began = time.perf_counter()
    phi, root = _transition(omega, ZETA, 1.0, PEAK_REF_STEP)
    a_t, b_t = phi.T.copy(), root.T.copy()
    ends = [int(round(t / PEAK_REF_STEP)) for t in TIMES]
    assert all(abs(e * PEAK_REF_STEP - t) < 1e-12 for e, t in zip(ends, TIMES))
    subs = (1, 2, 4)
    # Per (quantity column, time, grid): sums of x - shift to the powers 1-4, and of the paired
    # differences (grid s minus grid 2s) of x and of (x - shift)^2 with their squares.
    shift = None
    sums = np.zeros((2, len(TIMES), len(subs), 4))
    dsums = np.zeros((2, len(TIMES), len(subs) - 1, 2, 2))
    n_total = 0
    seeds = np.random.SeedSequence(PEAK_REF_SEED).spawn(PEAK_REF_PATHS // PEAK_REF_CHUNK)
    for seed in seeds:
        n = PEAK_REF_CHUNK
        rng = np.random.Generator(np.random.SFC64(seed))
        y, y2, z = np.zeros((n, 4)), np.empty((n, 4)), np.empty((n, 4))
        peaks = np.zeros((len(subs), 2, n))  # per grid: max |G|, max |D|
        tmp = np.empty(n)
        for k in range(1, ends[-1] + 1):
            rng.standard_normal(out=z)
            np.matmul(y, a_t, out=y2)
            y2 += z @ b_t
            y, y2 = y2, y
            for g, s in enumerate(subs):
                if k % s == 0:
                    for col in (0, 1):
                        np.abs(y[:, 2 + col], out=tmp)
                        np.maximum(peaks[g, col], tmp, out=peaks[g, col])
            if k in ends:
                ti = ends.index(k)
                if shift is None:
                    shift = np.zeros((2, len(TIMES)))
                if n_total == 0:
                    shift[:, ti] = peaks[0].mean(axis=1)
                for col in (0, 1):
                    c = peaks[:, col] - shift[col, ti]
                    for p in range(4):
                        sums[col, ti, :, p] += (c ** (p + 1)).sum(axis=1)
                    for g in range(len(subs) - 1):
                        dm = c[g] - c[g + 1]
                        dv = c[g] ** 2 - c[g + 1] ** 2
                        dsums[col, ti, g, 0] += [dm.sum(), (dm * dm).sum()]
                        dsums[col, ti, g, 1] += [dv.sum(), (dv * dv).sum()]
        n_total += n
        print(f"peak reference: {n_total} paths, {time.perf_counter() - began:.0f} s",
              file=sys.stderr, flush=True)
    n = n_total
    out, info = {}, {"step": PEAK_REF_STEP, "paths": n, "seed": PEAK_REF_SEED,
                     "grids": [PEAK_REF_STEP * s for s in subs], "rows": {}}
    for col, name in enumerate(("peak_speed", "peak_displacement")):
        for ti in range(len(TIMES)):
            m = sums[col, ti] / n  # raw moments of x - shift, per grid
            mean = m[:, 0]
            var = (m[:, 1] - mean ** 2) * n / (n - 1)
            # Central fourth moment of the finest grid, for the variance's standard error.
            m1, m2, m3, m4 = m[0]
            c4 = m4 - 4 * m1 * m3 + 6 * m1 ** 2 * m2 - 3 * m1 ** 4
            se = {"mean": math.sqrt(var[0] / n),
                  "var": math.sqrt(max(c4 - var[0] ** 2, 0.0) / n)}
            for stat, values, idx in (("mean", mean + shift[col, ti], 0), ("var", var, 1)):
                # Paired differences finer minus coarser grid: d1 (dt, 2 dt), d2 (2 dt, 4 dt).
                d = []
                for g in range(len(subs) - 1):
                    s1, s2 = dsums[col, ti, g, idx]
                    dm = s1 / n
                    if stat == "var":
                        # Var_f - Var_2f = E[c_f^2 - c_2f^2] - (E c_f)^2 + (E c_2f)^2.
                        dm = (dm - mean[g] ** 2 + mean[g + 1] ** 2) * n / (n - 1)
                    d.append((dm, math.sqrt(max(s2 / n - (s1 / n) ** 2, 0.0) / n)))
                (d1, se1), (d2, se2) = d
                ratio = d2 / d1 if d1 != 0 else math.inf
                # The rest beyond the finest grid, falling by the measured ratio per halving
                # where both differences are resolved and it exceeds 2, else first order's
                # (ratio 2: the rest is d1 itself).
                r = ratio if (abs(d1) > 2 * se1 and abs(d2) > 2 * se2 and ratio > 2) else 2.0
                correction = d1 / (r - 1.0)
                value = float(values[0] + correction)
                ref_se = math.hypot(se[stat], correction)
                out[(name, stat, ti)] = (value, ref_se)
                info["rows"][f"{name}_{stat}@{TIMES[ti]:g}"] = {
                    "grids": [float(v) for v in values], "d1": d1, "d1_se": se1, "d2": d2,
                    "d2_se": se2, "ratio": ratio, "ratio_used": r, "correction": correction,
                    "statistical_se": se[stat], "value": value, "se": ref_se}
    info["wall_time"] = time.perf_counter() - began
    PEAK_REFERENCE_INFO.update(info)
    PEAK_REFERENCE_INFO["references"] = out
    cache.parent.mkdir(exist_ok=True)
    cache.write_text(json.dumps({"params": params, "info": info, "references": {
        f"{k[0]}|{k[1]}|{k[2]}": list(v) for k, v in out.items()}}, indent=1))
    return out


def ramp(t: float) -> float:
    """The smooth envelope: sin(pi t / 4)^2 on [0, 4] s (zero slope at both ends)."""
    return math.sin(math.pi * t / ENVELOPE_DURATION) ** 2


def envelope_references(omega: float = 2.0):
    """Var V, Var of the displacement and E int |V| at ENVELOPE_TIMES without friction under
    the smooth envelope: the covariance ODE of (x, x', G, D) (SciPy), no pieces."""
    w = omega
    a = np.array([[0.0, 1.0, 0.0, 0.0], [-w * w, -2 * ZETA * w, 0.0, 0.0],
                  [-w * w, -2 * ZETA * w, 0.0, 0.0], [0.0, 0.0, 1.0, 0.0]])
    bb = np.outer([0.0, -1.0, 0.0, 0.0], [0.0, -1.0, 0.0, 0.0])

    def rhs(s, y):
        p = y.reshape(4, 4)
        return (a @ p + p @ a.T + ramp(s) ** 2 * bb).ravel()

    end = max(ENVELOPE_TIMES)
    sol = scipy.integrate.solve_ivp(rhs, (0.0, end), np.zeros(16), method="DOP853",
                                    rtol=1e-11, atol=1e-14, dense_output=True,
                                    t_eval=list(ENVELOPE_TIMES))
    assert sol.success, sol.message
    out = {}
    for i, t in enumerate(ENVELOPE_TIMES):
        p = sol.y[:, i].reshape(4, 4)
        out[("velocity", "var", i)] = (float(p[2, 2]), 0.0)
        out[("displacement", "var", i)] = (float(p[3, 3]), 0.0)
        sd_integral = scipy.integrate.quad(
            lambda s: math.sqrt(max(sol.sol(s)[10], 0.0)), 0.0, t, limit=200, epsabs=1e-13,
            epsrel=1e-10)[0]
        out[("distance", "mean", i)] = (math.sqrt(2.0 / math.pi) * sd_integral, 0.0)
    return out


#: The friction statistics the Euler peer gives: name, stat, column of coupled_at, index.
FRICTION_STATS = (("distance_at_stop", "var", 0, None), ("distance_at_stop", "mean", 0, None),
                  ("distance", "mean", 1, 0), ("velocity", "var", 2, 0))


def _extrapolated(fine: np.ndarray, coarse: np.ndarray, stat: str):
    """First-order extrapolation to dt -> 0 of paired runs at dt and 2 dt, per path: value,
    standard error, and the raw values at dt and 2 dt."""
    n = fine.size
    if stat == "mean":
        phi = 2.0 * fine - coarse
        return float(phi.mean()), float(phi.std(ddof=1) / math.sqrt(n)), float(fine.mean()), \
            float(coarse.mean())
    a, b = fine - fine.mean(), coarse - coarse.mean()
    phi = 2.0 * a * a - b * b  # the influence function of 2 Var(dt) - Var(2 dt)
    value = 2.0 * fine.var(ddof=1) - coarse.var(ddof=1)
    return float(value), float(phi.std(ddof=1) / math.sqrt(n)), float(fine.var(ddof=1)), \
        float(coarse.var(ddof=1))


def euler_reference(recompute: bool = False):
    """The friction references from the Euler peer (cached in REFERENCE_CACHE)."""
    if REFERENCE_CACHE.exists() and not recompute:
        return json.loads(REFERENCE_CACHE.read_text())
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    from peers import numba_kt
    numba_kt.warm_up()
    points = []
    for j, dt in enumerate(EULER_DT):
        start = time.perf_counter()
        fine, coarse = numba_kt.coupled_at(EULER_PATHS, dt, FRICTION_TIME, t0=T0, omega=2.0,
                                           zeta=ZETA, h=1.0, mu_g=1.0, seed=700 + j)
        point = {"dt": dt, "paths": EULER_PATHS, "seed": 700 + j,
                 "seconds": time.perf_counter() - start, "stats": {}}
        for name, stat, col, i in FRICTION_STATS:
            v, se, f, c = _extrapolated(fine[:, col], coarse[:, col], stat)
            point["stats"][f"{name}_{stat}"] = {"extrapolated": v, "stderr": se,
                                                 "at_dt": f, "at_2dt": c}
        points.append(point)
        print(f"Euler dt {dt:g}: {point['seconds']:.0f} s " + ", ".join(
            f"{k} {x['extrapolated']:.4f} +- {x['stderr']:.4f}"
            for k, x in point["stats"].items()), file=sys.stderr, flush=True)
    finest, next_ = points[-1], points[-2]
    refs = {}
    for name, stat, _, _ in FRICTION_STATS:
        k = f"{name}_{stat}"
        a, b = finest["stats"][k], next_["stats"][k]
        refs[k] = {"value": a["extrapolated"], "stderr": a["stderr"],
                   # First order holds if the extrapolations at dt and 2 dt agree: their
                   # difference over its standard error (independent paths).
                   "check_difference": a["extrapolated"] - b["extrapolated"],
                   "check_z": (a["extrapolated"] - b["extrapolated"])
                   / math.hypot(a["stderr"], b["stderr"])}
    data = {"how": "bench/peers/numba_kt.py coupled_at (Euler-Maruyama filter, Euler body, the "
                   "same noise at dt and 2 dt), omega = 2, zeta = 0.6, h = 1, mu g = 1 (static "
                   "= kinetic), t0 = 10 s, output at 5 s; per path 2 X(dt) - X(2 dt) (means) "
                   "and 2 Var(dt) - Var(2 dt) (variances, stderr from the influence function); "
                   "the reference is the finest dt's, the check compares it with the next.",
            "omega": 2.0, "zeta": ZETA, "h": 1.0, "mu_g": 1.0, "t0": T0,
            "output_time": FRICTION_TIME, "points": points, "references": refs}
    REFERENCE_CACHE.parent.mkdir(exist_ok=True)
    REFERENCE_CACHE.write_text(json.dumps(data, indent=1))
    return data


def finer_euler(blocks: int, paths: int, publish: bool):
    """The Euler peer at half the reference's finest step (dt = EULER_DT[-1] / 2, paired with
    EULER_DT[-1] on the same noise), in blocks of ``paths``: whether its step bias keeps
    halving with dt, which the first-order extrapolation of the reference assumes. Per block
    and pooled: the paired difference X(2 dt) - X(dt) (first order predicts half the
    reference's at EULER_DT[-1]: its ``at_2dt - at_dt``) and the extrapolated value 2 X(dt) -
    X(2 dt). Written after every block (an interrupted run keeps the blocks it finished)."""
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    from peers import numba_kt
    numba_kt.warm_up()
    ref = euler_reference()
    dt = EULER_DT[-1] / 2
    finest = ref["points"][-1]["stats"]
    out = {"dt": dt, "paths_per_block": paths, "blocks": [],
           "command": " ".join(["bench/filtered_error.py"] + sys.argv[1:])}
    cols = [(name, stat, col) for name, stat, col, _ in FRICTION_STATS]
    acc = {f"{n}_{s}": ([], []) for n, s, _ in cols}
    for j in range(blocks):
        start = time.perf_counter()
        fine, coarse = numba_kt.coupled_at(paths, dt, FRICTION_TIME, t0=T0, omega=2.0,
                                           zeta=ZETA, h=1.0, mu_g=1.0, seed=900 + j)
        block = {"seed": 900 + j, "seconds": time.perf_counter() - start, "stats": {}}
        for name, stat, col in cols:
            k = f"{name}_{stat}"
            v, se, f, c = _extrapolated(fine[:, col], coarse[:, col], stat)
            if stat == "mean":
                d = coarse[:, col] - fine[:, col]
                diff, diff_se = float(d.mean()), float(d.std(ddof=1) / math.sqrt(paths))
            else:
                a, b = coarse[:, col] - coarse[:, col].mean(), fine[:, col] - fine[:, col].mean()
                d = a * a - b * b
                diff, diff_se = c - f, float(d.std(ddof=1) / math.sqrt(paths))
            block["stats"][k] = {"extrapolated": v, "stderr": se, "at_dt": f, "at_2dt": c,
                                 "difference": diff, "difference_se": diff_se}
            acc[k][0].append((v, se))
            acc[k][1].append((diff, diff_se))
        out["blocks"].append(block)
        pooled = {}
        for k, (vals, diffs) in acc.items():
            w = [1 / se ** 2 for _, se in vals]
            wd = [1 / se ** 2 for _, se in diffs]
            prev = finest[k]["at_2dt"] - finest[k]["at_dt"]
            pooled[k] = {"extrapolated": sum(x * wi for (x, _), wi in zip(vals, w)) / sum(w),
                         "stderr": 1 / math.sqrt(sum(w)),
                         "difference": sum(x * wi for (x, _), wi in zip(diffs, wd)) / sum(wd),
                         "difference_se": 1 / math.sqrt(sum(wd)),
                         "reference_difference_at_2dt": prev,
                         "first_order_prediction": prev / 2,
                         "reference": ref["references"][k]["value"],
                         "reference_se": ref["references"][k]["stderr"]}
        out["pooled"] = pooled
        print(f"block {j}: {block['seconds']:.0f} s; " + "; ".join(
            f"{k} difference {p['difference']:.5f} +- {p['difference_se']:.5f} (first order "
            f"{p['first_order_prediction']:.5f}), extrapolated {p['extrapolated']:.5f} +- "
            f"{p['stderr']:.5f} (reference {p['reference']:.5f})" for k, p in pooled.items()),
            file=sys.stderr, flush=True)
        write("filtered_error_friction_finer", out, _plot_finer, publish=publish)


CONTROLLED_CACHE = Path(__file__).resolve().parent / "results" / \
    "filtered_error_friction_controlled.json"


def _controlled(y: np.ndarray, x: np.ndarray):
    """The mean of ``y`` minus a multiple of the mean-0 controls ``x`` (columns), cross-fitted:
    the coefficients are fitted by least squares on each half of the paths and applied to the
    other, so that no path's own noise enters its coefficient and the estimate stays unbiased.
    Returns the estimate, its standard error (from the residuals) and the share R^2 of y's
    variance the controls explain."""
    n = y.size
    halves = (slice(0, n // 2), slice(n // 2, n))
    resid = np.empty(n)
    for fit, use in ((halves[0], halves[1]), (halves[1], halves[0])):
        xf, yf = x[fit], y[fit]
        beta, *_ = np.linalg.lstsq(xf - xf.mean(0), yf - yf.mean(), rcond=None)
        resid[use] = y[use] - x[use] @ beta
    return float(resid.mean()), float(resid.std(ddof=1) / math.sqrt(n)), \
        float(1.0 - resid.var() / y.var())


def controlled_euler(blocks: int, paths: int, dt: float):
    """The friction references again, from the Euler peer with control variates
    (numba_kt.coupled_at_controls: sums of functions of the Euler filter's a_g, ground
    velocity and displacement, with exact means from the recursion's covariance, and sums of
    each step's noise times the body's state before it, with mean 0), at dt and 2 dt on the
    same noise, extrapolated per path at first order as ``euler_reference`` does. The controls
    leave each block's expectation unchanged and shrink its standard error 2-7x (R^2 0.55-0.98),
    so a few blocks pin the reference down. Blocks are added to CONTROLLED_CACHE after each
    one (an interrupted run keeps those it finished); each block also records every control's
    sample mean in standard errors (a check of the exact means)."""
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    from peers import numba_kt
    numba_kt.warm_up()
    data = (json.loads(CONTROLLED_CACHE.read_text()) if CONTROLLED_CACHE.exists()
            else {"how": controlled_euler.__doc__.split("\n\n")[0].replace("\n    ", " "),
                  "omega": 2.0, "zeta": ZETA, "h": 1.0, "mu_g": 1.0, "t0": T0,
                  "output_time": FRICTION_TIME, "controls": list(numba_kt.CONTROL_NAMES),
                  "blocks": []})
    for _ in range(blocks):
        seed = 1300 + len(data["blocks"])
        start = time.perf_counter()
        fine, coarse, x = numba_kt.coupled_at_controls(
            paths, dt, FRICTION_TIME, t0=T0, omega=2.0, zeta=ZETA, h=1.0, mu_g=1.0, seed=seed)
        block = {"dt": dt, "paths": paths, "seed": seed,
                 "seconds": time.perf_counter() - start, "stats": {},
                 "control_mean_z": [float(v) for v in
                                    x.mean(0) / (x.std(0, ddof=1) / math.sqrt(paths))]}
        for name, stat, col, _ in FRICTION_STATS:
            f, c = fine[:, col], coarse[:, col]
            if stat == "mean":
                y = 2.0 * f - c
            else:
                a, b = f - f.mean(), c - c.mean()
                y = 2.0 * a * a - b * b  # the influence function of 2 Var(dt) - Var(2 dt)
            v, se, r2 = _controlled(y, x)
            plain_v, plain_se = _extrapolated(f, c, stat)[:2]
            if stat == "var":
                v += plain_v - float(y.mean())  # the unbiased (ddof 1) variances' value
            block["stats"][f"{name}_{stat}"] = {"extrapolated": v, "stderr": se, "r2": r2,
                                                 "plain": plain_v, "plain_stderr": plain_se}
        data["blocks"].append(block)
        data["pooled"] = _pool_controlled(data["blocks"])
        data["command"] = " ".join(["bench/filtered_error.py"] + sys.argv[1:])
        CONTROLLED_CACHE.write_text(json.dumps(data, indent=1))
        pooled = data["pooled"][f"{dt:g}"]
        print(f"controlled block seed {seed} ({block['seconds']:.0f} s): " + "; ".join(
            f"{k} {b['extrapolated']:.5f} +- {b['stderr']:.5f} (R^2 {b['r2']:.2f}), pooled "
            f"at dt {dt:g} {pooled[k]['value']:.5f} +- {pooled[k]['stderr']:.5f}"
            for k, b in block["stats"].items()), file=sys.stderr, flush=True)


def _pool_controlled(blocks):
    """Per step dt (a key "%g"), each friction statistic's inverse-variance weighted mean of
    the controlled blocks at that dt, its standard error, and the chi^2 of their spread."""
    return {f"{dt:g}": _pool([b for b in blocks if b["dt"] == dt])
            for dt in sorted({b["dt"] for b in blocks})}


def _pool(blocks):
    """Each friction statistic's inverse-variance weighted mean of the blocks' extrapolated
    values, its standard error, and the chi^2 of their spread about it (with its p-value)."""
    out = {}
    for name, stat, _, _ in FRICTION_STATS:
        k = f"{name}_{stat}"
        w = np.array([1.0 / b["stats"][k]["stderr"] ** 2 for b in blocks])
        x = np.array([b["stats"][k]["extrapolated"] for b in blocks])
        value = float(np.sum(w * x) / np.sum(w))
        chi2 = float(np.sum(w * (x - value) ** 2))
        out[k] = {"value": value, "stderr": float(1.0 / math.sqrt(np.sum(w))),
                  "blocks": len(blocks), "chi2": chi2,
                  "chi2_p": float(scipy.stats.chi2.sf(chi2, len(blocks) - 1))
                  if len(blocks) > 1 else None}
    return out


def controlled_reference():
    """The friction references from the controlled Euler blocks at their finest step (each
    statistic's pooled value), or None without the cache. The first-order extrapolation
    leaves a term of second order, c dt^2 at dt and 4 c dt^2 at 2 dt: where blocks at twice
    the finest step exist, a third of the difference of the two steps' pooled values estimates
    it at the finest, and the reference's standard error ("stderr") is its statistical one and
    that estimate in quadrature ("statistical_stderr" and "extrapolation" keep both)."""
    if not CONTROLLED_CACHE.exists():
        return None
    blocks = json.loads(CONTROLLED_CACHE.read_text())["blocks"]
    pooled = _pool_controlled(blocks)
    dt = min(b["dt"] for b in blocks)
    out = pooled[f"{dt:g}"]
    coarser = pooled.get(f"{2 * dt:g}")
    for k, ref in out.items():
        ref["statistical_stderr"] = ref["stderr"]
        ref["extrapolation"] = (abs(coarser[k]["value"] - ref["value"]) / 3.0
                                if coarser is not None else 0.0)
        ref["stderr"] = math.hypot(ref["stderr"], ref["extrapolation"])
    return out


def _plot_finer(data, path):
    """The pooled paired differences at half the finest step against first order's halving."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    keys = list(data["pooled"])
    fig, ax = plt.subplots(figsize=(7, 3.6))
    x = np.arange(len(keys))
    got = [data["pooled"][k]["difference"] / data["pooled"][k]["first_order_prediction"]
           for k in keys]
    err = [1.96 * data["pooled"][k]["difference_se"]
           / abs(data["pooled"][k]["first_order_prediction"]) for k in keys]
    ax.errorbar(x, got, yerr=err, fmt="o", capsize=3)
    ax.axhline(1.0, color="k", lw=0.8, ls="--", label="first order (half the previous)")
    ax.set_xticks(x)
    ax.set_xticklabels(keys, fontsize=7)
    ax.set_ylabel("paired difference / first-order prediction")
    ax.set_title(f"Euler at dt = {data['dt']:g} s and twice it ({len(data['blocks'])} blocks)")
    ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=110)


def reference_check(blocks: int):
    """More independent blocks of EULER_PATHS paths at the coarsest step (its extrapolation
    agreed with the finer ones), added to the cache as "check_blocks": a tighter reference
    for the statistics whose extrapolation does not move with dt."""
    data = euler_reference()
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    from peers import numba_kt
    numba_kt.warm_up()
    done = data.setdefault("check_blocks", [])
    dt = EULER_DT[0]
    for j in range(blocks):
        seed = 710 + len(done)
        start = time.perf_counter()
        fine, coarse = numba_kt.coupled_at(EULER_PATHS, dt, FRICTION_TIME, t0=T0, omega=2.0,
                                           zeta=ZETA, h=1.0, mu_g=1.0, seed=seed)
        block = {"dt": dt, "paths": EULER_PATHS, "seed": seed,
                 "seconds": time.perf_counter() - start, "stats": {}}
        for name, stat, col, _ in FRICTION_STATS:
            v, se, f, c = _extrapolated(fine[:, col], coarse[:, col], stat)
            block["stats"][f"{name}_{stat}"] = {"extrapolated": v, "stderr": se,
                                                 "at_dt": f, "at_2dt": c}
        done.append(block)
        REFERENCE_CACHE.write_text(json.dumps(data, indent=1))
        print(f"check block seed {seed}: {block['seconds']:.0f} s " + ", ".join(
            f"{k} {x['extrapolated']:.4f} +- {x['stderr']:.4f}"
            for k, x in block["stats"].items()), file=sys.stderr, flush=True)


def pooled_reference():
    """Each friction statistic's inverse-variance weighted mean of every independent Euler
    extrapolation in the cache (the three steps and the check blocks), with its standard
    error: the extrapolations agree across dt (their paired differences halve with dt)."""
    data = euler_reference()
    return _pool(data["points"] + data.get("check_blocks", []))


def recount(stem: str, publish: bool, against: str = "pooled"):
    """The coverage of a friction calibration's stored per-seed values and errors against
    the pooled Euler reference (pooled_reference) instead of the finest step's alone, or
    (``against="controlled"``) against the controlled Euler blocks' (controlled_reference)."""
    src = Path(__file__).resolve().parent / "results" / f"{stem}.json"
    data = json.loads(src.read_text())
    pooled = controlled_reference() if against == "controlled" else pooled_reference()
    out = {"source": str(src.name), "reference_kind": against, "pooled_reference": pooled,
           "cases": {}}
    for cname, c in data["cases"].items():
        if not cname.startswith("friction_"):  # (the pooled reference is the friction case's)
            continue
        rel = c["rel_error"]
        rows = {}
        for rname, row in c["rows"].items():
            ref = pooled[rname.split("@")[0]]
            v, e = np.array(row["value"]), np.array(row["error"])
            n = v.size
            inside = int(np.sum(np.abs(v - ref["value"]) <= Z95 * e))
            inside_se = int(np.sum(np.abs(v - ref["value"]) <= Z95 * np.hypot(e, ref["stderr"])))
            z = (v - ref["value"]) / e
            rows[rname] = {"reference": ref["value"], "reference_se": ref["stderr"],
                           "seeds": n, "coverage": inside / n,
                           "coverage_interval": clopper_pearson(inside, n),
                           "coverage_with_reference_se": inside_se / n,
                           "coverage_with_reference_se_interval": clopper_pearson(inside_se, n),
                           "within_target_fraction":
                               float(np.mean(np.abs(v - ref["value"]) <= rel * abs(ref["value"]))),
                           "rms_z": float(np.sqrt(np.mean(z * z))), "mean_z": float(np.mean(z)),
                           "mean_difference": float(np.mean(v - ref["value"])),
                           "mean_difference_se": float(np.std(v, ddof=1) / math.sqrt(n))}
            print(f"{cname} {rname:24s} {against} ref {ref['value']:.5f} +- {ref['stderr']:.5f} "
                  f"(chi2 p {ref['chi2_p'] or 1.0:.2f}): coverage {inside / n:.3f} (with ref se "
                  f"{inside_se / n:.3f}, CP {rows[rname]['coverage_with_reference_se_interval'][0]:.3f}-"
                  f"{rows[rname]['coverage_with_reference_se_interval'][1]:.3f}), mean z "
                  f"{np.mean(z):+.2f}, {n} seeds")
        out["cases"][cname] = {"seeds": c["seeds"], "rows": rows}
    out["command"] = " ".join(["bench/filtered_error.py"] + sys.argv[1:])
    write(f"{stem}_recount" + ("_controlled" if against == "controlled" else ""), out, plot,
          publish=publish)


def cases(recompute_reference: bool = False):
    """name -> (scene, statistics, target kind, target, references: key -> (value, its se))."""
    frictionless = Scene(mu=0.0, g=1.0, excitation=KanaiTajimi(omega=2.0, zeta=ZETA, h=1.0),
                         t0=T0, times=list(TIMES),
                         observe=["velocity", "displacement", "distance"])
    refs = frictionless_references
    out = {}
    for rel in (0.02, 0.05):
        out[f"frictionless_rel_{rel:g}"] = (
            frictionless, ["velocity:var", "displacement:var", "distance:mean"], "rel_error",
            rel, refs)
    peaks = Scene(mu=0.0, g=1.0, excitation=KanaiTajimi(omega=2.0, zeta=ZETA, h=1.0), t0=T0,
                  times=list(TIMES), observe=["velocity", "displacement", "peaks"])
    for rel in (0.02, 0.01):
        out[f"frictionless_peaks_rel_{rel:g}"] = (
            peaks, ["peak_speed:mean", "peak_speed:var", "peak_displacement:mean",
                    "peak_displacement:var"], "rel_error", rel, frictionless_peak_references)
    # Nearly without friction (mu g = 1e-4): the default step is then the filter's 1 / omega
    # (0.5 s; level 0 at 2 s, graded), so coarse that the peaks' grid bias is a sizeable part
    # of the error and the bias estimate is put to the test. The friction's deceleration is at
    # most mu g, so |V + G| <= mu g t and |U + D| <= mu g t^2 / 2: the maxima differ from the
    # frictionless ones by at most that (and a variance by 2 sd delta + delta^2), counted as
    # the reference's error in quadrature with its standard error.
    mu_g = 1e-4
    tiny = Scene(mu=mu_g, g=1.0, excitation=KanaiTajimi(omega=2.0, zeta=ZETA, h=1.0), t0=T0,
                 times=list(TIMES), observe=["velocity", "displacement", "peaks"])

    def tiny_references():
        out = {}
        for (name, stat, i), (value, se) in frictionless_peak_references().items():
            t = TIMES[i]
            delta = mu_g * t if name == "peak_speed" else mu_g * t * t / 2.0
            if stat == "var":
                delta = 2.0 * math.sqrt(value) * delta + delta * delta
            out[(name, stat, i)] = (value, math.hypot(se, delta))
        return out

    for rel in (0.02, 0.01):
        out[f"tiny_friction_peaks_rel_{rel:g}"] = (
            tiny, ["peak_speed:mean", "peak_speed:var", "peak_displacement:mean",
                   "peak_displacement:var"], "rel_error", rel, tiny_references)
    for tag, omega, anchor, se, targets in (("euler_omega_tstar_4", 2.0, 0.776, 0.003,
                                             (0.03, 0.06)),
                                            ("euler_omega_tstar_1", 0.5, 0.168, 0.002,
                                             (0.02, 0.04))):
        sc = Scene(mu=1.0, g=1.0, excitation=KanaiTajimi(omega=omega, zeta=ZETA, h=1.0), t0=T0,
                   times=[T0], observe=["distance", "stop"])
        for eps in targets:
            out[f"{tag}_error_{eps:g}"] = (
                sc, ["distance_at_stop:mean"], "error", eps,
                lambda anchor=anchor, se=se: {
                    ("distance_at_stop", "mean", None): (anchor * WHITE, se * WHITE)})
    env = envelopes.from_function(ramp, ENVELOPE_DURATION, pieces=4)
    enveloped = Scene(mu=0.0, g=1.0, excitation=KanaiTajimi(omega=2.0, zeta=ZETA),
                      envelope=env, times=list(ENVELOPE_TIMES),
                      observe=["velocity", "displacement", "distance"])
    for rel in (0.02, 0.05):
        out[f"frictionless_envelope_rel_{rel:g}"] = (
            enveloped, ["velocity:var", "displacement:var", "distance:mean"], "rel_error", rel,
            envelope_references)
    friction = Scene(mu=1.0, g=1.0, excitation=KanaiTajimi(omega=2.0, zeta=ZETA, h=1.0), t0=T0,
                     times=[FRICTION_TIME], observe=["distance", "velocity", "stop"])

    def friction_refs():
        # The controlled Euler blocks' (standard errors 3-7x smaller), where they exist.
        r = controlled_reference() or euler_reference(recompute_reference)["references"]
        return {(name, stat, i): (r[f"{name}_{stat}"]["value"], r[f"{name}_{stat}"]["stderr"])
                for name, stat, _, i in FRICTION_STATS}

    for rel in (0.02, 0.05, 0.01, 0.014):
        out[f"friction_omega_tstar_4_rel_{rel:g}"] = (
            friction, [f"{name}:{stat}" for name, stat, _, _ in FRICTION_STATS], "rel_error",
            rel, friction_refs)

    def friction_mean_refs():
        return {k: v for k, v in friction_refs().items() if k[1] == "mean"}

    # The means alone to an absolute error of 0.004 (0.1 % at the stop, 0.26 % at 5 s): the
    # controls leave few base paths, so the bias estimate is a large part of the error; the
    # controlled reference's standard errors (about 2e-4) are far below it.
    out["friction_omega_tstar_4_means_error_0.004"] = (
        friction, ["distance_at_stop:mean", "distance:mean"], "error", 0.004,
        friction_mean_refs)
    # The stop time (the last time at rest) against bench/stop_time_reference.py's Euler peer
    # with the Brownian-bridge touches counted, extrapolated to dt -> 0 (stop_time_references).
    for tag, omega, kind, target in (("omega_tstar_4", 2.0, "error", 0.01),
                                     ("omega_tstar_4", 2.0, "error", 0.003),
                                     ("omega_tstar_1", 0.5, "rel_error", 0.01)):
        sc = Scene(mu=1.0, g=1.0, excitation=KanaiTajimi(omega=omega, zeta=ZETA, h=1.0), t0=T0,
                   times=[T0], observe=["distance", "stop"])
        out[f"stop_time_{tag}_{'error' if kind == 'error' else 'rel'}_{target:g}"] = (
            sc, ["stop_time:mean", "stop_time:var"], kind, target,
            lambda omega=omega: stop_time_references(omega))
    return out


STOP_TIME_REFERENCE = Path(__file__).resolve().parent / "results" / "stop_time_reference.json"


def stop_time_references(omega: float):
    """The stop time's mean and variance at omega: bench/stop_time_reference.py's reference
    (an Euler peer, its touches at rest counted by the Brownian bridge's probability; the
    finest step's extrapolated values, pooled with the paths of its --more where run), each
    with its standard error."""
    ref = json.loads(STOP_TIME_REFERENCE.read_text())["cases"][f"omega_{float(omega)}"]["reference"]
    return {("stop_time", stat, None): (ref[stat][0], ref[stat][1]) for stat in ("mean", "var")}


def clopper_pearson(k: int, n: int):
    lo = 0.0 if k == 0 else float(scipy.stats.beta.ppf(0.025, k, n - k + 1))
    hi = 1.0 if k == n else float(scipy.stats.beta.ppf(0.975, k + 1, n - k))
    return [lo, hi]


def key_name(key, times) -> str:
    name, stat, i = key
    return f"{name}_{stat}" + ("" if i is None else f"@{times[i]:g}")


#: With --refit: how many runs' rounds asked whether to refit, and how many did.
REFITS = {"asked": 0, "refitted": 0}


def force_refit(rule: str) -> None:
    """--refit PILOT,RATIO: the base level's refit (docs/methods/adaptive.md, "A refit for
    long runs") on runs far shorter than its own rule reaches, so that the calibration's cases
    check its estimates; the refits that happened are counted in REFITS."""
    from crandall.adaptive import levels, schedule
    pilot, ratio = rule.split(",")
    levels.REFIT_PILOT, levels.REFIT_RATIO = int(pilot), float(ratio)
    ask = schedule._Schedule._refits

    def counted(self, want):
        yes = ask(self, want)
        REFITS["asked"] += 1
        REFITS["refitted"] += int(yes)
        return yes

    schedule._Schedule._refits = counted


def run_case(name, case, seeds: int, first_seed: int, threads: int, deadline=None):
    scene, statistics, kind, target, refs = case
    refs = refs()  # computed (or read from the cache) only for the cases run
    times = list(scene.times)
    rows = {key_name(k, times): {"reference": v[0], "reference_se": v[1], "inside": 0,
                          "inside_with_reference_se": 0, "within_target": 0, "z": [],
                          "value": [], "error": [], "bias": []} for k, v in refs.items()}
    costs = []
    for s in range(first_seed, first_seed + seeds):
        if deadline is not None and datetime.datetime.now(datetime.timezone.utc) >= deadline:
            print(f"{name}: deadline reached after {s - first_seed} seeds", file=sys.stderr)
            break
        r = crandall.simulate(scene, seed=s, threads=threads, statistics=statistics,
                              **{kind: target})
        assert r.model == "filtered_levels"
        costs.append(r.cost)
        for key, (ref, ref_se) in refs.items():
            q, stat, i = key
            value = r.mean(q) if stat == "mean" else r.var(q)
            err, bias = r.error(q, stat), r.bias(q, stat)
            if i is not None:
                value, err, bias = value[i], err[i], bias[i]
            row = rows[key_name(key, times)]
            tol = target if kind == "error" else target * abs(ref)
            row["inside"] += int(abs(value - ref) <= Z95 * err)
            row["inside_with_reference_se"] += int(abs(value - ref) <= Z95 * math.hypot(err, ref_se))
            row["within_target"] += int(abs(value - ref) <= tol)
            row["z"].append(float((value - ref) / err))
            row["value"].append(float(value))
            row["error"].append(float(err))
            row["bias"].append(float(bias))
        print(f"{name} seed {s}: {time.strftime('%H:%M:%S')}", file=sys.stderr, flush=True)
    seeds = len(costs)
    if seeds == 0:
        return None
    for row in rows.values():
        row["coverage"] = row["inside"] / seeds
        row["coverage_interval"] = clopper_pearson(row["inside"], seeds)
        row["coverage_with_reference_se"] = row["inside_with_reference_se"] / seeds
        row["coverage_with_reference_se_interval"] = clopper_pearson(
            row["inside_with_reference_se"], seeds)
        row["within_target_fraction"] = row["within_target"] / seeds
        row["within_target_interval"] = clopper_pearson(row["within_target"], seeds)
        row["rms_z"] = float(np.sqrt(np.mean(np.square(row["z"]))))
        row["mean_z"] = float(np.mean(row["z"]))
        row["max_error"] = max(row["error"])
        row["mean_bias_over_error"] = float(np.mean(np.array(row["bias"]) / np.array(row["error"])))
    return {"scene": scene.to_dict(), "statistics": statistics, kind: target, "seeds": seeds,
            "first_seed": first_seed, "rows": rows,
            "wall_time_mean": float(np.mean([c["wall_time"] for c in costs])),
            "paths_mean": [float(np.mean([c["paths"][k] if k < len(c["paths"]) else 0
                                          for c in costs]))
                           for k in range(max(len(c["paths"]) for c in costs))]}


def plot(data, path):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    labels, cov, lo, hi = [], [], [], []
    for cname, c in data["cases"].items():
        for rname, row in c["rows"].items():
            labels.append(f"{cname} ({c['seeds']} seeds): {rname}")
            cov.append(row["coverage_with_reference_se"])
            lo.append(row["coverage_with_reference_se_interval"][0])
            hi.append(row["coverage_with_reference_se_interval"][1])
    y = np.arange(len(labels))
    fig, ax = plt.subplots(figsize=(8, 0.4 * len(labels) + 1.5))
    ax.errorbar(cov, y, xerr=[np.array(cov) - lo, np.array(hi) - cov], fmt="o")
    ax.axvline(0.95, color="g", label="nominal 95 %")
    ax.set_yticks(y, labels)
    ax.set_xlim(0.8, 1.0)
    ax.set_xlabel("coverage of the 95 % interval (with the reference's se; "
                  "Clopper-Pearson 95 %)")
    ax.legend(loc="lower left")
    fig.tight_layout()
    fig.savefig(path, dpi=110)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=200)
    ap.add_argument("--first-seed", type=int, default=1000)
    ap.add_argument("--threads", type=int, default=1)
    ap.add_argument("--cases", default=None, help="comma-separated subset of the cases")
    ap.add_argument("--stem", default="filtered_error", help="the output files' name")
    ap.add_argument("--deadline", default=None,
                    help="HH:MM UTC: start no seed after it (the JSON gives the seeds run)")
    ap.add_argument("--recompute-reference", action="store_true",
                    help="rerun the Euler references of the friction cases (else the cache)")
    ap.add_argument("--check-reference", type=int, default=0, metavar="K",
                    help="only add K blocks of Euler paths at the coarsest step to the "
                         "reference cache (a check of the friction references)")
    ap.add_argument("--recount", default=None, metavar="STEM",
                    help="only recount bench/results/STEM.json's per-seed values against the "
                         "pooled Euler reference (writes STEM_recount)")
    ap.add_argument("--finer-euler", type=int, default=0, metavar="K",
                    help="only run K blocks of --finer-paths Euler paths at half the "
                         "reference's finest step (a check of its first-order extrapolation)")
    ap.add_argument("--finer-paths", type=int, default=250_000)
    ap.add_argument("--against", choices=("pooled", "controlled"), default="pooled",
                    help="--recount's reference: the pooled Euler blocks or the controlled ones")
    ap.add_argument("--controlled-euler", type=int, default=0, metavar="K",
                    help="only add K blocks of the Euler peer with control variates to "
                         "results/filtered_error_friction_controlled.json (a tighter "
                         "reference for the friction statistics)")
    ap.add_argument("--controlled-paths", type=int, default=500_000)
    ap.add_argument("--controlled-dt", type=float, default=1e-3)
    ap.add_argument("--refit", default=None, metavar="PILOT,RATIO",
                    help="force the base level's refit onto these shorter runs: its pilot and "
                         "ratio (adaptive.levels.REFIT_PILOT, REFIT_RATIO), e.g. 16384,0.25")
    ap.add_argument("--publish", action="store_true")
    a = ap.parse_args()
    if a.refit:
        force_refit(a.refit)
    if a.controlled_euler:
        controlled_euler(a.controlled_euler, a.controlled_paths, a.controlled_dt)
        return
    if a.finer_euler:
        finer_euler(a.finer_euler, a.finer_paths, a.publish)
        return
    if a.check_reference:
        reference_check(a.check_reference)
        return
    if a.recount:
        recount(a.recount, a.publish, a.against)
        return
    t = time.perf_counter()
    deadline = None
    if a.deadline:
        now = datetime.datetime.now(datetime.timezone.utc)
        hh, mm = (int(x) for x in a.deadline.split(":"))
        deadline = now.replace(hour=hh, minute=mm, second=0, microsecond=0)
    chosen = cases(a.recompute_reference)
    if a.cases:
        chosen = {k: chosen[k] for k in a.cases.split(",")}
    data = {"seeds": a.seeds, "cases": {}}
    for name, case in chosen.items():
        done = run_case(name, case, a.seeds, a.first_seed, a.threads, deadline)
        if done is not None:
            data["cases"][name] = done
    if PEAK_REFERENCE_INFO:
        data["peak_reference"] = {k: v for k, v in PEAK_REFERENCE_INFO.items()
                                  if k != "references"}
    if any(n.startswith("friction_") for n in chosen):
        data["friction_reference"] = euler_reference()
    if a.refit:
        data["refit"] = dict(REFITS, rule=a.refit)
    data["wall_time_total"] = time.perf_counter() - t
    data["command"] = " ".join(["bench/filtered_error.py"] + sys.argv[1:])
    data["crandall"] = crandall.__version__
    for cname, c in data["cases"].items():
        for rname, row in c["rows"].items():
            print(f"{cname:22s} {rname:24s} coverage {row['coverage']:.3f} "
                  f"(with ref se {row['coverage_with_reference_se']:.3f}, "
                  f"CP {row['coverage_with_reference_se_interval'][0]:.3f}-"
                  f"{row['coverage_with_reference_se_interval'][1]:.3f})  within target "
                  f"{row['within_target_fraction']:.3f}  rms z {row['rms_z']:.2f}  "
                  f"mean z {row['mean_z']:+.2f}")
    for c in data["cases"].values():
        for row in c["rows"].values():
            # The per-seed values and errors stay (a recount against another reference,
            # --recount); z and the bias are summarised above.
            del row["z"], row["bias"]
    write(a.stem, data, plot, publish=a.publish)


if __name__ == "__main__":
    main()
