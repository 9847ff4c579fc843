"""Every random stream of a run, derived from its seed in one place.

The core draws a path's noise from Philox4x32-10 keyed by a 64-bit key, with the path's index
and the step pair in the counter (docs/rng.md): a path's draws depend on (key, path index)
only, so chunks, threads, Dask tasks and resumed checkpoints give the same paths. The keys:

- a fixed-step run: the seed itself (its paths 0, 1, ...; the refine method's substeps use
  the same key with the path index's top bit set);
- level l of a run to an accuracy: :func:`level_key` (seed, l); the pilot that fits the
  control coefficients is the first paths of level 0, which the estimate then leaves out;
- the coupled run of a fixed-step run's bias estimate: :func:`bias_key` (seed), the stream
  2^20, beyond any level; for a scene given as an envelope, its run on twice the pieces uses
  the same key (the same paths, paired by index, so the piece error's difference has a small
  variance);
- a tail run (crandall.tail): :func:`tail_key` (seed), the stream 2^20 + 1; within it the
  core's path index numbers the replicas' and the pilots' paths (crandall/tail/);
- sample paths to draw (crandall.paths): :func:`paths_key` (seed), the stream 2^20 + 2, path i
  the core's path index i.

Every Dask task checks first that its worker draws the client's random stream
(:func:`check_random_stream`): a cluster never mixes two streams' numbers.

Derived keys are splitmix64 of (seed, stream), in the manner of numpy's SeedSequence.spawn:
each is a pure function of the seed and the stream's number, and distinct streams are
decorrelated. A new estimator takes a stream number of its own here.
"""

from __future__ import annotations

from . import _core
from .errors import ParameterError

__all__ = ["key", "level_key", "bias_key", "tail_key", "paths_key", "BIAS_STREAM",
           "TAIL_STREAM", "PATHS_STREAM", "RANDOM_STREAM", "check_random_stream"]

#: Version of the random stream this build draws (docs/random-numbers.md): the same seed gives
#: the same numbers in every crandall that draws the same stream.
RANDOM_STREAM: int = int(_core.RANDOM_STREAM)

_MASK = (1 << 64) - 1
#: The stream of a fixed-step run's bias estimate (beyond the levels of a run to an accuracy).
BIAS_STREAM = 1 << 20
#: The stream of the rare-event estimators' paths.
TAIL_STREAM = BIAS_STREAM + 1
#: The stream of crandall.paths' sample paths.
PATHS_STREAM = BIAS_STREAM + 2


def key(seed: int, stream: int) -> int:
    """The Philox key of stream ``stream`` of a run with this seed: splitmix64 of
    (seed, stream)."""
    z = (seed + 0x9E3779B97F4A7C15 * (stream + 1)) & _MASK
    z = ((z ^ (z >> 30)) * 0xBF58476D1CE4E5B9) & _MASK
    z = ((z ^ (z >> 27)) * 0x94D049BB133111EB) & _MASK
    return z ^ (z >> 31)


def check_random_stream(stream) -> None:
    """Refuse a task whose client draws another random stream than this worker (``stream``:
    the client's :data:`RANDOM_STREAM`), naming ``random_stream``. Every Dask task calls it
    first: the fixed-step chunks (``engine.run_chunks``), a run to an accuracy's batches
    (``adaptive.batch_task``) and a tail run's samples (``tail.sample``)."""
    if stream != RANDOM_STREAM:
        raise ParameterError(
            "random_stream", f"random_stream: this worker's crandall draws random stream "
            f"{RANDOM_STREAM}, the client's draws stream {stream}; install the same crandall "
            "version on every worker")


def level_key(seed: int, level: int) -> int:
    """The key of level ``level``'s paths in a run to an accuracy."""
    return key(seed, level)


def bias_key(seed: int) -> int:
    """The key of the coupled run that estimates a fixed-step run's bias."""
    return key(seed, BIAS_STREAM)


def tail_key(seed: int) -> int:
    """The key of a tail run's paths (every replica and pilot path, by path index)."""
    return key(seed, TAIL_STREAM)


def paths_key(seed: int) -> int:
    """The key of crandall.paths' sample paths (path i: the core's path index i)."""
    return key(seed, PATHS_STREAM)
