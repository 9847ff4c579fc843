"""After the noise is switched off at tau0: the coast (eq13a-eq13c), the stop (eq14) and eq7.

With X = U1(tau0), a = |X| and delta = tau - tau0 >= 0 the body coasts:
U1 = sign(X) (a - 2 delta)_+, U3 = U3(tau0) + a delta' - delta'^2 with delta' = min(delta, a/2),
U2 = U2(tau0) + X delta' - sign(X) delta'^2, and stops at tau_s = tau0 + a/2 (eq14). Every
quantity below averages these over the law of (U1, U2, U3)(tau0). Derivations:
docs/analytic.md, "After switch-off".
"""

from __future__ import annotations

import math
from typing import Union

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.special import erfc, erfcx

from ..errors import ParameterError
from . import _data
from ._check import ArrayLike, Values, as_real, as_tau0, as_time, scalar_or_array
from .noise_on import SWITCH, velocity_pdf

__all__ = [
    "coast_distance_increment",
    "coast_velocity_second_moment",
    "displacement_at_stop_var",
    "distance_at_stop_mean",
    "distance_at_stop_var",
    "stop_time_mean",
    "stop_time_pdf",
    "stop_time_var",
]

_SQPI_INV = 1.0 / math.sqrt(math.pi)


def _scaled_ierfc(v):
    """J_n(v) = exp(v^2) i^n erfc(v), n = 0, 1, 2, for v >= 0 (repeated integrals of erfc).

    Forward recurrence 2n J_n = J_(n-2) - 2v J_(n-1) below v = 2 (mild cancellation);
    above, J_n is the minimal solution and Miller's backward recurrence is used, normalised by
    J_0 = erfcx(v).
    """
    v = np.atleast_1d(np.asarray(v, dtype=float))
    J0 = erfcx(v)
    J1 = _SQPI_INV - v * J0
    J2 = (J0 - 2 * v * J1) / 4
    big = v >= 2
    if np.any(big):
        vb = v[big]
        # (a, b) = (y_n, y_(n-1)), stepped down with y_(n-2) = 2 n y_n + 2 v y_(n-1)
        a = np.zeros_like(vb)
        b = np.full_like(vb, 1e-300)
        y2 = None
        for n in range(60, 1, -1):
            a, b = b, 2 * n * a + 2 * vb * b  # now (y_(n-1), y_(n-2))
            if n == 3:
                y2 = a
            scale = np.where(np.abs(b) > 1e250, 1e-250, 1.0)
            a, b = a * scale, b * scale
            if y2 is not None:
                y2 = y2 * scale
        # after n == 2: a = y_1, b = y_0 (y2 was rescaled along with them)
        norm = erfcx(vb) / b
        J1 = J1.copy()
        J2 = J2.copy()
        J1[big] = a * norm
        J2[big] = y2 * norm
    return J0, J1, J2


