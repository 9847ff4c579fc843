"""The law of the velocity at any time and of the stop time: CDFs, survival functions,
quantiles, and the velocity's atom at 0 after the switch-off (docs/analytic.md, "Laws").

With the noise on (tau <= tau0), |U1(tau)| has the survival function

    S(y; tau) = P(|U1(tau)| > y) = [erfc(v) + e^(-2y) erfc(w)] / 2,
    v = (y + 2 tau)/(2 sqrt tau),  w = (y - 2 tau)/(2 sqrt tau),

and U1 is symmetric, so P(U1 > y) = S(|y|)/2 for y >= 0. After the switch-off the body coasts:
U1(tau) = sign(X) (|X| - 2 delta)_+, X = U1(tau0), delta = tau - tau0, so
P(|U1(tau)| > y) = S(y + 2 delta; tau0) for y >= 0 and U1(tau) has an atom at 0 of mass
1 - S(2 delta; tau0) = P(tau_s <= tau): the stop time tau_s = tau0 + |X|/2 has the CDF
1 - S(2 (t - tau0); tau0).
"""

from __future__ import annotations

import math

import numpy as np
from scipy.optimize import brentq
from scipy.special import erfc, erfcx

from ..errors import ParameterError
from ._check import ArrayLike, Values, as_real, as_tau0, as_time, scalar_or_array
from .noise_on import velocity_pdf

__all__ = [
    "stop_time_cdf",
    "stop_time_quantile",
    "stop_time_sf",
    "velocity_atom",
    "velocity_cdf",
    "velocity_quantile",
    "velocity_sf",
]

_GL_X, _GL_W = np.polynomial.legendre.leggauss(24)


def _log_s(y, t):
    """log S(y; t) for y >= 0, t > 0 (floats), without under/overflow of the pieces.

    w < 0:  S = e^(-2y) [erfc(w) + e^(-w^2) erfcx(v)] / 2   (e^(2y) erfc(v) = e^(-w^2) erfcx(v))
    w >= 0: S = e^(-v^2) [erfcx(v) + erfcx(w)] / 2          (e^(-2y) erfc(w) = e^(-v^2) erfcx(w))
    """
    rt = math.sqrt(t)
    with np.errstate(over="ignore"):
        w = float(np.float64(y) / (2 * rt) - rt)
        v = float(np.float64(y) / (2 * rt) + rt)
    if math.isinf(v):
        return -math.inf  # |y| / sqrt(t) beyond the largest double: S underflows long before
    if w < 0:
        return -2 * y + math.log(0.5 * (erfc(w) + math.exp(-w * w) * erfcx(v)))
    inner = 0.5 * (erfcx(v) + erfcx(w))
    return -(v * v) + math.log(inner) if inner > 0 else -math.inf


def _s(y, t):
    ls = _log_s(y, t)
    return math.exp(ls) if ls > -746 else 0.0


def _f_abs(y, t):
    """P(|U1(t)| <= y), relative accuracy also where it is small: 1 - S where S <= 1/2, else
    the integral of the density 2 f over [0, y] (y then below the density's scale)."""
    s = _s(y, t)
    if s <= 0.5:
        return 1.0 - s
    nodes = 0.5 * y * (1 + _GL_X)
    return float(0.5 * y * np.sum(_GL_W * 2 * np.asarray(velocity_pdf(nodes, t))))


def _scale(t):
    return min(math.sqrt(t), 0.5)


def _s_inv(p, t):
    """y >= 0 with S(y; t) = p, 0 < p <= 1: root of log S(y) - log p (S is decreasing)."""
    if p >= 1.0:
        return 0.0
    lp = math.log(p)
    hi = _scale(t)
    while _log_s(hi, t) > lp:
        hi *= 2
    # disp=False: where the root is below the smallest double, the best estimate (0) is right
    return brentq(lambda y: _log_s(y, t) - lp, 0.0, hi, xtol=hi * 1e-300 + 5e-324, rtol=1e-15,
                  maxiter=500, disp=False)


