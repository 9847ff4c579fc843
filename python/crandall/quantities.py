"""What each quantity is, in one table: the core variable that carries it, its factor, its SI
unit, its long name, what a scene must observe for it, and its twin at the stop.

Every module that names a quantity reads this table (the scene's observables, the core's
flags, the statistics of a result, the units and long names of saved files); adding a
quantity is adding a row here (docs/architecture.md).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Callable, Dict, Iterable, Optional, Tuple

__all__ = ["Quantity", "QUANTITIES", "OBSERVABLES", "DEFAULT_OBSERVE", "STOP_QUANTITIES",
           "VARIABLES", "HISTOGRAM_VARIABLES", "quantity", "find", "names_for", "core_flags",
           "simulated_variables"]

#: The core's simulated variables, in the order of its accumulators (paper eq3: U1, U2, U3).
VARIABLES = ("velocity", "displacement", "distance")
VELOCITY, DISPLACEMENT, DISTANCE = 0, 1, 2
#: The observable that asks the core for the stop (the stop time and the values there).
STOP = "stop"
#: The observable that asks the core for the running maxima of |U1| and |U2| (the peaks).
PEAKS = "peaks"
#: The magnitude of the displacement at the stop (with "stop" and "displacement").
RESIDUAL = "residual"
#: What the core bins per slot, in the order of its histogram axes (``slot * 5 + index``):
#: over time U1, U2, U3, max |U1| and max |U2| up to the output time; in the stop slot the
#: time from the switch-off to the stop, U2 and U3 there, and the peaks over the whole path.
HISTOGRAM_VARIABLES = ("velocity", "displacement", "distance", "peak_speed",
                       "peak_displacement")
PEAK_SPEED, PEAK_DISPLACEMENT = 3, 4


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
    peak : bool
        A running maximum (of |U1| or |U2|): its moments are in the core's peaks accumulator
        (``variable`` 0 for the speed, 1 for |U2|), not in the moments of (U1, U2, U3).
    magnitude : bool
        The magnitude |variable| at the stop: its moments are the stop's second slot (the
        core's ``residual`` option), its distribution the variable's folded at 0.
    tail : str or None
        Its score in a tail run (``crandall.tail``, whose quantities are the rows with one): a
        key of ``crandall.tail.problem.SCORES``, the function of a path's state whose value at
        the last grid point (its maximum over the path for a ``peak``) is the quantity over
        ``factor(scene)``; None: ``crandall.tail`` refuses it. The tail's other facts are the
        row's: ``at_stop`` (the horizon is the end of the shaking), ``peak``, and whether it is
        a function of the velocity alone (``variable`` VELOCITY: exact on any grid).
    held : bool
        Whether results hold it (the core accumulates its moments); False for a quantity only
        a tail run estimates (the speed |V(t)|).
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
    peak: bool = False
    magnitude: bool = False
    tail: Optional[str] = None
    held: bool = True

    @property
    def histogram_variable(self) -> int:
        """The index of its core variable among ``HISTOGRAM_VARIABLES`` (its histogram axis
        is ``slot * 5 + histogram_variable``)."""
        return self.variable + (PEAK_SPEED if self.peak else 0)

    def long_name_in(self, units: str) -> str:
        """The long name in a scene of ``units`` ("SI" or "scaled")."""
        text = self.long_name + (f" {self.symbol}" if units == "scaled" and self.symbol else "")
        return text + (" at the stop" if self.at_stop else "")

    @property
    def velocity_only(self) -> bool:
        """A function of the velocity alone (the peak speed too): no step bias in a tail run."""
        return self.variable == VELOCITY

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
             kind="velocity", tail="velocity"),
    Quantity("displacement", DISPLACEMENT, "m", "displacement", ("displacement",),
             symbol="U2", twin="displacement_at_stop", kind="length"),
    Quantity("distance", DISTANCE, "m", "distance travelled", ("distance",), symbol="U3",
             twin="distance_at_stop", kind="length"),
    Quantity("kinetic_energy", VELOCITY, "J", "kinetic energy", ("kinetic_energy",),
             factor=_kinetic, power=2),
    Quantity("dissipated_energy", DISTANCE, "J", "energy dissipated by friction",
             ("dissipated_energy",), factor=_energy_dissipated,
             twin="dissipated_energy_at_stop"),
    # The running maxima up to each output time (the design values of base isolation):
    # max |U1| and max |U2| over the grid points of [0, t]. They are maxima over a grid of a
    # continuous path, so they fall short of the path's maxima: the peak speed by about 0.09
    # scaled units at the default step, falling like sqrt(dt) (docs/distributions.md, "Peaks
    # and their discretisation error", measured by bench/peaks.py).
    Quantity("peak_speed", 0, "m/s", "peak speed (largest |velocity| so far)", (PEAKS,),
             symbol="max|U1|", twin="peak_speed_at_stop", kind="velocity", peak=True),
    Quantity("peak_displacement", 1, "m", "peak displacement (largest |displacement| so far)",
             (PEAKS, "displacement"), symbol="max|U2|", twin="peak_displacement_at_stop",
             kind="length", peak=True),
)


#: The tail scores of the stop twins (Quantity.tail): the energy's is the distance's times
#: its factor m mu g.
_STOP_TAILS = {"displacement_at_stop": "displacement_at_stop",
               "distance_at_stop": "distance_at_stop",
               "dissipated_energy_at_stop": "distance_at_stop",
               "peak_speed_at_stop": "peak_speed_at_stop",
               "peak_displacement_at_stop": "peak_displacement_at_stop"}


def _at_stop(q: Quantity) -> Quantity:
    return Quantity(q.twin, q.variable, q.si_unit, q.long_name, (STOP,) + q.needs,
                    factor=q.factor, power=q.power, symbol=q.symbol, at_stop=True, twin=q.name,
                    kind=q.kind, peak=q.peak, tail=_STOP_TAILS.get(q.twin))


def _stop_time_offset(scene) -> float:
    return scene.t0


#: Every quantity, time-resolved ones first, in the order results list them.
QUANTITIES: Tuple[Quantity, ...] = _OVER_TIME + (
    Quantity("stop_time", VELOCITY, "s", "stop time", (STOP,), at_stop=True, kind="time",
             offset=_stop_time_offset, tail="stop_time"),
) + tuple(_at_stop(q) for q in _OVER_TIME if q.twin is not None) + (
    # |U(t_s)|: how far from where it started the body comes to rest, in either direction
    # (displacement_at_stop is signed).
    Quantity("residual_displacement", DISPLACEMENT, "m",
             "residual displacement (magnitude of the displacement)",
             (STOP, "displacement", RESIDUAL), symbol="|U2|", at_stop=True, kind="length",
             magnitude=True, tail="residual_displacement"),
    # |V(t)|: a tail run's quantity only (the core keeps no moments of it).
    Quantity("speed", VELOCITY, "m/s", "speed (magnitude of the velocity)", ("velocity",),
             symbol="|U1|", kind="velocity", tail="speed", held=False),
)

#: Everything a scene can observe: each time-resolved quantity but the peaks, "stop" (the
#: stop time; with displacement, distance or dissipated energy also observed, their values at
#: the stop) and "peaks" (the peak speed, and with the displacement the peak displacement, up
#: to every output time and over the whole path).
OBSERVABLES: Tuple[str, ...] = tuple(q.name for q in _OVER_TIME if not q.peak) + (
    STOP, PEAKS, RESIDUAL)
#: What a scene observes by default: everything but the peaks and the residual displacement's
#: magnitude (each costs a little in the kernel; a scene asks for them).
DEFAULT_OBSERVE: Tuple[str, ...] = tuple(n for n in OBSERVABLES if n not in (PEAKS, RESIDUAL))

#: Scalar quantities at the stop, and the observable each needs besides "stop".
STOP_QUANTITIES: Dict[str, Optional[str]] = {
    q.name: next((n for n in q.needs if n != STOP), None) for q in QUANTITIES
    if q.at_stop and q.held}


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
    return tuple(q.name for q in QUANTITIES if q.held and set(q.needs) <= obs)


def simulated_variables(observe: Iterable[str], *, at_stop: bool) -> Tuple[int, ...]:
    """The core variables that carry the observed quantities over time or at the stop."""
    held = names_for(observe)
    return tuple(sorted({q.variable for q in QUANTITIES
                         if q.at_stop == at_stop and q.name in held and not q.peak}))


def core_flags(observe: Iterable[str]) -> Dict[str, bool]:
    """The core's ``Options`` flags (velocity, displacement, distance, stop, and peaks when
    observed) for ``observe``.

    The core always simulates the velocity; it records it when a quantity over time needs it,
    or when nothing else is recorded (a scene observing only "stop" or "peaks"). The "peaks"
    flag is present only when the peaks are observed, so that a scene without them sets no
    option a core without peaks lacks.
    """
    variables = simulated_variables(observe, at_stop=False)
    integrals = [v for v in variables if v != VELOCITY]
    flags = {name: i in variables for i, name in enumerate(VARIABLES)}
    flags["velocity"] = VELOCITY in variables or not integrals
    flags[STOP] = STOP in set(observe)
    if PEAKS in set(observe):
        flags[PEAKS] = True
    if RESIDUAL in set(observe):
        flags[RESIDUAL] = True
    if "kinetic_energy" in set(observe):
        # The moments of V^2 (its variance's standard error needs E V^8).
        flags["energy"] = True
    return flags