def _coast_h(c, tau0):
    """H(c) = E[(|U1(tau0)| - c)_+^2], c >= 0 (array), tau0 > 0 (float).

    With S(y) = P(|U1(tau0)| > y) = [erfc(v_y) + e^(-2y) erfc(w_y)] / 2,
    v_y = (y + 2 tau0)/(2 sqrt tau0), w_y = (y - 2 tau0)/(2 sqrt tau0), and H(c) =
    int_c^inf 2 (y - c) S(y) dy:

        H(c) = 4 tau0 i^2erfc(v) - sqrt(tau0) i^1erfc(v) - erfc(v)/4 + e^(-2c) erfc(w)/4

    at v = v_c, w = w_c. Regimes (docs/analytic.md, "Evaluating the coast"):

    * H <= 4 tau0 exp(-w^2) for w >= 0 (both halves of S are below erfc(w_y)), so where
      that bound is below the smallest double H is 0;
    * exp(-v^2) underflows for v > 27.3 and with it every i^n erfc(v) term (each is at most
      tau0 / v^3, v >= sqrt(tau0)): only e^(-2c) erfc(w)/4 is left;
    * tau0 < 0.05: the O(1) and O(sqrt tau0) terms cancel twice (H = O(tau0)), relative
      loss ~ 1/tau0: there H is rewritten as a sum of positive terms (:func:`_coast_h_small`).
    """
    c = np.atleast_1d(np.asarray(c, dtype=float))
    t = float(tau0)
    rt = math.sqrt(t)
    out = np.zeros(c.shape)
    with np.errstate(over="ignore"):  # c / sqrt(tau0) -> inf is cut by `live` below
        w = (c - 2 * t) / (2 * rt)
        v = (c + 2 * t) / (2 * rt)
        live = ~((w > 0) & (w * w > 745.0 + math.log(4 * t)))
    if t < _SMALL_BELOW:
        if np.any(live):
            out[live] = _coast_h_small(w[live], v[live], t)
        return np.maximum(out, 0.0)
    vv = live & (v < 27.3)
    if np.any(vv):
        J0, J1, J2 = _scaled_ierfc(v[vv])
        bracket = 4 * t * J2 - rt * J1 - J0 / 4
        ev = np.exp(-v[vv] ** 2)
        wv = w[vv]
        pos = wv >= 0
        part = np.empty(wv.shape)
        # 2c + w^2 = v^2: for w >= 0 both pieces share the factor exp(-v^2)
        part[pos] = ev[pos] * (bracket[pos] + erfcx(wv[pos]) / 4)
        neg = ~pos
        part[neg] = ev[neg] * bracket[neg] + np.exp(-2 * c[vv][neg]) * erfc(wv[neg]) / 4
        out[vv] = part
    rest = live & ~vv
    if np.any(rest):
        wr = w[rest]
        # exp(-2c) erfc(w) = exp(-v^2) erfcx(w) for w >= 0: both factors stay in range
        out[rest] = np.where(
            wr >= 0,
            np.exp(-np.minimum(v[rest], 1e154) ** 2) * erfcx(np.maximum(wr, 0)) / 4,
            np.exp(-2 * c[rest]) * erfc(np.minimum(wr, 0)) / 4,
        )
    return np.maximum(out, 0.0)


_SMALL_BELOW = 0.05

# 3 panels x 16 Gauss-Legendre nodes on [0, s*] (see _coast_h_small)
_P_X, _P_W = np.polynomial.legendre.leggauss(16)
_PANELS = ((0.0, 0.125), (0.125, 0.5), (0.5, 1.0))


def _coast_h_small(w, v, t):
    """H for tau0 < 0.05 as a sum of positive terms (no cancellation, double precision).

    With y = 2 tau0 + 2 sqrt(tau0) u and eps = 2 sqrt(tau0) = v - w, the part of H from the
    e^(-2y) erfc(w_y) half of S is 4 tau0 e^(-eps^2) int_w^inf (u - w) e^(-2 eps u) erfc(u) du,
    so, with s = u - w,

        H = 4 tau0 [ i^2erfc(v) + e^(-eps^2 - 2 eps w) int_0^inf s e^(-2 eps s) erfc(w + s) ds ]
          = 4 tau0 e^(-v^2) [ J_2(v) + int_0^inf s e^(-2 v s - s^2) erfcx(w + s) ds ]   (w >= 0),

    using erfc(w + s) = erfcx(w + s) e^(-(w + s)^2) and eps + w = v. Here w >= -sqrt(tau0) >
    -0.23, so the integrand decays like e^(-2 v s - s^2) (w >= 0) or like erfc(w + s) (w < 0):
    it is below e^-36 of its scale beyond s* = sqrt(v^2 + 36) - v (w >= 0) or 7 (w < 0);
    [0, s*] is split into three Gauss-Legendre panels.
    """
    eps = 2 * math.sqrt(t)
    out = np.empty(w.shape)
    pos = w >= 0
    if np.any(pos):
        wp, vp = w[pos], v[pos]
        smax = np.sqrt(vp * vp + 36.0) - vp
        integral = np.zeros(wp.shape)
        for a, b in _PANELS:
            s_ = smax[:, None] * (a + (b - a) * (1 + _P_X) / 2)
            f = s_ * np.exp(-2 * vp[:, None] * s_ - s_ * s_) * erfcx(wp[:, None] + s_)
            integral += smax * (b - a) / 2 * (f @ _P_W)
        _, _, J2 = _scaled_ierfc(vp)
        out[pos] = 4 * t * np.exp(-vp * vp) * (J2 + integral)
    neg = ~pos
    if np.any(neg):
        wn, vn = w[neg], v[neg]
        integral = np.zeros(wn.shape)
        for a, b in _PANELS:
            s_ = 7.0 * (a + (b - a) * (1 + _P_X) / 2)
            f = s_[None, :] * np.exp(-2 * eps * s_[None, :]) * erfc(wn[:, None] + s_[None, :])
            integral += 7.0 * (b - a) / 2 * (f @ _P_W)
        _, _, J2 = _scaled_ierfc(vn)
        out[neg] = 4 * t * (np.exp(-vn * vn) * J2 + np.exp(-eps * eps - 2 * eps * wn) * integral)
    return out


