"""Variances of the displacement and the distance while the body coasts (tau0 < tau), at every
tau, not only at the stop (docs/analytic.md, "Var U2 and Var U3 during the coast").

With X = U1(tau0), a = |X|, sigma = sign X, delta = tau - tau0 and c = 2 delta, the coast gives

    U2(tau) = U2(tau0) + sigma g(a),   U3(tau) = U3(tau0) + g(a),
    g(a) = a delta' - delta'^2 = (a^2 - (a - c)_+^2) / 4,   delta' = min(delta, a/2),

so, E U2 being 0,

    Var U2(tau) = E[U2(tau0)^2] + 2 E[U2(tau0) sigma g(a)] + E[g(a)^2],
    Var U3(tau) = Var U3(tau0) + 2 Cov(U3(tau0), g(a)) + Var g(a).

The mixed terms come from the Markov property at tau0 (docs/analytic.md): with R = |U1|,
rho(x, s) its density at s, V_phi(x, t) = E_x[phi(R_t); R not killed at 0 by t] (paths that
reach 0 forget their sign, so the signed expectation is the killed one), and s = tau0 - t,

    E[U2(tau0) sigma phi(a)] = int_0^tau0 dt int_0^inf dx rho(x, s) x V_phi(x, t),
    Cov(U3(tau0), phi(a))    = int_0^tau0 dt int_0^inf dx G(x, s) V_phi'(x, t),

G(x, s) = E[(R_s - E R_s) 1{R_s > x}] >= 0. Both integrands are non-negative for phi = g. The
y-integral inside V is closed (repeated integrals of erfc, g being piecewise quadratic); the
(t, x) integral is a Gauss-Legendre product rule on panels fitted to the integrand's scales.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.special import erfc, erfcx

from . import _data
from ._check import ArrayLike, Values, as_tau0, as_time, scalar_or_array
from .noise_on import SWITCH
from .switch_off import _coast_c

__all__ = ["coast_displacement_var", "coast_distance_var", "coast_velocity_abs_distance_cov",
           "coast_velocity_displacement_cov"]

_SQPI = math.sqrt(math.pi)
_SQPI_INV = 1 / _SQPI

# Beyond t = _T_CUT the killed process has survived with probability below ~e^-(t - 1): the
# integrand of A is below 1e-30 of its scale there (docs/analytic.md).
_T_CUT = 70.0

# 16 nodes per panel of the (t, x) product rule, 40 per panel of the 1-D law integrals
_GX, _GW = np.polynomial.legendre.leggauss(16)
_GX1, _GW1 = np.polynomial.legendre.leggauss(40)
_X_FRACTIONS = (1 / 16, 1 / 8, 1 / 4, 1 / 2, 1.0)
# panel edges at these multiples of sqrt(t) from x = 0 and from x = c: the layers there are
# erfc-shaped, of width ~ sqrt(t), and erfc(12 / 2) = 2e-17
_LAYER = (4.0, 12.0)
_T_FRACTIONS = (0, 1 / 8, 1 / 4, 1 / 2, 1.0)
_S_FRACTIONS = (0, 1 / 4, 1 / 2, 1.0)


def _panels(edges, x=_GX, w=_GW):
    """Gauss-Legendre nodes and weights on consecutive panels between ``edges`` (1-D)."""
    edges = np.asarray(edges, dtype=float)
    a, b = edges[:-1, None], edges[1:, None]
    nodes = (a + (b - a) * (1 + x) / 2).ravel()
    weights = ((b - a) / 2 * w).ravel()
    return nodes, weights


# Miller's starting index by band of z: the backward recurrence converges faster for larger z
# (start 60 at z = 2 and 20 at z = 6 both give 2e-15 against a start at 120)
_MILLER_BANDS = ((2.0, 60), (3.0, 40), (4.0, 30), (6.0, 20))


def _scaled_ierfc_fast(z):
    """J_n(z) = e^(z^2) i^n erfc(z), n = 0, 1, 2, z >= 0: as switch_off._scaled_ierfc (forward
    recurrence below z = 2, Miller's backward recurrence above), without its per-step
    rescaling and with a start that shrinks as z grows (_MILLER_BANDS): started at 1e-300, the
    backward sweep grows by at most (120 + 2z)^59 < 1e490 for z <= 1e8, inside the range of a
    double; beyond, the leading asymptotic terms J_1 = J_0 / (2z), J_2 = J_0 / (4 z^2) are
    exact to (1/z^2) < 1e-16.
    """
    J0 = erfcx(z)
    J1 = _SQPI_INV - z * J0
    J2 = (J0 - 2 * z * J1) / 4
    uppers = [b[0] for b in _MILLER_BANDS[1:]] + [np.inf]
    for (lo, start), hi in zip(_MILLER_BANDS, uppers):
        band = (z >= lo) & (z < hi)
        if not np.any(band):
            continue
        zb = z[band]
        huge = zb > 1e8
        zm = np.where(huge, 2.0, zb)
        a = np.zeros_like(zm)
        b = np.full_like(zm, 1e-300)
        for n in range(start, 2, -1):
            a, b = b, 2 * n * a + 2 * zm * b  # (y_(n-1), y_(n-2))
        y2 = a
        a, b = b, 4 * a + 2 * zm * b  # n = 2: (y_1, y_0)
        norm = J0[band] / b
        J1[band] = np.where(huge, J0[band] / (2 * zb), a * norm)
        J2[band] = np.where(huge, J0[band] / (2 * zb) / (2 * zb), y2 * norm)
    return J0, J1, J2


def _ierfc_any(z):
    """i^n erfc(z), n = 0, 1, 2, for any real z (array), each a sum of non-negative terms
    for z < 0 and e^(-z^2) J_n(z) for z >= 0."""
    z = np.asarray(z, dtype=float)
    out = [np.empty(z.shape) for _ in range(3)]
    pos = z >= 0
    if np.any(pos):
        e = np.exp(-z[pos] ** 2)
        J0, J1, J2 = _scaled_ierfc_fast(z[pos])
        out[0][pos], out[1][pos], out[2][pos] = e * J0, e * J1, e * J2
    neg = ~pos
    if np.any(neg):
        zn = z[neg]
        i0 = erfc(zn)
        i1 = np.exp(-zn * zn) / _SQPI - zn * i0
        i2 = (i0 - 2 * zn * i1) / 4
        out[0][neg], out[1][neg], out[2][neg] = i0, i1, i2
    return out


def _killed_moments(x, t, K):
    """E_x[(R_t - K)_+^n ; not killed by t], n = 1, 2, for |U1| started at x >= 0, killed at 0.

    int_0^inf k(x, y, t) (y - K)_+^n dy with k = n(y; x - 2t, 2t) - e^(2x) n(y; -x - 2t, 2t):
    E[(N - K)_+^n] = (2 sqrt t)^n n! i^n erfc(z) / 2 for N ~ n(m, 2t), z = (K - m) / (2 sqrt t).
    The image term carries e^(2x) i^n erfc(z2) = e^(-z1^2 - x K / t) J_n(z2), z2 >= 0, so
    nothing overflows (2x - z2^2 = -z1^2 - x K / t).
    """
    rt = np.sqrt(t)
    z1 = (K - x + 2 * t) / (2 * rt)
    z2 = (K + x + 2 * t) / (2 * rt)
    _, J1b, J2b = _scaled_ierfc_fast(z2.ravel())
    J1b, J2b = J1b.reshape(z2.shape), J2b.reshape(z2.shape)
    image = np.exp(-(z1 * z1) - x * K / t)
    _, i1, i2 = _ierfc_any(z1)
    m1 = rt * (i1 - image * J1b)  # (2 sqrt t) 1! / 2 = sqrt t
    m2 = 4 * t * (i2 - image * J2b)  # (2 sqrt t)^2 2! / 2 = 4 t
    return m1, m2


def _alive_above(x, t, y):
    """Q(y) = P_x(R_t > y, not killed by t) = [erfc(z1) - e^(2x) erfc(z2)] / 2, z1, z2 =
    (y -+ x + 2t) / (2 sqrt t); e^(2x) erfc(z2) = e^(-z1^2 - x y / t) erfcx(z2), z2 >= 0."""
    rt = np.sqrt(t)
    z1 = (y - x + 2 * t) / (2 * rt)
    z2 = (y + x + 2 * t) / (2 * rt)
    image = np.exp(-(z1 * z1) - x * y / t) * erfcx(z2)
    with np.errstate(under="ignore"):
        return np.where(z1 >= 0, np.exp(-(z1 * z1)) * erfcx(np.maximum(z1, 0)),
                        erfc(np.minimum(z1, 0))) / 2 - image / 2


def _killed_g(x, t, c):
    """V_g(x, t) = E_x[g_c(R_t); alive] and V_g'(x, t) = E_x[g_c'(R_t); alive] (x, t arrays).

    From the closed moments, V_g = (m2(0) - m2(c)) / 4 and V_g' = (m1(0) - m1(c)) / 2; for c
    small against the spread of R_t (x + sqrt t) these differences would lose digits, so there
    g_c(R) = int_0^inf min(y, c)/2 1{R > y} dy is used instead:

        V_g' = (1/2) int_0^c Q(y) dy,   V_g = (1/2) int_0^c y Q(y) dy + (c/2) m1(c),

    Q(y) = P_x(R_t > y, alive), smooth on [0, c] there (8-point Gauss-Legendre). Also
    returns m1(c) = V_phi for phi = (y - c)_+.
    """
    m1_c, m2_c = _killed_moments(x, t, c)
    near = c <= (x + np.sqrt(t)) / 2
    vg = np.empty(x.shape)
    vd = np.empty(x.shape)
    far = ~near
    if np.any(far):
        m1_0, m2_0 = _killed_moments(x[far], t[far], 0.0)
        vg[far] = (m2_0 - m2_c[far]) / 4
        vd[far] = (m1_0 - m1_c[far]) / 2
    if np.any(near):
        xn, tn = x[near][:, None], t[near][:, None]
        y = c * (1 + _GD_X) / 2
        Q = _alive_above(xn, tn, y[None, :])
        w = c / 2 * _GD_W
        vd[near] = (Q @ w) / 2
        vg[near] = (Q @ (w * y)) / 2 + c / 2 * m1_c[near]
    return vg, vd, m1_c


def _abs_density(x, s):
    """rho(x, s) = 2 f(x, s), the density of |U1(s)|, x >= 0, s > 0 (as velocity_pdf)."""
    rt = np.sqrt(s)
    z = x / (2 * rt) - rt
    c = 1.0 / (_SQPI * rt)
    out = np.empty(np.broadcast(x, s).shape)
    z, c, xb = np.broadcast_arrays(z, c, x)
    rtb = np.broadcast_to(rt, z.shape)
    pos = z >= 0
    out[pos] = np.exp(-(z[pos] + 2 * rtb[pos]) ** 2) * (c[pos] + erfcx(z[pos]))
    neg = ~pos
    out[neg] = np.exp(-2 * xb[neg]) * (erfc(z[neg]) + c[neg] * np.exp(-z[neg] ** 2))
    return out


_SMALL_S = 0.05  # below, E(R_s - xi)_+ is formed without its O(1) terms (see _excess)
_GD_X, _GD_W = np.polynomial.legendre.leggauss(8)


def _excess(xi, s, m):
    """G(xi, s) = E[(R_s - m) 1{R_s > xi}], R_s = |U1(s)|, m = E R_s (given); xi >= 0, s > 0.

    G = E(R_s - xi)_+ - (m - xi) S(xi), S(xi) = P(R_s > xi) = [erfc(v) + e^(-2 xi) erfc(w)] / 2,
    v, w = (xi +- 2 s) / (2 sqrt s). Integrating S from xi to infinity (by parts for its second
    half, with e^(-2y - w_y^2) = e^(-v_y^2)):

        E(R_s - xi)_+ = sqrt(s) i^1erfc(v) + D / 4,   D = e^(-2 xi) erfc(w) - erfc(v) >= 0.

    For s >= 0.05, D is formed as written (it loses at most |log10 sqrt s| < 1 digit). Below,
    D = O(sqrt s) would come out of O(1) terms, so it is rewritten as a positive integral:
    2 xi + w^2 = v^2 gives D = e^(-v^2) (erfcx(w) - erfcx(v)) and erfcx' = -2 J_1, so

        D = 2 e^(-v^2) int_w^v J_1(u) du,   v - w = 2 sqrt s < 0.45,

    by 8-point Gauss-Legendre (J_1 is smooth: error far below 1e-16). G >= 0: it is
    int_xi^inf (x - m) rho(x) dx, also equal to int_0^xi (m - x) rho(x) dx.
    """
    rs = np.sqrt(s)
    v = xi / (2 * rs) + rs
    w = xi / (2 * rs) - rs
    ev = np.exp(-v * v)
    J0v, J1v, _ = _scaled_ierfc_fast(v.ravel())
    J0v, J1v = J0v.reshape(v.shape), J1v.reshape(v.shape)
    # e^(-2 xi) erfc(w) = e^(-v^2) erfcx(w) for w >= 0 (both factors in range)
    with np.errstate(under="ignore"):
        tail_w = np.where(w >= 0, ev * erfcx(np.maximum(w, 0)),
                          np.exp(-2 * xi) * erfc(np.minimum(w, 0)))
    S = (ev * J0v + tail_w) / 2
    small = np.broadcast_to(s < _SMALL_S, v.shape)
    D = np.empty(v.shape)
    big = ~small
    D[big] = tail_w[big] - (ev * J0v)[big]
    if np.any(small):
        ws = w[small]
        eps = 2 * np.broadcast_to(rs, v.shape)[small]  # v - w, exact (v - w in floats is not)
        u = ws[:, None] + eps[:, None] * (1 + _GD_X) / 2
        _, J1u, _ = _scaled_ierfc_fast(u.ravel())
        integral = eps / 2 * (J1u.reshape(u.shape) @ _GD_W)
        D[small] = 2 * ev[small] * integral
    return rs * ev * J1v + D / 4 - (m - xi) * S


def _mixed(c, t0, want):
    """The mixed terms at tau0 for each c (1-D array), tau0 = t0 > 0, L = min(sqrt(tau0), 1),
    g_c(y) = (y^2 - (y - c)_+^2) / 4, as a dict over ``want``:

    * "displacement": E[U2 sigma g_c(a)] / (tau0 L^3) = int dt int dx rho x V_g / (tau0 L^3);
    * "distance": Cov(U3, g_c(a)) / (tau0 L^3) = int dt int dx G V_g' / (tau0 L^3);
    * "displacement_cov": E[U2 sigma (a - c)_+] / (tau0 L^2), phi = (y - c)_+ in the first;
    * "distance_cov": Cov(U3, (a - c)_+) / (tau0 L^2), phi' = 1{y > c} in the second,

    s = tau0 - t, V_phi(x, t) = E_x[phi(R_t); not killed by t] (docs/analytic.md): sums of
    non-negative terms. Every factor is formed in units of its own scale (rho dx, x / L,
    G / L, V / L^n, dt / tau0), so nothing underflows unless the result itself does.
    """
    L = min(math.sqrt(t0), 1.0)  # scale of |U1|: sqrt(tau0) when small, O(1) after
    # t = tau0 - s, the time since the velocity was last looked at: u = sqrt(t) near t = 0
    # (the integrand has half-integer powers of t there), v = sqrt(s) near s = 0 (those of rho)
    if t0 <= 2 * _T_CUT:
        uh = math.sqrt(t0 / 2)
        u, wu = _panels(uh * np.array(_T_FRACTIONS))
        v, wv = _panels(uh * np.array(_S_FRACTIONS))
        t = np.concatenate([u * u, t0 - v * v])
        s = np.concatenate([t0 - u * u, v * v])
        wt = np.concatenate([2 * u * wu, 2 * v * wv]) / t0
    else:
        u, wu = _panels(math.sqrt(_T_CUT) * np.array(_T_FRACTIONS))
        t, s, wt = u * u, t0 - u * u, 2 * u * wu / t0
    rt = np.sqrt(t)
    m_s = _data.S100(s, SWITCH)  # E|U1(s)|
    # x range: rho(x, s) is below e^-2x, and below a Gaussian of width sqrt(2 s) about -2 s
    xmax = np.minimum(16 * np.sqrt(s), 24.0)
    fixed = ([np.zeros_like(t)] + [np.minimum(k * rt, xmax) for k in _LAYER]
             + [xmax * f for f in _X_FRACTIONS])
    out = {k: np.full(c.shape, np.nan) for k in want}
    for i, ci in enumerate(c):
        # x panels per t: the killing's boundary layer (width ~ sqrt t), the kink of g (the
        # step of g'') at x = c, smoothed over ~ sqrt t, and geometric panels for rho's decay
        kink = [np.clip(ci + sign * k * rt, 0, xmax) for k in _LAYER for sign in (-1, 1)]
        pts = np.sort(np.stack(fixed + kink, axis=1), axis=1)
        a, b = pts[:, :-1, None], pts[:, 1:, None]
        x = (a + (b - a) * (1 + _GX) / 2).reshape(len(t), -1)
        wx = ((b - a) / 2 * _GW).reshape(len(t), -1) / L
        tt = np.broadcast_to(t[:, None], x.shape)
        ss = np.broadcast_to(s[:, None], x.shape)
        ms = np.broadcast_to(m_s[:, None], x.shape)
        vg, vd, m1 = _killed_g(x, tt, ci)
        vg, vd, m1 = vg / (L * L), vd / L, m1 / L
        if "displacement" in want or "displacement_cov" in want:
            base = wx * _abs_density(x, ss) * L * (x / L)
            for key, v in (("displacement", vg), ("displacement_cov", m1)):
                if key in want:
                    out[key][i] = np.sum(wt * np.sum(base * v, axis=1))
        if "distance" in want or "distance_cov" in want:
            base = wx * _excess(x, ss, ms) / L
            if "distance" in want:
                out["distance"][i] = np.sum(wt * np.sum(base * vd, axis=1))
            if "distance_cov" in want:
                q = _alive_above(x, tt, np.float64(ci))
                out["distance_cov"][i] = np.sum(wt * np.sum(base * q, axis=1))
    return out


def _law_moments(c, t0):
    """E g_c(a) / L^2, E g_c(a)^2 / L^4, E[g_c(a) (a - c)_+] / L^3 and E(a - c)_+ / L over the
    law of a = |U1(tau0)| (panels of 40 Gauss-Legendre points, split at c where g_c and
    (a - c)_+ have their kinks)."""
    L = min(math.sqrt(t0), 1.0)
    ymax = min(16 * math.sqrt(t0), 24.0)
    out = np.empty((4, c.size))
    for i, ci in enumerate(c):
        edges = np.unique(np.clip([0, ymax / 16, ymax / 8, ymax / 4, ymax / 2, ci, ymax],
                                  0, ymax))
        y, w = _panels(edges, _GX1, _GW1)
        rho = _abs_density(y, np.float64(t0)) * w
        # g_c(y) = y^2/4 below c, c (2y - c)/4 above: no difference of near-equal squares
        g = np.where(y <= ci, y * y, ci * (2 * y - ci)) / (4 * L * L)
        out[0, i] = np.sum(rho * g)
        out[1, i] = np.sum(rho * g * g)
        excess = np.maximum(y - ci, 0) / L
        out[2, i] = np.sum(rho * g * excess)
        out[3, i] = np.sum(rho * excess)
    return out


def _reach(t0):
    """a = |U1(tau0)| beyond which the law of a has no weight that matters: P(a > reach) and
    E(a - reach)_+^4 are below e^-48 of their scales (a Gaussian tail 11 standard deviations
    out for small tau0, the stationary tail e^(-2a) for large), so for c >= reach the variances
    equal their values at the stop to 1e-13 (test_limit_at_the_stop)."""
    return min(16 * math.sqrt(t0), 24.0)


def _evaluate(c, t0, which):
    """The quantity ``which`` at c = 2 (tau - tau0) >= 0 (array), tau0 = t0 >= 1e-100:
    "displacement" Var U2, "distance" Var U3, "displacement_cov" E[U1 U2],
    "distance_cov" Cov(|U1|, U3)."""
    out = np.empty(c.shape)
    stopped = c >= _reach(t0)  # no |U1(tau0)| with weight still moves: at the stop
    t0a = np.array([t0])
    at_stop = {"displacement": _data.VAR_U2_AT_STOP(t0a, SWITCH)[0],
               "distance": _data.HALF_INT_M200(t0a, SWITCH)[0],
               "displacement_cov": 0.0, "distance_cov": 0.0}
    out[stopped] = at_stop[which]
    live = ~stopped
    if np.any(live):
        cu, inv = np.unique(c[live], return_inverse=True)
        L2 = min(t0, 1.0)
        L = math.sqrt(L2)
        mixed = _mixed(cu, t0, (which,))[which]
        eg, eg2, eg_ex, e_ex = _law_moments(cu, t0)
        if which == "displacement":
            # m020 + 2 E[U2 sigma g] + E g^2
            val = _data.M020(t0a, SWITCH)[0] + 2 * t0 * L2 * L * mixed + L2 * L2 * eg2
        elif which == "distance":
            # Var U3 + 2 Cov(U3, g) + Var g
            val = _data.VAR_U3(t0a, SWITCH)[0] + 2 * t0 * L2 * L * mixed + L2 * L2 * (eg2 - eg * eg)
        elif which == "displacement_cov":
            # U1(tau) U2(tau) = sigma (a - c)_+ (U2(tau0) + sigma g): both parts >= 0
            val = t0 * L2 * mixed + L2 * L * eg_ex
        else:
            # Cov(U3(tau0) + g, (a - c)_+): both parts >= 0
            val = t0 * L2 * mixed + L2 * L * (eg_ex - eg * e_ex)
        out[live] = val[inv]
    return np.maximum(out, 0.0)


# Below this tau0 the drift is invisible (relative O(sqrt tau0) < 1e-50) and the variances
# scale exactly, to double precision, as tau0^2 F(c / sqrt tau0): they are evaluated at
# _TINY and rescaled, which keeps denormal tau0 away from the quadrature.
_TINY = 1e-100


_POWER = {"displacement": 2.0, "distance": 2.0, "displacement_cov": 1.5, "distance_cov": 1.5}


def _coast(t, t0, which, elapsed=None):
    c = _coast_c(t, t0, elapsed)
    if t0 >= _TINY:
        return _evaluate(c, t0, which)
    # Var(c; tau0) = (tau0 / T)^2 Var(c sqrt(T / tau0); T) at leading order in sqrt(tau0), the
    # covariances (of U1 ~ sqrt(tau0) with g ~ tau0) likewise with the power 3/2
    with np.errstate(over="ignore"):
        cs = c * math.sqrt(_TINY / t0)
    cs = np.where(np.isfinite(cs), cs, np.finfo(float).max)
    return (t0 / _TINY) ** _POWER[which] * _evaluate(cs, _TINY, which)


def _coast_checked(tau, tau0, which, elapsed=None):
    """``which`` (as in :func:`_evaluate`) at the scaled times tau > tau0, validated; 0 where
    there is no coast (tau0 = 0: never any noise; tau0 = inf: never switched off).
    ``elapsed``: tau - tau0 where the caller knows it better (switch_off._coast_c)."""
    t = as_time(tau)
    t0 = as_tau0(tau0)
    if t0 == 0 or np.isinf(t0):
        return scalar_or_array(np.zeros_like(t))
    return scalar_or_array(_coast(t, t0, which, elapsed))


def coast_displacement_var(tau: ArrayLike, tau0: ArrayLike, elapsed: ArrayLike = None) -> Values:
    """Var U2(tau) for tau > tau0 (noise off); see :func:`crandall.analytic.displacement_var`."""
    return _coast_checked(tau, tau0, "displacement", elapsed)


def coast_distance_var(tau: ArrayLike, tau0: ArrayLike, elapsed: ArrayLike = None) -> Values:
    """Var U3(tau) for tau > tau0 (noise off); see :func:`crandall.analytic.distance_var`."""
    return _coast_checked(tau, tau0, "distance", elapsed)


def coast_velocity_displacement_cov(tau: ArrayLike, tau0: ArrayLike) -> Values:
    """E[U1(tau) U2(tau)] for tau > tau0 (noise off); see
    :func:`crandall.analytic.velocity_displacement_cov`."""
    return _coast_checked(tau, tau0, "displacement_cov")


def coast_velocity_abs_distance_cov(tau: ArrayLike, tau0: ArrayLike) -> Values:
    """Cov(|U1(tau)|, U3(tau)) for tau > tau0 (noise off); see
    :func:`crandall.analytic.velocity_abs_distance_cov`."""
    return _coast_checked(tau, tau0, "distance_cov")
