"""Runs to a requested accuracy: multilevel Monte Carlo on the exactly coupled grids.

``crandall.simulate(scene, error=EPS)`` lands here. The method, its measurements and its
error estimates are in docs/methods/adaptive.md; in short:

- Level 0 simulates paths on a coarse base grid; level l >= 1 simulates other paths on the
  grid refined 2^l times and forms, on each path, the difference between the statistic's
  per-path value on that grid and on every second point of it (the grid of level l - 1, on the
  same exact path: the coupling is perfect, no extra random numbers). The telescoping sum of
  the level means estimates the statistic on the finest grid; its discretisation bias is
  estimated from the finest level's mean.
- The variance of the distance at the stop (and of the dissipated energy there) is the mean of
  int_0^t0 sigma^2 V^2 dt / c^2 (Ito's isometry, crandall.model.ISOMETRY): a per-path value with
  far less spread than (S(t_s) - E S(t_s))^2, still an integral on the grid, so its levels
  and bias are estimated as for any other.
- Statistics exact in law at any step (every moment of the velocity, the kinetic energy, the
  stop time) need level 0 only, and their bias is exactly 0. So does the mean distance (and
  the mean dissipated energy), through the identity
  E S(t) = (sigma^2 min(t, t0) - E X(t)^2) / (2 c) that Ito's formula gives for a body
  starting at rest (c the friction deceleration, sigma the noise intensity).
- Samples are allocated across levels as Giles' multilevel Monte Carlo prescribes, from level
  variances and costs (steps per path) estimated on the run, in rounds. Every decision is a
  function of the merged sums at a round's end, and every path's numbers are a function of
  (seed, level, path index): the result is bitwise the same for any thread count.
"""

from __future__ import annotations

import functools
import hashlib
import json
import math
import os
import time
import warnings
from dataclasses import dataclass
from typing import Dict, Iterable, List, Mapping, Optional, Sequence, Tuple

import numpy as np

from . import _core, bias, pieces
from ._resources import available_memory
from .checkpoint import json_state, read_json_state
from .driver import Estimator, Progress, Task, drive
from .errors import ParameterError
from .quantities import VELOCITY, DISTANCE, core_flags, names_for, quantity
from .model import EXACT_STEP, ITO_DISTANCE, LEVELS, ZERO_FRICTION, holds, isometry_applies, ito_constant
from .results import AccuracyResult, StatisticsWarning
from .scene import Scene
from .streams import RANDOM_STREAM, check_random_stream, level_key
from .engine import scene_options
from .spec import MAX_SEED, check_int, check_positive, check_scene, default_dt, grid_error

__all__ = ["simulate_to_error", "BASE_DT_FACTOR", "BASE_MIN_STEPS",
           "BATCH_PATHS", "PILOT_PATHS", "MAX_LEVELS", "STATS"]

#: The base grid (level 0): steps of at most BASE_DT_FACTOR times the default step
#: (0.25 in scaled time), graded so that every output time and the switch-off t are reached in
#: at least BASE_MIN_STEPS steps.
BASE_DT_FACTOR = 25
BASE_MIN_STEPS = 4
#: Paths per call of the core (fewer when a path's values and features would take more than
#: BATCH_BYTES in a batch: scenes with many output times); and the pilot of a new level.
BATCH_PATHS = 1 << 16
BATCH_BYTES = 64 << 20
PILOT_PATHS = 4096
#: Bytes of the matrices that fit the control coefficients, per call of the core.
FIT_BYTES = 32 << 20
#: Levels beyond the base (the finest grid is 2^MAX_LEVELS times finer than the base).
MAX_LEVELS = 14
#: Paths a level can draw (its Philox counters run to 2^62).
MAX_LEVEL_PATHS = float(1 << 62)
#: The default bound on a run's estimated time (s): past it the run stops with the estimate
#: (simulate's ``max_seconds`` raises it).
MAX_SECONDS = 3600.0
#: Path-steps per second above any machine's (bench/throughput.py measures tens of millions
#: per thread): a bound for what a pilot must at least cost.
FASTEST_RATE = 1e10
#: Path-steps of the measurement of a level's time per path before its first batch
#: (_Engine.measure): a few paths, discarded (at most one path, however long).
RATE_STEPS = 1 << 20
#: A round at most multiplies a level's paths by this (the variance estimates of a small
#: sample can be far off).
MAX_GROWTH = 16
#: Control variates on the base level (switch off to measure what they bring).
USE_CONTROLS = True
#: Output slots that carry control sums: every slot up to this many; beyond, this many slots
#: spread over the output times, each column using the nearest one's (any slot's sums have
#: mean 0, so any choice stays unbiased). The sums cost work per step and slot, so with
#: thousands of output times they cost more than the paths (docs/methods/adaptive.md).
CONTROL_SLOTS = 64
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


