"""A run to an accuracy as the driver's estimator (``_Engine``): its levels' batches run here or
as Dask tasks (``batch_task``), merged in order, measured and checked for memory, and its
estimates returned as an ``AccuracyResult`` (``_result``)."""

from __future__ import annotations

import functools
import math
import time
import warnings
from typing import Dict, List, Optional, Tuple

import numpy as np

from .. import _core, bias, pieces
from .._resources import available_memory
from ..driver import Estimator, Task
from ..errors import ParameterError
from ..quantities import core_flags
from ..model import FILTERED_EXCITATION
from ..results import AccuracyResult, StatisticsWarning
from ..scene import Scene
from ..streams import RANDOM_STREAM, check_random_stream
from ..spec import check_scene, default_dt
from .features import _control_slots, _Features
from .levels import (_check_statistics, _Level, _peaks_recorded, _sample_slots, _Sums, _targets,
                     BASE_DT_FACTOR, BATCH_PATHS, FILTER_BASE_DT_FACTOR, FILTER_MAX_PATHS,
                     MAX_SECONDS, levels_model)
from . import levels as _levels
from .schedule import MAX_LEVEL_PATHS, _Schedule
BATCH_BYTES = 64 << 20
#: Path-steps of the measurement of a level's time per path before its first batch
#: (_Engine.measure): a few paths, discarded (at most one path, however long).
RATE_STEPS = 1 << 20
#: Control variates on the base level (switch off to measure what they bring).
USE_CONTROLS = True


class _Engine(_Features, _Schedule, Estimator):
    """A run to an accuracy as the driver's estimator (:mod:`crandall.driver`): rounds of
    batches per level, each round's allocation decided from the merged sums."""

    name = "accuracy"
    checkpoint_seconds = 1.0  # CHECKPOINT_SECONDS, read when the module is loaded

    def __init__(self, scene: Scene, *, eps: Optional[float], rel: Optional[float], seed: int,
                 threads: int, statistics: Optional[set] = None) -> None:
        # here too: the Dask task builds its own engine
        self.scene = check_scene(scene, levels_model(scene),
                                 "a run to an accuracy (error=, rel_error=)")
        #: A filtered excitation (model.FILTERED_LEVELS): its own base grid and bias
        #: estimate, no control variates.
        self.filtered = FILTERED_EXCITATION in scene.effects
        #: The paths a level may be given (the filtered core's plans draw fewer; the last
        #: few are measure()'s).
        self.max_level_paths = (float(FILTER_MAX_PATHS - 64) if self.filtered
                                else MAX_LEVEL_PATHS)
        self.eps, self.rel = eps, rel
        self.seed = seed
        self.threads = threads
        self.targets = _targets(scene, statistics)
        #: Whether a target takes the isometry's integral (the samples' extra slot).
        self.quadratic = any(t.isometry for t in self.targets)
        flags = core_flags(scene.observe)
        self.integrals = flags["displacement"] or flags["distance"]
        self.base_dt = ((FILTER_BASE_DT_FACTOR if self.filtered else BASE_DT_FACTOR)
                        * default_dt(scene))
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
        if _peaks_recorded(scene):
            # A filtered run's peaks per output time and at the stop (the slots after the
            # stop's) use their output's controls: the ground features up to the same time.
            self.control_of.extend(self.control_of[:outputs])
        per_path = 8 * (slots * 2 * 3 + len(self.control_slots) * _core.CONTROLS
                        + 2 * len(self.widths))
        self.batch = int(min(BATCH_PATHS, max(256, BATCH_BYTES // per_path // 256 * 256)))
        #: Control variates on the base level (docs/methods/adaptive.md): with an observed
        #: integral (the controls need the grid's steps).
        #: Not without friction: the weights k = min(|X| / c, r) degenerate at c = 0, and on a
        #: frictionless scene (mu = 0, h = 1, t = 0.5) the mean distance with the controls came
        #: out 0.66 reported errors low on average over 20 seeds (without them: 0.14 +- 0.18),
        #: a shift not understood yet (docs/methods/adaptive.md, "Limits").
        #: A filtered excitation has its own: features of the ground motion alone (its
        #: intensity, velocity and displacement up to each slot's time) minus their exact
        #: means (docs/filtered.md, "Control variates"), with or without friction.
        self.use_controls = USE_CONTROLS and (
            self.filtered or (self.integrals and scene.drift > 0))
        self.beta = None
        #: After a refit of the base level's control coefficients (levels.REFIT_PILOT): the
        #: estimation paths it set aside; None before.
        self.refit: Optional[int] = None
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
            raise ParameterError(
                "times", f"times: a run to an accuracy of {len(self.scene.times)} output times "
                f"({self.threads} threads) needs about {need / 2**20:.0f} MiB for its batches "
                f"and threads, more than the {have / 2**20:.0f} MiB this process may still "
                "allocate (free memory, rlimits, cgroup); give fewer times, statistics or "
                "threads")

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
        first = FILTER_MAX_PATHS - n if self.filtered else 1 << 61
        values = np.empty((n,) + tuple(lev.shape))
        t = time.perf_counter()
        if lev.controls:
            ctl = np.empty((n, len(lev.control_slots), _core.CONTROLS))
            _core.run_samples(lev.plan, first, n, self.threads, True, values, ctl,
                              lev.control_slots)
        else:
            _core.run_samples(lev.plan, first, n, self.threads, False, values)
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

    def config(self) -> Dict:
        """What a Dask worker needs to rebuild this engine (plain data)."""
        return {"scene": self.scene.to_dict(), "eps": self.eps, "rel": self.rel,
                "seed": self.seed, "threads": self.task_threads,
                "statistics": [f"{t.name}:{t.stat}" for t in self.targets],
                "centre": [float(c) for c in self.centre], "beta": self.beta,
                "use_controls": self.use_controls, "random_stream": RANDOM_STREAM}

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
        if self.filtered:
            # The levels' event depth and the controls (a checkpoint of a run whose paths
            # searched deeper, or whose coefficients fitted other controls, is another run).
            spec["event_depth"] = _levels.FILTER_EVENT_DEPTH
            spec["controls"] = _core.CONTROLS
            # When and on how many paths the base level refits them (a checkpoint written
            # with another rule would carry on as neither run).
            spec["refit"] = [_levels.REFIT_PILOT, _levels.REFIT_RATIO]
        return spec


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
