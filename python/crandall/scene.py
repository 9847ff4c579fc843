"""What to simulate: the body, the excitation, the output times and the observables."""

from __future__ import annotations

import math
from typing import Iterable, Optional, Sequence

import numpy as np

from .units import Scaling

__all__ = ["Scene", "OBSERVABLES", "STOP_QUANTITIES"]

#: Everything a scene can observe. "stop" is the stop time; with displacement, distance or
#: dissipated energy also observed, their values at the stop as well.
OBSERVABLES = (
    "velocity",
    "displacement",
    "distance",
    "kinetic_energy",
    "dissipated_energy",
    "stop",
)

#: Scalar quantities at the stop, and the observable each needs besides "stop".
STOP_QUANTITIES = {
    "stop_time": None,
    "displacement_at_stop": "displacement",
    "distance_at_stop": "distance",
    "dissipated_energy_at_stop": "dissipated_energy",
}


def _number(name: str, value, *, positive: bool = False, allow_inf: bool = False) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise ValueError(f"{name} must be a real number, got {value!r}")
    value = float(value)
    if math.isnan(value):
        raise ValueError(f"{name} must not be NaN")
    if math.isinf(value) and not (allow_inf and value > 0):
        raise ValueError(f"{name} must be finite, got {value!r}")
    if value < 0 or (positive and value == 0):
        raise ValueError(f"{name} must be {'> 0' if positive else '>= 0'}, got {value!r}")
    return value


def _times(times, t0: float, observe: Sequence[str]) -> np.ndarray:
    if times is None:
        times = []
    try:
        arr = np.asarray(times, dtype=float)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"times must be a sequence of numbers: {exc}") from None
    arr = np.atleast_1d(arr)
    if arr.ndim != 1:
        raise ValueError(f"times must be one-dimensional, got shape {arr.shape}")
    if np.isnan(arr).any():
        raise ValueError("times must not contain NaN")
    if not np.isfinite(arr).all():
        raise ValueError("times must be finite")
    if (arr < 0).any():
        raise ValueError(f"times must be >= 0, got {arr[arr < 0][0]!r}")
    if arr.size > 1 and not (np.diff(arr) > 0).all():
        raise ValueError("times must be strictly increasing (sorted, no repeats)")
    if arr.size == 0 and tuple(observe) != ("stop",):
        raise ValueError("times must not be empty (only a scene observing just 'stop' may omit them)")
    return arr


def _observe(observe) -> tuple:
    if isinstance(observe, str):
        observe = (observe,)
    try:
        names = list(observe)
    except TypeError:
        raise ValueError(f"observe must be a name or a list of names, got {observe!r}") from None
    unknown = [n for n in names if n not in OBSERVABLES]
    if unknown:
        raise ValueError(
            f"observe: unknown observable {unknown[0]!r}; choose from {', '.join(OBSERVABLES)}"
        )
    if not names:
        raise ValueError("observe must name at least one observable")
    return tuple(n for n in OBSERVABLES if n in names)


