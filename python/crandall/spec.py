"""A run's specification: what makes two runs the same run.

A :class:`RunSpec` (scene, paths, seed, dt, method, min_steps, event_depth) is checked once,
when it is made; everything downstream (the core's plan, the checkpoint's identity, a saved file's
attributes, a Dask task) takes a spec and trusts it. The result of a run is a pure function of
its spec (and the crandall version): the thread count, the chunking and the machine do not
enter it. A new run option is a new field here (docs/architecture.md).
"""

from __future__ import annotations

import dataclasses
import math
import numbers
from dataclasses import dataclass
from typing import Any, Dict, Optional

import numpy as np

from .methods import MAX_EVENT_DEPTH, MIN_EVENT_DEPTH, DEFAULT_DT_FILTER, DEFAULT_DT_TAU, DEFAULT_DT_TAU_FILTER, DEFAULT_METHOD, DEFAULT_MIN_STEPS, DEFAULT_STEPS_FREE, GRIDS, METHODS
from .errors import ParameterError, UnresolvableGrid
from .model import FILTERED_EXCITATION, GRID_ORDERS, Identity, check_simulated, holds, require
from .scene import Scene

__all__ = ["RunSpec", "default_dt", "default_method", "MAX_PATHS", "MIN_EVENT_DEPTH",
           "MAX_EVENT_DEPTH", "check_int", "check_scene", "check_positive",
           "draw_seed", "is_real"]

#: Most paths one run may have: path indices and chunk counts stay well inside 64 bits.
MAX_PATHS = 1 << 63
#: Seeds are 64-bit.
MAX_SEED = (1 << 64) - 1


def check_int(name: str, value, minimum: int, maximum: Optional[int] = None) -> int:
    """``value`` as an int within [minimum, maximum]; else a ParameterError naming ``name``."""
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
        raise ParameterError(name, f"{name} must be an integer, got {value!r}")
    value = int(value)
    if value < minimum:
        raise ParameterError(name, f"{name} must be >= {minimum}, got {value}")
    if maximum is not None and value > maximum:
        raise ParameterError(name, f"{name} must be <= {maximum}, got {value}")
    return value


def draw_seed() -> int:
    """A seed drawn from the operating system's entropy, 0 <= seed < 2**64: what every entry
    point (``simulate``, ``simulate_many``, runs to an accuracy, ``tail``, ``crandall.paths``,
    ``crandall tail``) takes for ``seed=None``, and records so that the run can be repeated."""
    return int(np.random.SeedSequence().entropy % (1 << 64))


def as_seed(seed):
    """A seed as simulate takes it: None, an int, or numpy's ``SeedSequence`` (its first 64-bit
    word of state: ``int(seed.generate_state(1, numpy.uint64)[0])``, the same for the same
    entropy) or ``Generator`` (one draw ``integers(0, 2**64, dtype=numpy.uint64)``, which
    advances it). Ints are checked where the spec is made."""
    if isinstance(seed, np.random.SeedSequence):
        return int(seed.generate_state(1, np.uint64)[0])
    if isinstance(seed, np.random.Generator):
        return int(seed.integers(0, 2 ** 64, dtype=np.uint64))
    return seed


def default_dt(scene: Scene) -> float:
    """The longest internal step that ``simulate(dt=None)`` uses for this scene, in its units.

    Scaled scenes: ``DEFAULT_DT_TAU`` (0.01), divided by r^2 when a piecewise intensity has a
    piece r > 1 times the scaled unit. Physical scenes with friction and excitation: the
    same step in scaled time, ``0.01 * 2 h^2 / (mu g)^2`` seconds. Without friction (mu = 0),
    or when that time scale is beyond doubles (``Scene.scaling`` is None): the horizon (the
    last output time or t0) over ``DEFAULT_STEPS_FREE``. Without excitation
    (h = 0) the body stays at rest and the step does not matter. A filtered excitation's step
    is ``DEFAULT_DT_TAU_FILTER`` scaled units (its skeleton is exact at any step; the step sets
    how often its event test looks) and at most ``DEFAULT_DT_FILTER`` of its time scale
    1 / omega.

    With ``dt=None`` the grid is also graded (``DEFAULT_MIN_STEPS``): before an output time or
    the switch-off t the step is at most ``t / DEFAULT_MIN_STEPS``, so horizons far shorter
    than this step are still resolved.
    """
    if scene.units == "scaled":
        # A piecewise scene's relative intensities r: the time scale shrinks as 1 / r^2, so a
        # piece stronger than the unit gets a step that much finer (the same resolution as a
        # physical scene's default, whose scale is that of its largest intensity).
        strongest = (max(n for _, n in scene.pieces) / math.sqrt(2.0)
                     if scene.pieces is not None else 1.0)
        return DEFAULT_DT_TAU / strongest ** 2 if strongest > 1.0 else DEFAULT_DT_TAU
    limit = DEFAULT_DT_FILTER * scene.excitation.time_scale()  # inf for white noise
    tau = DEFAULT_DT_TAU if math.isinf(limit) else DEFAULT_DT_TAU_FILTER
    if scene.scaling is not None:
        return min(scene.scaling.to_t(tau), limit)
    horizon = max([t for t in (scene.times[-1] if scene.times.size else 0.0, scene.t0)
                   if math.isfinite(t)] + [0.0])
    return min(horizon / DEFAULT_STEPS_FREE if horizon > 0 else 1.0, limit)


