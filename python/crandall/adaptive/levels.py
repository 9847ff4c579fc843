"""The levels of a run to an accuracy: the base grid and batch sizes, the statistics a run may
target, the per-level sums the core fills (``_Level``, ``_Sums``) and the small linear algebra
of their moments."""

from __future__ import annotations

import functools
from dataclasses import dataclass
from typing import Iterable, List, Mapping, Optional, Sequence, Tuple

import numpy as np

from .. import _core
from ..quantities import PEAKS, VELOCITY, DISTANCE, names_for, quantity
from ..model import (EXACT_STEP, FILTERED_EXCITATION, FILTERED_LEVELS, ITO_DISTANCE, LEVELS,
                     ZERO_FRICTION, Identity, holds, isometry_applies)
from ..errors import ParameterError
from ..scene import Scene
from ..streams import level_key
from ..engine import scene_options
from ..spec import grid_error

#: The base grid (level 0): steps of at most BASE_DT_FACTOR times the default step
#: (0.25 in scaled time), graded so that every output time and the switch-off t are reached in
#: at least BASE_MIN_STEPS steps.
BASE_DT_FACTOR = 25
BASE_MIN_STEPS = 4
#: A filtered excitation's base grid (model.FILTERED_LEVELS): steps of at most this many times
#: its default step (crandall.methods.DEFAULT_DT_TAU_FILTER), so that level 2, the pilot's
#: finest, is the grid of a fixed-step run at the default step. Its skeleton is exact at any
#: step and its events are searched for by bisection (docs/filtered.md), so coarse grids are
#: already close: the level means of the mean distance at the stop were 4e-5, 1.3e-5, 6e-6 of
#: 3.9 (Kanai-Tajimi, omega t* = 4, levels 1-3).
FILTER_BASE_DT_FACTOR = 4
#: The event depth of every level of a filtered excitation's run to an accuracy: the finer
#: levels measure and correct what a shallow search leaves, so the core's default depth 8
#: (made for fixed-step runs, where nothing corrects it) is not needed, and depth 4 costs
#: 2-4x less per path (bench/filtered.py; the calibration, bench/filtered_error.py, is at
#: this depth).
FILTER_EVENT_DEPTH = 4
#: The filtered core's bound on a plan's paths (cpp/src/filter.cpp).
FILTER_MAX_PATHS = 1 << 40
#: Paths per call of the core (fewer when a path's values and features would take more than
#: BATCH_BYTES in a batch: scenes with many output times); and the pilot of a new level.
BATCH_PATHS = 1 << 16
PILOT_PATHS = 4096
#: A filtered excitation's pilot on the levels after the base (and the whole batches they grow
#: by): their differences cost 2 grids of 2^l times the base's steps each, and the base level's
#: spread sets the error, so 4096 of them were most of a loose target's time (docs/methods/
#: adaptive.md, "A filtered excitation"). The base level keeps PILOT_PATHS (its controls'
#: coefficients are fitted on them).
FILTER_LEVEL_PILOT = 1024
#: A filtered excitation's long runs refit the base level's control coefficients on a second,
#: larger pilot of this many paths (at most a batch): when a round's estimates ask the base
#: level for at least REFIT_RATIO times what the refit costs (that pilot and the base level's
#: estimation paths so far, set aside), the coefficients of the first pilot
#: (PILOT_PATHS) and the base level's estimate so far are set aside, the coefficients are
#: fitted again on the next REFIT_PILOT paths and the estimate starts again after them (the
#: coefficients stay independent of the paths they are applied to): docs/methods/adaptive.md,
#: "A filtered excitation". The refit costs at most 1/REFIT_RATIO of the base level's paths.
REFIT_PILOT = 1 << 16
REFIT_RATIO = 64
#: The default bound on a run's estimated time (s): past it the run stops with the estimate
#: (simulate's ``max_seconds`` raises it).
MAX_SECONDS = 3600.0
#: The statistics a run reports for each quantity.
STATS = ("mean", "var")
#: The two-sided normal quantile of the reported 95 % interval.
Z95 = 1.959963984540054


