"""The analytic values in SI units, through :class:`crandall.units.Scaling` (eq8)."""

from __future__ import annotations

import numpy as np

from ..units import Scaling

__all__ = ["physical", "PHYSICAL_NAMES"]

# name -> (scale attribute, power, takes tau0 as the time argument)
_TABLE = {
    "velocity_var": ("velocity_scale", 2, False),
    "velocity_abs_mean": ("velocity_scale", 1, False),
    "displacement_var": ("length_scale", 2, False),
    "distance_mean": ("length_scale", 1, False),
    "distance_var": ("length_scale", 2, False),
    "stop_time_mean": ("time_scale", 1, True),
    "stop_time_var": ("time_scale", 2, True),
    "distance_at_stop_mean": ("length_scale", 1, True),
    "distance_at_stop_var": ("length_scale", 2, True),
    "displacement_at_stop_var": ("length_scale", 2, True),
}
PHYSICAL_NAMES = tuple(sorted(_TABLE))


def physical(name, t=None, *, mu, h, g=9.81, t0=np.inf):
    """An analytic quantity in SI units.

    Parameters
    ----------
    name : str
        One of ``PHYSICAL_NAMES``: "velocity_var" (m^2/s^2), "velocity_abs_mean" (m/s),
        "displacement_var" (m^2), "distance_mean" (m), "distance_var" (m^2), and, as functions
        of the switch-off time t0 only, "stop_time_mean" (s, the mean stop instant t_s),
        "stop_time_var" (s^2), "distance_at_stop_mean" (m), "distance_at_stop_var" (m^2),
        "displacement_at_stop_var" (m^2).
    t : float or array_like
        Physical time in seconds (ignored, may be None, for the at-stop quantities).
    mu, h, g : float, keyword-only
        Friction coefficient (> 0), noise intensity in m s^-3/2 (> 0), gravity in m s^-2.
    t0 : float, keyword-only
        Switch-off time in seconds (default never); required finite for the at-stop names.

    Returns
    -------
    float or ndarray
        scale**power * (scaled value), with the scales of eq8 (``Scaling``); variances scale
        with the square of the scale.
    """
    if name not in _TABLE:
        raise ValueError(f"name must be one of {PHYSICAL_NAMES}, got {name!r}")
    from .. import analytic  # the public functions, resolved at call time (no import cycle)

    sc = Scaling(mu=mu, h=h, g=g)
    attr, power, at_stop = _TABLE[name]
    func = getattr(analytic, name)
    t0 = float(t0)
    if np.isnan(t0) or t0 < 0:
        raise ValueError(f"t0 must be >= 0 (or inf), got {t0!r}")
    tau0 = sc.to_tau(t0) if np.isfinite(t0) else np.inf
    if at_stop:
        if not np.isfinite(t0):
            raise ValueError(f"t0 must be finite for {name!r}")
        value = func(tau0)
    else:
        if t is None:
            raise ValueError(f"t is required for {name!r}")
        tau = sc.to_tau(np.asarray(t, dtype=float))
        value = func(tau, tau0)
    return getattr(sc, attr) ** power * value