def check_scene(scene, needs: Optional[Identity] = None, what: str = "") -> Scene:
    """``scene`` if it is a :class:`Scene` whose every effect the core simulates
    (:func:`crandall.model.check_simulated`); else a ParameterError naming ``scene``.

    The one check every entry point passes before anything else is worked out or any path
    drawn: a spec (:class:`RunSpec`, so ``simulate``, ``simulate_many``, the fixed-step Dask
    task, the bias estimate's and the envelope pieces' runs), a run to an accuracy and its Dask
    task (``adaptive``), a tail run and its Dask task (``tail._Problem``) and
    ``crandall.paths``. An effect the core does not simulate would otherwise be run, silently,
    as the paper's scene.

    ``needs``: the model an estimator rests on (``model.LEVELS`` for a run to an accuracy,
    ``model.TAIL_MODEL`` for tails and sample paths), refused for a scene whose effects it does
    not support (:func:`crandall.model.require`; ``what`` names the estimator).
    """
    if not isinstance(scene, Scene):
        raise ParameterError("scene", f"scene must be a crandall.Scene, got "
                                      f"{type(scene).__name__}")
    check_simulated(scene)
    if needs is not None:
        require(scene, needs, what)
    return scene


def is_real(value) -> bool:
    """Whether ``value`` is a real number (a bool or a string is not: NumPy and float() would
    take True as 1 and "1" as 1.0)."""
    return isinstance(value, numbers.Real) and not isinstance(value, (bool, np.bool_))


def check_positive(name: str, value) -> float:
    """``value`` as a float, finite and > 0 (a step, a target error, a time bound); else a
    ParameterError naming ``name``. A bool or a string is not a number (:func:`is_real`)."""
    if not is_real(value):
        raise ParameterError(name, f"{name} must be a number, got {value!r}")
    value = float(value)
    if not math.isfinite(value) or value <= 0:
        raise ParameterError(name, f"{name} must be finite and > 0, got {value!r}")
    return value


def check_method(method, scene: Optional[Scene] = None) -> str:
    """``method`` if it is one of ``METHODS`` (and, given the scene, one it runs with); else
    a ValueError naming ``method``."""
    if method not in METHODS:
        raise ParameterError("method", f"method must be one of {', '.join(METHODS)}, got {method!r}")
    if scene is not None and method != "exact" and not holds(scene, GRID_ORDERS):
        raise ParameterError("method", f"method: {method!r} rests on the white-noise skeleton "
                             "(its grid orders, its sign-drift step); a scene with "
                             f"{', '.join(sorted(scene.effects - GRID_ORDERS.supports))} "
                             "runs with 'exact'")
    return method


def check_event_depth(event_depth, scene: Scene) -> Optional[int]:
    """``event_depth`` if it is None (the core's default) or an int in [``MIN_EVENT_DEPTH``,
    ``MAX_EVENT_DEPTH``] for a scene with a filtered excitation; else a ParameterError naming
    ``event_depth``."""
    if event_depth is None:
        return None
    if FILTERED_EXCITATION not in scene.effects:
        raise ParameterError("event_depth", "event_depth: only a filtered excitation "
                             "(crandall.KanaiTajimi, crandall.CloughPenzien) searches its steps "
                             "for events; this scene's white noise has no event search")
    return check_int("event_depth", event_depth, MIN_EVENT_DEPTH, MAX_EVENT_DEPTH)


def default_method(scene: Scene) -> str:
    """The method ``simulate`` uses for ``scene`` when none is given: ``DEFAULT_METHOD``, or
    "exact" for a scene whose grid bias does not expand as the Richardson methods assume
    (:data:`crandall.model.GRID_ORDERS`: a filtered excitation)."""
    return DEFAULT_METHOD if holds(scene, GRID_ORDERS) else "exact"


