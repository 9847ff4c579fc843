"""The pure chunk runner: a run specification in, the core's plan, chunks of accumulators out.

Nothing here knows of checkpoints, clusters or progress bars (``crandall.simulate`` does):
a chunk's accumulators are a pure function of (spec, chunk index), bitwise the same for any
thread count and machine, which is what lets the orchestration merge chunks from anywhere in
chunk order. This is the only module besides persistence (``crandall.io``,
``crandall.checkpoint``) and ``crandall.results`` that calls the compiled core.
"""

from __future__ import annotations

import dataclasses
import math
from typing import Any, Dict, List, NamedTuple, Optional, Sequence, Tuple, Union

import numpy as np

from . import _core
from .bins import REACH, VARIABLE_COUNT, Axis, axes as _scene_axes
from .quantities import core_flags
from .spec import RunSpec, grid_error
from .streams import RANDOM_STREAM, check_random_stream

__all__ = ["make_plan", "plan_options", "scene_options", "run_chunk", "run_chunks", "velocity_samples", "histogram_axes",
           "axis_edges", "plain_axes", "Chunk", "RANDOM_STREAM", "CHUNK_PATHS"]

#: Paths per chunk: the unit of work, of checkpoints and of Dask tasks.
CHUNK_PATHS: int = int(_core.CHUNK_PATHS)


class Chunk(NamedTuple):
    """One chunk's accumulators (picklable: what a Dask task sends back).

    ``times`` and ``stop`` are the moments of (U1, U2, U3) per output time and at the stop;
    ``peaks`` and ``peaks_stop`` those of the running maxima (None unless the scene observes
    "peaks"); ``counts`` the histograms' counts, one uint64 array per recorded axis in the
    order of :func:`histogram_axes` (None without distributions); ``energy`` the moments of
    V^2 (None unless the scene observes "kinetic_energy").
    """

    times: Any
    stop: Any
    peaks: Any = None
    peaks_stop: Any = None
    counts: Optional[Tuple[np.ndarray, ...]] = None
    #: The moments of (V^2, 0, 0) per output time (None unless the scene observes the
    #: kinetic energy): its variance's standard error.
    energy: Any = None


def histogram_axes(spec: Union[RunSpec, Any], axes: Optional[Sequence] = None) -> List[Axis]:
    """The recorded histogram axes of a run (``crandall.bins.axes`` of its scene), or
    ``axes`` as given: a list of :class:`~crandall.bins.Axis` or of their plain dicts (a Dask
    task gets the client's, so that every worker bins with the client's bits whatever its
    SciPy computes for the scales)."""
    if axes is None:
        scene = spec.scene if isinstance(spec, RunSpec) else spec
        return _scene_axes(scene)
    out = []
    for a in axes:
        if isinstance(a, dict):
            a = dict(a)
            if a.get("edges") is not None:
                a["edges"] = tuple(float(x) for x in a["edges"])
            a = Axis(**a)
        out.append(a)
    return out


def _bin_edges(axis: Axis) -> "_core.BinEdges":
    if axis.edges is not None:
        return _core.BinEdges.from_edges(np.asarray(axis.edges, dtype=np.float64))
    return _core.BinEdges.log_linear(axis.scale, axis.per_octave, REACH, axis.symmetric)


def axis_edges(axes: Sequence[Axis]) -> List[np.ndarray]:
    """The edges (float64) the core bins with on each axis."""
    return [np.asarray(_bin_edges(a).edges, dtype=np.float64) for a in axes]


def scene_options(scene) -> "_core.Options":
    """The core's options that a scene sets, for every estimator's plans: the model (friction,
    intensity or its pieces, switch-off, start state), the output times and what to observe."""
    o = _core.Options()
    o.drift = scene.drift
    o.noise = scene.noise
    o.switch_off = scene.t0
    if scene.pieces is not None:
        o.piece_ends = [e for e, _ in scene.pieces]
        o.piece_noise = [n for _, n in scene.pieces]
    o.start_velocity = scene.v0
    o.start_displacement = scene.u0
    # The excitation's own options (none for white noise: its plans stay as they were).
    for name, value in scene.excitation.core_options().items():
        setattr(o, name, value)
    if scene.static_drift != scene.drift:
        o.static_drift = scene.static_drift
    o.times = scene.times.tolist()
    for flag, on in core_flags(scene.observe).items():
        setattr(o, flag, on)
    return o


