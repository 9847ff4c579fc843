"""A tail run's problem: the quantities it estimates, the scene's grid its paths are stored on,
the quantities' scores, and the paths continued from any grid point (``_core.extend_paths``)."""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any, Callable, Dict, Iterator, NamedTuple, Optional, Sequence

import numpy as np

from .. import _core, quantities
from ..errors import ParameterError
from ..model import (FILTERED_EXCITATION, ITO_DISTANCE, MOVING_AT_SWITCH_OFF, TAIL_MODEL,
                     TAIL_SPLITTING, holds)
from ..quantities import Quantity
from ..scene import Scene
from ..spec import check_positive, check_scene, default_dt, is_real
from . import detmath


class _TailQuantities(Mapping):
    """The quantities a tail run estimates: the rows of ``crandall.quantities.QUANTITIES`` with
    a tail score (``Quantity.tail``), by name, in the table's order. A view of the table as it
    is now, so that a row added to it reaches crandall.tail (and the CLI's and
    crandall.fragility's checks) with no other change."""

    def _rows(self) -> Dict[str, Quantity]:
        return {q.name: q for q in quantities.QUANTITIES if q.tail is not None}

    def __getitem__(self, name: str) -> Quantity:
        return self._rows()[name]

    def __iter__(self) -> Iterator[str]:
        return iter(self._rows())

    def __len__(self) -> int:
        return len(self._rows())

    def __repr__(self) -> str:
        return f"TAIL_QUANTITIES({', '.join(self)})"


#: The quantities a tail run estimates (rows of QUANTITIES; their SI unit is ``si_unit``).
TAIL_QUANTITIES = _TailQuantities()


