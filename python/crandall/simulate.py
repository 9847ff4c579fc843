"""Running scenes: the public entry points and the fixed-step estimator.

:func:`simulate` and :func:`simulate_many` check their arguments into a
:class:`~crandall.spec.RunSpec` and hand a :class:`FixedStep` per scene to the driver
(:mod:`crandall.driver`), which runs its chunks here or as Dask tasks
(:func:`crandall.engine.run_chunks`), merges them in chunk order, keeps the checkpoint and shows
the progress bar. The chunks themselves come from :mod:`crandall.engine`.
"""

from __future__ import annotations

import math
import os
import time
import warnings
from typing import Any, List, Optional, Sequence, Union

import numpy as np

from . import _dataset
from . import checkpoint as _ckpt
from . import engine, pieces
from ._resources import available_memory
from .driver import Estimator, Progress, Task, Tasks, check_client, drive
from .driver import threads as resolve_threads
from .adaptive import MAX_SECONDS, simulate_to_error
from .bins import Histograms, axes as _histogram_axes
from .methods import DEFAULT_METHOD, GRIDS, METHODS
from .quantities import names_for, quantity, simulated_variables
from .results import MONOMIALS, Result, StatisticsWarning
from .scene import Scene
from .spec import MAX_PATHS, RunSpec, as_seed, default_dt, draw_seed
from .errors import ParameterError, UnresolvableGrid
from .model import EXACT_STEP, holds

__all__ = ["simulate", "simulate_many", "default_dt", "METHODS", "MAX_PATHS"]

def _memory_need(scene: Scene, threads: int, method: str) -> int:
    # Per output time, 39 doubles: a Moments (count, 3 means, 35 central sums) or a block's
    # sums (3 centres, 35 raw sums, count). Per grid (3 for richardson, 2 for richardson2):
    # each thread's block sums, up to one finished block per thread waiting for its turn, and
    # the chunk's sums; then the combined chunk, the total, and raw moments and copies in
    # Python. Nothing grows with the number of paths. Each OpenMP thread also maps a stack.
    per_slot = 39 * 8
    grids = GRIDS[method]
    slots = scene.times.size
    if "peaks" in scene.observe:
        per_slot *= 2  # the peaks' moments, laid out as the others
    if "kinetic_energy" in scene.observe:
        per_slot += 39 * 8  # the moments of V^2
    need = slots * per_slot * (grids * (2 * threads + 1) + 5) + threads * (16 << 20)
    if scene.distributions:
        # Histograms (the fine grid only): each thread's, the chunk's, the total and copies
        # in Python; counts of 8 bytes, about (bins + 3) per axis. Fixed, not per path.
        cells = sum(_axis_cells(a) for a in _histogram_axes(scene))
        need += cells * 8 * (2 * threads + 6)
    return need


def _axis_cells(axis) -> int:
    if axis.edges is not None:
        return len(axis.edges) + 2
    # Log-linear: m bins per octave from 0 to the first power of two >= REACH scales, one
    # octave below the scale for [0, b): at most m (log2(REACH) + 3) per side.
    return axis.per_octave * (math.ceil(math.log2(engine.REACH)) + 3) * (
        2 if axis.symmetric else 1) + 3


def _check_memory(scene: Scene, threads: int, method: str = DEFAULT_METHOD) -> None:
    need = _memory_need(scene, threads, method)
    have = available_memory()
    if need > have:
        raise ParameterError(
            "times", f"times: {scene.times.size} output times ({len(scene.observe)} observables, "
            f"{threads} threads) need about {need / 2**20:.0f} MiB of accumulators, more than "
            f"the {have / 2**20:.0f} MiB this process may still allocate (free memory, "
            "rlimits, cgroup); give fewer times or threads"
        )