def _f_inv(q, t):
    """y >= 0 with P(|U1(t)| <= y) = q, 0 < q <= 1/2 (where 1 - q would lose digits)."""
    hi = _scale(t)
    while _f_abs(hi, t) < q:
        hi *= 2
    return brentq(lambda y: _f_abs(y, t) - q, 0.0, hi, xtol=hi * 1e-300 + 5e-324, rtol=1e-15,
                  maxiter=500, disp=False)


def _twice_gap(t, t0):
    """2 (t - t0) as a float, inf where it overflows (the law is then at its limit)."""
    with np.errstate(over="ignore"):
        return float(2 * (np.float64(t) - np.float64(t0)))


def _setup(x, name, tau, tau0):
    x = as_real(x, name)
    if np.any(np.isnan(x)):
        raise ParameterError(name, f"{name} must not be NaN")
    t = as_time(tau)
    t0 = as_tau0(tau0)
    try:
        x, t = np.broadcast_arrays(x, t)
    except ValueError as exc:
        raise ParameterError(f"{name}, tau", f"{name} and tau must broadcast together, got shapes "
                                             f"{x.shape} and {t.shape}") from exc
    return x.astype(float), t.astype(float), t0


def _tail(ay, t, t0):
    """P(|U1(t)| > ay), ay >= 0 (floats), for any t >= 0 given the switch-off at t0."""
    if math.isinf(ay):
        return 0.0
    if t <= t0:
        if t == 0:
            return 0.0  # U1(0) = 0
        return _s(ay, t)
    if t0 == 0:
        return 0.0  # never any noise: at rest
    with np.errstate(over="ignore"):
        shifted = float(np.float64(ay) + _twice_gap(t, t0))
    return _s(shifted, t0) if math.isfinite(shifted) else 0.0


def velocity_sf(y: ArrayLike, tau: ArrayLike, tau0: ArrayLike = np.inf) -> Values:
    """Survival function of the scaled velocity, P(U1(tau) > y).

    With the noise on, P(U1 > y) = S(y)/2 for y >= 0 and 1 - S(|y|)/2 for y < 0,
    S(y) = [erfc((y + 2tau)/(2 sqrt tau)) + e^(-2y) erfc((y - 2tau)/(2 sqrt tau))]/2 the
    survival function of |U1| (the integral of the paper's density f from y to infinity). After
    the switch-off (tau > tau0) the coast shifts it: P(|U1(tau)| > y) = S(y + 2(tau - tau0); tau0).

    Parameters
    ----------
    y : float or array_like
        Scaled velocity (+-inf allowed), broadcast against tau.
    tau : float or array_like
        Scaled time, 0 <= tau < inf (tau = 0: U1 = 0).
    tau0 : float, optional
        Scaled switch-off time, >= 0; default never.

    Returns
    -------
    float or ndarray
        Probability in [0, 1]; relative accuracy ~1e-14 also in the far upper tail (computed
        as e^(log S), never as 1 - CDF).
    """
    y, t, t0 = _setup(y, "y", tau, tau0)
    out = np.empty(y.shape)
    for i, (yi, ti) in enumerate(zip(y.flat, t.flat)):
        tail = _tail(abs(yi), ti, t0) / 2
        if yi > 0:
            out.flat[i] = tail
        elif yi == 0:
            out.flat[i] = 0.5 * _tail(0.0, ti, t0)  # excludes the atom at 0, if any
        else:
            out.flat[i] = 1.0 - tail
    return scalar_or_array(out)


def velocity_cdf(y: ArrayLike, tau: ArrayLike, tau0: ArrayLike = np.inf) -> Values:
    """CDF of the scaled velocity, P(U1(tau) <= y); see :func:`velocity_sf`.

    Equal to velocity_sf(-y) by symmetry (U1 -> -U1), which is how it is computed, so the
    lower tail keeps its relative accuracy. After the switch-off the CDF jumps at 0 by
    :func:`velocity_atom`.

    Parameters
    ----------
    y : float or array_like
        Scaled velocity (+-inf allowed), broadcast against tau.
    tau : float or array_like
        Scaled time, 0 <= tau < inf.
    tau0 : float, optional
        Scaled switch-off time, >= 0; default never.

    Returns
    -------
    float or ndarray
        Probability in [0, 1].
    """
    y, t, t0 = _setup(y, "y", tau, tau0)
    out = np.empty(y.shape)
    for i, (yi, ti) in enumerate(zip(y.flat, t.flat)):
        tail = _tail(abs(yi), ti, t0) / 2
        out.flat[i] = tail if yi < 0 else 1.0 - tail
    return scalar_or_array(out)