_GL_X, _GL_W = np.polynomial.legendre.leggauss(24)


def _abs_cdf(y, t):
    """P(|U1(t)| <= y), y >= 0, t > 0 (absolute error ~1e-16: used where that suffices)."""
    rt = math.sqrt(t)
    v = (y + 2 * t) / (2 * rt)
    w = (y - 2 * t) / (2 * rt)
    return 1.0 - 0.5 * (erfc(v) + np.exp(-2 * y) * erfc(w))


def _coast_k(delta, tau0):
    """K(delta) = E[U3(tau0 + delta)] - E[U3(tau0)] = E[a delta' - delta'^2],
    a = |U1(tau0)|, delta' = min(delta, a/2); delta >= 0 (array), tau0 > 0.

    Two exact forms, each used where it does not cancel:

    * K = (E a^2 - H(2 delta)) / 4, for delta > E a / 4 (then K >= E a^2 / 16 roughly, the
      difference loses at most a digit);
    * K = delta E a - delta^2 + int_0^(2 delta) P(a <= y) (delta - y/2) dy, for delta <= E a / 4
      (d^2K/d delta^2 = -2 P(a > 2 delta)): a sum of non-negative terms with the first
      dominant; the integral, at most 3 % of K, by 24-point Gauss-Legendre.
    """
    d = np.atleast_1d(np.asarray(delta, dtype=float))
    t = float(tau0)
    ea = float(_data.S100(np.array([t]), SWITCH)[0])
    ea2 = float(_data.M200(np.array([t]), SWITCH)[0])
    out = np.empty(d.shape)
    big = d > ea / 4
    if np.any(big):
        out[big] = (ea2 - _coast_h(2 * d[big], t)) / 4
    small = ~big
    for i in np.flatnonzero(small):
        di = float(d.flat[i])
        if di == 0.0:
            out.flat[i] = 0.0
            continue
        y = di * (1 + _GL_X)  # nodes on [0, 2 delta]
        r = di * float(np.sum(_GL_W * _abs_cdf(y, t) * (di - y / 2)))
        out.flat[i] = di * ea - di * di + r
    return np.maximum(out, 0.0)


def coast_velocity_second_moment(tau: ArrayLike, tau0: ArrayLike,
                                 elapsed: ArrayLike = None) -> Values:
    """E[U1(tau)^2] for tau > tau0 (noise off): E[(|U1(tau0)| - 2 (tau - tau0))_+^2].

    Called by :func:`crandall.analytic.velocity_var` for tau > tau0; see there. ``elapsed``:
    tau - tau0, where the caller knows it better than the difference of two doubles.
    """
    t = as_time(tau)
    t0 = as_tau0(tau0)
    if t0 == 0:
        return scalar_or_array(np.zeros_like(t))
    return scalar_or_array(_coast_h(_coast_c(t, t0, elapsed), t0))


def _coast_c(t, t0, elapsed=None):
    """c = 2 (tau - tau0), finite even where tau - tau0 overflows (|tau|, tau0 near 1e308).

    ``elapsed`` (an array like ``t``), when given, is tau - tau0 itself: a caller that knows
    the time since the switch-off more exactly than the difference of the two doubles passes
    it (:func:`crandall.analytic.physical`: t - t0 in seconds, then scaled; just after a
    switch-off at tau0 = 5e15, one ulp of tau0 is 1, so tau - tau0 would round to 0 or 1)."""
    with np.errstate(over="ignore"):
        c = 2 * (t - t0) if elapsed is None else 2 * np.broadcast_to(
            np.asarray(elapsed, dtype=float), np.shape(t))
    return np.where(np.isfinite(c), c, np.finfo(float).max)


