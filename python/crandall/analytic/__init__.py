"""Analytic reference for Crandall's problem (Berezin & Zayats), in the scaled units of eq3.

dU1 = -2 sign(U1) dtau + sqrt(2) dW (noise switched off at tau0), dU2 = U1 dtau,
dU3 = |U1| dtau, U(0) = 0. Velocity U1, displacement U2, distance travelled U3; tau is scaled
time (eq8). All functions take numpy arrays and return floats or arrays; every argument is checked by one
validator (``_check.py``): bad input raises a ValueError naming the parameter. Derivations, the
correction to the printed eq10u and the post-switch-off formulas: docs/analytic.md.

This package imports numpy, scipy and mpmath only; ``symbolic`` (exact closed forms of any
moment) and ``laplace_moment(..., exact=True)`` import sympy when called.
"""

from __future__ import annotations

from typing import Union

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..errors import ParameterError
from . import _data
from . import coast_var as _cv
from . import switch_off as _so
from ._check import ArrayLike, Values, as_tau0, as_time, scalar_or_array
from ._laplace import laplace_moment, moment, signed_moment
from .noise_on import SWITCH as _SWITCH
from .noise_on import (
    distance_mean_noise_on as _distance_mean_on,
    distance_second_moment,
    velocity_abs_mean,
    velocity_logpdf,
    velocity_pdf,
    velocity_var_noise_on as _velocity_var_on,
)
from .laws import (
    stop_time_cdf,
    stop_time_quantile,
    stop_time_sf,
    velocity_atom,
    velocity_cdf,
    velocity_quantile,
    velocity_sf,
)
from .physical import physical
from . import schedule
from .start import (
    coast_distance,
    coast_stop_time,
    distance_at_stop_mean_from,
    distance_mean_from_velocity,
)
from .switch_off import (
    displacement_at_stop_var,
    distance_at_stop_mean,
    distance_at_stop_var,
    stop_time_mean,
    stop_time_pdf,
    stop_time_var,
)

#: What a closed form returns: a float for a scalar time, an array (of the times' shape) for
#: an array of times.
Scalar = Union[float, "NDArray[np.float64]"]

__all__ = [
    "schedule",
    "coast_distance",
    "coast_stop_time",
    "distance_at_stop_mean_from",
    "distance_mean_from_velocity",
    "displacement_at_stop_var",
    "displacement_var",
    "distance_at_stop_mean",
    "distance_at_stop_var",
    "distance_mean",
    "distance_second_moment",
    "distance_var",
    "laplace_moment",
    "moment",
    "physical",
    "signed_moment",
    "stop_time_cdf",
    "stop_time_mean",
    "stop_time_pdf",
    "stop_time_quantile",
    "stop_time_sf",
    "stop_time_var",
    "velocity_abs_mean",
    "velocity_atom",
    "velocity_cdf",
    "velocity_logpdf",
    "velocity_pdf",
    "velocity_quantile",
    "velocity_sf",
    "velocity_abs_distance_cov",
    "velocity_displacement_cov",
    "velocity_var",
]


def _on_then_coast(tau, tau0, on, coast):
    """The quantity at every tau: ``on(t)`` (closed form) where tau <= tau0, ``coast(t, t0)``
    after the switch-off."""
    t = as_time(tau)
    t0 = as_tau0(tau0)
    out = np.empty(t.shape)
    before = t <= t0
    if np.any(before):
        out[before] = on(t[before])
    if np.any(~before):
        out[~before] = coast(t[~before], t0)
    return scalar_or_array(out)


def _coast_since(name, elapsed, tau0):
    """The quantity ``name`` of :func:`physical`'s table (not at the stop) a scaled time
    ``elapsed`` > 0 after the switch-off at ``tau0`` (finite, > 0), for a caller that knows the
    elapsed time more exactly than tau - tau0 in doubles would give it."""
    t0 = float(tau0)
    e = float(elapsed)
    t = np.array([t0 + e])  # only the checks of tau > tau0 use it
    el = np.array([e])
    if name == "velocity_var":
        value = _so.coast_velocity_second_moment(t, t0, el)
    elif name == "distance_mean":
        value = _distance_mean_on(np.array([t0]))[0] + _so.coast_distance_increment(t, t0, el)
    elif name == "displacement_var":
        value = _cv.coast_displacement_var(t, t0, el)
    elif name == "distance_var":
        value = _cv.coast_distance_var(t, t0, el)
    else:
        raise ParameterError("name", f"name: {name!r} has no closed form after the switch-off")
    return float(np.ravel(value)[0])