def run_spec(scene, *, paths, seed, dt, method, threads, event_depth=None):
    """simulate's arguments checked: the run's spec, and the thread count (not part of it:
    results do not depend on it; the driver checks it against the memory the accumulators
    need, :meth:`FixedStep.check_memory`)."""
    spec = RunSpec.create(scene, paths=paths, seed=seed, dt=dt, method=method,
                          event_depth=event_depth)
    cores = resolve_threads(threads)[0]
    if spec.scene.envelope is not None:
        engine.make_plan(spec)  # the run's own grid first (UnresolvableGrid: simulate's)
        # An envelope's pieces, refined until their error (as estimated) is within the run's
        # standard errors (crandall.pieces): the same choice for the same spec, so resumed
        # runs and Dask tasks find the same pieces.
        chosen, _ = pieces.choose(spec.scene, names_for(spec.scene.observe), paths=spec.paths,
                                  seed=spec.seed, threads=cores,
                                  target=pieces.stderr_target(spec.paths),
                                  step_length=spec.dt, dt=dt, method=spec.method,
                                  event_depth=spec.event_depth)
        if chosen is not spec.scene:
            spec = RunSpec.create(chosen, paths=spec.paths, seed=spec.seed, dt=dt,
                                  method=spec.method, event_depth=spec.event_depth)
    return spec, cores


