"""Multilevel rates on exactly coupled grids, and unbiased variance reduction, for the paper's scene.

The exact skeleton gives the velocity exactly in law at every grid point, and the grid of step
2h is every other point of the grid of step h: simulating one path on the finest grid
h_L = 2^-L gives, for every level l <= L (h_l = 2^-l, h_0 = 1), the trapezoid sums of that
level on *the same path*. The level differences P_l - P_(l-1) therefore couple perfectly, and
this bench measures, for every statistic the paper's curves use (scaled units, tau0 = 5,
outputs tau = 1 and 5, and the stop):

- alpha: |E[P_l - P_(l-1)]| ~ 2^(-alpha l)  (the bias decay);
- beta:  V_l = Var[P_l - P_(l-1)] ~ 2^(-beta l);
- gamma: the cost of a level-l sample, 5 2^l path-steps to tau0 (gamma = 1 by construction);

for the plain trapezoid levels and for Richardson-combined levels (the `richardson` method:
weights on h, 2h, 4h for the exponents 1.5 and 2), fitted as power laws with standard errors.
A mean statistic uses f(P) = P; a variance statistic uses f(P) = (P - m)^2 with m the analytic
mean (the delta-method form of E[P^2] - E[P]^2: its level differences are
Delta(P^2) - 2 m Delta(P), and its level-0 variance is the per-path variance of a sample
variance). The velocity and the stop time are exact at every level (the same grid value on
every level), so their level differences are identically 0.

Variance reduction that keeps the estimator unbiased, measured on the same paths:

- control variates with mean exactly 0: sums over the steps of level l of g(state at the step
  start) times a centred increment of the step, either the increment of the reflected driving
  Brownian motion B' of |X| (the sum of the fine steps' sqrt(h) Z; d|X| = -2 dt + sqrt 2 dB' +
  dL) or X(t_i) - E[X(t_i) | X(t_(i-1))] (closed form from the killed transition density).
  The coefficients are fitted on a pilot sample and applied to an independent main sample;
- antithetic pairs: the second path of each pair uses the negated normals and the same
  exponentials and coins (a measure-preserving map of the noise).

The controls include sign(X) dB (the increment of W away from the zeros); a second fit uses
only the controls without dM (JSON `*_cv_dB`, indices in `controls_without_dM`), which need no
transcendental function per step. Two Ito identities give other unbiased estimators of the
same statistics: E U3(tau) = tau/2 - E U1(tau)^2/4 (exact in law) and
Var U3(tau_s) = E[(1/2) int_0^tau0 U1^2] (statistics marked "(ito)").

Costs: Giles' MLMC allocation per statistic for eps in {1e-2, 1e-3, 1e-4} on the measured
levels (plain, with controls, with the base level chosen), the best single level, randomised
truncation (work per unit variance), and today's default (richardson, dt = 0.01), all in
path-steps. docs/methods/mlmc.md discusses the results.

The skeleton is simulated with NumPy's generator and the project's exact step formula
(tests/reference_rng.py): the law is what matters here, not the project's stream.

Writes bench/out/mlmc_rates.json and .png; --publish copies both to bench/results/.

    .venv/bin/python bench/mlmc_rates.py [--quick] [--publish]
"""

from __future__ import annotations

import argparse
import math
import os
import platform
import sys
import time
from pathlib import Path

import numpy as np
from scipy.special import erfcx, ndtr

from crandall import analytic

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent / "tests"))
from reference_rng import exact_step  # noqa: E402
from _publish import write  # noqa: E402

TAU0 = 5.0
TIMES = (1.0, 5.0)
DRIFT, NOISE = 2.0, math.sqrt(2.0)
EPS = (1e-2, 1e-3, 1e-4)
# richardson: sum w = 1, sum w_j 2^(j p) = 0 for p = 3/2, 2 (docs/methods/richardson.md)
_A = np.array([[1.0, 1.0, 1.0], [1.0, 2.0**1.5, 4.0**1.5], [1.0, 4.0, 16.0]])
W_RICH = np.linalg.solve(_A, np.array([1.0, 0.0, 0.0]))