def _check_statistics(scene: Scene, statistics) -> Optional[set]:
    """``statistics`` as a set of (name, stat), each held by the scene; None for all."""
    if statistics is None:
        return None
    if isinstance(statistics, str):
        statistics = [statistics]
    if isinstance(statistics, Mapping) or not isinstance(statistics, Iterable):
        # A dict would be read as its keys (the means), whatever its values say.
        raise ValueError(f"statistics: give a list such as ['distance:var', 'velocity:mean'] "
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
            raise ValueError(f"statistics: give names such as 'distance:var' or pairs "
                             f"(name, stat), got {item!r}")
        if name not in held:
            raise ValueError(f"statistics: {name!r} is not observed by the scene; it holds "
                             f"{', '.join(held)}")
        if stat not in STATS:
            raise ValueError(f"statistics: the statistic of {name!r} must be one of "
                             f"{', '.join(STATS)}, got {stat!r}")
        out.add((name, stat))
    if not out:
        raise ValueError("statistics: name at least one statistic")
    return out


def _targets(scene: Scene, statistics: Optional[set] = None) -> List[_Target]:
    out = []
    n_times = len(scene.times)
    for name in names_for(scene.observe):
        q = quantity(name)
        slots = [(n_times, None)] if q.at_stop else [(i, i) for i in range(n_times)]
        for slot, ti in slots:
            for stat in STATS:
                if statistics is not None and (name, stat) not in statistics:
                    continue
                # Velocity, kinetic energy, stop time; and a quantity whose factor is 0 (the
                # dissipated energy without friction), which is 0 on every path. Each only
                # where its identity holds for the scene (crandall.model).
                exact = ((q.variable == VELOCITY and holds(scene, EXACT_STEP))
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


def _sample_slots(scene: Scene, quadratic: bool) -> int:
    """A path's slots of per-path values: the output times, the stop, and with ``quadratic``
    the isometry's integral."""
    return len(scene.times) + (1 if "stop" in scene.observe else 0) + (1 if quadratic else 0)


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
        o.paths = 1 << 62
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


def _control_slots(scene: Scene, slots: int) -> Tuple[List[int], List[int]]:
    """The slots that carry control sums (every slot, or CONTROL_SLOTS of them spread evenly
    over the slot indices, the last slot among them) and, per slot, the index among them of
    the one whose sums it uses: the nearest in the time its sums run to (its output time, at
    most the switch-off; the stop's: the switch-off), ties to the later one."""
    if slots <= CONTROL_SLOTS:
        return list(range(slots)), list(range(slots))
    chosen = sorted({round(i * (slots - 1) / (CONTROL_SLOTS - 1)) for i in range(CONTROL_SLOTS)})
    until = np.full(slots, scene.t0, dtype=float)
    until[:len(scene.times)] = np.minimum(scene.times, scene.t0)
    gap = np.abs(until[:, None] - until[None, chosen])
    # The last of the nearest: argmin of the reversed columns.
    nearest = len(chosen) - 1 - np.argmin(gap[:, ::-1], axis=1)
    return chosen, [int(a) for a in nearest]


@functools.lru_cache(maxsize=None)
def _triu(w: int):
    return np.triu_indices(w)


class _Engine(Estimator):
    """A run to an accuracy as the driver's estimator (:mod:`crandall.driver`): rounds of
    batches per level, each round's allocation decided from the merged sums."""

    name = "accuracy"
    checkpoint_seconds = 1.0  # CHECKPOINT_SECONDS, read when the module is loaded

    def __init__(self, scene: Scene, *, eps: Optional[float], rel: Optional[float], seed: int,
                 threads: int, statistics: Optional[set] = None) -> None:
        # here too: the Dask task builds its own engine
        self.scene = check_scene(scene, LEVELS, "a run to an accuracy (error=, rel_error=)")
        self.eps, self.rel = eps, rel
        self.seed = seed
        self.threads = threads
        self.targets = _targets(scene, statistics)
        #: Whether a target takes the isometry's integral (the samples' extra slot).
        self.quadratic = any(t.isometry for t in self.targets)
        flags = core_flags(scene.observe)
        self.integrals = flags["displacement"] or flags["distance"]
        self.base_dt = BASE_DT_FACTOR * default_dt(scene)
        self.levels: List[_Level] = []
        self.centre = None
        self.path_steps = 0
        self.round_count = 0
        # Feature columns: per target one (mean) or two (var: first and second power).
        self.cols: List[Tuple[int, int]] = []
        for i, t in enumerate(self.targets):
            self.cols.append((i, 1))
            if t.stat == "var" and not t.isometry:
                self.cols.append((i, 2))
        self.widths = [2 if t.stat == "var" and not t.isometry else 1 for t in self.targets]
        # Paths per batch: a pure function of the scene and the statistics (the batches a run
        # makes must not depend on the machine), small enough that a batch's per-path values,
        # control sums and feature columns stay within BATCH_BYTES.
        outputs = len(scene.times) + (1 if "stop" in scene.observe else 0)
        slots = _sample_slots(scene, self.quadratic)
        #: The slots that carry control sums, and per slot the one whose sums it uses (the
        #: isometry's integral runs to the switch-off, as the stop's sums do).
        self.control_slots, self.control_of = _control_slots(scene, outputs)
        if self.quadratic:
            self.control_of.append(self.control_of[-1])
        per_path = 8 * (slots * 2 * 3 + len(self.control_slots) * _core.CONTROLS
                        + 2 * len(self.widths))
        self.batch = int(min(BATCH_PATHS, max(256, BATCH_BYTES // per_path // 256 * 256)))
        #: Control variates on the base level (docs/methods/adaptive.md): with an observed
        #: integral (the controls need the grid's steps).
        #: Not without friction: the weights k = min(|X| / c, r) degenerate at c = 0, and on a
        #: frictionless scene (mu = 0, h = 1, t = 0.5) the mean distance with the controls came
        #: out 0.66 reported errors low on average over 20 seeds (without them: 0.14 +- 0.18),
        #: a shift not understood yet (docs/methods/adaptive.md, "Limits").
        self.use_controls = USE_CONTROLS and self.integrals and scene.drift > 0
        self.beta = None
        self.sums_width = sum(w + w * (w + 1) // 2 for w in self.widths)
        #: What is left of the current round: [level, paths] to grow to, in order.
        self.pending: Optional[List[List[int]]] = None
        self.checkpoint = None  # where the driver keeps the state (for messages only)
        self.text = ""  # the progress bar's text
        self.max_seconds = MAX_SECONDS
        #: Seconds spent before the levels (an envelope's pieces' pilot), counted against
        #: max_seconds.
        self.pilot_seconds = 0.0
        #: Per target, the error of an envelope's pieces (core units; crandall.pieces), or
        #: None.
        self.piece_bias: Optional[List[float]] = None
        #: Per (name, stat): the largest scale over the output times, for rel_error's floor.
        self.sizes: Dict[Tuple[str, str], float] = {}
        #: Per level, [seconds, paths] run here in this call (its measurement first): every
        #: batch run here is checked against max_seconds before it starts (_checked). Per
        #: level, since a path's cost is not its steps alone: a path at rest through a pause
        #: costs nothing on the finer levels, the base level's control sums every step.
        self.timing: Dict[int, List[float]] = {}
        #: The start and path-steps of this call.
        self.call = (time.perf_counter(), 0)
        self.task_threads = 1
        self.started = time.perf_counter()
        self.wall_before = 0.0
        self.level_targets = [i for i, t in enumerate(self.targets) if not t.exact]
        self._targets_cache = None
        self._columns_cache = None
        self._feature_buffer: Optional[np.ndarray] = None

    def check_memory(self) -> None:
        """Refuse, before anything is allocated, a run whose batches (one level's buffers of
        per-path values and control sums, the feature columns and their temporaries) and
        threads (a stack each) would not fit in what this process may still allocate."""
        slots = _sample_slots(self.scene, self.quadratic)
        per_path = 8 * (max(slots * 2 * 3, slots * 3 + len(self.control_slots) * _core.CONTROLS)
                        + 3 * len(self.cols))
        need = self.batch * per_path + self.threads * (16 << 20)
        have = available_memory()
        if need > have:
            raise ValueError(
                f"times: a run to an accuracy of {len(self.scene.times)} output times "
                f"({self.threads} threads) needs about {need / 2**20:.0f} MiB for its batches "
                f"and threads, more than the {have / 2**20:.0f} MiB this process may still "
                "allocate (free memory, rlimits, cgroup); give fewer times, statistics or "
                "threads")

    # -- per-path values ------------------------------------------------------------------

    # The centring constants and the control coefficients: setting either renews the feature
    # columns handed to the core.
    @property
    def centre(self) -> Optional[np.ndarray]:
        return self._centre

    @centre.setter
    def centre(self, value: Optional[np.ndarray]) -> None:
        self._centre = value
        self._columns_cache = None

    @property
    def beta(self) -> Optional[List[List[float]]]:
        return self._beta

    @beta.setter
    def beta(self, value: Optional[List[List[float]]]) -> None:
        self._beta = value
        self._columns_cache = None

    def _target_columns(self) -> "_core.FeatureColumns":
        """One column per target: how its per-path value is formed from the samples (its slot
        and variable; the value itself, the stop time from the switch-off included; its
        square; the mean distance's Ito identity (sigma^2 elapsed - V^2) / (2 c), with V = 0
        at the stop; or the isometry's int sigma^2 V^2 dt / c^2), with centre 0 and power 1."""
        if self._targets_cache is None:
            sc = self.scene
            c = _core.FeatureColumns()
            kind, const = [], []
            for t in self.targets:
                if t.ito:
                    kind.append(2 if t.time_index is not None else 3)
                    elapsed = (min(sc.times[t.time_index], sc.t0) if t.time_index is not None
                               else sc.t0)
                    const.append(ito_constant(sc, elapsed))
                elif t.isometry:
                    kind.append(5)
                    const.append(1.0 / (sc.drift * sc.drift))
                else:
                    first = t.power == 1 or (t.stat == "mean" and t.variable == VELOCITY
                                             and t.time_index is None)
                    kind.append(4 if t.magnitude else 0 if first else 1)
                    const.append(0.0)
            c.slot = [t.slot for t in self.targets]
            c.variable = [VELOCITY if t.ito or t.isometry else t.variable
                          for t in self.targets]
            c.kind, c.constant = kind, const
            c.power = [1] * len(self.targets)
            c.centre = [0.0] * len(self.targets)
            c.inexact = [int(not t.exact) for t in self.targets]
            self._targets_cache = c
        return self._targets_cache

    def _columns(self) -> "_core.FeatureColumns":
        """The feature columns: per column its target's value minus the target's centre, to
        the column's power; with the control coefficients once fitted."""
        if self._columns_cache is None:
            per_target = self._target_columns()
            c = _core.FeatureColumns()
            which = [i for i, _ in self.cols]
            for field in ("slot", "variable", "kind", "constant", "inexact"):
                values = getattr(per_target, field)
                setattr(c, field, [values[i] for i in which])
            c.power = [p for _, p in self.cols]
            c.centre = [float(self.centre[i]) for i in which]
            if self.beta is not None:
                c.control = [self.control_of[self.targets[i].slot] for i in which]
                c.beta = [b for row in self.beta for b in row]
            self._columns_cache = c
        return self._columns_cache

    def _values(self, block: np.ndarray) -> np.ndarray:
        """Every target's per-path value on the fine grid, one column each."""
        out = np.empty((block.shape[0], len(self.targets)))
        return _core.form_features(block, self._target_columns(), 2.0 * self.scene.drift, 0,
                                   out, None, self.threads)

    def _features(self, block: np.ndarray, level: int,
                  controls: Optional[np.ndarray] = None) -> np.ndarray:
        """The feature columns of a batch (formed in the core, into a buffer kept between
        batches): on the base level minus the controls' multiples once their coefficients
        are fitted (mean exactly 0: still unbiased), on a finer level the fine grid's minus
        the coarse grid's."""
        n = block.shape[0]
        if self._feature_buffer is None or self._feature_buffer.shape[0] < n:
            self._feature_buffer = np.empty((max(n, self.batch), len(self.cols)))
        out = self._feature_buffer[:n]
        use = controls if (level == 0 and controls is not None and self.beta is not None) else None
        return _core.form_features(block, self._columns(), 2.0 * self.scene.drift, level, out,
                                   use, self.threads)

    def _fit_controls(self, block: np.ndarray, controls: np.ndarray) -> None:
        """The control coefficients of every feature column: least squares on the pilot paths
        (which the estimates then leave out, so that the coefficients are independent of the
        paths they are applied to)."""
        raw = self._features(block, 0)
        n, k = len(raw), controls.shape[2]
        width = k + 1
        flat_width = width + width * (width + 1) // 2
        # Many columns' [feature, controls of its slot] in one call: each group's sums are
        # accumulated on their own, so they are the bits of a call per column.
        per_call = max(1, FIT_BYTES // (8 * n * width))
        anchor = np.array([self.control_of[self.targets[i].slot] for i, _ in self.cols],
                          dtype=np.intp)
        covs = np.empty((len(self.cols), width, width))
        m = np.empty((n, min(per_call, len(self.cols)), width))
        for start in range(0, len(self.cols), per_call):
            stop = min(start + per_call, len(self.cols))
            g = m[:, :stop - start]
            g[:, :, 0] = raw[:, start:stop]
            g[:, :, 1:] = controls[:, anchor[start:stop], :]
            flat = _core.sum_products(np.ascontiguousarray(g.reshape(n, -1)),
                                      [width] * (stop - start), self.threads)
            # As a level's sums would hold them (0 plus the sums), then their covariances.
            flat = 0.0 + flat.reshape(stop - start, flat_width)
            covs[start:stop] = _moments(flat, n, width)[1]
        # The controls' covariance is the same for every column that uses a slot's sums:
        # one elimination per such slot, every column's right-hand side through it.
        by_slot: Dict[int, List[int]] = {}
        for c, a in enumerate(anchor.tolist()):
            by_slot.setdefault(a, []).append(c)
        beta = [None] * len(self.cols)
        for cs in by_slot.values():
            xs = _solve_many(covs[cs[0]][1:, 1:], covs[cs, 1:, 0])
            for c, x in zip(cs, xs):
                beta[c] = x
        self.beta = beta

    def _batch(self, lev: _Level, first: int, n: int) -> np.ndarray:
        """The flat sums of paths [first, first + n) of a level (centre and coefficients
        known): a pure function of the engine's configuration, run here or on a Dask worker."""
        block, controls = lev.samples(first, n)
        return _core.sum_products(self._features(block, lev.level, controls), self.widths,
                                  self.threads)

    def _add(self, lev: _Level, n: int, flat: np.ndarray) -> None:
        if lev.sums is None:
            lev.sums = _Sums(self.widths)
        lev.sums.add(n, flat)
        self.path_steps += n * lev.cost

    def merge(self, task, output) -> None:
        """A batch's flat sums; or the first batch's samples, which fix the centring constants
        and, on the base level, the control coefficients."""
        level, first, n = task.key
        lev = self.levels[level]
        if first is None:
            self._add(lev, n, np.asarray(output))
            return
        block, controls = output
        if self.centre is None:
            # The first batch of a run fixes the centring constants (its means: they only
            # keep the sums of squares well conditioned, any fixed value gives an unbiased
            # estimate). Every column's sum in one call (each group's sums are those of a call
            # per column, so the bits are too).
            values = self._values(block)
            sums = _core.sum_products(values, [1] * values.shape[1], self.threads)
            self.centre = np.array([float(x) / len(values) for x in sums[0::2]])
        if lev.controls and self.beta is None:
            # On the base level the first batch fits the control coefficients; its paths are
            # then left out of the estimate.
            self._fit_controls(block, controls)
            lev.start = first + n
            self.path_steps += n * lev.cost
        else:
            self._add(lev, n, _core.sum_products(
                self._features(block, lev.level, controls), self.widths, self.threads))

    def _simulate(self, lev: _Level, first: int, count: int):
        """The batches of paths [first, first + count) of a level (a generator of the
        driver's batches)."""
        batches = []
        done = 0
        while done < count:
            n = min(self.batch, count - done)
            batches.append((first + done, n))
            done += n
        if self.centre is None or (lev.controls and self.beta is None):
            # Run here (its samples are used at once, from the level's buffers): the first
            # batch fixes what every later batch's features need.
            start, n = batches.pop(0)
            run = functools.partial(lev.samples, start, n)
            yield [Task(None, (), functools.partial(self._checked, lev, n, run), n,
                        key=(lev.level, start, n))]
        if not batches:
            return
        if self.workers is None:
            yield [Task(None, (), functools.partial(self._checked, lev, n, functools.partial(
                self._batch, lev, start, n)), n, key=(lev.level, None, n))
                for start, n in batches]
            return
        # On a Dask cluster: every batch a task; merged in batch order, so bitwise the local
        # result.
        config = self.config()
        yield [Task(batch_task, (config, lev.level, start, n), None, n,
                    key=(lev.level, None, n)) for start, n in batches]

    def measure(self, lev: _Level) -> Tuple[float, int]:
        """(seconds, paths) of a few paths of a level as its batches run them (with its
        control sums; RATE_STEPS path-steps, at least one path): their values are discarded
        (paths far beyond any the run draws), so the run is unchanged."""
        n = max(1, min(64, RATE_STEPS // lev.cost))
        values = np.empty((n,) + tuple(lev.shape))
        t = time.perf_counter()
        if lev.controls:
            ctl = np.empty((n, len(lev.control_slots), _core.CONTROLS))
            _core.run_samples(lev.plan, 1 << 61, n, self.threads, True, values, ctl,
                              lev.control_slots)
        else:
            _core.run_samples(lev.plan, 1 << 61, n, self.threads, False, values)
        return time.perf_counter() - t, n

    def path_seconds(self, level: int) -> float:
        """A level's seconds per path, as measured in this call (first: measure)."""
        if level not in self.timing:
            self.timing[level] = list(self.measure(self._level(level)))
        seconds, paths = self.timing[level]
        return seconds / paths

    def _checked(self, lev: _Level, n: int, run):
        """run() (a batch of n paths of a level, run here), unless at the level's time per
        path measured in this call it would end past max_seconds: then refused, with what was
        merged kept (the driver's checkpoint)."""
        seconds = n * self.path_seconds(lev.level)
        if time.perf_counter() - self.call[0] + seconds > self.max_seconds:
            raise self._too_long(seconds, n * lev.cost,
                                 f"the next {n} paths of level {lev.level} alone")
        t = time.perf_counter()
        out = run()
        timing = self.timing[lev.level]
        timing[0] += time.perf_counter() - t
        timing[1] += n
        return out

    def _drivers(self, asks: Dict[int, float], shown: int = 3) -> str:
        """The statistics that ask for most of the work left (``asks``: path-steps per
        target), for a refusal: each with its time and the share of the work it asks for, and
        what to ask instead."""
        total = sum(asks.values())
        if not total > 0:
            return ""
        # The few that matter (at least 5 % of the work each).
        order = [i for i in sorted(asks, key=lambda i: -asks[i])[:shown]
                 if asks[i] >= 0.05 * total]
        parts = []
        for i in order:
            t = self.targets[i]
            when = "at the stop" if t.time_index is None else (
                f"at {self.scene.time_name} = {self.scene.times[t.time_index]:g}")
            parts.append(f"the {t.stat} of {t.name} {when} ({100 * asks[i] / total:.0f} % "
                         "of the work)")
        names = list(dict.fromkeys(f"{self.targets[i].name}:{self.targets[i].stat}"
                                   for i in order))
        return (f"; most of it is for {', '.join(parts)}: leave {' and '.join(names)} out of "
                "the statistics the target applies to (statistics=, crandall run "
                "--statistics), or ask "
                + ("an absolute error= for " if self.rel is not None else "a larger error= for ")
                + ("it" if len(names) == 1 else "them") + " in a run of its own")

    def _too_long(self, seconds: float, steps: float, what: str, drivers: str = "") -> ValueError:
        """The refusal of a run that would outlast max_seconds: what it would take and what
        would help (``drivers``: the statistics that ask for most of it, :meth:`_drivers`)."""
        elapsed = time.perf_counter() - self.call[0]
        calm = self._calm_time()
        end = self.scene.t0 if "stop" in self.scene.observe else float(self.scene.times.max())
        pause = (f"; {calm:.3g} s of the {end:.3g} s its paths are stepped through have no "
                 f"noise (h = 0), where nothing random happens but the grid's steps still "
                 f"cost" if calm > 0 else "")
        return ValueError(
            f"max_seconds: reaching {self._target_text()} would take about {seconds:.3g} s "
            f"more ({what}: {steps:.3g} path-steps at the times per path measured, "
            f"{elapsed:.3g} s spent), beyond max_seconds={self.max_seconds:g}{pause}{drivers}; "
            f"raise max_seconds or ask for a larger target"
            + (" (the checkpoint keeps what was done)" if self.checkpoint else ""))

    def _calm_time(self) -> float:
        """The time the paths are stepped through without noise (pieces of h = 0)."""
        end = self.scene.t0 if "stop" in self.scene.observe else float(self.scene.times.max())
        pieces = list(self.scene.pieces) if self.scene.pieces is not None else [(self.scene.t0, self.scene.noise)]
        calm, start = 0.0, 0.0
        for stop, noise in pieces:
            if noise == 0:
                calm += max(min(stop, end) - start, 0.0)
            start = stop
        return calm

    def config(self) -> Dict:
        """What a Dask worker needs to rebuild this engine (plain data)."""
        return {"scene": self.scene.to_dict(), "eps": self.eps, "rel": self.rel,
                "seed": self.seed, "threads": self.task_threads,
                "statistics": [f"{t.name}:{t.stat}" for t in self.targets],
                "centre": [float(c) for c in self.centre], "beta": self.beta,
                "use_controls": self.use_controls, "random_stream": RANDOM_STREAM}

    def _level(self, level: int) -> _Level:
        while len(self.levels) <= level:
            self.levels.append(_Level(self.scene, len(self.levels), self.seed, self.base_dt,
                                      self.threads, self.integrals, self.quadratic))
            self.levels[-1].siblings = self.levels
            self.levels[-1].batch = self.batch
            if len(self.levels) == 1 and self.use_controls:
                self.levels[0].controls = True
                self.levels[0].control_slots = self.control_slots
        return self.levels[level]

    def _grow(self, level: int, target: int):
        lev = self._level(level)
        have = lev.sums.n if lev.sums is not None else 0
        if lev.controls and self.beta is None:
            yield from self._simulate(lev, 0, PILOT_PATHS)  # the pilot: coefficients only
        if target > have:
            yield from self._simulate(lev, lev.start + have, target - have)

    # -- estimates ------------------------------------------------------------------------

    def estimates(self):
        """Per target: (value, standard error, bias, level variances V_l)."""
        out = []
        for i, t in enumerate(self.targets):
            used = [lev for lev in self.levels if lev.sums is not None and lev.sums.n > 0]
            if t.exact:
                used = used[:1]
            groups = [lev.sums.group(i) for lev in used]
            d = sum(m[0] for m, _ in groups)
            var_d = sum(c[0, 0] / lev.sums.n for (_, c), lev in zip(groups, used))
            if t.stat == "mean" or t.isometry:
                value = self.centre[i] + d
                # A column constant on every path (a quantity identically 0 on a level, an
                # identity's constant) can leave its sum of squares a rounding below 0.
                level_var = [max(c[0, 0], 0.0) for _, c in groups]
                level_mean = [m[0] for m, _ in groups]
            else:
                m2 = sum(m[1] for m, _ in groups)
                # E[d^2] = (E d)^2 + Var d: add Var d back so that the variance is unbiased.
                value = m2 - d * d + var_d
                # The delta method: the estimate moves like the level means of
                # (P - c)^2 - 2 d (P - c).
                level_var = [max(c[1, 1] - 4 * d * c[0, 1] + 4 * d * d * c[0, 0], 0.0)
                             for _, c in groups]
                level_mean = [m[1] - 2 * d * m[0] for m, _ in groups]
            level_se = [math.sqrt(v / lev.sums.n) for v, lev in zip(level_var, used)]
            se = math.sqrt(sum(x * x for x in level_se))
            bias = 0.0 if t.exact else self._bias(level_mean, level_se)
            out.append((value, se, bias, level_var))
        return out

    @staticmethod
    def _bias(level_mean: Sequence[float], level_se: Sequence[float]) -> float:
        """Giles' estimate of the levels left out: the level means fall like 2^(-alpha l), so
        the bias of stopping at level L is about |Y_L| / (2^alpha - 1). alpha is measured from
        the two finest levels when both means are resolved (beyond 2 standard errors), within
        [ALPHA_MIN, ALPHA_MAX]; else ALPHA, the trapezoid rule's leading exponent on this
        skeleton (docs/integrals.md). Then also at least |Y_(L-1)| 2^-alpha / (2^alpha - 1),
        so that a finest mean that is small by chance does not hide the bias."""
        if len(level_mean) < 3:
            return math.inf
        last, prev = abs(level_mean[-1]), abs(level_mean[-2])
        alpha = ALPHA
        if last > 2 * level_se[-1] and prev > 2 * level_se[-2]:
            alpha = min(max(math.log2(prev / last), ALPHA_MIN), ALPHA_MAX)
        return max(last, prev * 2.0 ** -alpha) / (2.0 ** alpha - 1.0)

    def tolerance(self, i: int, value: float, level_var) -> float:
        """The target of statistic i in the core's variable (the scene asks in the
        quantity's own units: an energy is a factor times its variable)."""
        t = self.targets[i]
        if self.eps is not None:
            f = abs(quantity(t.name).factor(self.scene))
            if f == 0.0:
                return math.inf  # 0 on every path: any target is met
            return self.eps / (f if t.stat == "mean" else f * f)
        scale = abs(value)
        if t.stat == "mean" and level_var:
            # A mean that is 0 by symmetry (velocity, displacement) is measured against the
            # quantity's spread instead.
            scale = max(scale, math.sqrt(max(level_var[0], 0.0)))
        # Never tighter than relative to REL_FLOOR of the statistic's largest value over the
        # output times: a variance when almost every path is at rest is tiny, and its
        # relative error would cost without bound (the crate's velocity variance at 2.75 s
        # asked for 94 % of a run refused as 4.86e4 s).
        return self.rel * max(scale, REL_FLOOR * self.sizes.get((t.name, t.stat), 0.0))

    def _measure_sizes(self, est) -> None:
        """Per (name, stat), the largest scale over the output times (:meth:`tolerance`)."""
        sizes: Dict[Tuple[str, str], float] = {}
        for t, (value, _, _, level_var) in zip(self.targets, est):
            scale = abs(value)
            if t.stat == "mean" and level_var:
                scale = max(scale, math.sqrt(max(level_var[0], 0.0)))
            if math.isfinite(scale):
                key = (t.name, t.stat)
                sizes[key] = max(sizes.get(key, 0.0), scale)
        self.sizes = sizes

    # -- the schedule ---------------------------------------------------------------------

    def _target_text(self) -> str:
        return (f"error={self.eps!r}" if self.eps is not None
                else f"rel_error={self.rel!r}")

    def _unreachable(self, i: int, why: str) -> ValueError:
        t = self.targets[i]
        return ValueError(
            f"{'error' if self.eps is not None else 'rel_error'}: {self._target_text()} "
            f"cannot be reached for the {t.stat} of {t.name}: {why}; ask for a larger one")

    def rounds(self):
        """The schedule to its end (or on from a checkpoint's state), as the driver's
        batches."""
        if self.pending is None:
            deepest = 2 if self.level_targets and self.integrals else 0
            self.pending = [[level, PILOT_PATHS] for level in range(deepest + 1)]
            # The first estimate comes after the pilot: a scene whose pilot alone would
            # outlast max_seconds at a rate no machine reaches is refused before it starts.
            pilot = sum(PILOT_PATHS * self._level(level).cost for level, _ in self.pending)
            if pilot / FASTEST_RATE > self.max_seconds:
                raise ValueError(
                    f"max_seconds: the pilot alone ({PILOT_PATHS} paths per level, "
                    f"{pilot:.3g} path-steps) would take at least {pilot / FASTEST_RATE:.3g} s "
                    f"even at {FASTEST_RATE:.0e} path-steps per second, beyond max_seconds="
                    f"{self.max_seconds:g}; give shorter times or t0, or observe only velocity, "
                    "kinetic_energy and stop (no internal steps)")
        started, steps_before = time.perf_counter(), self.path_steps
        self.call = (started, steps_before)
        self.timing = {}
        if self.workers is None:
            # The round in progress (the pilot: many batches on a long grid) as a whole, at
            # its levels' measured times per path; each batch again before it starts.
            seconds = steps = 0.0
            for level, n in self.pending:
                lev = self._level(level)
                have = lev.sums.n if lev.sums is not None else 0
                # A level with control variates fits their coefficients on paths of its own.
                paths = max(n - have, 0) + (PILOT_PATHS if lev.controls and self.beta is None
                                            else 0)
                if not paths:
                    continue
                seconds += paths * self.path_seconds(level)
                steps += paths * lev.cost
                # Judged after each level's measurement: a finer level's path costs more.
                if time.perf_counter() - started + seconds > self.max_seconds:
                    raise self._too_long(seconds, steps,
                                         "the round in progress alone" if self.round_count
                                         else f"the pilot alone, {PILOT_PATHS} paths per level")
        while True:
            while self.pending:
                level, target = self.pending[0]
                yield from self._grow(level, target)
                self.pending.pop(0)
            yield []  # the round's end: a checkpoint
            self.round_count += 1
            est = self.estimates()
            self._measure_sizes(est)
            want = [lev.sums.n for lev in self.levels]
            # Per statistic: the path-steps it alone would still ask for (what a refusal
            # names as driving the cost).
            asks: Dict[int, float] = {}
            done = True
            deeper = False
            worst = 0.0  # the largest error / target, for the progress bar
            for i, (value, se, grid_bias, level_var) in enumerate(est):
                tol = self.tolerance(i, value, level_var)
                if tol == math.inf:
                    continue  # 0 on every path (its factor is 0)
                if not (tol > 0):
                    if value == 0.0 and all(v == 0.0 for v in level_var):
                        continue  # a statistic that is exactly 0 (e.g. at time 0)
                    raise self._unreachable(i, "the target is 0 in doubles")
                # The envelope's pieces' error (crandall.pieces), where the levels can still
                # meet the target beside it (the result reports a target it makes missed).
                piece = self.piece_bias[i] if self.piece_bias is not None else 0.0
                if not piece < tol / 2.0:
                    piece = 0.0
                err2 = se * se + (grid_bias + piece) ** 2
                worst = max(worst, math.sqrt(err2) / tol)
                if err2 > tol * tol:
                    done = False
                if grid_bias + piece > tol / math.sqrt(2.0):
                    deeper = True
                grid_bias += piece
                # Giles' allocation with the variance budget left by the bias (at least half).
                budget = (max(tol * tol - grid_bias * grid_bias, 0.5 * tol * tol)
                          if math.isfinite(grid_bias) else 0.5 * tol * tol)
                costs = [lev.cost for lev in self.levels[:len(level_var)]]
                total = sum(math.sqrt(v * c) for v, c in zip(level_var, costs))
                for level, (v, c) in enumerate(zip(level_var, costs)):
                    if v <= 0:
                        continue
                    x = math.sqrt(v / c) * total / budget if budget > 0 else math.inf
                    if not x < MAX_LEVEL_PATHS:
                        raise self._unreachable(
                            i, f"level {level} would need {x:.3g} paths, beyond the "
                            f"{MAX_LEVEL_PATHS:.3g} a level can draw")
                    want[level] = max(want[level], math.ceil(x))
                    asks[i] = asks.get(i, 0.0) + max(x - self.levels[level].sums.n, 0.0) * c
            if done:
                self._show(worst, 0.0)
                return
            # What the rest is estimated to cost, at the rate measured in this call.
            left = sum(max(n - lev.sums.n, 0) * lev.cost for n, lev in zip(want, self.levels))
            elapsed = time.perf_counter() - started
            ran = self.path_steps - steps_before
            # No rate yet when a resumed run starts at a round's end: judged next round.
            seconds = left * elapsed / ran if ran > 0 else math.nan
            if self.workers is None and ran > 0:
                # Here: at each level's own time per path (a path's cost is not its steps
                # alone: see timing).
                seconds = sum(max(n - lev.sums.n, 0) * self.path_seconds(lev.level)
                              for n, lev in zip(want, self.levels))
            self._show(worst, seconds)
            if self.pilot_seconds + elapsed + seconds > self.max_seconds:
                raise self._too_long(seconds, left, f"after {self.round_count} rounds",
                                     self._drivers(asks))
            if deeper and len(self.levels) <= MAX_LEVELS:
                self.pending = [[len(self.levels), PILOT_PATHS]]
                continue
            if deeper:
                raise ValueError(
                    f"error: the discretisation bias is still above the target on a grid "
                    f"2^{MAX_LEVELS} times finer than the base; ask for a larger error")
            self.pending = []
            for level, n in enumerate(want):
                have = self.levels[level].sums.n
                n = min(n, have * MAX_GROWTH)
                # Whole batches beyond the pilot, so that small increments do not cost a call.
                n = -(-n // PILOT_PATHS) * PILOT_PATHS
                if n > have:
                    self.pending.append([level, n])

    def _show(self, worst: float, seconds: float) -> None:
        left = ("done" if seconds == 0 else "estimating" if math.isnan(seconds)
                else f"about {seconds:.3g} s left")
        self.text = f"round {self.round_count}, error/target {worst:.3g}, {left}"

    def progress(self) -> Progress:
        return Progress(text=self.text)

    def result(self) -> AccuracyResult:
        return _result(self, self.wall_before + time.perf_counter() - self.started)

    # -- checkpoints ----------------------------------------------------------------------

    def identity(self) -> Dict:
        """The run's spec: what makes two runs the same run (in a checkpoint's identity)."""
        spec = {"scene": self.scene.to_dict(), "error": self.eps, "rel_error": self.rel,
                "seed": self.seed,
                "statistics": [f"{t.name}:{t.stat}" for t in self.targets]}
        # The statistics estimated through Ito's isometry (a checkpoint of a run that summed
        # them otherwise is another run: refused naming this field).
        isometry = [f"{t.name}:{t.stat}" for t in self.targets if t.isometry]
        if isometry:
            spec["isometry"] = isometry
        return spec

    def _state(self) -> Dict:
        return {"centre": None if self.centre is None else [float(c) for c in self.centre],
                "beta": self.beta, "path_steps": self.path_steps, "rounds": self.round_count,
                "wall_time": self.wall_before + (time.perf_counter() - self.started),
                "pending": self.pending,
                "levels": [{"start": lev.start, "n": 0 if lev.sums is None else lev.sums.n,
                            "flat": None if lev.sums is None else [float(v) for v in lev.sums.flat]}
                           for lev in self.levels]}

    def state(self) -> Dict[str, np.ndarray]:
        """The state as one JSON text (floats written exactly, as Python's repr round-trips
        them) with its checksum."""
        st = self._state()
        st["checksum"] = _checksum(st)
        return json_state(st)

    def restore(self, arrays: Dict[str, np.ndarray], path) -> None:
        """Carry on from a checkpoint's state (its identity already matched this run's)."""
        where = f"checkpoint: {os.fspath(path)}"
        st = read_json_state(path, arrays, "a run to an accuracy")
        # Every edit is refused, even one that keeps the fields consistent with each other (a
        # level's path count and its sums changed together): the file is the run's own only
        # if its checksum matches.
        if st.get("checksum") != _checksum({k: v for k, v in st.items() if k != "checksum"}):
            raise ValueError(f"{where} is damaged (field checksum: it does not match the "
                             "contents, which were edited or damaged); remove it to start again")
        try:
            self._restore_fields(st)
        except (KeyError, TypeError, ValueError, OverflowError) as exc:
            field = exc.args[0] if isinstance(exc, (KeyError, ValueError)) and exc.args else exc
            raise ValueError(f"{where} is damaged (field {field})") from None

    def _restore_fields(self, st: Dict) -> None:
        """The state's fields, each checked against what a run can have written (a
        ValueError whose argument names the field)."""
        levels = st["levels"]
        if not isinstance(levels, list) or len(levels) > MAX_LEVELS + 1:
            raise ValueError(f"levels: {MAX_LEVELS + 1} at most")
        steps = 0
        for k, lv in enumerate(levels):
            lev = self._level(k)
            start = _nonneg_int(lv["start"], f"levels[{k}].start")
            # Only the base level leaves paths out: the first batch of its pilot.
            if start not in ((0, min(self.batch, PILOT_PATHS)) if k == 0 else (0,)):
                raise ValueError(f"levels[{k}].start")
            n = _nonneg_int(lv["n"], f"levels[{k}].n")
            if n > MAX_LEVEL_PATHS:
                raise ValueError(f"levels[{k}].n")
            lev.start = start
            if lv["flat"] is not None:
                flat = np.array(lv["flat"], dtype=float)
                if flat.shape != (self.sums_width,) or not np.all(np.isfinite(flat)) or n < 1:
                    raise ValueError(f"levels[{k}].flat")
                lev.sums = _Sums(self.widths)
                lev.sums.add(n, flat)
            elif n != 0:
                raise ValueError(f"levels[{k}].n")
            steps += (start + n) * lev.cost
        if st["centre"] is not None:
            centre = np.array(st["centre"], dtype=float)
            if centre.shape != (len(self.targets),) or not np.all(np.isfinite(centre)):
                raise ValueError("centre")
            self.centre = centre
        if st["beta"] is not None:
            beta = [[float(v) for v in row] for row in st["beta"]]
            if len(beta) != len(self.cols) or any(len(r) != _core.CONTROLS for r in beta) \
                    or not all(math.isfinite(v) for r in beta for v in r):
                raise ValueError("beta")
            self.beta = beta
        # Every path a level drew, pilot included, was counted at that level's steps.
        self.path_steps = _nonneg_int(st["path_steps"], "path_steps")
        if self.path_steps != steps:
            raise ValueError("path_steps")
        self.round_count = _nonneg_int(st["rounds"], "rounds")
        wall = st["wall_time"]
        if isinstance(wall, bool) or not isinstance(wall, (int, float)) \
                or not (math.isfinite(wall) and wall >= 0):
            raise ValueError("wall_time")
        self.wall_before = float(wall)
        pending = st["pending"]
        if pending is not None:
            pending = [[_nonneg_int(a, "pending"), _nonneg_int(b, "pending")]
                       for a, b in pending]
            if any(a > MAX_LEVELS or b > MAX_LEVEL_PATHS for a, b in pending):
                raise ValueError("pending")
        self.pending = pending


def _checksum(state: Dict) -> str:
    """SHA-256 of the state as canonical JSON (keys sorted; floats as Python writes them,
    which round-trip exactly)."""
    text = json.dumps(state, sort_keys=True, separators=(",", ":"))
    return hashlib.sha256(text.encode("utf-8")).hexdigest()


def _nonneg_int(value, field: str) -> int:
    if isinstance(value, bool) or not isinstance(value, int) or value < 0:
        raise ValueError(field)
    return value


#: Checkpoints of runs to an accuracy (crandall.checkpoint's format, the state a JSON text
#: with a checksum) are replaced atomically at most every CHECKPOINT_SECONDS and at every
#: round's end.
CHECKPOINT_SECONDS = 1.0


#: rel_error is relative to a statistic's value, or to this fraction of its largest value
#: over the output times where that is larger (docs/methods/adaptive.md).
REL_FLOOR = 0.01


#: The exponent of the level means' decay assumed by the bias estimate where it is not
#: resolved, and the range a measured one is kept in (docs/methods/adaptive.md).
ALPHA = 1.5
ALPHA_MIN, ALPHA_MAX = 1.0, 3.0


def batch_task(config: Dict, level: int, first: int, count: int) -> np.ndarray:
    """A Dask worker's task: the flat sums of one batch of a run to an accuracy."""
    check_random_stream(config["random_stream"])
    scene = Scene.from_dict(config["scene"])
    engine = _Engine(scene, eps=config["eps"], rel=config["rel"], seed=config["seed"],
                     threads=config["threads"],
                     statistics=_check_statistics(scene, config["statistics"]))
    engine.use_controls = config["use_controls"]
    engine.centre = np.array(config["centre"], dtype=float)
    engine.beta = config["beta"]
    return engine._batch(engine._level(level), first, count)


def _result(engine: _Engine, wall: float) -> AccuracyResult:
    """The run's statistics as a :class:`crandall.results.AccuracyResult` (plain data)."""
    # An envelope's pieces: the levels estimate the pieces' statistics; the error of the
    # pieces against the envelope is added to every bias (crandall.bias), and nothing is
    # exact. More paths or levels cannot reduce it: a target it exceeds is reported missed.
    # As many paths as the run (at most bias.BIAS_PATHS): never more than the run's cost.
    run_paths = sum(lev.sums.n for lev in engine.levels if lev.sums is not None)
    pieces = bias.piece_errors(engine.scene, sorted({t.name for t in engine.targets}),
                               seed=engine.seed, paths=max(run_paths, 2),
                               threads=engine.threads)
    estimates: Dict[Tuple[str, str], list] = {}
    exact = {(t.name, t.stat): t.exact for t in engine.targets}
    missed = []
    est = engine.estimates()
    engine._measure_sizes(est)
    for i, (t, e) in enumerate(zip(engine.targets, est)):
        row = [float(x) for x in e[:3]]
        key = (t.name, t.stat)
        if key in pieces:
            values = pieces[key][0]
            row[2] += float(values[t.time_index if t.time_index is not None else 0])
            exact[key] = False
            if math.hypot(row[1], row[2]) > engine.tolerance(i, row[0], e[3]):
                missed.append(f"{t.stat} of {t.name}")
        estimates.setdefault(key, []).append(row)
    if missed:
        warnings.warn(f"error: the target is missed for the {', '.join(sorted(set(missed)))}: "
                      "the error of the envelope's pieces (in Result.bias; estimated by "
                      "halving them) exceeds it, and more paths cannot reduce it; give the "
                      "envelope more pieces", StatisticsWarning, stacklevel=4)
    arrays = {k: np.array(v, dtype=float) for k, v in estimates.items()}
    return AccuracyResult(
        scene=engine.scene, seed=engine.seed, error_target=engine.eps,
        rel_error_target=engine.rel,
        estimates=arrays,
        exact=exact,
        levels=[{"level": lev.level, "paths": lev.sums.n, "steps_per_path": lev.cost,
                 "dt": lev.plan.options.dt / 2 ** lev.level}
                for lev in engine.levels if lev.sums is not None],
        path_steps=engine.path_steps, rounds=engine.round_count, wall_time=wall)


def simulate_to_error(scene: Scene, *, error: Optional[float] = None,
                      rel_error: Optional[float] = None, seed: int, threads: int,
                      statistics=None, checkpoint=None, client=None,
                      task_threads: int = 1, progress=None,
                      max_seconds: float = MAX_SECONDS) -> AccuracyResult:
    """Run ``scene`` until every statistic's estimated total error is within the target
    (see :func:`crandall.simulate`)."""
    check_scene(scene, LEVELS, "a run to an accuracy (error=, rel_error=)")
    if progress is not None and not isinstance(progress, bool):
        raise ValueError(f"progress must be True, False or None, got {progress!r}")
    max_seconds = check_positive("max_seconds", max_seconds)
    if (error is None) == (rel_error is None):
        raise ValueError("error: give exactly one of error= and rel_error=")
    eps = check_positive("error", error) if error is not None else None
    rel = check_positive("rel_error", rel_error) if rel_error is not None else None
    seed = check_int("seed", seed, 0, MAX_SEED)
    if "peaks" in scene.observe:
        raise ValueError("observe: 'peaks' is not available with error= or rel_error= (the "
                         "peaks are maxima over the grid, whose shortfall the levels do not "
                         "estimate); run the peaks with paths=")
    if scene.distributions:
        raise ValueError("distributions: a run to an accuracy estimates means and variances "
                         "and keeps no histograms; leave distributions out of the scene, or "
                         "run them with paths=")
    if scene.envelope is not None and scene.envelope.function is None:
        # Its piece error, part of every statistic's total error, cannot be estimated: a
        # target could only be claimed met without it.
        raise ParameterError("scene", "scene: its function envelope came back from plain data "
                             "(a saved result, a checkpoint), which keep the pieces, not the "
                             "function, so the piece error a target must include is unknown; "
                             "give envelopes.from_function(...) again")
    chosen = _check_statistics(scene, statistics)
    piece_bias = None
    began = time.perf_counter()
    if scene.envelope is not None:
        # An envelope's pieces, refined until their error (as estimated) is at most half of
        # every target (crandall.pieces); the levels then meet the rest, with the pieces'
        # error counted in each statistic's bias.
        targets = _targets(scene, chosen)
        scene, info = pieces.choose(scene, sorted({t.name for t in targets}),
                                    paths=pieces.PILOT_PATHS, seed=seed, threads=threads,
                                    target=pieces.accuracy_target(scene, eps, rel, REL_FLOOR),
                                    step_length=default_dt(scene),
                                    stats={(t.name, t.stat) for t in targets},
                                    max_seconds=max_seconds)
        if info is not None:
            piece_bias = info["table"]
    engine = _Engine(scene, eps=eps, rel=rel, seed=seed, threads=threads, statistics=chosen)
    if piece_bias is not None:
        engine.piece_bias = [
            float(piece_bias[(t.name, t.stat)][0][t.time_index if t.time_index is not None
                                                  else 0])
            for t in engine.targets]
    engine.max_seconds = max_seconds
    # The pieces' pilot counts against the run's bound.
    engine.pilot_seconds = time.perf_counter() - began if piece_bias is not None else 0.0
    engine.checkpoint = checkpoint
    engine.task_threads = task_threads
    engine.checkpoint_seconds = CHECKPOINT_SECONDS
    return drive(engine, checkpoints=checkpoint, client=client, progress=progress)[0]