class Scene:
    """A body on a randomly shaken foundation, in physical (SI) units.

    The body's velocity V relative to the foundation obeys (paper eq1)
    ``dV = -mu g sign(V) dt + h dW`` for ``t < t0`` and ``dV = -mu g sign(V) dt`` after,
    starting at rest; displacement ``U = int V dt``, distance ``S = int |V| dt``.

    Parameters
    ----------
    mu : float
        Coefficient of kinetic friction, >= 0 (0: a free Brownian body, which never stops).
    h : float
        Intensity of the white-noise acceleration of the foundation, m s^-3/2, >= 0
        (0: the body stays at rest).
    t0 : float
        Time the excitation is switched off, s, >= 0; ``math.inf`` for never.
    g : float, default 9.81
        Acceleration of gravity, m s^-2, > 0.
    mass : float, default 1.0
        Mass of the body, kg, > 0 (scales the energies only).
    times : sequence of float
        Output times, s, strictly increasing, >= 0; may lie beyond t0 and the stop.
    observe : str or sequence of str
        Any of ``OBSERVABLES``: "velocity" (m/s), "displacement" (m), "distance" (m),
        "kinetic_energy" (J), "dissipated_energy" (J, friction loss mu m g S, eq4), "stop" (the
        stop time, s, and the stop values of the other observed quantities). Default: all
        (without "stop" when the body cannot stop: mu = 0 or t0 infinite).

    Use :meth:`Scene.scaled` for the paper's dimensionless units (eq3, eq8).
    """

    def __init__(
        self,
        *,
        mu: float,
        h: float,
        t0: float,
        g: float = 9.81,
        mass: float = 1.0,
        times: Iterable[float],
        observe: Optional[Sequence[str]] = None,
    ) -> None:
        mu = _number("mu", mu)
        h = _number("h", h)
        t0 = _number("t0", t0, allow_inf=True)
        g = _number("g", g, positive=True)
        mass = _number("mass", mass, positive=True)
        self._setup(
            units="SI",
            drift=mu * g,
            noise=h,
            t0=t0,
            times=times,
            observe=observe,
            mass=mass,
            params={"mu": mu, "h": h, "t0": t0, "g": g, "mass": mass},
            scaling=Scaling(mu, h, g) if mu > 0 and h > 0 else None,
        )

    @classmethod
    def scaled(
        cls,
        *,
        tau0: float,
        times: Iterable[float],
        observe: Optional[Sequence[str]] = None,
    ) -> "Scene":
        """A scene in the paper's scaled units (eq3): dU1 = -2 sign(U1) dtau + sqrt(2) dW.

        Times are scaled times tau; velocity is U1, displacement U2, distance U3; kinetic
        energy is U1^2/2 and dissipated energy 2 U3 (both per unit mass, in units of the squared
        velocity scale, so that the energy law eq7 reads E[dissipated energy at stop] = tau0).

        Parameters
        ----------
        tau0 : float
            Scaled switch-off time, >= 0, or ``math.inf``.
        times, observe
            As for :class:`Scene`, in scaled time.
        """
        self = cls.__new__(cls)
        tau0 = _number("tau0", tau0, allow_inf=True)
        self._setup(
            units="scaled",
            drift=2.0,
            noise=math.sqrt(2.0),
            t0=tau0,
            times=times,
            observe=observe,
            mass=1.0,
            params={"tau0": tau0},
            scaling=None,
        )
        return self

    def _setup(self, *, units, drift, noise, t0, times, observe, mass, params, scaling):
        can_stop = math.isfinite(t0) and (drift > 0 or noise == 0)
        if observe is None:
            observe = OBSERVABLES if can_stop else OBSERVABLES[:-1]
        observe = _observe(observe)
        if "stop" in observe and not math.isfinite(t0):
            name = "t0" if units == "SI" else "tau0"
            raise ValueError(f"observe: 'stop' needs a finite {name}: the excitation never ends")
        if "stop" in observe and not can_stop:
            raise ValueError("observe: 'stop' needs mu > 0: without friction the body never stops")
        self.units = units
        self.drift = float(drift)
        self.noise = float(noise)
        self.t0 = float(t0)
        self.times = _times(times, t0, observe)
        self.times.setflags(write=False)
        self.observe = observe
        self.mass = float(mass)
        self.params = dict(params)
        self.scaling = scaling

    @property
    def time_name(self) -> str:
        return "t" if self.units == "SI" else "tau"

    def units_of(self, name: str) -> str:
        """Units of an observable or stop quantity in this scene ("" in scaled units)."""
        if self.units == "scaled":
            return ""
        base = name.replace("_at_stop", "")
        return {"velocity": "m/s", "displacement": "m", "distance": "m", "kinetic_energy": "J",
                "dissipated_energy": "J", "stop_time": "s"}[base]

    def __repr__(self) -> str:
        args = ", ".join(f"{k}={v!r}" for k, v in self.params.items())
        ctor = "Scene" if self.units == "SI" else "Scene.scaled"
        return f"{ctor}({args}, times=<{self.times.size} times>, observe={list(self.observe)!r})"