class _Problem:
    """A scene, a quantity and the grid its paths are simulated on, with the quantity's score."""

    def __init__(self, scene: Scene, quantity: str, time: Optional[float], dt: Optional[float],
                 breaks: Sequence[float] = (), coarse: bool = False):
        # tail() and its Dask task (sample) both start here
        check_scene(scene, TAIL_SPLITTING, "crandall.tail")
        row = quantities.find(quantity) if isinstance(quantity, str) else None
        if row is None or row.tail is None:
            held = "" if row is None else f" ({quantity} has no tail score)"
            raise ParameterError("quantity", f"quantity must be one of {', '.join(TAIL_QUANTITIES)}; got {quantity!r}{held}")
        if row.tail not in SCORES:
            raise ParameterError("quantity", f"quantity: {quantity}'s tail score {row.tail!r} is "
                                 f"not one of {', '.join(SCORES)}")
        self.scene, self.q = scene, row
        #: The paths are the core's filtered walk (_FilteredGrid), not the exact skeleton of
        #: the sign-drift diffusion (_core.extend_paths), which holds where TAIL_MODEL does.
        self.filtered = not holds(scene, TAIL_MODEL)
        if self.filtered and FILTERED_EXCITATION not in scene.effects:
            # A kind TAIL_SPLITTING was declared to hold for before the tail had its paths.
            missing = ", ".join(sorted(frozenset(scene.effects) - TAIL_MODEL.supports))
            raise ParameterError("scene", f"scene: crandall.tail continues the paths of the "
                                 f"sign-drift diffusion or of a filtered excitation, not those "
                                 f"of a scene with {missing}")
        if self.filtered and self.q.peak:
            raise ParameterError(
                "quantity", f"quantity: {quantity} is not available for a filtered "
                "excitation (a continued filtered path's state does not carry the running "
                "maxima of the path it branched from; a fixed-step run gives its law)")
        c = scene.drift
        end = scene.pieces[-1][0] if scene.pieces is not None else scene.t0
        if self.q.at_stop:
            if time is not None:
                raise ParameterError("time", f"time: {quantity} is a quantity at the stop; it takes no output time")
            if not (math.isfinite(end) and c > 0):
                raise ParameterError("quantity", f"quantity: {quantity} needs the stop, which needs mu > 0 and a finite t0")
            horizon = end
        else:
            if time is None:
                raise ParameterError("time", f"time: {quantity} is a quantity at an output time; give time=")
            if not is_real(time):
                raise ParameterError("time", f"time must be a number, got {time!r}")
            time = float(time)
            if not (math.isfinite(time) and time >= 0):
                raise ParameterError("time", f"time must be finite and >= 0, got {time}")
            horizon = min(time, end)
        self.time = time
        self.horizon = horizon
        self.coast = (time - horizon) if time is not None else 0.0  # noiseless time after the grid
        dt = check_positive("dt", default_dt(scene) if dt is None else dt)
        self.dt = dt
        self.args = (scene, quantity, time, dt)
        self._grid = None
        if self.filtered:
            # The filtered walk's grid is its plan's (as a fixed-step run builds it), ending at
            # the horizon; a piece's end is a segment's end there too.
            self._grid = _FilteredGrid(scene, horizon, dt)
            lengths, noises = self._grid.lengths, self._grid.noises
            starts = np.concatenate([[0.0], np.cumsum(lengths)[:-1]]) if len(lengths) else []
        else:
            lengths, noises, starts = white_noise_grid(scene, horizon, dt, breaks, coarse)
        self.lengths = np.asarray(lengths, dtype=np.float64)
        self.noises = np.asarray(noises, dtype=np.float64)
        self.drifts = np.full(len(lengths), c, dtype=np.float64)
        self.step_starts = np.asarray(starts, dtype=np.float64)
        # The expected drift of the distance still to come: S + V^2/(2c) grows at the constant
        # rate sigma^2/(2c) while the noise acts (docs/methods/tails.md), so adding what is still
        # to come makes the distance's score its conditional mean. Not under a filtered
        # excitation (d(S + V^2/(2c)) = -V a_g / c dt there): its score is where the body would
        # stop if the shaking ended now.
        if c > 0 and holds(scene, ITO_DISTANCE):
            per_step = self.noises ** 2 * self.lengths / (2 * c)
            self.remaining = np.concatenate([np.cumsum(per_step[::-1])[::-1], [0.0]])
        else:
            self.remaining = np.zeros(len(lengths) + 1)
        self._normal = None  # the splitting score's normalisation (_normaliser), built on demand

    def _normaliser(self):
        """What the normalised splitting score needs, per grid point (docs/methods/tails.md,
        "The score splitting ranks by, for one level"): the point's time, the cumulative sums of sigma^2 dt, sigma^2 dt r and
        sigma^2 dt r^2 over the steps before it (r: a step's midpoint), and the variance the
        rest of the excitation adds at the stationary speed, sum of sigma^6 dt / (2 c^4) over
        the steps after it; and each point's step length."""
        if self._normal is None:
            # Overflow to inf (an intensity far outside a physical range) is what
            # normalisable() looks for.
            with np.errstate(over="ignore", invalid="ignore"):
                c = self.scene.drift
                points = np.concatenate([[0.0], np.cumsum(self.lengths)])
                w = self.noises ** 2 * self.lengths
                mid = self.step_starts + self.lengths / 2
                cum = [np.concatenate([[0.0], np.cumsum(w * mid ** k)]) for k in range(3)]
                stat = self.noises ** 6 * self.lengths / (2 * c ** 4)
                stationary = np.concatenate([np.cumsum(stat[::-1])[::-1], [0.0]])
                step = np.concatenate([self.lengths, self.lengths[-1:]])
                self._normal = (points, cum, stationary, step)
        return self._normal

    @property
    def tail_score(self) -> "TailScore":
        """The quantity's tail score (its row's ``tail``, a key of SCORES) and what the tail's
        methods know of it."""
        return SCORES[self.q.tail]

    def first_random_point(self) -> int:
        """The first grid point that differs between paths: the end of the first noisy step."""
        return int(np.argmax(self.noises > 0)) + 1

    def split_score(self, states: np.ndarray, top: Optional[float], uncoast: bool = False):
        """(the score splitting ranks paths by, the quantity's score), both of shape
        states.shape[:2]. With ``top`` (a run of one level, for a score declared ``normalised``) the
        first is (m - top) / sd, m the quantity's score (its conditional mean, or where the body
        would stop now) and sd^2 an estimate of the variance still to come: sigma^2 (|V| / c -
        r)^2 integrated while the speed would decay to zero, plus the stationary speed's share
        of the rest. At the last point sd is a floor eps, so the score there is (Q - top) / eps
        and Q > top is a score above 0 (split_threshold). Otherwise both are m, or with
        ``uncoast`` (:meth:`coasts_to_rest`) the first is :meth:`uncoasted`."""
        m = self.score(states)
        if top is None:
            return (self.uncoasted(states) if uncoast else m), m
        points, cum, stationary, step = self._normaliser()
        c = self.scene.drift
        q = np.abs(states[..., 0]) / c
        end = points + q  # when the speed would reach zero without noise
        # The grid point at or after it, counted in the steps of the point's own piece (the
        # pieces' steps differ a little; a score needs no more than that).
        ahead = np.ceil(np.minimum(q / step, self.steps)).astype(np.int64)
        e = np.minimum(np.arange(self.steps + 1) + ahead, self.steps)
        var = (end * end * (cum[0][e] - cum[0]) - 2 * end * (cum[1][e] - cum[1])
               + (cum[2][e] - cum[2]))
        np.maximum(var, 0.0, out=var)
        var += stationary
        var[..., -1] = 0.0
        var += self.floor2()
        return (m - top) / (self._scale() * np.sqrt(var)), m

    def _scale(self) -> float:
        """The quantity's unit over its score's (its factor: the energy's m mu g)."""
        return self.q.factor(self.scene)

    def normalisable(self, schedule: bool = True) -> bool:
        """Whether split_score's normalisation serves: a ``normalised`` score, one intensity
        (unless ``schedule`` is False: bench/tails_score.py measures the others), its
        sums finite and its floor eps^2 positive (an intensity far outside a physical range can
        overflow sigma^6 or underflow it to 0; such a run keeps the plain score)."""
        if (not holds(self.scene, TAIL_MODEL) or not self.tail_score.normalised
                or (schedule and not self.one_intensity())):
            return False
        points, cum, stationary, step = self._normaliser()
        f = self.floor2()
        return (math.isfinite(f) and f > 0 and all(np.all(np.isfinite(x)) for x in cum)
                and bool(np.all(np.isfinite(stationary))))

    def one_intensity(self) -> bool:
        """Whether the noise acts with one intensity over one stretch of time (calm before or
        after it allowed): the scenes where the normalised score is measured to help. On a
        build-up, two pieces or an envelope it was as often worse as better (1/0.6 to 1/1.24
        times the plain score's work between 1e-3 and 1e-5), and across a lull followed by more
        shaking (a pause, an aftershock) far worse (25 to 50 times the work): its spread to
        come shrinks faster than the quantity's true tail there, the score drops for every
        path, and the path maxima stop measuring progress (docs/methods/tails.md)."""
        noisy = np.flatnonzero(self.noises > 0)
        if len(noisy) == 0:
            return False
        stretch = self.noises[noisy[0]:noisy[-1] + 1]
        return bool(np.all(stretch == stretch[0]))

    def floor2(self) -> float:
        """eps^2 of split_score: a millionth of the stationary variance to come at the start."""
        return 1e-6 * float(self._normaliser()[2][0])

    def split_threshold(self, level: float, top: float) -> float:
        """The normalised score's value at the last point for Q = level (0 for level = top)."""
        return (level - top) / (self._scale() * np.sqrt(0.0 + self.floor2()))

    @property
    def core_quantity(self) -> Optional[int]:
        """The quantity's index in the core's splitting loop (split_core.py), or None where
        splitting.py's Python loop, the reference, runs it: the paths are the filtered walk's,
        or the core has no score of the quantity. The core names the quantities it scores
        (_core.SPLIT_QUANTITIES, split.hpp's kSplitQuantityNames): its own table of the rows
        it computes, which the row's name is looked up in."""
        names = _core.SPLIT_QUANTITIES
        if self.filtered or self.q.name not in names:
            return None
        return names.index(self.q.name)

    @property
    def in_core(self) -> bool:
        """Whether splitting's loop runs in the core (:attr:`core_quantity`)."""
        return self.core_quantity is not None

    @property
    def noisy_steps(self) -> int:
        return int(np.count_nonzero(self.noises > 0))

    @property
    def noisy_time(self) -> float:
        return float(np.sum(self.lengths[self.noises > 0]))

    @property
    def steps(self) -> int:
        return len(self.lengths)

    @property
    def columns(self) -> int:
        """The numbers of a path's state at a grid point: (V, U, S), and under a filtered
        excitation the time of the last arrival at rest and the filter's state z."""
        return self._grid.columns if self.filtered else 3

    @property
    def path_bytes(self) -> int:
        return 8 * self.columns * (self.steps + 1)

    def start_states(self, n: int) -> np.ndarray:
        states = np.empty((n, self.steps + 1, self.columns))
        states[:, 0, :3] = (self.scene.v0, self.scene.u0, 0.0)
        if self.filtered:
            states[:, 0, 3] = 0.0
            states[:, 0, 4:] = self._grid.z0
        return states

    def coasts_to_rest(self, levels: np.ndarray) -> bool:
        """Whether splitting ranks the paths by :meth:`uncoasted`: the velocity and the speed
        after the switch-off, at levels >= 0 (where Q > L if and only if the unclipped value
        exceeds L, so that a path past the level is always ranked past it)."""
        return (self.tail_score.uncoast is not None and self.coast > 0
                and bool(np.min(levels) >= 0))

    def uncoasted(self, states: np.ndarray) -> np.ndarray:
        """The velocity (speed) at the output time without the clip at rest: v - c coast
        (|v| - c coast). The coasted quantity is 0 for every path whose speed at the end of the
        grid is below c coast, long after the switch-off almost all of them: as a splitting
        score it would tie them all at 0 (extinction at the first iteration). This one ranks
        them, and above 0 it is the quantity."""
        v = states[..., 0]
        shift = self.scene.drift * self.coast
        return self._times_factor(self.tail_score.uncoast(v) - shift)

    def _coasted(self, v):
        """The velocity at the output time from the velocity at the end of the grid."""
        if self.coast == 0.0:
            return v
        c = self.scene.drift
        return np.sign(v) * np.maximum(np.abs(v) - c * self.coast, 0.0)

    def score(self, states: np.ndarray) -> np.ndarray:
        """The score at every grid point, shape states.shape[:2]; its last point (or, for the
        peaks, its maximum over the path) is the quantity: its row's score (SCORES) times its
        factor."""
        return self._times_factor(self.tail_score.function(self, states))

    def _times_factor(self, out: np.ndarray) -> np.ndarray:
        f = self.q.factor(self.scene)
        return out if f == 1.0 else out * f

    def in_score_units(self, x):
        """A value of the quantity (a level) in its score's units: over its factor."""
        f = self.q.factor(self.scene)
        return x if f == 1.0 else x / f

    def value(self, score: np.ndarray) -> np.ndarray:
        return score.max(axis=-1) if self.q.peak else score[..., -1]

    def coarse_for(self, window: float) -> "_Problem":
        """The same problem on the coarsest grid with a break at horizon - window: one exact
        step per piece and part (velocity quantities only, which are exact on any grid)."""
        return _Problem(*self.args, breaks=(self.horizon - window,), coarse=True)

    def describe(self) -> Dict[str, Any]:
        return {"quantity": self.q.name, "time": self.time, "dt": self.dt, "steps": self.steps}


