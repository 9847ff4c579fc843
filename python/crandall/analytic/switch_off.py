"""After the noise is switched off at tau0: the coast (eq13a-eq13c), the stop (eq14) and eq7.

With X = U1(tau0), a = |X| and delta = tau - tau0 >= 0 the body coasts:
U1 = sign(X) (a - 2 delta)_+, U3 = U3(tau0) + a delta' - delta'^2 with delta' = min(delta, a/2),
U2 = U2(tau0) + X delta' - sign(X) delta'^2, and stops at tau_s = tau0 + a/2 (eq14). Every
quantity below averages these over the law of (U1, U2, U3)(tau0). Derivations:
docs/analytic.md, "After switch-off".
"""

from __future__ import annotations

import math

import numpy as np
from scipy.special import erfc, erfcx

from . import _data
from ._check import as_time, as_tau0, scalar_or_array
from .noise_on import SWITCH, velocity_pdf

__all__ = [
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
    """H(c) = E[(|U1(tau0)| - c)_+^2], c >= 0, tau0 > 0 (arrays, broadcast).

    With N ~ Normal(-2 tau0, 2 tau0), S(y) = P(|U1(tau0)| > y) = P(N > y)
    + e^(-2y) erfc((y - 2 tau0)/(2 sqrt tau0)) / 2, and H(c) = int_c^inf 2 (y - c) S(y) dy
    = E[(N - c)_+^2] - E[(N - c)_+] - P(N > c)/2 + e^(-2c) erfc(w)/4,
    E[(N - c)_+^n] = (2 sqrt tau0)^n n! i^n erfc(v) / 2,
    v = (c + 2 tau0)/(2 sqrt tau0), w = (c - 2 tau0)/(2 sqrt tau0).
    """
    c, t = np.broadcast_arrays(np.asarray(c, float), np.asarray(tau0, float))
    c, t = np.atleast_1d(c).astype(float), np.atleast_1d(t).astype(float)
    rt = np.sqrt(t)
    v = (c + 2 * t) / (2 * rt)
    w = (c - 2 * t) / (2 * rt)
    J0, J1, J2 = _scaled_ierfc(v)
    bracket = 4 * t * J2 - rt * J1 - J0 / 4
    out = np.empty(c.shape)
    pos = w >= 0
    # 2c + w^2 = v^2: for w >= 0 both pieces share the factor exp(-v^2)
    out[pos] = np.exp(-v[pos] ** 2) * (bracket[pos] + erfcx(w[pos]) / 4)
    neg = ~pos
    out[neg] = np.exp(-v[neg] ** 2) * bracket[neg] + np.exp(-2 * c[neg]) * erfc(w[neg]) / 4
    # For small tau0 the O(1) and O(sqrt tau0) terms cancel twice (H = O(tau0)): relative loss
    # ~ 1/tau0 in double. There the same formula is evaluated in 40-digit arithmetic.
    tiny = t < _MP_BELOW
    for i in np.flatnonzero(tiny):
        out.flat[i] = _coast_h_mp(float(c.flat[i]), float(t.flat[i]))
    return np.maximum(out, 0.0)


_MP_BELOW = 0.05


def _coast_h_mp(c, t):
    ctx = _MP
    c = ctx.mpf(c)
    t = ctx.mpf(t)
    rt = ctx.sqrt(t)
    v = (c + 2 * t) / (2 * rt)
    w = (c - 2 * t) / (2 * rt)
    i0 = ctx.erfc(v)
    i1 = ctx.exp(-v * v) / ctx.sqrt(ctx.pi) - v * i0
    i2 = (i0 - 2 * v * i1) / 4
    return float(4 * t * i2 - rt * i1 - i0 / 4 + ctx.exp(-2 * c) * ctx.erfc(w) / 4)


def _mp_context():
    import mpmath

    ctx = mpmath.MPContext()
    ctx.dps = 40
    return ctx


_MP = _mp_context()


def coast_velocity_second_moment(tau, tau0):
    """E[U1(tau)^2] for tau > tau0 (noise off): E[(|U1(tau0)| - 2 (tau - tau0))_+^2].

    Called by :func:`crandall.analytic.velocity_var` for tau > tau0; see there.
    """
    t = as_time(tau)
    t0 = as_tau0(tau0)
    if t0 == 0:
        return scalar_or_array(np.zeros_like(t))
    return scalar_or_array(_coast_h(2 * (t - t0), t0))


def _tau0_array(tau0, positive=False):
    t0 = as_time(tau0, "tau0", allow_zero=not positive)
    return t0


def stop_time_mean(tau0):
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


def stop_time_var(tau0):
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


def stop_time_pdf(t, tau0):
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
    t = np.asarray(t, dtype=float)
    if np.any(np.isnan(t)) or np.any(np.isinf(t)):
        raise ValueError("t must be finite and not NaN")
    t0 = as_time(tau0, "tau0", allow_zero=False)
    t, t0 = np.broadcast_arrays(t, t0)
    y = np.where(t >= t0, 2 * (t - t0), 0.0)
    out = np.where(t >= t0, 4 * velocity_pdf(y, t0), 0.0)
    return scalar_or_array(out)


def distance_at_stop_mean(tau0):
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


def distance_at_stop_var(tau0):
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


def displacement_at_stop_var(tau0):
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