def velocity_var(tau: ArrayLike, tau0: float = np.inf) -> Scalar:
    """Variance of the scaled velocity, Var U1(tau) = E[U1^2] (E U1 = 0 by symmetry).

    For tau <= tau0 (eq10s):

    .. math:: \\sigma_{U_1}^2 = \\tfrac12\\big[\\mathrm{erf}\\sqrt\\tau
              + 4\\tau(\\tau+1)\\,\\mathrm{erfc}\\sqrt\\tau
              - 2(1 + 2\\tau)\\sqrt{\\tau/\\pi}\\,e^{-\\tau}\\big]

    For tau > tau0 the coast eq13a averaged over the law of U1(tau0):
    E[(|U1(tau0)| - 2 (tau - tau0))_+^2], in closed form through repeated integrals of erfc
    (docs/analytic.md, "After switch-off"); 0 once every path has stopped.

    Parameters
    ----------
    tau : float or array_like
        Scaled time (eq8), 0 <= tau < inf.
    tau0 : float, optional
        Scaled switch-off time, >= 0; default never (numpy.inf).

    Returns
    -------
    float or ndarray
        Var U1 in scaled units (U1 = mu g V / h^2). Limits: 2 tau at small tau, 1/2 at large.

    Notes
    -----
    Accuracy for tau <= tau0: relative error below 1e-12 over 1e-8 <= tau <= 1e6, below 1e-10
    over 1e-300 <= tau <= 1e300. For tau > tau0, any tau0 in [0, 1e300]: relative error below
    1e-10 where the value exceeds 1e-25 E[U1(tau0)^2]; beyond (the Gaussian far tail, stop
    almost surely reached) absolute error below 1e-17 E[U1(tau0)^2]; exactly 0 where a bound
    shows the value is below the smallest double (docs/analytic.md, "Evaluating the coast").
    Speed: about a microsecond per point, in double precision for every tau0.
    """
    return _on_then_coast(tau, tau0, _velocity_var_on, _so.coast_velocity_second_moment)


def distance_mean(tau: ArrayLike, tau0: float = np.inf) -> Scalar:
    """Mean scaled distance travelled, E[U3(tau)].

    For tau <= tau0 (eq10r):

    .. math:: \\bar u_3 = \\tfrac18\\big[2(1 + 2\\tau)\\sqrt{\\tau/\\pi}\\,e^{-\\tau}
              - 4\\tau^2\\mathrm{erfc}\\sqrt\\tau + (4\\tau - 1)\\,\\mathrm{erf}\\sqrt\\tau\\big]

    For tau > tau0, eq13c averaged: E[U3(tau0)] + K(delta), K = E[a delta' - delta'^2],
    a = |U1(tau0)|, delta = tau - tau0, delta' = min(delta, a/2), which tends to tau0/2 (eq7) as
    the body stops. K is evaluated as a sum of non-negative terms (docs/analytic.md,
    "Evaluating the coast"), never as tau0/2 - E[(a/2 - delta)_+^2], which cancels just after
    the switch-off.

    Parameters
    ----------
    tau : float or array_like
        Scaled time (eq8), 0 <= tau < inf.
    tau0 : float, optional
        Scaled switch-off time, >= 0; default never.

    Returns
    -------
    float or ndarray
        E U3 in scaled units (U3 = mu^3 g^3 S / (2 h^4)). Limits: (4/3) tau^(3/2)/sqrt(pi) at
        small tau, tau/2 - 1/8 at large tau.

    Notes
    -----
    Accuracy: relative error below 1e-12 for 1e-8 <= tau <= 1e6 (tau <= tau0), below 1e-10
    for 1e-300 <= tau <= 1e300; below 1e-10 after switch-off for any tau0 in [0, 1e300].
    """
    # E U3(tau0) + E[a delta' - delta'^2]: a sum of non-negative terms (a form t0/2 - H/4
    # would cancel catastrophically just after the switch-off)
    return _on_then_coast(tau, tau0, _distance_mean_on, lambda t, t0: (
        _distance_mean_on(np.array([t0]))[0] + _so.coast_distance_increment(t, t0)))