def _stop_time(p: _Problem, states: np.ndarray) -> np.ndarray:
    v = states[..., 0]
    c = p.scene.drift
    if not holds(p.scene, MOVING_AT_SWITCH_OFF):
        # A filtered body may come to rest for good before the horizon: at rest, its stop is
        # the last time it came to rest (states[..., 3], the filtered walk's).
        return np.where(v == 0.0, states[..., 3], p.horizon + np.abs(v) / c)
    return p.horizon + np.abs(v) / c


def _velocity(p: _Problem, states: np.ndarray) -> np.ndarray:
    return p._coasted(states[..., 0])


def _speed(p: _Problem, states: np.ndarray) -> np.ndarray:
    return np.abs(p._coasted(states[..., 0]))


def _distance_at_stop(p: _Problem, states: np.ndarray) -> np.ndarray:
    v, s = states[..., 0], states[..., 2]
    return s + v * v / (2 * p.scene.drift) + p.remaining


def _ahead(p: _Problem, states: np.ndarray) -> np.ndarray:
    """The displacement where the body would stop now (the coast at the deceleration c)."""
    v, u = states[..., 0], states[..., 1]
    return u + v * np.abs(v) / (2 * p.scene.drift)


def _residual_displacement(p: _Problem, states: np.ndarray) -> np.ndarray:
    return np.abs(_ahead(p, states))