# statistic -> (path quantity, kind, output time for the controls)
STATS = {
    "distance_mean@1": ("U3@1", "mean", 1.0),
    "distance_mean@5": ("U3@5", "mean", 5.0),
    "velocity_var@1": ("X@1", "var", 1.0),
    "velocity_var@5": ("X@5", "var", 5.0),
    "displacement_var@1": ("U2@1", "var", 1.0),
    "displacement_var@5": ("U2@5", "var", 5.0),
    "distance_var@1": ("U3@1", "var", 1.0),
    "distance_var@5": ("U3@5", "var", 5.0),
    "stop_time_mean": ("Ts", "mean", 5.0),
    "distance_at_stop_mean": ("U3s", "mean", 5.0),
    "distance_at_stop_var": ("U3s", "var", 5.0),
    "displacement_at_stop_var": ("U2s", "var", 5.0),
    # Ito identities (d(U1^2) = -4 |U1| dtau + 2 sqrt 2 U1 dW + 2 dtau): the same statistics
    # from other path functionals with the same expectation
    "distance_mean@1 (ito)": ("Id@1", "mean", 1.0),
    "distance_mean@5 (ito)": ("Id@5", "mean", 5.0),
    "distance_at_stop_var (ito)": ("IS", "mean", 5.0),
}
EXACT_IN_LAW = {"X@1", "X@5", "Ts", "Id@1", "Id@5"}


def analytic_means() -> dict:
    t = np.array(TIMES)
    d = analytic.distance_mean(t, TAU0)
    return {"U3@1": float(d[0]), "U3@5": float(d[1]), "U2@1": 0.0, "U2@5": 0.0, "X@1": 0.0, "X@5": 0.0,
            "U3s": TAU0 / 2, "U2s": 0.0, "Ts": float(analytic.stop_time_mean(TAU0)), "Id@1": 0.0, "Id@5": 0.0, "IS": 0.0}


def analytic_values() -> dict:
    t = np.array(TIMES)
    out = {}
    for i, tau in enumerate(TIMES):
        out[f"distance_mean@{tau:g}"] = float(analytic.distance_mean(t, TAU0)[i])
        out[f"velocity_var@{tau:g}"] = float(analytic.velocity_var(t, TAU0)[i])
        out[f"displacement_var@{tau:g}"] = float(analytic.displacement_var(t, TAU0)[i])
        out[f"distance_var@{tau:g}"] = float(analytic.distance_var(t, TAU0)[i])
    out["stop_time_mean"] = float(analytic.stop_time_mean(TAU0))
    out["distance_at_stop_mean"] = float(analytic.distance_at_stop_mean(TAU0))
    out["distance_at_stop_var"] = float(analytic.distance_at_stop_var(TAU0))
    out["displacement_at_stop_var"] = float(analytic.displacement_at_stop_var(TAU0))
    out["distance_mean@1 (ito)"] = out["distance_mean@1"]
    out["distance_mean@5 (ito)"] = out["distance_mean@5"]
    out["distance_at_stop_var (ito)"] = out["distance_at_stop_var"]
    return out


def cond_mean(x: np.ndarray, h: float) -> np.ndarray:
    """E[X(t + h) | X(t) = x] for dX = -c sign X dt + sigma dW, in closed form.

    If the path reaches 0 during the step its sign is a fair coin, so only the paths that do not
    reach 0 contribute: sign(x) E[(|x| + D) 1{no hit}], from the killed density (method of
    images). The image term is written with erfcx so that nothing overflows.
    """
    a = np.abs(x)
    v = NOISE * NOISE * h
    s = math.sqrt(v)
    m1 = a - DRIFT * h
    z2 = (a + DRIFT * h) / math.sqrt(2 * v)
    e = m1 * ndtr(m1 / s) + (a + DRIFT * h) * 0.5 * erfcx(z2) * np.exp(-(m1 * m1) / (2 * v))
    return np.sign(x) * e


N_CONTROLS = 22
# the controls without dM: no transcendental function per step (dM needs exp and erfcx)
DB_ONLY = list(range(8)) + list(range(15, 22))


def controls_increment(dB, dM, X0, U2, U3, r):
    """The control increments of one step of a level: g(state at the step start) * increment.

    g is chosen from the Ito representations: U3 + U1^2/4 - tau/2 = (sqrt 2/2) int |U1| dB'
    (so g = |X| for the distance, min(|X|/2, r) for its finite-horizon form, r the time left to
    the output), U2 = int (t - s) dU1 + drift terms (g = r, min(|X|/2, r) against dM), and the
    products with the running integrals for the second moments. The last seven use
    sign(X) dB, the increment of W = int sign(X) dB' away from the zeros, in place of dM: the
    same weights without the conditional mean's exp and erfcx.
    """
    a = np.abs(X0)
    k = np.minimum(0.5 * a, r)
    sB = np.sign(X0) * dB
    return (dB, a * dB, r * dB, k * dB, U3 * a * dB, U3 * k * dB, a * a * k * dB, U3 * dB,
            dM, r * dM, k * dM, U2 * dM, U2 * k * dM, X0 * a * k * dM, U2 * r * dM,
            sB, r * sB, k * sB, U2 * sB, U2 * k * sB, X0 * a * k * sB, U2 * r * sB)