class FixedStep(Estimator):
    """A fixed-step run as the driver's estimator (:mod:`crandall.driver`): one batch, its
    chunks (one task each here; on a cluster about four contiguous ranges per worker thread),
    merged in chunk order; its checkpoint holds the merge of the finished chunks."""

    name = _ckpt.PATHS

    def __init__(self, spec: RunSpec, *, threads: int, task_threads: int = 1):
        self.started = time.perf_counter()
        self.spec = spec
        self.scene = spec.scene
        self.paths = spec.paths
        self.threads = threads
        self.task_threads = task_threads
        self.axes = engine.histogram_axes(spec)
        self.plan = engine.make_plan(spec, self.axes)
        self.indices = tuple(a.index for a in self.axes)
        self.edges = tuple(engine.axis_edges(self.axes))
        self.peaks = "peaks" in self.scene.observe
        self.done, self.acc = 0, None

    # -- the driver's interface ----------------------------------------------------------

    def identity(self):
        return self.spec.to_dict()

    def state(self):
        return _ckpt.state(self.done, self.acc, histograms=(self.indices, self.edges))

    def restore(self, arrays, path):
        self.done, self.acc = _ckpt.restore(path, _ckpt.identity(self.spec), arrays,
                                            self.plan.chunks,
                                            histograms=(self.indices, self.edges))

    def check_memory(self):
        _check_memory(self.scene, self.threads, self.spec.method)

    def rounds(self):
        if self.done >= self.plan.chunks:
            return
        if self.workers is None:
            first = self.done
            yield Tasks(self.plan.chunks - first,
                        lambda i: Task(None, (), self._local(first + i, first + i + 1),
                                       self.plan.chunk_paths(first + i)))
            return
        # The run's own axes go with every task: every worker bins on the client's edges.
        axes = engine.plain_axes(self.axes)
        yield [Task(engine.run_chunks, (self.spec.to_dict(), first, last, self.task_threads,
                                        engine.RANDOM_STREAM, axes),
                    size=self.paths_in(first, last))
               for first, last in self.ranges(4 * self.workers)]

    def _local(self, first, last):
        return lambda: [engine.run_chunk(self.plan, c, self.threads, self.indices)
                        for c in range(first, last)]

    def merge(self, task, output):
        for chunk in output:
            self.add(chunk)

    def progress(self):
        return Progress(self.paths_in(0, self.done), self.paths)

    # -- chunks --------------------------------------------------------------------------

    @property
    def times_acc(self):
        return None if self.acc is None else self.acc.times

    @property
    def stop_acc(self):
        return None if self.acc is None else self.acc.stop

    def paths_in(self, first, last):
        # Every chunk holds CHUNK_PATHS paths, the last one the rest.
        size = engine.CHUNK_PATHS
        return min(last * size, self.paths) - min(first * size, self.paths)

    def add(self, chunk: engine.Chunk):
        """Merge the next chunk (chunk ``self.done``)."""
        self._check_chunk(chunk)
        if self.acc is None:
            counts = None if chunk.counts is None else tuple(
                np.array(c, dtype=np.uint64) for c in chunk.counts)
            self.acc = chunk._replace(counts=counts)
        else:
            acc = self.acc
            acc.times.merge(chunk.times)
            acc.stop.merge(chunk.stop)
            if acc.peaks is not None:
                acc.peaks.merge(chunk.peaks)
            if acc.peaks_stop is not None:
                acc.peaks_stop.merge(chunk.peaks_stop)
            if acc.energy is not None:
                acc.energy.merge(chunk.energy)
            if acc.counts is not None:
                # Integer addition: exact and order-free, so any split of the paths into
                # threads, chunks, checkpoints or Dask tasks gives the same counts.
                for total, part in zip(acc.counts, chunk.counts):
                    np.add(total, part, out=total)
        self.done += 1

    def _check_chunk(self, chunk) -> None:
        """A chunk carries what this run records (a worker of another crandall might not)."""
        if self.peaks and (chunk.peaks is None
                           or ("stop" in self.scene.observe and chunk.peaks_stop is None)):
            raise ValueError("peaks: a chunk came back without the peaks this run records "
                             "(a Dask worker with another crandall version?)")
        if "kinetic_energy" in self.scene.observe and chunk.energy is None:
            raise ValueError("kinetic_energy: a chunk came back without the moments of V^2 "
                             "this run records (a Dask worker with another crandall version?)")
        if self.indices:
            sizes = None if chunk.counts is None else [len(c) for c in chunk.counts]
            if sizes != [len(e) + 2 for e in self.edges]:
                raise ValueError("distributions: a chunk's histograms do not have this run's "
                                 "bins (a Dask worker with another crandall version?)")

    def ranges(self, tasks):
        """Split the chunks still to do into about ``tasks`` contiguous ranges."""
        left = self.plan.chunks - self.done
        tasks = max(1, min(tasks, left))
        bounds = [self.done + (left * i) // tasks for i in range(tasks + 1)]
        return [(a, b) for a, b in zip(bounds[:-1], bounds[1:]) if b > a]

    def result(self):
        self._check_finite()
        spec = self.spec
        acc = self.acc
        stop = "stop" in self.scene.observe
        hist = None
        if self.indices:
            hist = Histograms(self.indices, self.edges, tuple(acc.counts))
        return Result(spec=spec, moments=acc.times,
                      stop_moments=acc.stop if stop else None,
                      steps_per_path=self.plan.steps_per_path,
                      random_stream=engine.RANDOM_STREAM,
                      peaks=acc.peaks if self.peaks else None,
                      stop_peaks=acc.peaks_stop if self.peaks and stop else None,
                      histograms=hist, wall_time=time.perf_counter() - self.started,
                      energy=acc.energy)

    def _check_finite(self):
        # Means and variances must be numbers; only fourth moments may overflow (var_stderr
        # then says so). Non-finite values come from scenes whose values exceed doubles.
        obs = set(self.scene.observe)
        at_times = list(simulated_variables(obs, at_stop=False))
        at_stop = list(simulated_variables(obs, at_stop=True))
        exps = MONOMIALS
        held = [quantity(n) for n in names_for(obs)]
        peak_times = sorted({q.variable for q in held if q.peak and not q.at_stop})
        peak_stop = sorted({q.variable for q in held if q.peak and q.at_stop})
        acc_all = self.acc
        for acc, variables, what in ((self.times_acc, at_times, "at the output times"),
                                     (self.stop_acc if "stop" in obs else None, at_stop,
                                      "at the stop"),
                                     (acc_all.peaks if self.peaks else None, peak_times,
                                      "at the output times"),
                                     (acc_all.peaks_stop if self.peaks else None, peak_stop,
                                      "at the stop")):
            if acc is None or acc.slots == 0 or not variables:
                continue
            second = [i for i, e in enumerate(exps)
                      if sorted(e) == [0, 0, 2] and any(e[v] == 2 for v in variables)]
            if not (np.isfinite(acc.means[:, variables]).all()
                    and np.isfinite(acc.central[:, second]).all()):
                names = ("mu, h, g, t0, times" if self.scene.units == "SI" else "tau0, times")
                if what == "at the stop":
                    names = "observe, " + names
                raise ParameterError(names, f"{names}: this scene's means or variances {what} are not "
                                 "finite numbers (its values exceed the range of doubles, or "
                                 "the computation failed); choose units or times in which "
                                 "they are nearer 1" + (", or leave 'stop' out of observe"
                                                        if what == "at the stop" else ""))


#: What simulate takes as a seed: an int, a numpy SeedSequence or Generator, or None.
Seed = Union[None, int, np.random.SeedSequence, np.random.Generator]


def simulate(
    scene: Scene,
    *,
    paths: Optional[int] = None,
    seed: Seed = None,
    dt: Optional[float] = None,
    method: Optional[str] = None,
    threads: Optional[int] = None,
    checkpoint: Optional[Union[str, "os.PathLike[str]"]] = None,
    client: Any = None,
    progress: Optional[bool] = None,
    error: Optional[float] = None,
    rel_error: Optional[float] = None,
    statistics: Optional[Sequence] = None,
    max_seconds: Optional[float] = None,
    event_depth: Optional[int] = None,
) -> Result:
    """Simulate a scene and return its statistics: ``paths`` paths on a fixed grid, or as
    many as a requested accuracy needs (``error=`` or ``rel_error=``).

    Parameters
    ----------
    scene : Scene
        What to simulate (physical or scaled units).
    paths : int
        Number of independent paths, 1 <= paths <= ``MAX_PATHS`` (2**63). Memory does not grow
        with it. Variances need at least 2 (see :class:`Result`). Required unless ``error`` or
        ``rel_error`` is given.
    error : float, optional
        Ask for an accuracy instead of ``paths``: crandall chooses the grids and the number of
        paths (multilevel Monte Carlo, docs/methods/adaptive.md) until the estimated
        root-mean-square error (discretisation bias and statistical error together) of every
        statistic the scene asks for (the mean and the variance of each observed quantity at
        each output time and at the stop) is at most ``error``, in the scene's units. Returns a
        :class:`crandall.AccuracyResult`, whose ``error``, ``bias``, ``stderr`` and
        ``interval`` report it. Not with ``paths``, ``dt``, ``method`` or ``client``; with
        ``checkpoint`` the run's state is kept in that file (crandall's checkpoint format,
        replaced atomically at most every second and at the end of every round) and a rerun with the same
        arguments carries on from it, to a result bitwise the same as an uninterrupted run's.
        ``seed`` None draws one; give a seed to resume. One ``error`` applies to every
        statistic in its own units: a mean energy in J, its variance in J^2. To ask the means
        and the variances for different accuracies, run each with ``statistics=``. A target
        that no run could reach (a level would need more than 2^62 paths) is refused naming
        ``error``.
    rel_error : float, optional
        The same, relative: at most ``rel_error`` times the statistic's size (its absolute
        value; for a mean, at least the quantity's standard deviation, so that a mean that is
        0 by symmetry has a finite target).
    statistics : sequence, optional
        With ``error`` / ``rel_error``: the statistics the target applies to (and that the
        result holds), as ``"name:stat"`` strings or ``(name, stat)`` pairs with stat "mean"
        or "var", e.g. ``["distance:var"]``; default: every statistic of the scene.
    max_seconds : float, optional
        With ``error`` / ``rel_error``: after every round (the first after the pilot paths of
        each level) the run estimates the time it still needs from the paths each level
        still needs and the rate measured so far, shows it on the progress bar, and stops with
        a ValueError quoting the estimate once the time spent and the estimate together pass
        ``max_seconds`` (default 3600; with ``checkpoint`` what was done is kept, so a rerun
        with a larger bound carries on).
    seed : int, numpy.random.SeedSequence or numpy.random.Generator, optional
        0 <= seed < 2**64. The result is a pure function of (seed, scene, paths, dt, method,
        crandall version): bitwise the same for any ``threads``, checkpointed or not, local or
        on a Dask cluster. None draws a seed from the operating system and records it as
        ``Result.seed`` (with an existing ``checkpoint``: the checkpoint's seed). A
        ``SeedSequence`` gives the int ``seed.generate_state(1, numpy.uint64)[0]`` (the same
        for the same entropy), a ``Generator`` one draw ``integers(0, 2**64,
        dtype=numpy.uint64)`` (advancing it); ``Result.seed`` records the int.
    dt : float, optional
        Longest internal step, in the scene's time units, used where a time integral
        (displacement, distance, dissipated energy) is observed, and always by "euler". The
        exact method needs no internal step for velocity, kinetic energy and the stop: it steps
        from one output time to the next. Default: :func:`default_dt`, on a graded grid: the
        step before each output time or the switch-off t is also at most
        ``t / DEFAULT_MIN_STEPS`` (``crandall.methods``), so that every output time and the
        switch-off are resolved to the default method's documented accuracy whatever the
        scene's units and horizon. An explicit dt gives a uniform grid of steps <= dt.
    method : str
        One of ``crandall.METHODS`` (see ``crandall.methods``); default ``DEFAULT_METHOD``
        ("exact" for a filtered excitation: :func:`crandall.spec.default_method`).
    event_depth : int, optional
        A filtered excitation's event search: a step in which a stop or an onset may happen is
        bisected by exact bridges down to steps of dt / 2^event_depth, 2 to 20; default (None)
        8. Fewer bisections cost less per path and move the statistics by an error that
        ``Result.bias`` estimates (docs/filtered.md, "The event depth"). Not for white noise
        (no event search), nor with ``error`` or ``rel_error`` (their levels keep 8, the depth
        their filtered calibration was measured at).
    threads : int, optional
        OpenMP threads; default: all cores (with ``client``: threads per task, default 1, as
        Dask runs one task per worker thread).
    checkpoint : str or os.PathLike, optional
        A file that holds the finished chunks of paths (65536 each): replaced atomically after
        every chunk, so killing the run loses at most the chunk in flight. If it exists, the run
        resumes from it (and returns at once if it is complete); a checkpoint of a different run
        (scene, paths, seed, dt, method or crandall version) is a ValueError. The resumed result
        is bitwise identical to an uninterrupted one. The file is kept after the run.
    client : distributed.Client, optional
        Run the chunks as tasks on a Dask distributed cluster (``pip install
        crandall[distributed]``); the workers need crandall installed. The accumulators come back
        to this process and are merged in chunk order: bitwise the local result.
    progress : bool, optional
        Show a progress bar (``tqdm.auto``: on stderr, or a widget in a notebook; for a run to
        an accuracy, the round, the largest error over its target and the estimated time
        left). Default: only on a terminal (not in CI or pytest) and only once the run has
        lasted two seconds.

    Returns
    -------
    Result

    Raises
    ------
    ValueError
        On any bad argument (the message names it); when the output times' accumulators would
        not fit in the memory this process may still allocate (free memory, its rlimits and
        its memory cgroup), before allocating them; when a scene's values overflow doubles.
        KeyboardInterrupt (Ctrl-C) interrupts the run within a fraction of a second.

    Warns
    -----
    StatisticsWarning
        When the scene's integrals (displacement, distance, dissipated energy, peaks) would
        need more than 2^53 internal steps while it also observes what needs none (velocity,
        kinetic energy, stop): those are answered, exact in law, and the warning names the
        integrals left out (the result's scene observes the rest only). A scene with nothing
        exact to answer, or a ``statistics`` naming an integral, is refused instead.

    See Also
    --------
    simulate_many : several scenes (a parameter sweep), locally or on a cluster.
    """
    seed = as_seed(seed)
    given = dict(paths=paths, seed=seed, dt=dt, method=method, threads=threads,
                 checkpoint=checkpoint, client=client, progress=progress, error=error,
                 rel_error=rel_error, statistics=statistics, max_seconds=max_seconds,
                 event_depth=event_depth)
    try:
        return _simulate(scene, **given)
    except UnresolvableGrid as exc:
        exact = _exact_part(scene, statistics)
        if exact is None:
            raise
        warnings.warn(
            f"observe: {', '.join(exc.integrals)} cannot be resolved (their grid would need "
            f"more than 2^53 steps); answering {', '.join(exact.observe)} only, which need no "
            "internal steps and are exact in law (the mean friction loss at the stop follows "
            "from the energy law: crandall.analytic.physical('distance_at_stop_mean', ...))",
            StatisticsWarning, stacklevel=2)
        return _simulate(exact, **given)


#: What needs no internal steps (exact in law at any step): a scene that also observes
#: integrals its grid cannot resolve is answered for these.
EXACT_OBSERVABLES = ("velocity", "kinetic_energy", "stop")


def _exact_part(scene: Scene, statistics) -> Optional[Scene]:
    """The scene cut to its observables that need no internal steps (with the distributions
    and bins of their quantities), or None if that leaves nothing, or nothing out, or drops a
    statistic asked for by name."""
    if not holds(scene, EXACT_STEP):
        return None
    d = scene.to_dict()
    keep = [o for o in d["observe"] if o in EXACT_OBSERVABLES]
    if not keep or len(keep) == len(d["observe"]):
        return None
    held = names_for(keep)
    if statistics is not None:
        if isinstance(statistics, str):
            statistics = [statistics]
        if not isinstance(statistics, (list, tuple, set)):
            return None  # refused as it stands (adaptive._check_statistics)
        for item in statistics:
            name = (item.partition(":")[0] if isinstance(item, str)
                    else item[0] if isinstance(item, tuple) and item else None)
            if name not in held:
                return None
    d["observe"] = keep
    if isinstance(d.get("distributions"), list):
        d["distributions"] = [n for n in d["distributions"] if n in held]
        if not d["distributions"]:
            del d["distributions"]
            d.pop("bins", None)
    if isinstance(d.get("bins"), dict):
        d["bins"] = {k: v for k, v in d["bins"].items() if k in held or k == "per_octave"}
    if scene.envelope is not None:
        # The envelope itself: a function envelope's plain data are its pieces alone, which
        # would rebuild a plain piecewise scene, reported exact with no piece error.
        d.pop("h", None)
        d.pop("t0", None)
        d["envelope"] = scene.envelope
    return Scene.from_dict(d)


def _simulate(scene: Scene, *, paths, seed, dt, method, threads, checkpoint, client, progress,
              error, rel_error, statistics, max_seconds, event_depth=None):
    """simulate's work, for one scene as given (checked by the spec, or by the run to an
    accuracy: :func:`crandall.spec.check_scene`)."""
    if error is not None or rel_error is not None:
        for name, value in (("paths", paths), ("dt", dt), ("method", method)):
            if value is not None:
                raise ParameterError(name, f"{name}: not with error= or rel_error= (the run chooses its "
                                 "grids and paths itself)")
        if event_depth is not None:
            raise ParameterError("event_depth", "event_depth: not with error= or rel_error= (their "
                                 "levels search events to depth 4, at which their coverage "
                                 "was calibrated, and correct what it leaves)")
        check_client(client)
        if checkpoint is not None and not isinstance(checkpoint, (str, os.PathLike)):
            raise ParameterError("checkpoint", f"checkpoint must be a path, got {checkpoint!r}")
        if seed is None:
            seed = draw_seed()
        threads, task_threads = resolve_threads(threads)
        return simulate_to_error(scene, error=error, rel_error=rel_error, seed=seed,
                                 threads=threads, statistics=statistics,
                                 checkpoint=checkpoint, client=client,
                                 task_threads=task_threads, progress=progress,
                                 max_seconds=MAX_SECONDS if max_seconds is None
                                 else max_seconds)
    if statistics is not None:
        raise ParameterError("statistics", "statistics: only with error= or rel_error=")
    if max_seconds is not None:
        raise ParameterError("max_seconds", "max_seconds: only with error= or rel_error= (a run of paths= has "
                         "a known size)")
    if paths is None:
        raise ParameterError("paths", "paths: give the number of paths, or error= / rel_error= for an "
                         "accuracy")
    if checkpoint is not None:
        if not isinstance(checkpoint, (str, os.PathLike)):
            raise ParameterError("checkpoint", f"checkpoint must be a path, got {checkpoint!r}")
        if seed is None:
            seed = _ckpt.stored_seed(checkpoint)
    check_client(client)
    spec, cores = run_spec(scene, paths=paths, seed=seed, dt=dt, method=method,
                           threads=threads, event_depth=event_depth)
    run = FixedStep(spec, threads=cores, task_threads=resolve_threads(threads)[1])
    return drive(run, checkpoints=checkpoint, client=client, progress=progress)[0]


def simulate_many(
    scenes: Sequence[Scene],
    *,
    paths: int,
    seed: Seed = None,
    dt: Optional[float] = None,
    method: Optional[str] = None,
    threads: Optional[int] = None,
    checkpoint_dir: Optional[Union[str, "os.PathLike[str]"]] = None,
    client: Any = None,
    progress: Optional[bool] = None,
    dataset: bool = False,
    event_depth: Optional[int] = None,
) -> Any:
    """Simulate several scenes (a parameter sweep); one :class:`Result` per scene, in order.

    Each result is bitwise ``simulate(scene, paths=paths, seed=seed, dt=dt, method=method)``.
    With a Dask ``client`` every scene's chunks are submitted at once, so the cluster is kept
    busy across scenes.

    Parameters
    ----------
    scenes : sequence of Scene
        The scenes, e.g. ``[Scene(mu=m, h=1, t0=2, times=ts) for m in (0.1, 0.2, 0.3)]``.
    paths, method, threads, client, progress, event_depth
        As for :func:`simulate` (event_depth for every scene: each must then have a filtered
        excitation).
    seed : int, optional
        One seed for every scene (common random numbers: the sweep's curves are smooth in the
        parameter); None draws one, recorded on every result.
    dt : float, optional
        As for :func:`simulate`; None: each scene's :func:`default_dt`.
    checkpoint_dir : str or os.PathLike, optional
        A directory (created if missing) holding one checkpoint per scene,
        ``scene-0000.ckpt``, ``scene-0001.ckpt``, ... in the order of ``scenes``, each as
        ``checkpoint`` of :func:`simulate`. Rerunning the same call after an interruption
        resumes every scene where it stopped (finished scenes return at once) with a bitwise
        identical result. With ``seed=None`` the seed is taken from the first existing
        checkpoint. Checkpoints of a different sweep (scene, paths, seed, dt, method) are a
        ValueError.

    dataset : bool
        Return one ``xarray.Dataset`` instead (needs ``crandall[io]``): every statistic with a
        leading dimension ``scene`` and the scenes' parameters as coordinates over it
        (``crandall.io.sweep``). The scenes must have the same quantities and output times.

    Returns
    -------
    list of Result, or xarray.Dataset with ``dataset=True``
    """
    if not isinstance(dataset, bool):
        raise ParameterError("dataset", f"dataset must be True or False, got {dataset!r}")
    if isinstance(scenes, Scene) or not isinstance(scenes, (list, tuple)):
        raise ParameterError("scenes", f"scenes must be a list of crandall.Scene, got {type(scenes).__name__}")
    if not scenes:
        raise ParameterError("scenes", "scenes must not be empty")
    seed = as_seed(seed)
    files: List[Optional[str]] = [None] * len(scenes)
    if checkpoint_dir is not None:
        if not isinstance(checkpoint_dir, (str, os.PathLike)):
            raise ParameterError("checkpoint_dir", f"checkpoint_dir must be a path, got "
                                                  f"{checkpoint_dir!r}")
        if os.path.exists(checkpoint_dir) and not os.path.isdir(checkpoint_dir):
            raise ParameterError("checkpoint_dir", f"checkpoint_dir must be a directory: {os.fspath(checkpoint_dir)!r}")
        _ckpt.make_folder(checkpoint_dir)  # a ValueError if it cannot be created
        files = [os.path.join(checkpoint_dir, f"scene-{i:04d}.ckpt") for i in range(len(scenes))]
        if seed is None:
            stored = [_ckpt.stored_seed(f) for f in files]
            seed = next((x for x in stored if x is not None), None)
    check_client(client)
    runs = []
    for i, scene in enumerate(scenes):
        if not isinstance(scene, Scene):
            raise ParameterError("scenes", f"scenes[{i}] must be a crandall.Scene, got {type(scene).__name__}")
        spec, t = run_spec(scene, paths=paths, seed=seed, dt=dt, method=method,
                           threads=threads, event_depth=event_depth)
        seed = spec.seed  # a drawn seed is shared by the following scenes
        runs.append(FixedStep(spec, threads=t, task_threads=resolve_threads(threads)[1]))
    results = drive(runs, checkpoints=files, client=client, progress=progress)
    return _dataset.sweep(results) if dataset else results