@dataclass(frozen=True)
class RunSpec:
    """What to run: a scene, the number of paths, the seed, the step and the method.

    Checked when made (a ValueError names the field); use :meth:`create` to fill in the
    defaults ``simulate`` uses (a drawn seed, :func:`default_dt` on a graded grid).

    Attributes
    ----------
    scene : Scene
    paths : int
        1 <= paths <= ``MAX_PATHS``.
    seed : int
        0 <= seed < 2**64.
    dt : float
        Longest internal step, in the scene's time units, finite and > 0.
    method : str
        One of ``crandall.METHODS``.
    min_steps : int
        The graded grid's resolution: the step before an output time or the switch-off t is
        at most t / min_steps (0: steps of dt only).
    event_depth : int or None
        A filtered excitation's event search: a step in which a stop or an onset may happen
        is bisected down to steps of dt / 2^event_depth (docs/filtered.md, "The event
        depth"). ``MIN_EVENT_DEPTH`` (2) to ``MAX_EVENT_DEPTH`` (20); None (the default):
        the core's, 8. Refused for white noise, which has no event search. None is left out
        of :meth:`to_dict`, so that the specs, checkpoints and files of runs that do not set
        it are what they were.
    """

    scene: Scene
    paths: int
    seed: int
    dt: float
    method: str
    min_steps: int = 0
    event_depth: Optional[int] = None

    def __post_init__(self) -> None:
        check_scene(self.scene)
        fields = {"paths": check_int("paths", self.paths, 1, MAX_PATHS),
                  "seed": check_int("seed", self.seed, 0, MAX_SEED),
                  "dt": check_positive("dt", self.dt),
                  "method": check_method(self.method, self.scene),
                  "min_steps": check_int("min_steps", self.min_steps, 0),
                  "event_depth": check_event_depth(self.event_depth, self.scene)}
        for name, value in fields.items():
            object.__setattr__(self, name, value)

    @classmethod
    def create(cls, scene: Scene, *, paths: int, seed: Optional[int] = None,
               dt: Optional[float] = None, method: Optional[str] = None,
               event_depth: Optional[int] = None) -> "RunSpec":
        """The spec of ``simulate(scene, paths=..., seed=..., dt=..., method=...,
        event_depth=...)``.

        ``seed=None`` draws one from the operating system (recorded in the spec, so the run
        can be repeated); ``method=None`` takes :func:`default_method`; ``dt=None`` takes :func:`default_dt` on the graded grid
        (``min_steps = DEFAULT_MIN_STEPS``); an explicit dt gives a uniform grid.

        Raises
        ------
        ValueError
            Naming the first bad argument, in the order scene, paths, seed, dt, method,
            event_depth.
        """
        check_scene(scene)
        check_int("paths", paths, 1, MAX_PATHS)  # before any default is worked out
        if seed is None:
            seed = draw_seed()
        check_int("seed", seed, 0, MAX_SEED)
        min_steps = 0
        if dt is None:
            dt = default_dt(scene)
            min_steps = DEFAULT_MIN_STEPS
            if not (math.isfinite(dt) and dt > 0):
                raise ParameterError("dt", f"dt: the scene's default step {dt!r} is not a usable number "
                                 "(times or t0 out of range); give dt")
        if method is None:
            method = default_method(scene)
        return cls(scene, paths, seed, dt, method, min_steps, event_depth)

    # -- plain data: checkpoints, saved files, Dask tasks -----------------------------------

    def to_dict(self) -> Dict[str, Any]:
        """The spec as plain data (JSON-able); :meth:`from_dict` rebuilds an equal spec.

        The identity of a checkpoint (``crandall.checkpoint.identity``), the run attributes
        of a saved result and the argument of a Dask task are this dictionary. An
        ``event_depth`` of None (the core's default) is left out: the dictionary of a run that
        does not set it is what it was before the field existed.
        """
        out = {f.name: getattr(self, f.name) for f in dataclasses.fields(self)
               if not (f.name == "event_depth" and self.event_depth is None)}
        out["scene"] = self.scene.to_dict()
        return out

    @classmethod
    def from_dict(cls, data: Dict[str, Any]) -> "RunSpec":
        """Rebuild a spec from :meth:`to_dict`'s output (checked as any spec)."""
        fields = dict(data)
        scene = fields.pop("scene")
        return cls(scene if isinstance(scene, Scene) else Scene.from_dict(scene), **fields)


def grid_error(exc: ValueError, scene: Scene, *, dt_given: bool) -> ValueError:
    """The core's refusal of a grid too long for 2^53 steps, told in what the user can change:
    the integrals need internal steps, the velocity, the kinetic energy and the stop do not
    (they are exact in law with none). Any other error is returned as it is."""
    if "2^53 steps" not in str(exc):
        return exc
    integrals = [n for n in ("displacement", "distance", "dissipated_energy", "peaks")
                 if n in scene.observe]
    fix = "give a larger dt or " if dt_given else ""
    return UnresolvableGrid(integrals,
        f"observe: {', '.join(integrals) or 'the integrals'} "
        f"{'needs' if len(integrals) == 1 else 'need'} internal steps, and this "
        f"scene's horizon would take more than 2^53 of them; {fix}observe only velocity, "
        "kinetic_energy and stop (exact in law with no internal steps: the stop's mean "
        "dissipated energy then follows from the energy law, analytic.physical), or give "
        "shorter times or t0")

