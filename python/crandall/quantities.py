"""What each quantity is, in one table: the core variable that carries it, its factor, its SI
unit, its long name, what a scene must observe for it, and its twin at the stop.

Every module that names a quantity reads this table (the scene's observables, the core's
flags, the statistics of a result, the units and long names of saved files); adding a
quantity is adding a row here (docs/architecture.md).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Callable, Dict, Iterable, Optional, Tuple

__all__ = ["Quantity", "QUANTITIES", "OBSERVABLES", "STOP_QUANTITIES", "VARIABLES", "quantity",
           "find", "names_for", "core_flags", "simulated_variables"]

#: The core's simulated variables, in the order of its accumulators (paper eq3: U1, U2, U3).
VARIABLES = ("velocity", "displacement", "distance")
VELOCITY, DISPLACEMENT, DISTANCE = 0, 1, 2
#: The observable that asks the core for the stop (the stop time and the values there).
STOP = "stop"


def _one(scene: Any) -> float:
    return 1.0


@dataclass(frozen=True)
class Quantity:
    """One quantity a result can hold.

    Attributes
    ----------
    name : str
        Its name in ``Result.mean(name)`` and in saved files.
    variable : int
        The core variable (index into ``VARIABLES``) it is a function of.
    si_unit : str
        Its unit in a physical scene (scaled scenes are dimensionless).
    long_name : str
        Its name in words (saved files), without the scaled symbol or "at the stop".
    needs : tuple of str
        The observables a scene must have for a result to hold it.
    factor : callable
        ``factor(scene)``: the quantity is ``factor * variable ** power`` (energies per body).
    power : int
        1, or 2 for the kinetic energy (a mean of the squared velocity).
    symbol : str
        The paper's symbol of the scaled variable ("U1"), shown in scaled long names.
    at_stop : bool
        A scalar at the stop (one slot), rather than an array over the output times.
    twin : str or None
        The same quantity at the stop (for a time quantity) or over time (for a stop one).
    kind : str or None
        What its scaled unit is (a key of ``crandall.units.KINDS``: "velocity", "length",
        "time"); None where a physical value has no single scale (the energies, which also
        carry the mass).
    offset : callable or None
        ``offset(scene)`` added to the mean: the core keeps the stop time from the switch-off,
        the result reports it from the start (exact at any t0).
    """

    name: str
    variable: int
    si_unit: str
    long_name: str
    needs: Tuple[str, ...]
    factor: Callable[[Any], float] = _one
    power: int = 1
    symbol: str = ""
    at_stop: bool = False
    twin: Optional[str] = None
    kind: Optional[str] = None
    offset: Optional[Callable[[Any], float]] = None

    def long_name_in(self, units: str) -> str:
        """The long name in a scene of ``units`` ("SI" or "scaled")."""
        text = self.long_name + (f" {self.symbol}" if units == "scaled" and self.symbol else "")
        return text + (" at the stop" if self.at_stop else "")

    @property
    def has_var_stderr(self) -> bool:
        """Whether the standard error of its variance is available (needs 4th moments of it)."""
        return self.power == 1


def _energy_dissipated(scene) -> float:
    # Friction force times distance: m mu g S (mu g is the scene's drift; 2 in scaled units).
    return scene.mass * scene.drift


def _kinetic(scene) -> float:
    return 0.5 * scene.mass


# Time-resolved quantities; each is also an observable of the same name.
_OVER_TIME = (
    Quantity("velocity", VELOCITY, "m/s", "velocity", ("velocity",), symbol="U1",
             kind="velocity"),
    Quantity("displacement", DISPLACEMENT, "m", "displacement", ("displacement",),
             symbol="U2", twin="displacement_at_stop", kind="length"),
    Quantity("distance", DISTANCE, "m", "distance travelled", ("distance",), symbol="U3",
             twin="distance_at_stop", kind="length"),
    Quantity("kinetic_energy", VELOCITY, "J", "kinetic energy", ("kinetic_energy",),
             factor=_kinetic, power=2),
    Quantity("dissipated_energy", DISTANCE, "J", "energy dissipated by friction",
             ("dissipated_energy",), factor=_energy_dissipated,
             twin="dissipated_energy_at_stop"),
)


def _at_stop(q: Quantity) -> Quantity:
    return Quantity(q.twin, q.variable, q.si_unit, q.long_name, (STOP,) + q.needs,
                    factor=q.factor, power=q.power, symbol=q.symbol, at_stop=True, twin=q.name,
                    kind=q.kind)


def _stop_time_offset(scene) -> float:
    return scene.t0


#: Every quantity, time-resolved ones first, in the order results list them.
QUANTITIES: Tuple[Quantity, ...] = _OVER_TIME + (
    Quantity("stop_time", VELOCITY, "s", "stop time", (STOP,), at_stop=True, kind="time",
             offset=_stop_time_offset),
) + tuple(_at_stop(q) for q in _OVER_TIME if q.twin is not None)

#: Everything a scene can observe: each time-resolved quantity, and "stop" (the stop time;
#: with displacement, distance or dissipated energy also observed, their values at the stop).
OBSERVABLES: Tuple[str, ...] = tuple(q.name for q in _OVER_TIME) + (STOP,)

#: Scalar quantities at the stop, and the observable each needs besides "stop".
STOP_QUANTITIES: Dict[str, Optional[str]] = {
    q.name: next((n for n in q.needs if n != STOP), None) for q in QUANTITIES if q.at_stop}


def find(name: Any) -> Optional[Quantity]:
    """The table's row of ``name``, or None if there is none."""
    # A scan of the module's table as it is now, so that a row added to it (a test's toy
    # quantity) is seen everywhere.
    return next((q for q in QUANTITIES if q.name == name), None)


def quantity(name: str) -> Quantity:
    """The table's row of ``name`` (KeyError if there is none)."""
    q = find(name)
    if q is None:
        raise KeyError(name)
    return q


def names_for(observe: Iterable[str]) -> Tuple[str, ...]:
    """The quantities a result of a scene observing ``observe`` holds, in table order."""
    obs = set(observe)
    return tuple(q.name for q in QUANTITIES if set(q.needs) <= obs)


def simulated_variables(observe: Iterable[str], *, at_stop: bool) -> Tuple[int, ...]:
    """The core variables that carry the observed quantities over time or at the stop."""
    held = names_for(observe)
    return tuple(sorted({q.variable for q in QUANTITIES
                         if q.at_stop == at_stop and q.name in held}))


def core_flags(observe: Iterable[str]) -> Dict[str, bool]:
    """The core's ``Options`` flags (velocity, displacement, distance, stop) for ``observe``.

    The core always simulates the velocity; it records it when a quantity over time needs it,
    or when nothing else is recorded (a scene observing only "stop").
    """
    variables = simulated_variables(observe, at_stop=False)
    integrals = [v for v in variables if v != VELOCITY]
    flags = {name: i in variables for i, name in enumerate(VARIABLES)}
    flags["velocity"] = VELOCITY in variables or not integrals
    flags[STOP] = STOP in set(observe)
    return flags
