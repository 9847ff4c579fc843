"""Conversion between physical (SI) and the paper's scaled units (eq8 of Berezin & Zayats).

The paper scales the equations of motion (eq1)

    dV = -mu g sign(V) dt + h dW,   dU = V dt,   dS = |V| dt

to the dimensionless form (eq3) with

    U1 = mu g V / h^2,   U2 = mu^3 g^3 U / (2 h^4),   U3 = mu^3 g^3 S / (2 h^4),
    tau = mu^2 g^2 t / (2 h^2).

Each scale below is the physical size of one scaled unit, so that ``t = tau * time_scale``,
``V = U1 * velocity_scale``, ``U = U2 * length_scale`` and ``S = U3 * length_scale``.
Energies per unit mass: kinetic ``V^2/2 = velocity_scale^2 * U1^2/2`` and dissipated
``mu g S = 2 velocity_scale^2 * U3`` (eq4).

The scaling is singular when ``mu == 0`` (no friction) or ``h == 0`` (no excitation); those
scenes have no scaled form and these functions raise ``ValueError`` for them.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

__all__ = ["Scaling"]


def _check_positive_finite(name: str, value: float) -> float:
    value = float(value)
    if not math.isfinite(value) or value <= 0.0:
        raise ValueError(
            f"{name} must be positive and finite for the scaled units of eq8, got {value!r}"
        )
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

    @property
    def deceleration(self) -> float:
        """Friction deceleration mu g, m s^-2."""
        return self.mu * self.g

    @property
    def time_scale(self) -> float:
        """Seconds per unit of scaled time tau: 2 h^2 / (mu g)^2."""
        return 2.0 * (self.h / self.deceleration) ** 2

    @property
    def velocity_scale(self) -> float:
        """m/s per unit of scaled velocity U1: h^2 / (mu g)."""
        return self.h**2 / self.deceleration

    @property
    def length_scale(self) -> float:
        """Metres per unit of scaled displacement U2 or distance U3: 2 h^4 / (mu g)^3."""
        return 2.0 * self.h**4 / self.deceleration**3

    @property
    def energy_scale(self) -> float:
        """J/kg per unit of U1^2 (kinetic energy per unit mass is energy_scale * U1^2 / 2)."""
        return self.velocity_scale**2

    def to_tau(self, t):
        """Physical time t (s) to scaled time tau."""
        return t / self.time_scale

    def to_t(self, tau):
        """Scaled time tau to physical time t (s)."""
        return tau * self.time_scale
