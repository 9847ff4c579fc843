"""Variances of the displacement and the distance while the body coasts (tau0 < tau), at every
tau, not only at the stop (docs/analytic.md, "Var U2 and Var U3 during the coast").

With X = U1(tau0), a = |X|, sigma = sign X, delta = tau - tau0 and c = 2 delta, the coast gives

    U2(tau) = U2(tau0) + sigma g(a),   U3(tau) = U3(tau0) + g(a),
    g(a) = a delta' - delta'^2 = (a^2 - (a - c)_+^2) / 4,   delta' = min(delta, a/2),

so, E U2 being 0,

    Var U2(tau) = E[U2(tau0)^2] + 2 E[U2(tau0) sigma g(a)] + E[g(a)^2],
    Var U3(tau) = Var U3(tau0) + 2 Cov(U3(tau0), g(a)) + Var g(a).

The two mixed terms come from one functional of the killed process (docs/analytic.md):

    A[phi] = int_0^tau0 dt int_0^inf dx rho(x, tau0 - t) x int_0^inf k(x, y, t) phi(y) dy,
    E[U2(tau0) sigma phi(a)] = A[phi],
    Cov(U3(tau0), phi(a)) = -Cov(a^2, phi(a)) / 4 + A[phi'],

rho the density of |U1| and k(x, y, t) = n(y; x - 2t, 2t) - e^(2x) n(y; -x - 2t, 2t) the
transition density of |U1| killed at 0 (n a normal density, mean and variance). The y-integral
is closed (repeated integrals of erfc, g being piecewise quadratic); the (t, x) integral is a
Gauss-Legendre product rule on panels fitted to the scales of the integrand.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.special import erfc

from . import _data
from ._check import as_tau0, as_time, scalar_or_array
from .noise_on import SWITCH
from .switch_off import _scaled_ierfc

__all__ = ["coast_displacement_var", "coast_distance_var"]

_SQPI = math.sqrt(math.pi)

# Beyond t = _T_CUT the killed process has survived with probability below ~e^-(t - 1): the
# integrand of A is below 1e-30 of its scale there (docs/analytic.md).
_T_CUT = 70.0

_GX, _GW = np.polynomial.legendre.leggauss(20)
_GX1, _GW1 = np.polynomial.legendre.leggauss(40)


def _panels(edges, x=_GX, w=_GW):
    """Gauss-Legendre nodes and weights on consecutive panels between ``edges`` (1-D)."""
    edges = np.asarray(edges, dtype=float)
    a, b = edges[:-1, None], edges[1:, None]
    nodes = (a + (b - a) * (1 + x) / 2).ravel()
    weights = ((b - a) / 2 * w).ravel()
    return nodes, weights


def _ierfc_any(z):
    """i^n erfc(z), n = 0, 1, 2, for any real z (array), each a sum of non-negative terms
    for z < 0 and e^(-z^2) J_n(z) for z >= 0."""
    z = np.asarray(z, dtype=float)
    out = [np.empty(z.shape) for _ in range(3)]
    pos = z >= 0
    if np.any(pos):
        e = np.exp(-z[pos] ** 2)
        J0, J1, J2 = _scaled_ierfc(z[pos])
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
    _, J1b, J2b = _scaled_ierfc(z2.ravel())
    J1b, J2b = J1b.reshape(z2.shape), J2b.reshape(z2.shape)
    image = np.exp(-(z1 * z1) - x * K / t)
    _, i1, i2 = _ierfc_any(z1)
    m1 = rt * (i1 - image * J1b)  # (2 sqrt t) 1! / 2 = sqrt t
    m2 = 4 * t * (i2 - image * J2b)  # (2 sqrt t)^2 2! / 2 = 4 t
    return m1, m2


def _abs_density(x, s):
    """rho(x, s) = 2 f(x, s), the density of |U1(s)|, x >= 0, s > 0 (as velocity_pdf)."""
    rt = np.sqrt(s)
    z = x / (2 * rt) - rt
    c = 1.0 / (_SQPI * rt)
    out = np.empty(np.broadcast(x, s).shape)
    z, c, xb = np.broadcast_arrays(z, c, x)
    rtb = np.broadcast_to(rt, z.shape)
    pos = z >= 0
    from scipy.special import erfcx

    out[pos] = np.exp(-(z[pos] + 2 * rtb[pos]) ** 2) * (c[pos] + erfcx(z[pos]))
    neg = ~pos
    out[neg] = np.exp(-2 * xb[neg]) * (erfc(z[neg]) + c[neg] * np.exp(-z[neg] ** 2))
    return out


def _mixed(c, t0):
    """A[g_c] and A[g_c'] for each c (1-D array), tau0 = t0 > 0, in units scaled by L.

    g_c(y) = (y^2 - (y - c)_+^2) / 4, g_c'(y) = (y - (y - c)_+) / 2. Returns the pair of arrays.
    """
    L = min(math.sqrt(t0), 1.0)  # scale of |U1(tau0)|: sqrt(tau0) when small, O(1) after
    # the time t = tau0 - s since the noise was last seen: u = sqrt(t) near t = 0 (the
    # integrand has half-integer powers of t there), v = sqrt(s) near s = 0 (those of rho)
    T = min(t0, _T_CUT)
    if t0 <= 2 * _T_CUT:
        half = t0 / 2
        uh = math.sqrt(half)
        u, wu = _panels(uh * np.array([0, 0.125, 0.25, 0.5, 1.0]))
        v, wv = _panels(uh * np.array([0, 0.25, 0.5, 1.0]))
        t = np.concatenate([u * u, t0 - v * v])
        wt = np.concatenate([2 * u * wu, 2 * v * wv])
    else:
        uh = math.sqrt(T)
        u, wu = _panels(uh * np.array([0, 0.125, 0.25, 0.5, 1.0]))
        t, wt = u * u, 2 * u * wu
    s = t0 - t
    # x range: rho(x, s) <= e^-2x and <= (Gaussian of width sqrt(2 s) about -2 s) * O(1)
    xmax = np.minimum(16 * np.sqrt(s), 24.0)
    out_g = np.zeros(c.shape)
    out_d = np.zeros(c.shape)
    for i, ci in enumerate(c):
        rt = np.sqrt(t)
        # x panels per t: boundary layer of the killing (width ~ sqrt t) and the kink at c
        pts = np.stack([np.zeros_like(t), np.minimum(4 * rt, xmax),
                        np.clip(ci - 4 * rt, 0, xmax), np.clip(ci + 4 * rt, 0, xmax), xmax],
                       axis=1)
        pts = np.sort(pts, axis=1)
        a, b = pts[:, :-1, None], pts[:, 1:, None]
        x = (a + (b - a) * (1 + _GX) / 2).reshape(len(t), -1)
        wx = ((b - a) / 2 * _GW).reshape(len(t), -1)
        tt = t[:, None]
        xx = np.maximum(x, 0.0)
        m1_0, m2_0 = _killed_moments(xx, np.broadcast_to(tt, xx.shape), 0.0)
        m1_c, m2_c = _killed_moments(xx, np.broadcast_to(tt, xx.shape), ci)
        vg = (m2_0 - m2_c) / 4
        vd = (m1_0 - m1_c) / 2
        rho = _abs_density(xx, s[:, None])
        base = rho * xx * wx
        out_g[i] = np.sum(wt * np.sum(base * vg, axis=1))
        out_d[i] = np.sum(wt * np.sum(base * vd, axis=1))
    return out_g, out_d


def _law_moments(c, t0):
    """E g_c(a), E g_c(a)^2, E[a^2 g_c(a)] over the law of a = |U1(tau0)| (1-D quadrature)."""
    ymax = min(16 * math.sqrt(t0), 24.0)
    out = np.zeros((3, c.size))
    for i, ci in enumerate(c):
        edges = np.unique(np.clip([0, ymax / 8, ymax / 4, ymax / 2, ci, ymax], 0, ymax))
        y, w = _panels(edges, _GX1, _GW1)
        rho = _abs_density(y, np.float64(t0)) * w
        g = (y * y - np.maximum(y - ci, 0) ** 2) / 4
        out[0, i] = np.sum(rho * g)
        out[1, i] = np.sum(rho * g * g)
        out[2, i] = np.sum(rho * y * y * g)
    return out
