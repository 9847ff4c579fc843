"""The pure chunk runner: a run specification in, the core's plan, chunks of accumulators out.

Nothing here knows of checkpoints, clusters or progress bars (``crandall.simulate`` does):
a chunk's accumulators are a pure function of (spec, chunk index), bitwise the same for any
thread count and machine, which is what lets the orchestration merge chunks from anywhere in
chunk order. This is the only module besides persistence (``crandall.io``,
``crandall.checkpoint``) and ``crandall.results`` that calls the compiled core.
"""

from __future__ import annotations

import math
from typing import Any, Dict, List, Optional, Tuple, Union

import numpy as np

from . import _core
from .quantities import core_flags
from .spec import RunSpec

__all__ = ["make_plan", "run_chunk", "run_chunks", "velocity_samples", "RANDOM_STREAM",
           "CHUNK_PATHS"]

#: Version of the random stream this build draws (docs/random-numbers.md).
RANDOM_STREAM: int = int(_core.RANDOM_STREAM)
#: Paths per chunk: the unit of work, of checkpoints and of Dask tasks.
CHUNK_PATHS: int = int(_core.CHUNK_PATHS)


def make_plan(spec: RunSpec) -> "_core.Plan":
    """The core's validated plan of a run: its time grid and its partition into chunks."""
    scene = spec.scene
    o = _core.Options()
    o.drift = scene.drift
    o.noise = scene.noise
    o.switch_off = scene.t0
    o.times = scene.times.tolist()
    o.dt = spec.dt
    o.min_steps = spec.min_steps
    o.method = spec.method
    for flag, on in core_flags(scene.observe).items():
        setattr(o, flag, on)
    o.seed = spec.seed
    o.paths = spec.paths
    return _core.Plan(o)


def run_chunk(plan: "_core.Plan", chunk: int, threads: int) -> Tuple[Any, Any]:
    """Chunk ``chunk`` of a plan: its ``(times, stop)`` accumulators."""
    part = _core.run_chunk(plan, chunk, threads)
    return part.times, part.stop


def run_chunks(spec: Union[RunSpec, Dict[str, Any]], first: int, last: int, threads: int,
               random_stream: Optional[int] = None) -> List[Tuple[Any, Any]]:
    """Chunks ``first..last-1`` of a run, as a list of ``(times, stop)`` accumulators.

    The task a Dask worker runs: plain data in (a spec or its ``to_dict()``), picklable
    accumulators out. The caller merges the lists of all tasks in chunk order, which makes the
    result bitwise that of a local run. ``random_stream``: the caller's random-stream version;
    a worker whose crandall draws another stream refuses the task, so that a cluster never
    mixes two streams' numbers.
    """
    if random_stream is not None and random_stream != RANDOM_STREAM:
        raise ValueError(
            f"random_stream: this worker's crandall draws random stream {RANDOM_STREAM}, "
            f"the client's draws stream {random_stream}; install the same crandall version on "
            "every worker")
    if not isinstance(spec, RunSpec):
        spec = RunSpec.from_dict(spec)
    plan = make_plan(spec)
    return [run_chunk(plan, chunk, threads) for chunk in range(first, last)]


def velocity_samples(tau: float, paths: int, seed: int) -> np.ndarray:
    """``paths`` samples of the scaled velocity U1(tau) from rest, noise on (paper eq3).

    One exact step from 0 to tau per path: exact in law for any tau (docs/exact-step.md).
    """
    return _core.exact_steps(np.zeros(paths), float(tau), 2.0, math.sqrt(2.0), seed)