@dataclass
class _Target:
    """One statistic: (quantity, output slot, mean or var)."""

    name: str
    slot: int          # output-time index, or len(times) for the stop
    time_index: Optional[int]
    stat: str
    variable: int
    power: int
    exact: bool        # exact in law at any step: level 0 only, bias 0
    ito: bool = False  # the mean distance through the Ito identity
    magnitude: bool = False  # |variable| (the residual displacement)
    #: The variance of the distance at the stop as the mean of int sigma^2 V^2 dt / c^2 (Ito's
    #: isometry): one feature column, formed and summed like a mean's.
    isometry: bool = False


def levels_model(scene: Scene) -> Identity:
    """The multilevel model a run to an accuracy of ``scene`` rests on: the filtered core's
    (:data:`crandall.model.FILTERED_LEVELS`) for a filtered excitation, else the white-noise
    skeleton's (:data:`crandall.model.LEVELS`)."""
    return FILTERED_LEVELS if FILTERED_EXCITATION in scene.effects else LEVELS


def _check_statistics(scene: Scene, statistics) -> Optional[set]:
    """``statistics`` as a set of (name, stat), each held by the scene; None for all."""
    if statistics is None:
        return None
    if isinstance(statistics, str):
        statistics = [statistics]
    if isinstance(statistics, Mapping) or not isinstance(statistics, Iterable):
        # A dict would be read as its keys (the means), whatever its values say.
        raise ParameterError("statistics", f"statistics: give a list such as ['distance:var', 'velocity:mean'] "
                         f"or of pairs (name, stat), got {statistics!r}")
    held = names_for(scene.observe)
    out = set()
    for item in statistics:
        if isinstance(item, str):
            name, _, stat = item.partition(":")
            stat = stat or "mean"
        elif isinstance(item, tuple) and len(item) == 2:
            name, stat = item
        else:
            raise ParameterError("statistics", f"statistics: give names such as 'distance:var' or pairs "
                             f"(name, stat), got {item!r}")
        if name not in held:
            raise ParameterError("statistics", f"statistics: {name!r} is not observed by the scene; it holds "
                             f"{', '.join(held)}")
        if stat not in STATS:
            raise ParameterError("statistics", f"statistics: the statistic of {name!r} must be one of "
                             f"{', '.join(STATS)}, got {stat!r}")
        out.add((name, stat))
    if not out:
        raise ParameterError("statistics", "statistics: name at least one statistic")
    return out


def _targets(scene: Scene, statistics: Optional[set] = None) -> List[_Target]:
    out = []
    n_times = len(scene.times)
    for name in names_for(scene.observe):
        q = quantity(name)
        slots = [(n_times, None)] if q.at_stop else [(i, i) for i in range(n_times)]
        if q.peak:
            # The filtered core's per-path peaks, in the slots after the stop's
            # (Options::sample_slots); white noise's are refused (entry.simulate_to_error).
            slots = [(_peak_base(scene) + slot, ti) for slot, ti in slots]
        for slot, ti in slots:
            for stat in STATS:
                if statistics is not None and (name, stat) not in statistics:
                    continue
                # Velocity, kinetic energy, stop time; and a quantity whose factor is 0 (the
                # dissipated energy without friction), which is 0 on every path. Each only
                # where its identity holds for the scene (crandall.model).
                exact = ((q.variable == VELOCITY and not q.peak and holds(scene, EXACT_STEP))
                         or (q.factor(scene) == 0.0 and holds(scene, ZERO_FRICTION)))
                ito = (stat == "mean" and q.variable == DISTANCE and scene.drift > 0
                       and holds(scene, ITO_DISTANCE))
                isometry = stat == "var" and isometry_applies(q, scene)
                # The isometry's integral is the samples' slot after the stop's.
                out.append(_Target(name, n_times + 1 if isometry else slot, ti, stat,
                                   q.variable, q.power, exact or ito, ito, q.magnitude,
                                   isometry))
    return out