def _peak_displacement_at_stop(p: _Problem, states: np.ndarray) -> np.ndarray:
    out = np.abs(states[..., 1])
    out[..., -1] = np.maximum(out[..., -1], np.abs(_ahead(p, states)[..., -1]))
    return out


def _peak_speed_at_stop(p: _Problem, states: np.ndarray) -> np.ndarray:
    return np.abs(states[..., 0])  # the speed only falls after the last piece


def _stop_time_speed(p: _Problem, top: float) -> float:
    """The speed at the horizon from which the body coasts to rest at ``top``."""
    return (top - p.horizon) * p.scene.drift


def _speed_before_coast(p: _Problem, top: float) -> float:
    """The speed at the end of the grid that coasts down to |``top``| at the output time."""
    return abs(top) + p.scene.drift * p.coast


def _signed(v: np.ndarray) -> np.ndarray:
    return v


class TailScore(NamedTuple):
    """A tail score (``Quantity.tail`` names it) and what the tail's methods know of it; a row
    with this score has them all, whatever its name. The score's values are the quantity over
    the row's factor (levels go into them over it: ``_Problem.in_score_units``)."""

    #: ``function(problem, states)``: the score at every grid point (shape states.shape[:2]);
    #: its last value (its maximum over the path for a peak row) is the quantity over its factor.
    function: Callable[[_Problem, np.ndarray], np.ndarray]
    #: Splitting's normalised score serves it (a run of one level, _Problem.split_score): the
    #: score's martingale part grows at the rate sigma^2 V^2 / c^2 (the sign-drift diffusion,
    #: model.TAIL_MODEL), so the spread still to come normalises it.
    normalised: bool = False
    #: The score is the displacement where the body stops, u0 plus a stretch before the first
    #: touch of 0 plus the stretches between touches each with a fair sign: importance sampling
    #: re-draws those signs (importance.py, _resigned; with its own proposal drifts, speed
    #: thresholds and pilot size). "signed": the displacement; "magnitude": its magnitude,
    #: the signs tilted towards +level and -level. None: the signs are not re-drawn.
    signs: Optional[str] = None
    #: ``speed(problem, top)``: the speed a velocity quantity's large-deviation path reaches at
    #: the end of the grid for the score ``top`` (|V| climbs to it at the rate c of the
    #: reversed friction over its last speed / c): importance sampling adds that window to its
    #: pilot's (importance.py, _ld_windows). None: no such window.
    ld_speed: Optional[Callable[[_Problem, float], float]] = None
    #: ``uncoast(v)``: the velocity's function (v or |v|) whose value minus the coast c (time -
    #: horizon) splitting ranks by after the switch-off (_Problem.uncoasted); None: the score
    #: itself.
    uncoast: Optional[Callable[[np.ndarray], np.ndarray]] = None