def simulate(rng: np.random.Generator, n: int, L: int, with_controls: bool):
    """n paths (n/2 antithetic pairs: path j + n/2 negates path j's normals) on the grid 2^-L.

    Returns per level l = 0..L a dict of path quantities, and per level and output time the
    (n, N_CONTROLS) control sums (or None).
    """
    assert n % 2 == 0
    half = n // 2
    hL = 2.0**-L
    steps = int(round(TAU0 / hL))
    k1 = int(round(1.0 / hL))
    X = np.zeros(n)
    sx = np.zeros((L + 1, n))  # per level: sum of X at its grid points after 0
    sa = np.zeros((L + 1, n))
    sq = np.zeros((L + 1, n))
    snap = {}
    if with_controls:
        ctl = np.zeros((L + 1, 2, N_CONTROLS, n))
        dB = np.zeros((L + 1, n))
        Xs = np.zeros((L + 1, n))  # X at the level's last grid point
        sqh = math.sqrt(hL)
    for k in range(1, steps + 1):
        z = rng.standard_normal(half)
        z = np.concatenate([z, -z])
        e = np.tile(rng.standard_exponential(half), 2)
        c = np.tile((rng.random(half) < 0.5).astype(np.float64), 2)
        X = exact_step(X, hL, DRIFT, NOISE, z, e, c)
        aX = np.abs(X)
        if with_controls:
            dB += sqh * z
        for l in range(L, -1, -1):
            stride = 1 << (L - l)
            if k % stride:
                break  # coarser levels have a grid point only where finer ones do
            h = 2.0**-l
            if with_controls:
                s0 = (k - stride) * hL  # the step start
                X0 = Xs[l]
                # running trapezoid sums at the step start (their sums hold points up to s0)
                U2 = h * (sx[l] - 0.5 * X0)
                U3 = h * (sa[l] - 0.5 * np.abs(X0))
                dM = X - cond_mean(X0, h)
                for ti, tau in enumerate(TIMES):
                    if s0 + h <= tau + 1e-12:
                        inc = controls_increment(dB[l], dM, X0, U2, U3, tau - s0)
                        for j, v in enumerate(inc):
                            ctl[l, ti, j] += v
                dB[l] = 0.0
                Xs[l] = X
            sx[l] += X
            sa[l] += aX
            sq[l] += X * X
        if k == k1:
            snap["X@1"] = X.copy()
            snap["U2@1"] = (2.0 ** -np.arange(L + 1))[:, None] * (sx - 0.5 * X)
            snap["U3@1"] = (2.0 ** -np.arange(L + 1))[:, None] * (sa - 0.5 * aX)
    hs = (2.0 ** -np.arange(L + 1))[:, None]
    U2 = hs * (sx - 0.5 * X)
    U3 = hs * (sa - 0.5 * aX)
    q = {
        "X@1": np.broadcast_to(snap["X@1"], (L + 1, n)),
        "X@5": np.broadcast_to(X, (L + 1, n)),
        "U2@1": snap["U2@1"], "U3@1": snap["U3@1"], "U2@5": U2, "U3@5": U3,
        # the coast after tau0 in closed form (paper eq13a-eq14): stop at tau0 + |X|/2
        "Ts": np.broadcast_to(TAU0 + 0.5 * aX, (L + 1, n)),
        "U3s": U3 + 0.25 * X * X,
        "U2s": U2 + 0.25 * X * aX,
        # E U3(tau) = tau/2 - E U1(tau)^2/4: exact in law, no integral needed
        "Id@1": np.broadcast_to(0.5 - 0.25 * snap["X@1"] ** 2, (L + 1, n)),
        "Id@5": np.broadcast_to(0.5 * TAU0 - 0.25 * X * X, (L + 1, n)),
        # U3(tau_s) - tau0/2 = (sqrt 2/2) int_0^tau0 U1 dW, so Var U3(tau_s) = E[(1/2) int U1^2]
        "IS": 0.5 * hs * (sq - 0.5 * X * X),
    }
    return q, (ctl if with_controls else None)


def level_values(q: dict, stat: str, means: dict) -> np.ndarray:
    """f(P_l) for l = 0..L, shape (L + 1, n)."""
    key, kind, _ = STATS[stat]
    P = q[key]
    return P if kind == "mean" else (P - means[key]) ** 2


