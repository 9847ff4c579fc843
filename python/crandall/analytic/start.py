"""Closed forms for a body that starts moving: initial scaled velocity v0 = U1(0) (and any
initial displacement, which only shifts U2), scaled units of eq3 (drift 2, noise sqrt 2).

- The energy law from any start: Ito's formula for U1^2 with dU3 = |U1| dtau gives
  E U1(tau)^2 = v0^2 + 2 min(tau, tau0) - 4 E U3(tau), so the mean distance at the stop (U1 = 0)
  is (v0^2 + 2 tau0) / 4: the initial kinetic energy and the energy the noise fed in, both
  dissipated by friction (eq7 of the paper, with the start's energy added).
- Without noise (tau0 = 0) the coast is deterministic: the speed falls at rate 2, the body
  stops at |v0| / 2 after travelling v0^2 / 4 in the direction of v0.
"""

from __future__ import annotations

import numpy as np

from ..errors import ParameterError
from ._check import ArrayLike, Values, as_real, as_tau0, scalar_or_array

__all__ = ["distance_at_stop_mean_from", "coast_stop_time", "coast_distance",
           "distance_mean_from_velocity"]


def _v0(v0):
    v = as_real(v0, "v0")
    if np.any(~np.isfinite(v)):
        raise ParameterError("v0", "v0 must be finite")
    return v


def distance_at_stop_mean_from(v0: ArrayLike, tau0: ArrayLike) -> Values:
    """E U3(tau_s) = (v0^2 + 2 tau0) / 4 for a start at scaled velocity v0, noise on until tau0
    (finite)."""
    v = _v0(v0)
    t0 = as_tau0(tau0)
    if not np.isfinite(t0):
        raise ParameterError("tau0", "tau0 must be finite: without a switch-off the body never "
                                     "stops")
    return scalar_or_array((v * v + 2.0 * t0) / 4.0)


def coast_stop_time(v0: ArrayLike) -> Values:
    """The scaled stop time |v0| / 2 of a body coasting from v0 with no noise."""
    return scalar_or_array(np.abs(_v0(v0)) / 2.0)


def coast_distance(v0: ArrayLike) -> Values:
    """The scaled distance v0^2 / 4 a body coasting from v0 with no noise travels (its
    displacement is sign(v0) times this)."""
    v = _v0(v0)
    return scalar_or_array(v * v / 4.0)


def distance_mean_from_velocity(v0: ArrayLike, tau: ArrayLike, tau0: ArrayLike,
                                velocity_second_moment: ArrayLike) -> Values:
    """E U3(tau) = (v0^2 + 2 min(tau, tau0) - E U1(tau)^2) / 4, from the velocity's second
    moment (the identity a run to an accuracy uses for the mean distance)."""
    v = _v0(v0)
    t = as_real(tau, "tau")
    t0 = as_tau0(tau0)
    m2 = as_real(velocity_second_moment, "velocity_second_moment")
    return scalar_or_array((v * v + 2.0 * np.minimum(t, t0) - m2) / 4.0)