def coast_distance_increment(tau: ArrayLike, tau0: ArrayLike, elapsed: ArrayLike = None) -> Values:
    """E[U3(tau)] - E[U3(tau0)] for tau > tau0 (noise off); see
    :func:`crandall.analytic.distance_mean` (``elapsed`` as in
    :func:`coast_velocity_second_moment`)."""
    t = as_time(tau)
    t0 = as_tau0(tau0)
    if t0 == 0:
        return scalar_or_array(np.zeros_like(t))
    return scalar_or_array(_coast_k(_coast_c(t, t0, elapsed) / 2, t0))


def _tau0_array(tau0, positive=False):
    t0 = as_time(tau0, "tau0", allow_zero=not positive)
    return t0


def stop_time_mean(tau0: ArrayLike) -> Union[float, "NDArray[np.float64]"]:
    """Mean stop time E[tau_s] = tau0 + E|U1(tau0)| / 2 (eq14).

    .. math:: E\\tau_s = \\tau_0 + \\tfrac14 - \\tfrac12(\\tau_0 + \\tfrac12)\\mathrm{erfc}
              \\sqrt{\\tau_0} + \\tfrac12\\sqrt{\\tau_0/\\pi}\\,e^{-\\tau_0}

    Parameters
    ----------
    tau0 : float or array_like
        Scaled switch-off time, 0 <= tau0 < inf.

    Returns
    -------
    float or ndarray
        Scaled time. Relative error below 1e-12 for 1e-8 <= tau0 <= 1e6.
    """
    t0 = _tau0_array(tau0)
    return scalar_or_array(t0 + 0.5 * _data.S100(t0, SWITCH))


def stop_time_var(tau0: ArrayLike) -> Union[float, "NDArray[np.float64]"]:
    """Variance of the stop time, Var tau_s = (E[U1(tau0)^2] - E|U1(tau0)|^2) / 4 (eq14).

    .. math:: \\mathrm{Var}\\,\\tau_s = \\tfrac14\\big(\\sigma_{U_1}^2(\\tau_0)
              - (E|U_1(\\tau_0)|)^2\\big)

    formed in exact arithmetic before evaluation. Limits: (1/2 - 1/pi) tau0 at small tau0,
    1/16 at large tau0 (|U1| exponential with mean 1/2).

    Parameters
    ----------
    tau0 : float or array_like
        Scaled switch-off time, 0 <= tau0 < inf.

    Returns
    -------
    float or ndarray
        Scaled time squared; relative error below 1e-12 for 1e-8 <= tau0 <= 1e6.
    """
    t0 = _tau0_array(tau0)
    return scalar_or_array(_data.VAR_STOP_TIME(t0, SWITCH))


def stop_time_pdf(t: ArrayLike, tau0: ArrayLike) -> Values:
    """Density of the stop time tau_s = tau0 + |U1(tau0)|/2 (eq14).

    .. math:: f_{\\tau_s}(t) = 4 f\\big(2(t - \\tau_0), \\tau_0\\big), \\quad t \\ge \\tau_0,

    and 0 for t < tau0, with f the density of U1 (:func:`velocity_pdf`): |U1| has density 2f on
    y >= 0 and t = tau0 + y/2. (The paper's displayed "f_tau_s(y, tau)" is this f, the density
    of U1 at tau0, not of tau_s.)

    Parameters
    ----------
    t : float or array_like
        Scaled time, finite, broadcast against tau0.
    tau0 : float or array_like
        Scaled switch-off time, 0 < tau0 < inf.

    Returns
    -------
    float or ndarray
        Density in 1 / (scaled time); accuracy as :func:`velocity_pdf`.
    """
    t = as_real(t, "t")
    if np.any(np.isnan(t)) or np.any(np.isinf(t)):
        raise ParameterError("t", "t must be finite and not NaN")
    t0 = as_time(tau0, "tau0", allow_zero=False)
    try:
        t, t0 = np.broadcast_arrays(t, t0)
    except ValueError as exc:
        raise ParameterError("t, tau0", "t and tau0 must broadcast together, got shapes "
                                        f"{t.shape} and {t0.shape}") from exc
    with np.errstate(over="ignore"):
        y = np.where(t >= t0, 2 * (t - t0), 0.0)
    # |U1(tau0)| = y beyond the largest double: the density is 0 to double precision there
    finite = np.isfinite(y)
    out = np.zeros(y.shape)
    on = (t >= t0) & finite
    if np.any(on):
        out[on] = 4 * np.asarray(velocity_pdf(y[on], t0[on]))
    return scalar_or_array(out)


