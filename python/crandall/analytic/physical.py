"""The analytic values in SI units, with the scales of eq8 (as :class:`crandall.units.Scaling`).

The scales 2 h^2/(mu g)^2, h^2/(mu g) and 2 h^4/(mu g)^3 leave the range of a double for
extreme but legitimate inputs (mu = 1e-300 gives a time scale of 1e600 s) while the SI answer
is an ordinary number (with negligible friction Var V = h^2 t). So the scales and the
conversion t -> tau are formed in multi-precision, and a scaled time beyond the range of the
scaled functions is handled by their leading term there (exact to the precision of a double:
the next term is smaller by a factor sqrt(tau) < 1e-150 or 1/tau < 1e-300).
"""

from __future__ import annotations

from typing import Optional

import math

import numpy as np

from ..errors import ParameterError
from . import _data
from ._check import ArrayLike, Values, as_real, as_tau0, as_time
from ._forms import Form

__all__ = ["physical", "PHYSICAL_NAMES"]

# name -> (scale, power, takes tau0 as the time argument, exact form of the noise-on value)
_TABLE = {
    "velocity_var": ("velocity", 2, False, _data.M200),
    "velocity_abs_mean": ("velocity", 1, False, _data.S100),
    "displacement_var": ("length", 2, False, _data.M020),
    "distance_mean": ("length", 1, False, _data.M001),
    "distance_var": ("length", 2, False, _data.VAR_U3),
    "stop_time_mean": ("time", 1, True, Form({(2, 0, 0, 0): 1}) + _data.S100 * 0.5),
    "stop_time_var": ("time", 2, True, _data.VAR_STOP_TIME),
    "distance_at_stop_mean": ("length", 1, True, _data.MEAN_U3_AT_STOP),
    "distance_at_stop_var": ("length", 2, True, _data.HALF_INT_M200),
    "displacement_at_stop_var": ("length", 2, True, _data.VAR_U2_AT_STOP),
}
PHYSICAL_NAMES = tuple(sorted(_TABLE))
_NOISE_ON_ONLY = ("velocity_abs_mean",)

# scaled times the scaled functions are evaluated at; beyond, the leading term is used
_TAU_MIN, _TAU_MAX = 1e-300, 1e300


def _positive(value, name):
    a = as_real(value, name)
    if a.size != 1:
        raise ParameterError(name, f"{name} must be a single number, got shape {a.shape}")
    x = float(a.reshape(()))
    if not math.isfinite(x) or x <= 0:
        raise ParameterError(name, f"{name} must be positive and finite, got {x!r}")
    return x


def _leading(form, tau, ctx):
    """c tau^alpha, the form's leading term at tau -> 0 (tau < 1) or tau -> inf, in mp."""
    series, groups = form._prepare()
    if tau < 1:
        n = int(np.flatnonzero(series)[0])
        return ctx.mpf(float(series[n])) * tau ** (ctx.mpf(n) / 2)
    poly = {}
    for h, _m, _q, c in groups.get(0, []):
        poly[h] = poly.get(h, 0.0) + c
    h = max(k for k, c in poly.items() if c != 0)
    return ctx.mpf(poly[h]) * tau ** (ctx.mpf(h) / 2)


def physical(name: str, t: Optional[ArrayLike] = None, *, mu: float, h: float, g: float = 9.81,
             t0: float = np.inf) -> Values:
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
        Physical time in seconds, finite, >= 0 (ignored, may be None, for the at-stop
        quantities).
    mu, h, g : float, keyword-only
        Friction coefficient, noise intensity in m s^-3/2, gravity in m s^-2; each positive
        and finite.
    t0 : float, keyword-only
        Switch-off time in seconds, >= 0 (default never); required finite for the at-stop
        names.

    Returns
    -------
    float or ndarray
        scale**power * (scaled value), with the scales of eq8; variances scale with the square
        of the scale.

    Raises
    ------
    ValueError
        Naming the parameter at fault: a bad argument; a result beyond the range of a double;
        or, after the switch-off only, scaled times t/time_scale or t0/time_scale outside
        [1e-300, 1e300] (there the coast has no single leading term to fall back on).
    """
    if not isinstance(name, str) or name not in _TABLE:
        raise ParameterError("name", f"name must be one of {PHYSICAL_NAMES}, got {name!r:.80}")
    mu = _positive(mu, "mu")
    h = _positive(h, "h")
    g = _positive(g, "g")
    t0 = as_tau0(t0, "t0")
    import mpmath

    from .. import analytic  # the public functions, resolved at call time (no import cycle)

    ctx = mpmath.MPContext()
    ctx.dps = 30
    dec = ctx.mpf(mu) * ctx.mpf(g)
    hh = ctx.mpf(h)
    time_scale = 2 * (hh / dec) ** 2
    scales = {"time": time_scale, "velocity": hh**2 / dec, "length": 2 * hh**4 / dec**3}
    kind, power, at_stop, form = _TABLE[name]
    factor = scales[kind] ** power
    func = getattr(analytic, name)
    tau0 = ctx.mpf(t0) / time_scale if math.isfinite(t0) else ctx.inf

    def to_double(x):
        if abs(x) > ctx.mpf("1.7976931348623157e308"):
            raise ParameterError(name, 
                f"{name} = {ctx.nstr(x, 5)} is beyond the range of a double for mu={mu!r}, "
                f"h={h!r}, g={g!r}"
            )
        return float(x)

    if at_stop:
        if not math.isfinite(t0):
            raise ParameterError("t0", f"t0 must be finite for {name!r}")
        if tau0 == 0 or _TAU_MIN <= tau0 <= _TAU_MAX:
            return to_double(ctx.mpf(float(func(float(tau0)))) * factor)
        return to_double(_leading(form, tau0, ctx) * factor)
    if t is None:
        raise ParameterError("t", f"t is required for {name!r}")
    tt = as_time(t, "t")
    if name in _NOISE_ON_ONLY and np.any(tt > t0):
        raise ParameterError("t", 
            f"t must be <= t0 for {name!r} (known in closed form only while the noise is on), "
            f"got t = {float(tt.max())!r} > t0 = {t0!r}"
        )
    out = np.empty(tt.shape)
    for idx, ti in np.ndenumerate(tt):
        if ti > t0:
            if not (_TAU_MIN <= tau0 <= _TAU_MAX and ti / time_scale <= _TAU_MAX):
                raise ParameterError("t, t0", 
                    f"t, t0: after the switch-off the scaled times t/time_scale and "
                    f"t0/time_scale must lie in [1e-300, 1e300]; mu={mu!r}, h={h!r}, g={g!r} "
                    f"give time_scale = {ctx.nstr(time_scale, 5)} s"
                )
            # The time since the switch-off from t - t0 in seconds (exact in mp), not from the
            # two scaled times apart: just after a late switch-off their difference is lost to
            # rounding (t0 = 1e6 s at a time scale of 2e-10 s: one ulp of tau0 is 1).
            elapsed = (ctx.mpf(ti) - ctx.mpf(t0)) / time_scale
            value = analytic._coast_since(name, float(elapsed), float(tau0))
            out[idx] = to_double(ctx.mpf(float(value)) * factor)
            continue
        tau = ctx.mpf(ti) / time_scale
        if tau == 0 or _TAU_MIN <= tau <= _TAU_MAX:
            out[idx] = to_double(ctx.mpf(float(func(float(tau)))) * factor)
        else:
            out[idx] = to_double(_leading(form, tau, ctx) * factor)
    return out[()] if out.ndim == 0 else out
