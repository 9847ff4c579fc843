"""Moments and density of (U1, U2, U3) while the noise is on (tau <= tau0), closed form.

Scaled units of eq3: dU1 = -2 sign(U1) dtau + sqrt(2) dW, dU2 = U1 dtau, dU3 = |U1| dtau,
U(0) = 0. Derivations and the one printed typo (eq10u) are in docs/analytic.md.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.special import erfc, erfcx

from ..errors import ParameterError
from . import _data
from ._check import (ArrayLike, Values, as_real, as_tau0, as_time, only_before_switch_off,
                     scalar_or_array)

__all__ = [
    "distance_second_moment",
    "velocity_abs_mean",
    "velocity_logpdf",
    "velocity_pdf",
    "velocity_var_noise_on",
    "distance_mean_noise_on",
]

# Below SWITCH the Taylor series in sqrt(tau) is summed, above it the erfcx form; chosen so
# that neither side loses more than a few hundred ulp (tests/test_analytic_stability.py).
SWITCH = 1.0


def velocity_var_noise_on(tau: ArrayLike) -> Values:
    """E[U1^2] for tau <= tau0 (eq10s); see :func:`crandall.analytic.velocity_var`."""
    return _data.M200(tau, SWITCH)


def distance_mean_noise_on(tau: ArrayLike) -> Values:
    """E[U3] for tau <= tau0 (eq10r); see :func:`crandall.analytic.distance_mean`."""
    return _data.M001(tau, SWITCH)


def distance_second_moment(tau: ArrayLike, tau0: ArrayLike = np.inf) -> Values:
    """E[U3^2] for tau <= tau0: the second moment of eq10u, *corrected*.

    .. math::
        E[U_3^2] = \\tfrac14\\tau^2 + \\tfrac18\\tau - \\tfrac{11}{32}
        + e^{-\\tau}\\Big[\\tfrac12 - \\sqrt{\\tau/\\pi}\\big(\\tfrac12\\tau^3 + \\tfrac7{12}\\tau^2
        - \\tfrac{13}{24}\\tau + \\tfrac5{16}\\big)\\Big] + \\mathrm{erfc}\\sqrt\\tau\\,\\big(
        \\tfrac12\\tau^4 + \\tfrac56\\tau^3 - \\tfrac12\\tau^2 + \\tfrac38\\tau - \\tfrac5{32}\\big)

    The paper prints the e^-tau bracket without the term -(5/16) sqrt(tau/pi); the inverse
    Laplace transform of eq10pp has it (docs/analytic.md, "Correction to eq10u").

    Parameters
    ----------
    tau : float or array_like
        Scaled time, 0 <= tau <= tau0, finite; tau above 2 sqrt(DBL_MAX) ~ 2.7e154, where the
        value overflows a double, raises ValueError.
    tau0 : float, optional
        Scaled switch-off time (default never); tau > tau0 raises ValueError.

    Returns
    -------
    float or ndarray
        E[U3^2], scaled units of U3^2. Relative error below 1e-12 over 1e-8 <= tau <= 1e6
        (series in sqrt(tau) below tau = 1, erfcx form above).
    """
    t = as_time(tau)
    only_before_switch_off(t, as_tau0(tau0), "distance_second_moment")
    if np.any(t > _M002_TAU_MAX):
        raise ParameterError("tau", 
            f"tau must be <= {_M002_TAU_MAX:.4g} for distance_second_moment: E[U3^2] ~ tau^2/4 "
            f"is beyond the range of a double, got {float(t.max())!r} (distance_var stays finite)"
        )
    return scalar_or_array(_data.M002(t, SWITCH))


# E[U3^2] = tau^2/4 + tau/8 - 11/32 + (exponentially small): the largest tau whose value is a
# finite double (the Horner sum itself overflows a little earlier than tau^2/4 = DBL_MAX).
_M002_TAU_MAX = 2.0 * math.sqrt(np.finfo(float).max) * (1 - 1e-12)


def velocity_abs_mean(tau: ArrayLike, tau0: ArrayLike = np.inf) -> Values:
    """Mean speed E|U1(tau)| for tau <= tau0.

    .. math:: E|U_1| = \\tfrac12 - (\\tau + \\tfrac12)\\,\\mathrm{erfc}\\sqrt\\tau
              + \\sqrt{\\tau/\\pi}\\, e^{-\\tau}

    Not printed in the paper: inverse of the transform of E[sign(U1) U1], 1/(p (s+1)) with
    s = sqrt(p+1) (the F+ + F- variant of eq10i), equal to d E[U3] / d tau (eq10r). Limits:
    2 sqrt(tau/pi) at small tau, 1/2 (the stationary density e^-2|y|) at large tau.

    Parameters
    ----------
    tau : float or array_like
        Scaled time, 0 <= tau <= tau0, finite.
    tau0 : float, optional
        Scaled switch-off time (default never); tau > tau0 raises ValueError.

    Returns
    -------
    float or ndarray
        E|U1|, scaled velocity units (U1 = mu g V / h^2). Relative error below 1e-12 for
        1e-8 <= tau <= 1e6.
    """
    t = as_time(tau)
    only_before_switch_off(t, as_tau0(tau0), "velocity_abs_mean")
    return scalar_or_array(_data.S100(t, SWITCH))


_LOG_4PI = math.log(4 * math.pi)


def _pdf_parts(y, tau, tau0=np.inf):
    y = as_real(y, "y")
    if np.any(np.isnan(y)):
        raise ParameterError("y", "y must not be NaN")
    if np.any(np.isinf(y)):
        raise ParameterError("y", "y must be finite")
    t = as_time(tau, allow_zero=False)
    try:
        ay, t = np.broadcast_arrays(np.abs(y), t)
    except ValueError as exc:
        raise ParameterError("y, tau", f"y and tau must broadcast together, got shapes {y.shape} "
                                       f"and {t.shape}") from exc
    ay = ay.astype(float)
    t0 = as_tau0(tau0)
    off = t > t0
    if np.any(off):
        if t0 == 0:
            raise ParameterError("tau0", "tau0 = 0: no noise, U1 = 0 (an atom, no density) at "
                                         "every tau")
        # coast: U1(tau) = sign(X) (|X| - 2 delta)_+, so |U1(tau)| = y > 0 iff |X| = y + 2 delta
        with np.errstate(over="ignore"):
            ay = np.where(off, ay + 2 * (t - t0), ay)
        t = np.where(off, t0, t)
    rt = np.sqrt(t)
    with np.errstate(over="ignore"):  # |y| / sqrt(tau) -> inf: the density is 0 there
        x = ay / (2 * rt) - rt  # (|y| - 2 tau) / (2 sqrt tau), without forming 2 tau
    return ay, t, x


def _v_squared(ay, t, x):
    """(|y| + 2 tau)^2 / (4 tau) = y^2/(4 tau) + |y| + tau, as (x + 2 sqrt tau)^2 (inf where it
    overflows, the density being 0 there)."""
    with np.errstate(over="ignore"):
        return (x + 2 * np.sqrt(t)) ** 2


def velocity_logpdf(y: ArrayLike, tau: ArrayLike, tau0: ArrayLike = np.inf) -> Values:
    """Natural log of :func:`velocity_pdf`, finite wherever the density is positive (all y).

    Same parameters as :func:`velocity_pdf`. Use it where the density underflows (far tails
    at small tau). Absolute error below 1e-12 * max(1, |log f|).
    """
    ay, t, x = _pdf_parts(y, tau, tau0)
    out = np.empty(ay.shape)
    g0 = -0.5 * (_LOG_4PI + np.log(t))  # log of (4 pi tau)^-1/2
    pos = x >= 0
    with np.errstate(over="ignore"):
        if np.any(pos):
            e = _v_squared(ay[pos], t[pos], x[pos])
            out[pos] = -e + np.log(np.exp(g0[pos]) + 0.5 * erfcx(x[pos]))
        neg = ~pos
        if np.any(neg):
            xn = x[neg]
            out[neg] = -2 * ay[neg] + np.log(0.5 * erfc(xn) + np.exp(g0[neg] - xn * xn))
    if not np.all(np.isfinite(out)):
        raise ParameterError("y, tau", 
            "y, tau: the log-density is below -1.8e308 (beyond a double) where |y| / sqrt(tau) "
            "or |y| exceed ~1e308"
        )
    return scalar_or_array(out)


def velocity_pdf(y: ArrayLike, tau: ArrayLike, tau0: ArrayLike = np.inf) -> Values:
    """Density of the scaled velocity U1(tau) for a body at rest at tau = 0, tau <= tau0.

    .. math::
        f(y, \\tau) = (4\\pi\\tau)^{-1/2} e^{-y^2/(4\\tau) - |y| - \\tau}
        + \\tfrac12 e^{-2|y|}\\,\\mathrm{erfc}\\frac{|y| - 2\\tau}{2\\sqrt\\tau}

    (the paper's f in the Results section, there written with (|y| + 2 tau)^2 / (4 tau)).
    Evaluated as e^-2|y| [erfc(x)/2 + (4 pi tau)^-1/2 e^(-x^2)] for x = (|y| - 2tau)/(2 sqrt tau)
    < 0 and as e^(-y^2/(4tau) - |y| - tau) [(4 pi tau)^-1/2 + erfcx(x)/2] for x >= 0, so that
    neither exp(-2|y|) erfc(x) nor exp(+x^2) ever over/underflows separately.

    Parameters
    ----------
    y : float or array_like
        Scaled velocity, finite; broadcast against tau.
    tau : float or array_like
        Scaled time, 0 < tau < inf.
    tau0 : float, optional
        Scaled switch-off time (default never). For tau > tau0 the law of U1(tau) is an atom
        at 0 of mass :func:`velocity_atom` (the bodies that have stopped) plus the density
        returned here, f(|y| + 2(tau - tau0), tau0) (the coast eq13a shifts |U1| down by
        2(tau - tau0)); it integrates to 1 - velocity_atom. tau0 = 0 raises ValueError (no
        density: U1 = 0).

    Returns
    -------
    float or ndarray
        Density in 1 / (scaled velocity). Relative error below 1e-12 wherever the density is a
        normal double (> 1e-300), for |y| <= 1e3 and 1e-8 <= tau <= 1e6; 0 where it underflows
        (use :func:`velocity_logpdf` there). Stationary limit e^-2|y|.
    """
    ay, t, x = _pdf_parts(y, tau, tau0)
    out = np.empty(ay.shape)
    c = 0.5 / (math.sqrt(math.pi) * np.sqrt(t))  # (4 pi tau)^-1/2 without forming 4 pi tau
    pos = x >= 0
    with np.errstate(over="ignore"):
        if np.any(pos):
            e = _v_squared(ay[pos], t[pos], x[pos])
            out[pos] = np.exp(-e) * (c[pos] + 0.5 * erfcx(x[pos]))
        neg = ~pos
        if np.any(neg):
            xn = x[neg]
            out[neg] = np.exp(-2 * ay[neg]) * (0.5 * erfc(xn) + c[neg] * np.exp(-xn * xn))
    return scalar_or_array(out)