def distance_at_stop_mean(tau0: ArrayLike) -> Values:
    """Mean distance at the stop, E[U3(tau_s)] = E[U3(tau0)] + E[U1(tau0)^2]/4 (eq13c, eq14).

    Computed from eq10r and eq10s, not from eq7, so that it checks eq7: the sum is tau0/2 (the
    mean dissipated energy equals the foundation's mean kinetic energy h^2 t0 / 2).

    Parameters
    ----------
    tau0 : float or array_like
        Scaled switch-off time, 0 <= tau0 < inf.

    Returns
    -------
    float or ndarray
        Scaled distance; relative error below 1e-12 for 1e-8 <= tau0 <= 1e6.
    """
    t0 = _tau0_array(tau0)
    return scalar_or_array(_data.M001(t0, SWITCH) + 0.25 * _data.M200(t0, SWITCH))


def distance_at_stop_var(tau0: ArrayLike) -> Values:
    """Variance of the distance at the stop, Var U3(tau_s).

    Martingale identity (Ito on U1^2/4, docs/analytic.md): U3(tau_s) = tau0/2
    + (sqrt 2 / 2) int_0^tau0 U1 dW, hence Var U3(tau_s) = (1/2) int_0^tau0 E[U1^2] dtau:

    .. math:: \\mathrm{Var}\\,U_3(\\tau_s) = \\tfrac14\\tau_0 - \\tfrac18
              + \\sqrt{\\tau_0/\\pi}\\,e^{-\\tau_0}\\big(\\tfrac14 - \\tfrac13\\tau_0
              - \\tfrac13\\tau_0^2\\big) + \\mathrm{erfc}\\sqrt{\\tau_0}\\big(\\tfrac18
              - \\tfrac14\\tau_0 + \\tfrac12\\tau_0^2 + \\tfrac13\\tau_0^3\\big)

    Identical, in exact arithmetic, to Var U3(tau0) + Var(U1^2)/16 + Cov(U3, U1^2)/2 built
    from m_002, m_001, m_400, m_200, m_201 (checked in tests). Limits: tau0^2/2 at small tau0,
    tau0/4 - 1/8 at large tau0.

    Parameters
    ----------
    tau0 : float or array_like
        Scaled switch-off time, 0 <= tau0 < inf.

    Returns
    -------
    float or ndarray
        Scaled distance squared; relative error below 1e-12 for 1e-8 <= tau0 <= 1e6.
    """
    t0 = _tau0_array(tau0)
    return scalar_or_array(_data.HALF_INT_M200(t0, SWITCH))


def displacement_at_stop_var(tau0: ArrayLike) -> Values:
    """Variance of the displacement at the stop, Var U2(tau_s).

    U2(tau_s) = U2(tau0) + U1(tau0) |U1(tau0)| / 4 (eq13b at eq14), E[U2(tau_s)] = 0, so
    Var U2(tau_s) = m_020 + E[sign(U1) U1^2 U2]/2 + m_400/16 at tau0; the middle term is the
    inverse of the signed transform (F+ + F- in eq10i). Closed form:

    .. math:: \\tfrac58\\tau_0 - \\tfrac{15}{32} + \\tfrac14 e^{-\\tau_0}
              + \\sqrt{\\tau_0/\\pi}\\,e^{-\\tau_0}\\big(\\tfrac7{16} - \\tfrac{11}{24}\\tau_0
              - \\tfrac13\\tau_0^2\\big) + \\mathrm{erfc}\\sqrt{\\tau_0}\\big(\\tfrac7{32}
              - \\tfrac38\\tau_0 + \\tfrac58\\tau_0^2 + \\tfrac13\\tau_0^3\\big)

    Limits: (3/4) tau0^2 at small tau0 (from E[U1^4]/16 = (3/4) tau0^2), (5/8) tau0 - 15/32 at
    large tau0.

    Parameters
    ----------
    tau0 : float or array_like
        Scaled switch-off time, 0 <= tau0 < inf.

    Returns
    -------
    float or ndarray
        Scaled displacement squared; relative error below 1e-12 for 1e-8 <= tau0 <= 1e6.
    """
    t0 = _tau0_array(tau0)
    return scalar_or_array(_data.VAR_U2_AT_STOP(t0, SWITCH))
