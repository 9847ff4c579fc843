"""Input validation shared by the analytic functions: every error names the parameter."""

from __future__ import annotations

import numpy as np


def as_time(value, name="tau", *, allow_zero=True):
    """A float array of finite scaled times >= 0 (> 0 if not allow_zero)."""
    try:
        t = np.asarray(value, dtype=float)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{name} must be a real number or array of real numbers") from exc
    if np.any(np.isnan(t)):
        raise ValueError(f"{name} must not be NaN")
    if np.any(np.isinf(t)):
        raise ValueError(f"{name} must be finite")
    if allow_zero:
        if np.any(t < 0):
            raise ValueError(f"{name} must be >= 0, got {t.min()!r}")
    elif np.any(t <= 0):
        raise ValueError(f"{name} must be > 0, got {t.min()!r}")
    return t


def as_tau0(value, name="tau0"):
    """Switch-off time: a float >= 0 or +inf (noise never switched off)."""
    try:
        t0 = float(value)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{name} must be a real number (or numpy.inf)") from exc
    if np.isnan(t0) or t0 < 0:
        raise ValueError(f"{name} must be >= 0 (or numpy.inf), got {t0!r}")
    return t0


def only_before_switch_off(tau, tau0, func, tau_name="tau"):
    if np.any(tau > tau0):
        raise ValueError(
            f"{tau_name} > tau0: {func} is only known in closed form for {tau_name} <= tau0 "
            f"(noise on); got max {tau_name} {np.max(tau)!r} > tau0 = {tau0!r}"
        )


def scalar_or_array(out):
    out = np.asarray(out, dtype=float)
    return out[()] if out.ndim == 0 else out
