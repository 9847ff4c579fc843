"""Conversion between physical (SI) and the paper's scaled units (eq8 of Berezin & Zayats).

The paper scales the equations of motion (eq1)

    dV = -mu g sign(V) dt + h dW,   dU = V dt,   dS = |V| dt

to the dimensionless form (eq3) with

    U1 = mu g V / h^2,   U2 = mu^3 g^3 U / (2 h^4),   U3 = mu^3 g^3 S / (2 h^4),
    tau = mu^2 g^2 t / (2 h^2).

Each scale below is the physical size of one scaled unit, so that ``t = tau * time_scale``,
``V = U1 * velocity_scale``, ``U = U2 * length_scale`` and ``S = U3 * length_scale``. This
is the one convention: :meth:`Scaling.to_si` multiplies by a scale, :meth:`Scaling.to_scaled`
divides by it, and every conversion in crandall goes through them.
Energies per unit mass: kinetic ``V^2/2 = velocity_scale^2 * U1^2/2`` and dissipated
``mu g S = 2 velocity_scale^2 * U3`` (eq4).

The scaling is singular when ``mu == 0`` (no friction) or ``h == 0`` (no excitation); those
scenes have no scaled form and these functions raise ``ValueError`` for them. The scales are
computed from the ratio ``h / (mu g)`` (no intermediate power of h or mu g that could overflow
while the scale itself fits), and a ``Scaling`` whose time, velocity, length or energy scale
is not a finite, normal double (e.g. ``mu = 1e-300, h = 1``: a time scale of 1e598 s) is
refused with a ``ValueError`` naming mu, h and g.
"""

from __future__ import annotations

import math
import sys
from dataclasses import dataclass

from .errors import ParameterError

__all__ = ["Scaling", "KINDS"]

#: The kinds of value that have a scaled unit: time (tau), velocity (U1), length (U2, U3),
#: energy per unit mass (U1^2).
KINDS = ("time", "velocity", "length", "energy")


def _check_positive_finite(name: str, value: float) -> float:
    value = float(value)
    if not math.isfinite(value) or value <= 0.0:
        raise ParameterError(
            name, f"{name} must be positive and finite for the scaled units of eq8, got {value!r}")
    return value


@dataclass(frozen=True)
class Scaling:
    """The physical size of the paper's scaled units (eq8) for given mu, h and g.

    Parameters
    ----------
    mu : float
        Coefficient of kinetic friction, > 0.
    h : float
        Intensity of the white-noise acceleration of the foundation, m s^-3/2, > 0.
    g : float
        Acceleration of gravity, m s^-2, > 0.
    """

    mu: float
    h: float
    g: float = 9.81

    def __post_init__(self) -> None:
        for name in ("mu", "h", "g"):
            object.__setattr__(self, name, _check_positive_finite(name, getattr(self, name)))
        bad = [name for name in ("deceleration", "time_scale", "velocity_scale", "length_scale",
                                 "energy_scale")
               if not sys.float_info.min <= getattr(self, name) <= sys.float_info.max]
        if bad:
            raise ParameterError("mu, h, g", 
                f"mu, h, g: the scaled units of eq8 do not fit in doubles for mu={self.mu!r}, "
                f"h={self.h!r}, g={self.g!r} ({', '.join(bad)} outside the range of "
                "normal doubles); "
                "choose units in which h / (mu g) is nearer 1"
            )

    @property
    def _ratio(self) -> float:
        # h / (mu g), the scale every other one is built from: m s^-3/2 / (m s^-2) = s^1/2.
        return self.h / self.mu / self.g

    @property
    def deceleration(self) -> float:
        """Friction deceleration mu g, m s^-2."""
        return self.mu * self.g

    # Products, not powers: a float product overflows to inf (checked in __post_init__),
    # where ``**`` raises OverflowError.
    @property
    def time_scale(self) -> float:
        """Seconds per unit of scaled time tau: 2 h^2 / (mu g)^2."""
        r = self._ratio
        return 2.0 * r * r

    @property
    def velocity_scale(self) -> float:
        """m/s per unit of scaled velocity U1: h^2 / (mu g)."""
        return self.h * self._ratio

    @property
    def length_scale(self) -> float:
        """Metres per unit of scaled displacement U2 or distance U3: 2 h^4 / (mu g)^3."""
        r = self._ratio
        return 2.0 * (self.h * r) * r * r

    @property
    def energy_scale(self) -> float:
        """J/kg per unit of U1^2 (kinetic energy per unit mass is energy_scale * U1^2 / 2)."""
        v = self.velocity_scale
        return v * v

    # -- the conversions: every SI <-> scaled conversion in crandall goes through these ----

    def scale(self, kind: str) -> float:
        """The physical size of one scaled unit of ``kind`` (one of ``KINDS``)."""
        if kind not in KINDS:
            raise ParameterError("kind", f"kind must be one of {', '.join(KINDS)}, got {kind!r}")
        return getattr(self, kind + "_scale")

    def to_scaled(self, value, kind: str, power: int = 1):
        """A physical value of ``kind ** power`` (e.g. a variance of lengths: power 2) in
        scaled units: divided by the scale ``power`` times.

        One factor at a time: the power of a scale may overflow where the value does not.
        """
        scale = self.scale(kind)
        for _ in range(power):
            value = value / scale
        return value

    def to_si(self, value, kind: str, power: int = 1):
        """A scaled value of ``kind ** power`` in physical units: times the scale ``power``
        times (one factor at a time, as :meth:`to_scaled`)."""
        scale = self.scale(kind)
        for _ in range(power):
            value = value * scale
        return value

    def to_tau(self, t):
        """Physical time t (s) to scaled time tau."""
        return self.to_scaled(t, "time")

    def to_t(self, tau):
        """Scaled time tau to physical time t (s)."""
        return self.to_si(tau, "time")