def velocity_atom(tau: ArrayLike, tau0: ArrayLike) -> Values:
    """P(U1(tau) = 0): the mass of the velocity's atom at 0 (bodies that have stopped).

    0 while the noise is on (tau <= tau0, tau > 0: U1 has a density), 1 at tau = 0 or tau0 = 0;
    after the switch-off 1 - S(2(tau - tau0); tau0) = P(tau_s <= tau) (:func:`stop_time_cdf`).
    The rest of the law has the density f(|y| + 2(tau - tau0); tau0) (:func:`velocity_pdf`).

    Parameters
    ----------
    tau : float or array_like
        Scaled time, 0 <= tau < inf.
    tau0 : float
        Scaled switch-off time, >= 0 (numpy.inf: never).

    Returns
    -------
    float or ndarray
        Probability in [0, 1], relative accuracy ~1e-13 also where it is small.
    """
    t = as_time(tau)
    t0 = as_tau0(tau0)
    out = np.empty(t.shape)
    for i, ti in enumerate(t.flat):
        if ti == 0 or t0 == 0:
            out.flat[i] = 1.0
        elif ti <= t0:
            out.flat[i] = 0.0
        else:
            out.flat[i] = _stop_law_at(ti, t0, sf=False)  # stopped by tau: P(tau_s <= tau)
    return scalar_or_array(out)


def _check_q(q):
    q = as_real(q, "q")
    if np.any(np.isnan(q)) or np.any((q <= 0) | (q >= 1)):
        raise ParameterError("q", 
            "q must lie strictly between 0 and 1 (the laws have unbounded support: the 0 and 1 "
            "quantiles are infinite)"
        )
    return q


def velocity_quantile(q: ArrayLike, tau: ArrayLike, tau0: ArrayLike = np.inf) -> Values:
    """Quantile of the scaled velocity U1(tau): the smallest y with P(U1(tau) <= y) >= q.

    Solved from the survival function of |U1| (:func:`velocity_sf`) by Brent's method on
    log S, with q mapped to the tail it lies in (2q or 2(1 - q), both exact in floating point
    for q <= 1/2 and q >= 1/2 respectively). After the switch-off, q within the atom at 0
    (|q - 1/2| <= velocity_atom / 2) gives 0, and otherwise y = +-(S^-1(.; tau0) - 2 delta).

    Parameters
    ----------
    q : float or array_like
        Probability, 0 < q < 1, broadcast against tau.
    tau : float or array_like
        Scaled time, 0 <= tau < inf (tau = 0: always 0).
    tau0 : float, optional
        Scaled switch-off time, >= 0; default never.

    Returns
    -------
    float or ndarray
        Scaled velocity; relative accuracy ~1e-13 (absolute ~1e-16 * 2 delta after the
        switch-off, where a shift is subtracted).
    """
    q = _check_q(q)
    q, t, t0 = _setup(q, "q", tau, tau0)
    out = np.empty(q.shape)
    for i, (qi, ti) in enumerate(zip(q.flat, t.flat)):
        if ti == 0 or t0 == 0:
            out.flat[i] = 0.0
            continue
        p = 2 * qi if qi < 0.5 else 2 * (1 - qi)  # P(|U1| > |y|) at the quantile
        sign = -1.0 if qi < 0.5 else 1.0
        if ti <= t0:
            out.flat[i] = sign * _s_inv(p, ti) if qi != 0.5 else 0.0
            continue
        shift = _twice_gap(ti, t0)
        if not math.isfinite(shift) or p >= _s(shift, t0):
            out.flat[i] = 0.0
        else:
            out.flat[i] = sign * (_s_inv(p, t0) - shift)
    return scalar_or_array(out)