#: The tail scores (``Quantity.tail``), by key. The stop time, the velocity after the grid and
#: where the body would stop rest on the coast at the deceleration c once the shaking has ended
#: (model.TAIL_SPLITTING, checked by every tail run), the stop time from the horizon on the body
#: moving there (model.MOVING_AT_SWITCH_OFF), the distance's conditional mean
#: (``_Problem.remaining``) on model.ITO_DISTANCE. The core's loop computes the score of every
#: quantity named in _core.SPLIT_QUANTITIES.
SCORES: Dict[str, TailScore] = {
    "stop_time": TailScore(_stop_time, ld_speed=_stop_time_speed),
    "velocity": TailScore(_velocity, ld_speed=_speed_before_coast, uncoast=_signed),
    "speed": TailScore(_speed, ld_speed=_speed_before_coast, uncoast=np.abs),
    "distance_at_stop": TailScore(_distance_at_stop, normalised=True),
    "displacement_at_stop": TailScore(_ahead, normalised=True, signs="signed"),
    "residual_displacement": TailScore(_residual_displacement, normalised=True,
                                       signs="magnitude"),
    "peak_displacement_at_stop": TailScore(_peak_displacement_at_stop),
    "peak_speed_at_stop": TailScore(_peak_speed_at_stop, ld_speed=_speed_before_coast),
}