def rich_values(F: np.ndarray) -> np.ndarray:
    """Richardson-combined level values R_l = w0 F_l + w1 F_(l-1) + w2 F_(l-2), l = 2..L."""
    return W_RICH[0] * F[2:] + W_RICH[1] * F[1:-1] + W_RICH[2] * F[:-2]


def differences(F: np.ndarray) -> np.ndarray:
    """Row 0: the base level's values; row i > 0: level i minus level i - 1."""
    return np.concatenate([F[:1], F[1:] - F[:-1]])


class Acc:
    """Raw sums over batches of Y (rows), Y^2, Y^4, and of the antithetic pair averages."""

    def __init__(self):
        self.s = None

    def add(self, Y: np.ndarray):
        n = Y.shape[1]
        half = n // 2
        pa = 0.5 * (Y[:, :half] + Y[:, half:])
        parts = [np.full(Y.shape[0], float(n)), Y.sum(1), (Y**2).sum(1), (Y**3).sum(1), (Y**4).sum(1),
                 np.full(Y.shape[0], float(half)), pa.sum(1), (pa**2).sum(1)]
        s = np.stack(parts)
        self.s = s if self.s is None else self.s + s

    def summary(self) -> list[dict]:
        n, s1, s2, s3, s4, npair, p1, p2 = self.s
        out = []
        for i in range(len(n)):
            m = s1[i] / n[i]
            var = max(s2[i] / n[i] - m * m, 0.0)
            # central 4th moment from the raw sums: the standard error of a variance
            m4 = s4[i] / n[i] - 4 * m * s3[i] / n[i] + 6 * m * m * s2[i] / n[i] - 3 * m**4
            pm = p1[i] / npair[i]
            pvar = max(p2[i] / npair[i] - pm * pm, 0.0)
            out.append({
                "mean": m,
                # pairs are the independent units: the standard error of the mean uses them
                "mean_se": math.sqrt(pvar / npair[i]),
                "var": var,
                "var_se": math.sqrt(max(m4 - var * var, 0.0) / n[i]),
                "antithetic_gain": (0.5 * var / pvar) if pvar > 0 else None,
            })
        return out


def fit_power(ls, vals, ses):
    """Weighted least squares of log2 |value| on l: slope, its standard error, intercept."""
    ls = np.asarray(ls, float)
    y = np.log2(np.abs(vals))
    sy = np.asarray(ses) / (np.abs(vals) * math.log(2))
    sy = np.maximum(sy, 0.01)  # a floor so that one very precise point does not decide alone
    if len(ls) < 2:
        return None
    w = 1 / sy**2
    A = np.stack([np.ones_like(ls), ls], 1)
    cov = np.linalg.inv(A.T @ (A * w[:, None]))
    beta = cov @ (A.T @ (w * y))
    res = y - A @ beta
    chi2 = float((w * res**2).sum())
    dof = len(ls) - 2
    # inflate by the scatter when the points disagree with a straight line beyond their errors
    scale = max(1.0, chi2 / dof) if dof > 0 else 1.0
    return {"slope": float(-beta[1]), "slope_se": float(math.sqrt(cov[1, 1] * scale)),
            "intercept": float(beta[0]), "chi2_per_dof": chi2 / dof if dof > 0 else None,
            "levels": [int(x) for x in ls]}


def rates(levels: list[int], summ: list[dict], exact: bool) -> dict:
    """alpha (mean) and beta (variance) fits over the difference levels (not the base)."""
    rows = [(l, s) for l, s in zip(levels, summ)][1:]
    if exact:
        return {"alpha": None, "beta": None, "note": "exact in law: every level difference is identically 0"}
    vl = [(l, s["var"], s["var_se"]) for l, s in rows if s["var"] > 0]
    ml = [(l, s["mean"], s["mean_se"]) for l, s in rows if abs(s["mean"]) > 3 * s["mean_se"]]
    beta = fit_power(*zip(*vl)) if len(vl) >= 2 else None
    alpha = fit_power(*zip(*ml)) if len(ml) >= 2 else None
    # the finest five levels alone (closer to the asymptotic rate), and the local slopes
    beta_fine = fit_power(*zip(*vl[-5:])) if len(vl) >= 5 else None
    local = [math.log2(a[1] / b[1]) for a, b in zip(vl, vl[1:])]
    return {"alpha": alpha, "beta": beta, "beta_finest_5": beta_fine, "beta_local": local,
            "resolved_mean_levels": [l for l, _, _ in ml]}