def _stop_setup(x, name, tau0):
    x = as_real(x, name)
    if np.any(np.isnan(x)):
        raise ParameterError(name, f"{name} must not be NaN")
    t0 = as_time(tau0, "tau0")
    try:
        x, t0 = np.broadcast_arrays(x, t0)
    except ValueError as exc:
        raise ParameterError(f"{name}, tau0", f"{name} and tau0 must broadcast together, got "
                                              f"shapes {x.shape} and {t0.shape}") from exc
    return x.astype(float), t0.astype(float)


def _stop_law_at(t, t0, sf):
    """P(tau_s > t) if sf, else P(tau_s <= t), for floats t, t0 >= 0; each keeps its relative
    accuracy where it is small (S itself for the survival function, :func:`_f_abs` for the CDF,
    never one as 1 minus the other)."""
    if t < t0:
        return 1.0 if sf else 0.0
    at_rest = 0.0 if sf else 1.0
    if t0 == 0:
        return at_rest
    c = _twice_gap(t, t0)
    if not math.isfinite(c):
        return at_rest
    return _s(c, t0) if sf else _f_abs(c, t0)


def _stop_law(t, tau0, sf):
    t, t0 = _stop_setup(t, "t", tau0)
    out = np.empty(t.shape)
    for i, (ti, t0i) in enumerate(zip(t.flat, t0.flat)):
        out.flat[i] = _stop_law_at(ti, t0i, sf)
    return scalar_or_array(out)


def stop_time_cdf(t: ArrayLike, tau0: ArrayLike) -> Values:
    """CDF of the stop time, P(tau_s <= t) = P(|U1(tau0)| <= 2(t - tau0)) (eq14).

    0 for t < tau0; 1 - S(2(t - tau0); tau0) for t >= tau0, with S the survival function of
    |U1(tau0)| (:func:`velocity_sf`); computed with relative accuracy also just after tau0,
    where it is small (integral of the density there). tau0 = 0: tau_s = 0.

    Parameters
    ----------
    t : float or array_like
        Scaled time (+-inf allowed), broadcast against tau0.
    tau0 : float or array_like
        Scaled switch-off time, 0 <= tau0 < inf.

    Returns
    -------
    float or ndarray
        Probability in [0, 1].
    """
    return _stop_law(t, tau0, sf=False)


def stop_time_sf(t: ArrayLike, tau0: ArrayLike) -> Values:
    """P(tau_s > t) = S(2(t - tau0); tau0) for t >= tau0, 1 before; see :func:`stop_time_cdf`.
    Relative accuracy kept in the far tail (the probability that the body still slides).

    Parameters
    ----------
    t : float or array_like
        Scaled time (+-inf allowed), broadcast against tau0.
    tau0 : float or array_like
        Scaled switch-off time, 0 <= tau0 < inf.

    Returns
    -------
    float or ndarray
        Probability in [0, 1].
    """
    return _stop_law(t, tau0, sf=True)


def stop_time_quantile(q: ArrayLike, tau0: ArrayLike) -> Values:
    """Quantile of the stop time: tau0 + y/2 with P(|U1(tau0)| <= y) = q.

    For q >= 1/2 solved on the survival function (S(y) = 1 - q, exact), for q < 1/2 on the
    CDF itself, so that both tails keep their digits (the time by which the body is at rest
    with probability q).

    Parameters
    ----------
    q : float or array_like
        Probability, 0 < q < 1, broadcast against tau0.
    tau0 : float or array_like
        Scaled switch-off time, 0 <= tau0 < inf (0: the stop time is 0).

    Returns
    -------
    float or ndarray
        Scaled time >= tau0.
    """
    q = _check_q(q)
    q, t0 = _stop_setup(q, "q", tau0)
    out = np.empty(q.shape)
    for i, (qi, t0i) in enumerate(zip(q.flat, t0.flat)):
        if t0i == 0:
            out.flat[i] = 0.0
            continue
        y = _s_inv(1 - qi, t0i) if qi >= 0.5 else _f_inv(qi, t0i)
        out.flat[i] = t0i + y / 2
    return scalar_or_array(out)