def plan_options(spec: RunSpec, axes: Optional[Sequence[Axis]] = None, *,
                 histograms: bool = True) -> "_core.Options":
    """The core's options of a run: every field of the spec, the scene's observables and (with
    ``histograms``) its histogram axes (default: :func:`histogram_axes` of the spec). Every
    plan of a run is built from these (the run's own and the bias estimate's coupled run), so
    a run option reaches each of them here."""
    scene = spec.scene
    o = scene_options(scene)
    o.dt = spec.dt
    o.min_steps = spec.min_steps
    o.method = spec.method
    if spec.event_depth is not None:  # None: the core's default
        o.event_depth = spec.event_depth
    recorded = histogram_axes(spec, axes) if histograms else []
    if recorded:
        # Only a scene that asks sets the option: one that does not runs as before.
        slots = scene.times.size + (1 if "stop" in scene.observe else 0)
        full = [_core.BinEdges() for _ in range(slots * VARIABLE_COUNT)]
        for a in recorded:
            full[a.index] = _bin_edges(a)
        o.histogram_axes = full
    o.seed = spec.seed
    o.paths = spec.paths
    return o


def make_plan(spec: RunSpec, axes: Optional[Sequence[Axis]] = None) -> "_core.Plan":
    """The core's validated plan of a run: its time grid and its partition into chunks.

    ``axes``: the histogram axes (default: :func:`histogram_axes` of the spec).
    """
    try:
        return _core.Plan(plan_options(spec, axes))
    except ValueError as exc:
        raise grid_error(exc, spec.scene, dt_given=True) from None


def _recorded_indices(plan: "_core.Plan") -> List[int]:
    axes = getattr(plan.options, "histogram_axes", None) or []
    return [i for i, a in enumerate(axes) if a.bins > 0]


def run_chunk(plan: "_core.Plan", chunk: int, threads: int,
              recorded: Optional[Sequence[int]] = None) -> Chunk:
    """Chunk ``chunk`` of a plan: its accumulators (a :class:`Chunk`; ``chunk[:2]`` is the
    ``(times, stop)`` moments). ``recorded``: the indices of the recorded histogram axes
    (default: worked out from the plan)."""
    part = _core.run_chunk(plan, chunk, threads)
    options = plan.options
    peaks = peaks_stop = counts = None
    if getattr(options, "peaks", False):
        peaks = part.peaks
        peaks_stop = part.peaks_stop if options.stop else None
    if recorded is None:
        recorded = _recorded_indices(plan)
    if recorded:
        every = part.histogram_counts
        counts = tuple(np.array(every[i], dtype=np.uint64) for i in recorded)
    energy = part.energy if getattr(options, "energy", False) else None
    return Chunk(part.times, part.stop, peaks, peaks_stop, counts, energy)


def run_chunks(spec: Union[RunSpec, Dict[str, Any]], first: int, last: int, threads: int,
               random_stream: Optional[int] = None,
               axes: Optional[Sequence[Any]] = None) -> List[Chunk]:
    """Chunks ``first..last-1`` of a run, as a list of :class:`Chunk` accumulators (each
    starts with the ``(times, stop)`` moments).

    The task a Dask worker runs: plain data in (a spec or its ``to_dict()``), picklable
    accumulators out. The caller merges the lists of all tasks in chunk order, which makes the
    result bitwise that of a local run. ``random_stream``: the caller's random-stream version;
    a worker whose crandall draws another stream refuses the task, so that a cluster never
    mixes two streams' numbers. ``axes``: the caller's histogram axes (plain dicts of
    :class:`~crandall.bins.Axis`), so that every worker bins on the caller's edges.
    """
    if random_stream is not None:
        check_random_stream(random_stream)
    if not isinstance(spec, RunSpec):
        spec = RunSpec.from_dict(spec)
    plan = make_plan(spec, histogram_axes(spec, axes))
    recorded = _recorded_indices(plan)
    return [run_chunk(plan, chunk, threads, recorded) for chunk in range(first, last)]


def plain_axes(axes: Sequence[Axis]) -> List[Dict[str, Any]]:
    """Axes as plain data (a Dask task's argument; :func:`histogram_axes` reads it back)."""
    return [dataclasses.asdict(a) for a in axes]


def velocity_samples(tau: float, paths: int, seed: int) -> np.ndarray:
    """``paths`` samples of the scaled velocity U1(tau) from rest, noise on (paper eq3).

    One exact step from 0 to tau per path: exact in law for any tau (docs/exact-step.md).
    """
    return _core.exact_steps(np.zeros(paths), float(tau), 2.0, math.sqrt(2.0), seed)