def level_table(levels, summ, r, single=None, tail_to=40):
    """Per level l: V_l, |E Delta_l|, a bound on |E Delta_l| (the fitted law where alpha is
    resolved, else |mean| + 2 se), the single-level variance and the cost 5 2^l; extended beyond
    the finest measured level with the fitted rates (beta; alpha, or 1.5 from the last bound)."""
    tab = []
    a, b = (r or {}).get("alpha"), (r or {}).get("beta")
    for k, (l, s) in enumerate(zip(levels, summ)):
        bound = 2.0 ** (a["intercept"] - a["slope"] * l) if a else abs(s["mean"]) + 2 * s["mean_se"]
        tab.append({"l": l, "V": s["var"], "m": abs(s["mean"]), "m_se": s["mean_se"], "bound": bound,
                    "Vsingle": single[k]["var"] if single else None, "cost": TAU0 * 2.0**l})
    last = tab[-1]
    for l in range(levels[-1] + 1, tail_to + 1):
        V = 2.0 ** (b["intercept"] - b["slope"] * l) if b else 0.0
        bound = 2.0 ** (a["intercept"] - a["slope"] * l) if a else last["bound"] * 2.0 ** (-1.5 * (l - last["l"]))
        tab.append({"l": l, "V": V, "m": bound, "m_se": 0.0, "bound": bound, "Vsingle": last["Vsingle"],
                    "cost": TAU0 * 2.0**l, "extrapolated": True})
    return tab


def bias_after(tab, i, alpha):
    """Bias of stopping at row i: the later level means, geometric with the fitted alpha (1.5,
    the trapezoid's leading exponent, where unresolved) from row i's bound."""
    a = alpha["slope"] if alpha else 1.5
    a = max(a, 0.5)
    return tab[i]["bound"] * 2.0**-a / (1 - 2.0**-a)


def mlmc_cost(tab, alpha, eps, exact):
    """Giles' allocation: the shallowest finest level whose bias is below eps/sqrt 2, then
    N_l = ceil(2 eps^-2 sqrt(V_l/C_l) sum sqrt(V_k C_k)). Cost in path-steps to tau0."""
    if exact:
        # one exact jump to each output time (and tau0): two steps a path, one level
        n = math.ceil(tab[0]["V"] / eps**2)
        return {"finest_level": 0, "cost_path_steps": n * 2.0, "paths": [n], "bias": 0.0}
    for i in range(1, len(tab)):
        b = bias_after(tab, i, alpha)
        if b <= eps / math.sqrt(2):
            rows = tab[: i + 1]
            ssum = sum(math.sqrt(r["V"] * r["cost"]) for r in rows)
            N = [math.ceil(2 / eps**2 * math.sqrt(r["V"] / r["cost"]) * ssum) if r["V"] > 0 else 1 for r in rows]
            return {"finest_level": rows[-1]["l"], "cost_path_steps": float(sum(n * r["cost"] for n, r in zip(N, rows))),
                    "paths": N, "bias": b, "extrapolated": bool(rows[-1].get("extrapolated", False))}
    return None


def mlmc_cost_best_base(tab, alpha, eps, exact):
    """MLMC whose base level j is chosen too: the base uses its single-level variance (with the
    controls, the single-level variance falls with the level), the levels above it their
    difference variances."""
    if exact:
        return None
    for i in range(1, len(tab)):
        b = bias_after(tab, i, alpha)
        if b <= eps / math.sqrt(2):
            best = None
            for j in range(0, i + 1):
                rows = tab[j: i + 1]
                Vs = [tab[j]["Vsingle"]] + [r["V"] for r in rows[1:]]
                ssum = sum(math.sqrt(V * r["cost"]) for V, r in zip(Vs, rows))
                N = [math.ceil(2 / eps**2 * math.sqrt(V / r["cost"]) * ssum) if V > 0 else 1 for V, r in zip(Vs, rows)]
                c = float(sum(n * r["cost"] for n, r in zip(N, rows)))
                if best is None or c < best["cost_path_steps"]:
                    best = {"base_level": rows[0]["l"], "finest_level": rows[-1]["l"], "cost_path_steps": c,
                            "paths": N, "bias": b}
            return best
    return None


def single_level_cost(tab, alpha, eps, exact):
    """The best fixed step h = 2^-l: paths for the mean square error left after the bias."""
    if exact:
        n = math.ceil(tab[0]["Vsingle"] / eps**2)
        return {"level": None, "cost_path_steps": n * 2.0, "paths": n, "bias": 0.0}
    best = None
    for i, r in enumerate(tab):
        b = bias_after(tab, i, alpha)
        if b >= eps / math.sqrt(2):
            continue
        n = math.ceil(r["Vsingle"] / (eps**2 - b**2))
        c = n * r["cost"]
        if best is None or c < best["cost_path_steps"]:
            best = {"level": r["l"], "cost_path_steps": float(c), "paths": n, "bias": b}
    return best