class _Sums:
    """Per level: the number of paths, and per target the sums of its feature columns (one
    for a mean, two for a variance) and of their products."""

    def __init__(self, widths: Sequence[int]) -> None:
        self.n = 0
        self.widths = list(widths)
        self.flat = np.zeros(sum(w + w * (w + 1) // 2 for w in widths))
        self.offsets = np.cumsum([0] + [w + w * (w + 1) // 2 for w in widths])[:-1]

    def add(self, n: int, flat: np.ndarray) -> None:
        self.n += n
        self.flat += flat

    def group(self, g: int) -> Tuple[np.ndarray, np.ndarray]:
        """Target g's column means and unbiased covariance."""
        w, o = self.widths[g], self.offsets[g]
        means, covs = _moments(self.flat[None, o:o + w + w * (w + 1) // 2], self.n, w)
        return means[0], covs[0]


def _moments(flat: np.ndarray, n: int, w: int) -> Tuple[np.ndarray, np.ndarray]:
    """Per row of flat (G, w + w (w + 1) / 2: a group's column sums and the upper triangle of
    its products over n paths): the column means (G, w) and the unbiased covariances
    (G, w, w). The same elementwise operations for every row as for one row alone."""
    rows, cols = _triu(w)
    p = np.zeros((flat.shape[0], w, w))
    p[:, rows, cols] = flat[:, w:]
    # p plus its strict upper triangle transposed (np.triu(p, 1).T, row by row).
    p = p + np.where(_lower(w), 0.0, p).transpose(0, 2, 1)
    m = flat[:, :w] / n
    return m, (p - n * (m[:, :, None] * m[:, None, :])) / max(n - 1, 1)


@functools.lru_cache(maxsize=None)
def _lower(w: int) -> np.ndarray:
    """The diagonal and below: what np.triu(., 1) sets to 0."""
    return np.tri(w, w, k=0, dtype=bool)


def _peak_base(scene: Scene) -> int:
    """The first of the peaks' slots (after the output times' and the stop's)."""
    return len(scene.times) + (1 if "stop" in scene.observe else 0)


def _peaks_recorded(scene: Scene) -> bool:
    """Whether the core records each path's peaks per grid (the filtered core, with the peaks
    observed: Options::sample_slots)."""
    return FILTERED_EXCITATION in scene.effects and PEAKS in scene.observe


def _sample_slots(scene: Scene, quadratic: bool) -> int:
    """A path's slots of per-path values: the output times, the stop, with ``quadratic`` the
    isometry's integral, and under a filtered excitation with the peaks observed (max |V|,
    max |U|, 0) per output time and at the stop (the filtered core has no isometry slot)."""
    peaks = _peak_base(scene) if _peaks_recorded(scene) else 0
    return (len(scene.times) + (1 if "stop" in scene.observe else 0) + (1 if quadratic else 0)
            + peaks)


class _Level:
    def __init__(self, scene: Scene, level: int, seed: int, base_dt: float, threads: int,
                 integrals: bool, quadratic: bool = False) -> None:
        o = scene_options(scene)
        # The slot after the stop's: int sigma^2 V^2 dt, for the isometry's targets.
        o.quadratic_variation = quadratic
        o.dt = base_dt
        o.min_steps = BASE_MIN_STEPS
        o.refinement = level
        o.method = "richardson2" if level > 0 else "exact"
        o.seed = level_key(seed, level)
        #: The paths the level's plan can draw (the filtered core's plans fewer).
        self.max_paths = FILTER_MAX_PATHS if FILTERED_EXCITATION in scene.effects else 1 << 62
        if FILTERED_EXCITATION in scene.effects and FILTER_EVENT_DEPTH is not None:
            o.event_depth = FILTER_EVENT_DEPTH
        o.paths = self.max_paths
        try:
            self.plan = _core.Plan(o)
        except ValueError as exc:  # the user sets no step here: say what can change
            raise grid_error(exc, scene, dt_given=False) from None
        self.level = level
        self.threads = threads
        #: Steps a path of this level takes (its cost unit).
        self.cost = max(int(self.plan.steps_per_path), 1)
        #: (slots, grids, 3): one path's values.
        self.shape = (_sample_slots(scene, quadratic), 2 if level > 0 else 1, 3)
        self.sums: Optional[_Sums] = None
        #: Whether the level runs with control variates, and the first path its sums hold
        #: (the paths before it fitted the control coefficients).
        self.controls = False
        #: The slots whose control sums the level draws (ascending), when it draws them.
        self.control_slots: List[int] = []
        self.start = 0
        self.batch = BATCH_PATHS
        self._buffers = None
        #: Every level of the run (their buffers are released when this one takes its own).
        self.siblings: List["_Level"] = []

    def samples(self, first: int, n: int):
        """The per-path values (and control sums) of paths [first, first + n), written into
        buffers kept between batches (fresh arrays per batch cost more in page faults than
        a short grid's paths)."""
        if self._buffers is None:
            for other in self.siblings:  # one level's buffers at a time (the memory check)
                if other is not self:
                    other._buffers = None
            values = np.empty((self.batch,) + tuple(self.shape))
            ctl = (np.empty((self.batch, len(self.control_slots), _core.CONTROLS))
                   if self.controls else None)
            self._buffers = (values, ctl)
        values, ctl = self._buffers
        if self.controls:
            return _core.run_samples(self.plan, first, n, self.threads, True, values[:n],
                                     ctl[:n], self.control_slots)
        return _core.run_samples(self.plan, first, n, self.threads, False, values[:n]), None


def _solve_many(a: np.ndarray, bs: np.ndarray) -> List[List[float]]:
    """a x = b for each row b of bs, a symmetric positive semi-definite, by Gaussian
    elimination in IEEE doubles, one operation at a time (the same bits on every machine; no
    LAPACK). Columns without variance get 0; a ridge of 1e-12 of the largest diagonal keeps
    nearly dependent controls bounded. The pivots and the row operations depend on a only, so
    every right-hand side gets, operation by operation, the arithmetic it would get alone: a is
    eliminated once, the right-hand sides' rows are updated together (elementwise, so each
    element's bits are those of a right-hand side alone)."""
    n = a.shape[0]
    bs = np.asarray(bs, dtype=float).reshape(-1, n)
    keep = [j for j in range(n) if a[j, j] > 0.0]
    out = np.zeros((len(bs), n))
    if not keep:
        return out.tolist()
    ridge = 1e-12 * max(float(a[j, j]) for j in keep)
    m = [[float(a[i, j]) + (ridge if i == j else 0.0) for j in keep] for i in keep]
    rhs = [bs[:, i].copy() for i in keep]  # row i of the right-hand sides, one per b
    size = len(keep)
    for col in range(size):
        piv = max(range(col, size), key=lambda r: abs(m[r][col]))
        m[col], m[piv] = m[piv], m[col]
        rhs[col], rhs[piv] = rhs[piv], rhs[col]
        if m[col][col] == 0.0:
            continue
        for r in range(col + 1, size):
            f = m[r][col] / m[col][col]
            if f != 0.0:
                for c in range(col, size):
                    m[r][c] -= f * m[col][c]
                rhs[r] -= f * rhs[col]
    sol = [np.zeros(len(bs)) for _ in range(size)]
    for r in range(size - 1, -1, -1):
        if m[r][r] == 0.0:
            continue
        acc = np.zeros(len(bs))  # the running sum, from 0 in column order
        for c in range(r + 1, size):
            acc = acc + m[r][c] * sol[c]
        sol[r] = (rhs[r] - acc) / m[r][r]
    for j, v in zip(keep, sol):
        out[:, j] = v
    return out.tolist()


@functools.lru_cache(maxsize=None)
def _triu(w: int):
    return np.triu_indices(w)