def _extend(problem: _Problem, states, rows, starts, streams, key, threads, law=None,
            touched=None):
    if problem.filtered:
        if law is not None or touched is not None:
            raise RuntimeError("a filtered excitation's paths have no proposal law")
        problem._grid.extend(states, rows, starts, streams, key, threads)
        return
    law = law or _Law(problem.drifts)
    _core.extend_paths(states, np.asarray(rows, dtype=np.int64), np.asarray(starts, dtype=np.int64),
                       np.asarray(streams, dtype=np.uint64), problem.lengths, problem.noises,
                       law.drifts, key, threads, touched, law.slow,
                       None if law.slow is None else problem.drifts)


#: A filtered path's number is below 2^40 (the core's counter layout, cpp/src/filtered.cpp).
_FILTERED_PATHS = 1 << 40


def filtered_key(key: int, block: int) -> int:
    """The Philox key of the filtered paths numbered block * 2^40 + j (a splitting replica's
    streams): the core numbers a filtered path with 40 bits, so each block of 2^40 streams
    gets a key of its own, drawn from (key, block) by NumPy's SeedSequence."""
    state = np.random.SeedSequence([int(key), int(block), 7]).generate_state(1, np.uint64)
    return int(state[0])


#: The most steps a tail run's grid takes over one piece of the excitation.
MAX_PIECE_STEPS = 10_000_000


def _plan_options(scene: Scene, times: Sequence[float], dt: float):
    """The core's options of the scene's model (as engine.scene_options sets them: the tail
    does not reach the engine layer; tests/test_filtered_tail.py checks that the two agree)
    with output times ``times``, observing the velocity alone, the exact method and step dt."""
    o = _core.Options()
    o.drift = scene.drift
    o.noise = scene.noise
    o.switch_off = scene.t0
    if scene.pieces is not None:
        o.piece_ends = [e for e, _ in scene.pieces]
        o.piece_noise = [n for _, n in scene.pieces]
    o.start_velocity = scene.v0
    o.start_displacement = scene.u0
    for name, value in scene.excitation.core_options().items():
        setattr(o, name, value)
    if scene.static_drift != scene.drift:
        o.static_drift = scene.static_drift
    o.times = list(times)
    o.velocity = True
    o.displacement = o.distance = False
    o.stop = o.peaks = o.energy = o.residual = False
    o.dt = dt
    o.min_steps = 0
    o.method = "exact"
    o.seed = 0
    o.paths = 1
    return o