def today_default(tab, alpha, eps, exact):
    """Today's default, richardson at dt = 0.01 (500 steps to tau0): the per-path variance and
    bias of the level h = 2^-7 = 0.0078 (the nearest measured), paths for the rest of eps^2."""
    if exact:
        return single_level_cost(tab, alpha, eps, exact)
    r = next(t for t in tab if t["l"] == 7)
    i = tab.index(r)
    a = alpha["slope"] if alpha else 1.5
    # the bias of the step 0.01 from that of 2^-7: scaled by (0.01 * 128)^a
    b = bias_after(tab, i, alpha) * (0.01 * 128) ** a
    if b >= eps:
        return {"reachable": False, "bias": b}
    n = math.ceil(r["Vsingle"] / (eps**2 - b**2))
    return {"reachable": True, "cost_path_steps": n * 500.0, "paths": n, "bias": b}


def today_default_noise_only(tab, eps, exact):
    """The same, counting the statistical error only (the bias of richardson at dt = 0.01 is not
    resolved here): a lower bound on today's cost, which favours today's default."""
    r = tab[0] if exact else next(t for t in tab if t["l"] == 7)
    n = math.ceil(r["Vsingle"] / eps**2)
    return {"cost_path_steps": n * (2.0 if exact else 500.0), "paths": n}