def displacement_var(tau: ArrayLike, tau0: float = np.inf) -> Scalar:
    """Variance of the scaled displacement, Var U2(tau) = E[U2^2] (E U2 = 0 by symmetry).

    For tau <= tau0 (eq10t):

    .. math::
        \\sigma_{U_2}^2 = \\tfrac58\\tau - \\tfrac{27}{32} + e^{-\\tau}\\Big[1 - \\sqrt{\\tau/\\pi}
        \\big(\\tfrac12\\tau^3 + \\tfrac7{12}\\tau^2 - \\tfrac{13}{24}\\tau + \\tfrac5{16}\\big)\\Big]
        + \\mathrm{erfc}\\sqrt\\tau\\,\\big(\\tfrac12\\tau^4 + \\tfrac56\\tau^3 - \\tfrac12\\tau^2
        + \\tfrac38\\tau - \\tfrac5{32}\\big)

    For tau > tau0 the coast (eq13b) moves U2 by sigma g(a), a = |U1(tau0)|, sigma its sign,
    g(a) = a delta' - delta'^2, delta' = min(tau - tau0, a/2), so

    .. math:: \\mathrm{Var}\\,U_2(\\tau) = E[U_2(\\tau_0)^2] + 2E[U_2(\\tau_0)\\,\\sigma g(a)]
              + E[g(a)^2],

    the mixed term from the Markov property as a double integral over the killed process
    (docs/analytic.md, "Var U2 and Var U3 during the coast"); it tends to
    :func:`displacement_at_stop_var` as the body stops.

    Parameters
    ----------
    tau : float or array_like
        Scaled time (eq8), 0 <= tau < inf.
    tau0 : float, optional
        Scaled switch-off time, >= 0; default never (numpy.inf).

    Returns
    -------
    float or ndarray
        Var U2 in scaled units (U2 = mu^3 g^3 U / (2 h^4)). Small tau: (2/3) tau^3; large tau
        (noise on): (5/8) tau - 27/32.

    Notes
    -----
    Printed eq10t is correct (checked against the inverse Laplace transform of eq10p).
    Accuracy for tau <= tau0: relative error below 1e-12 over 1e-8 <= tau <= 1e6 (series in
    sqrt(tau) below tau = 1, erfcx form above). For tau > tau0: relative error below 1e-10 for
    every tau0 in [1e-100, 1e300] (Gauss-Legendre product rule in double precision, checked
    against an independent quadrature of the Markov formula and against the limits at tau0
    and at the stop); smaller tau0 by the exact small-tau0 scaling tau0^2 F((tau - tau0) /
    sqrt(tau0)) from tau0 = 1e-100 (the values leave the normal doubles below tau0 ~ 1e-154).
    About 10 ms per distinct tau; the value at the stop (closed form) once 2 (tau - tau0)
    exceeds every |U1(tau0)| with weight.
    """
    return _on_then_coast(tau, tau0, lambda t: _data.M020(t, _SWITCH),
                          _cv.coast_displacement_var)


def distance_var(tau: ArrayLike, tau0: float = np.inf) -> Scalar:
    """Variance of the scaled distance travelled, Var U3(tau) (eq10u, corrected).

    For tau <= tau0: Var U3 = E[U3^2] - E[U3]^2 with E[U3^2] from :func:`distance_second_moment`
    (eq10u with the missing -(5/16) sqrt(tau/pi) e^-tau restored) and E[U3] from eq10r, the
    difference formed in exact arithmetic (large tau, tau/4 - 23/64; small tau,
    (3/4 - 16/(9 pi)) tau^3, the Brownian limit).

    For tau > tau0 the coast (eq13c) adds g(a) = a delta' - delta'^2 to U3, a = |U1(tau0)|,
    delta' = min(tau - tau0, a/2):

    .. math:: \\mathrm{Var}\\,U_3(\\tau) = \\mathrm{Var}\\,U_3(\\tau_0)
              + 2\\,\\mathrm{Cov}(U_3(\\tau_0), g(a)) + \\mathrm{Var}\\,g(a),

    the covariance as a double integral of non-negative terms (docs/analytic.md, "Var U2 and
    Var U3 during the coast"); it tends to :func:`distance_at_stop_var` as the body stops.

    Parameters
    ----------
    tau : float or array_like
        Scaled time, 0 <= tau < inf.
    tau0 : float, optional
        Scaled switch-off time, >= 0; default never.

    Returns
    -------
    float or ndarray
        Var U3, scaled units (U3 = mu^3 g^3 S / (2 h^4)).

    Notes
    -----
    Accuracy: relative error below 1e-12 for 1e-8 <= tau <= 1e6 (tau <= tau0); after the
    switch-off, below 1e-10 for every tau0 in [1e-100, 1e300], scaled from 1e-100 below (as
    :func:`displacement_var`).
    """
    return _on_then_coast(tau, tau0, lambda t: _data.VAR_U3(t, _SWITCH),
                          _cv.coast_distance_var)