def white_noise_grid(scene: Scene, horizon: float, dt: float, breaks: Sequence[float] = (),
                     coarse: bool = False):
    """(lengths, noises, starts) of a white-noise tail run's grid to ``horizon``: the core's
    plan of the scene with output times at the horizon and the ``breaks`` before it, its
    segments (cut there and at the pieces' ends) each split into steps of at most about dt,
    one step without noise or when ``coarse`` (the velocity's law does not depend on the
    grid): ``_core.tail_grid`` (cpp/src/plan.cpp)."""
    times = sorted({float(horizon)} | {float(x) for x in breaks if 0 < x < horizon})
    try:
        plan = _core.Plan(_plan_options(scene, times, dt))
    except ValueError as exc:
        raise ParameterError("scene", f"scene: the core's plan of the grid to {horizon:g} "
                             f"refuses it ({exc})") from None
    try:
        lengths, noises, starts = _core.tail_grid(plan, dt, coarse, MAX_PIECE_STEPS)
    except ValueError as exc:
        raise ParameterError("dt", str(exc)) from None
    return (np.asarray(lengths, dtype=np.float64), np.asarray(noises, dtype=np.float64),
            np.asarray(starts, dtype=np.float64))


class _FilteredGrid:
    """A filtered excitation's paths for a tail run: the core's plan of a fixed-step run of the
    scene with one output time, the horizon (dt as given; no graded steps), and its walked
    grid; paths continued from any grid point by ``_core.extend_filtered_paths``."""

    def __init__(self, scene: Scene, horizon: float, dt: float):
        o = _plan_options(scene, [horizon], dt)
        o.displacement = o.distance = True
        try:
            self.plan = _core.Plan(o)
        except ValueError as exc:
            raise ParameterError("dt", f"dt: the filtered grid to {horizon:g} is refused by "
                                 f"the core ({exc})") from None
        lengths, noises, z0 = _core.filtered_grid(self.plan)
        self.lengths = np.asarray(lengths, dtype=np.float64)
        self.noises = np.asarray(noises, dtype=np.float64)
        self.z0 = np.asarray(z0, dtype=np.float64)
        self.columns = 4 + len(self.z0)

    def extend(self, states, rows, starts, streams, key, threads) -> None:
        rows = np.asarray(rows, dtype=np.int64)
        starts = np.asarray(starts, dtype=np.int64)
        streams = np.asarray(streams, dtype=np.uint64)
        blocks = streams >> np.uint64(40)
        for block in np.unique(blocks):
            pick = blocks == block
            _core.extend_filtered_paths(self.plan, states, rows[pick], starts[pick],
                                        streams[pick] & np.uint64(_FILTERED_PATHS - 1),
                                        filtered_key(key, int(block)), threads)


# -- the transition density (importance sampling's weights) --------------------------------


def log_transition_density(x, x0, t, c, sigma):
    """The sign-drift diffusion's log transition density (crandall.analytic.schedule's formula)
    computed with the same bits on every CPU (detmath.py): importance sampling's weights."""
    return detmath.log_transition_density(x, x0, t, c, sigma)


class _Law(NamedTuple):
    """A proposal's law on a grid: per step the drift, and (or None) the speed below which a
    step keeps the scene's friction; ``full`` (or None) the drifts of a defensive component
    over every noisy step that draws DEFENSIVE of the paths (see _proposal)."""

    drifts: np.ndarray
    slow: Optional[np.ndarray] = None
    full: Optional[np.ndarray] = None


def _coarse(problem: _Problem) -> bool:
    """Whether importance sampling runs on the coarsest grid (the velocity quantities)."""
    return problem.q.velocity_only and not problem.q.peak


def _grid_for(problem: _Problem, window: float) -> _Problem:
    """The grid importance sampling runs on: the coarsest one for the velocity quantities (the
    likelihood ratio of fewer grid values has a lighter tail: it no longer sees the time the
    path spends near 0), the problem's own otherwise."""
    if _coarse(problem):
        return problem.coarse_for(window)
    return problem