def rhee_glynn(tab, exact):
    """Single-term randomised truncation: P(N = l) = p_l, estimator Delta_N / p_N, unbiased.
    Optimal p_l proportional to sqrt(E[Delta_l^2] / C_l); variance x expected cost = (sum
    sqrt(E[Delta_l^2] C_l))^2 minus a small term, finite iff beta > gamma. Work per unit variance."""
    if exact:
        return None
    s = sum(math.sqrt((r["V"] + r["m"] ** 2) * r["cost"]) for r in tab)
    return s * s


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="smoke run: L = 5, few paths")
    ap.add_argument("--publish", action="store_true", help="copy JSON and PNG to bench/results/")
    ap.add_argument("--levels", type=int, default=None, help="finest level L (h = 2^-L)")
    ap.add_argument("--paths", type=int, default=None, help="main-sample paths")
    ap.add_argument("--pilot", type=int, default=None, help="pilot paths (control coefficients)")
    ap.add_argument("--seed", type=int, default=20261121)
    args = ap.parse_args()
    L = args.levels or (5 if args.quick else 8)
    n_main = args.paths or (4_000 if args.quick else 300_000)
    n_pilot = args.pilot or (2_000 if args.quick else 30_000)
    batch = 10_000
    started = time.perf_counter()
    load_before = os.getloadavg()
    rng = np.random.default_rng(args.seed)
    means = analytic_means()
    names = list(STATS)

    # Each estimator is a list of rows; its controls come from the finest grid it uses.
    def estimators(q, ctl):
        out = {}
        for st in names:
            F = level_values(q, st, means)
            ti = TIMES.index(STATS[st][2])
            R = rich_values(F)
            out[("trapezoid", st)] = (differences(F), None if ctl is None else ctl[:, ti])
            out[("richardson", st)] = (differences(R), None if ctl is None else ctl[2:, ti])
            out[("single_trapezoid", st)] = (F, None if ctl is None else ctl[:, ti])
            out[("single_richardson", st)] = (R, None if ctl is None else ctl[2:, ti])
        return out

    # Pilot: least-squares control coefficients per estimator row (fitted on these paths only).
    coef, coef_db = {}, {}
    n_done = 0
    gram = {}
    while n_done < n_pilot:
        m = min(batch, n_pilot - n_done)
        q, ctl = simulate(rng, m, L, True)
        for key, (Y, C) in estimators(q, ctl).items():
            for i in range(Y.shape[0]):
                Ci = C[i].T  # (n, K)
                A = np.concatenate([Ci, np.ones((m, 1))], 1)
                g = gram.setdefault((key, i), [0.0, 0.0])
                g[0] = g[0] + A.T @ A
                g[1] = g[1] + A.T @ Y[i]
        n_done += m
    for (key, i), (G, b) in gram.items():
        # ridge-free solve with a tiny jitter: unused controls (e.g. all-zero rows) get 0
        sol = np.linalg.lstsq(G + 1e-12 * np.trace(G) / len(G) * np.eye(len(G)), b, rcond=None)[0]
        coef[(key, i)] = sol[:-1]
        sub = DB_ONLY + [len(G) - 1]
        Gs = G[np.ix_(sub, sub)]
        sol = np.linalg.lstsq(Gs + 1e-12 * np.trace(Gs) / len(Gs) * np.eye(len(Gs)), b[sub], rcond=None)[0]
        coef_db[(key, i)] = sol[:-1]
    print(f"pilot {n_pilot} paths done in {time.perf_counter() - started:.0f} s", flush=True)

    accs, accs_cv, accs_db = {}, {}, {}
    n_done = 0
    while n_done < n_main:
        m = min(batch, n_main - n_done)
        q, ctl = simulate(rng, m, L, True)
        for key, (Y, C) in estimators(q, ctl).items():
            accs.setdefault(key, Acc()).add(Y)
            Ycv = np.stack([Y[i] - coef[(key, i)] @ C[i] for i in range(Y.shape[0])])
            accs_cv.setdefault(key, Acc()).add(Ycv)
            Ydb = np.stack([Y[i] - coef_db[(key, i)] @ C[i][DB_ONLY] for i in range(Y.shape[0])])
            accs_db.setdefault(key, Acc()).add(Ydb)
        n_done += m
        print(f"main {n_done}/{n_main} paths, {time.perf_counter() - started:.0f} s", flush=True)

    ref = analytic_values()
    result = {}
    for st in names:
        exact = STATS[st][0] in EXACT_IN_LAW
        entry = {"quantity": STATS[st][0], "kind": STATS[st][1], "exact_in_law": exact, "analytic": ref[st]}
        for fam, base in (("trapezoid", 0), ("richardson", 2)):
            summ = accs[(fam, st)].summary()
            summ_cv = accs_cv[(fam, st)].summary()
            single = accs[("single_" + fam, st)].summary()
            single_cv = accs_cv[("single_" + fam, st)].summary()
            summ_db = accs_db[(fam, st)].summary()
            single_db = accs_db[("single_" + fam, st)].summary()
            levels = list(range(base, L + 1))
            r = rates(levels, summ, exact)
            r_cv = rates(levels, summ_cv, exact)
            tab = level_table(levels, summ, r, single)
            tab_cv = level_table(levels, summ_cv, r, single_cv)  # the bias is that of the plain levels
            tab_db = level_table(levels, summ_db, r, single_db)
            # the level estimate of the statistic (telescoped) against the analytic value
            est = sum(s["mean"] for s in summ)
            est_se = math.sqrt(sum(s["mean_se"] ** 2 for s in summ))
            costs = {}
            if fam == "richardson" and L >= 7:
                for eps in EPS:
                    costs.setdefault(f"{eps:g}", {})["today_default"] = today_default(tab, r.get("alpha"), eps, exact)
                    costs[f"{eps:g}"]["today_default_noise_only"] = today_default_noise_only(tab, eps, exact)
            for eps in EPS:
                costs.setdefault(f"{eps:g}", {}).update({
                    "mlmc": mlmc_cost(tab, r.get("alpha"), eps, exact),
                    "mlmc_cv": mlmc_cost(tab_cv, r.get("alpha"), eps, exact),
                    "mlmc_cv_best_base": mlmc_cost_best_base(tab_cv, r.get("alpha"), eps, exact),
                    "mlmc_cv_dB_best_base": mlmc_cost_best_base(tab_db, r.get("alpha"), eps, exact),
                    "single_level_best_cv_dB": single_level_cost(tab_db, r.get("alpha"), eps, exact),
                    "single_level_best": single_level_cost(tab, r.get("alpha"), eps, exact),
                    "single_level_best_cv": single_level_cost(tab_cv, r.get("alpha"), eps, exact),
                })
            entry[fam] = {
                "levels": levels,
                "level_stats": summ,
                "level_stats_cv": summ_cv,
                "single_level_stats": single,
                "single_level_stats_cv": single_cv,
                "level_stats_cv_dB": summ_db,
                "single_level_stats_cv_dB": single_db,
                "rates": r,
                "rates_cv": r_cv,
                "gamma": 1.0,
                "telescoped_estimate": est,
                "telescoped_estimate_se": est_se,
                "telescoped_minus_analytic": est - ref[st] if STATS[st][1] == "mean" else None,
                "rhee_glynn_work_per_unit_variance": rhee_glynn(tab, exact),
                "costs": costs,
            }
        result[st] = entry
        rt = entry["trapezoid"]["rates"]
        rr = entry["richardson"]["rates"]

        def fmt(x):
            return "-" if not x else f"{x['slope']:.2f}±{x['slope_se']:.2f}"
        print(f"{st:26s} trapezoid a={fmt(rt.get('alpha'))} b={fmt(rt.get('beta'))}  "
              f"richardson a={fmt(rr.get('alpha'))} b={fmt(rr.get('beta'))}", flush=True)

    data = {
        "script": "bench/mlmc_rates.py",
        "command": "python bench/mlmc_rates.py" + (" --quick" if args.quick else "") + (" --publish" if args.publish else ""),
        "machine": platform.machine(), "cpus": os.cpu_count(), "numpy": np.__version__,
        "tau0": TAU0, "times": TIMES, "finest_level": L, "h0": 1.0, "paths_main": n_main, "paths_pilot": n_pilot,
        "seed": args.seed, "richardson_weights": W_RICH.tolist(), "eps": EPS,
        "controls": ["dB", "|X| dB", "r dB", "min(|X|/2,r) dB", "U3 |X| dB", "U3 min(|X|/2,r) dB",
                     "|X|^2 min(|X|/2,r) dB", "U3 dB", "dM", "r dM", "min(|X|/2,r) dM", "U2 dM",
                     "U2 min(|X|/2,r) dM", "X |X| min(|X|/2,r) dM", "U2 r dM",
                     "sB", "r sB", "min(|X|/2,r) sB", "U2 sB", "U2 min(|X|/2,r) sB", "X |X| min(|X|/2,r) sB",
                     "U2 r sB"],
        "controls_without_dM": DB_ONLY,
        "statistics": result,
        "load": [round(x, 2) for x in load_before], "load_after": [round(x, 2) for x in os.getloadavg()],
        "total_seconds": time.perf_counter() - started,
    }
    write("mlmc_rates", data, plot, publish=args.publish, default=float)
    print(f"done in {data['total_seconds']:.0f} s; load {data['load']} -> {data['load_after']}")