def velocity_displacement_cov(tau: ArrayLike, tau0: ArrayLike = np.inf) -> Values:
    """E[U1(tau) U2(tau)], the covariance of the scaled velocity and displacement (both have
    mean 0), equal to (1/2) d Var U2 / d tau.

    For tau <= tau0 the inverse of the Laplace recursion's transform (docs/analytic.md,
    section 2):

    .. math:: E[U_1U_2] = \\tfrac5{16} - \\tfrac12 e^{-\\tau}
              + \\sqrt{\\tau/\\pi}\\,e^{-\\tau}\\big(\\tfrac38 - \\tfrac34\\tau - \\tau^2\\big)
              + \\mathrm{erfc}\\sqrt\\tau\\,\\big(\\tfrac3{16} - \\tfrac12\\tau
              + \\tfrac54\\tau^2 + \\tau^3\\big)

    For tau > tau0, with a = |U1(tau0)|, sigma its sign, c = 2 (tau - tau0):
    U1(tau) U2(tau) = (a - c)_+ (sigma U2(tau0) + g(a)), so
    E[U1 U2](tau) = E[U2(tau0) sigma (a - c)_+] + E[g(a) (a - c)_+], both terms >= 0, by the
    same integrals as :func:`displacement_var`; 0 once the body has stopped.

    Parameters
    ----------
    tau : float or array_like
        Scaled time, 0 <= tau < inf.
    tau0 : float, optional
        Scaled switch-off time, >= 0; default never.

    Returns
    -------
    float or ndarray
        Scaled units of U1 U2. Limits (noise on): tau^2 at small tau (the Brownian limit),
        5/16 at large tau.

    Notes
    -----
    Accuracy as :func:`displacement_var`: 1e-12 relative (closed form) for tau <= tau0,
    1e-10 after the switch-off.
    """
    return _on_then_coast(tau, tau0, lambda t: _data.M110(t, _SWITCH),
                          _cv.coast_velocity_displacement_cov)


def velocity_abs_distance_cov(tau: ArrayLike, tau0: ArrayLike = np.inf) -> Values:
    """Cov(|U1(tau)|, U3(tau)), the covariance of the scaled speed and distance, equal to
    (1/2) d Var U3 / d tau.

    For tau <= tau0: E[|U1| U3] - E|U1| E U3, with E[|U1| U3] the inverse of the signed
    transform (docs/analytic.md, section 2),

    .. math:: E[|U_1|U_3] = \\tfrac1{16} + \\tfrac14\\tau - \\tfrac14 e^{-\\tau}
              + \\sqrt{\\tau/\\pi}\\,e^{-\\tau}\\big(\\tfrac38 - \\tfrac34\\tau - \\tau^2\\big)
              + \\mathrm{erfc}\\sqrt\\tau\\,\\big(\\tfrac3{16} - \\tfrac12\\tau
              + \\tfrac54\\tau^2 + \\tau^3\\big),

    the difference formed in exact arithmetic. For tau > tau0, with |U1(tau)| = (a - c)_+:
    Cov(U3(tau0), (a - c)_+) + Cov(g(a), (a - c)_+), both >= 0, by the same integrals as
    :func:`distance_var`; 0 once the body has stopped.

    Parameters
    ----------
    tau : float or array_like
        Scaled time, 0 <= tau < inf.
    tau0 : float, optional
        Scaled switch-off time, >= 0; default never.

    Returns
    -------
    float or ndarray
        Scaled units of U1 U3. Limits (noise on): (9/8 - 8/(3 pi)) tau^2 at small tau, 1/8 at
        large tau.

    Notes
    -----
    Accuracy as :func:`distance_var`.
    """
    return _on_then_coast(tau, tau0, lambda t: _data.COV_SPEED_U3(t, _SWITCH),
                          _cv.coast_velocity_abs_distance_cov)