def plot(data: dict, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(2, 2, figsize=(13, 9), sharex=True)
    names = [n for n, e in data["statistics"].items() if not e["exact_in_law"]]
    cmap = plt.get_cmap("tab10")
    for col, fam in enumerate(("trapezoid", "richardson")):
        for k, st in enumerate(names):
            e = data["statistics"][st][fam]
            ls = e["levels"][1:]
            rows = e["level_stats"][1:]
            V = [r["var"] for r in rows]
            b = e["rates"]["beta"]
            lab = st + (f" β={b['slope']:.2f}±{b['slope_se']:.2f}" if b else "")
            axes[0, col].plot(ls, np.log2(np.maximum(V, 1e-300)), "o-", color=cmap(k % 10), label=lab, ms=4)
            mres = [(l, abs(r["mean"])) for l, r in zip(ls, rows) if abs(r["mean"]) > 3 * r["mean_se"]]
            munr = [(l, abs(r["mean"]) + 2 * r["mean_se"]) for l, r in zip(ls, rows) if abs(r["mean"]) <= 3 * r["mean_se"]]
            a = e["rates"]["alpha"]
            lab = st + (f" α={a['slope']:.2f}±{a['slope_se']:.2f}" if a else " α: unresolved")
            if mres:
                axes[1, col].plot(*zip(*[(l, math.log2(m)) for l, m in mres]), "o-", color=cmap(k % 10), label=lab, ms=4)
            else:
                axes[1, col].plot([], [], "o-", color=cmap(k % 10), label=lab)
            if munr:
                axes[1, col].plot(*zip(*[(l, math.log2(m)) for l, m in munr]), "v", color=cmap(k % 10), ms=4, alpha=0.5)
        axes[0, col].set_title(f"{fam}: log2 Var[P_l - P_(l-1)]", fontsize=9)
        axes[1, col].set_title(f"{fam}: log2 |E[P_l - P_(l-1)]| (triangles: unresolved, |m| + 2 se)", fontsize=9)
        axes[1, col].set_xlabel("level l (h = 2^-l)")
        for r in (0, 1):
            axes[r, col].legend(fontsize=6)
            axes[r, col].grid(alpha=0.3)
    fig.suptitle(f"MLMC rates, exact skeleton, tau0 = {data['tau0']:g}; cost per sample 5·2^l path-steps (gamma = 1); "
                 f"{data['paths_main']} paths; velocity and stop time exact (differences 0)", fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    plt.close(fig)


if __name__ == "__main__":
    main()
