"""Running a scene: validation, the default step, the chunk loop."""

from __future__ import annotations

import math
import os
from typing import Optional

import numpy as np

from . import _core
from .methods import DEFAULT_DT_TAU, DEFAULT_METHOD, DEFAULT_STEPS_FREE, METHODS
from .results import Result
from .scene import Scene

__all__ = ["simulate", "default_dt", "METHODS"]


def default_dt(scene: Scene) -> float:
    """The internal step that ``simulate(dt=None)`` uses for this scene, in its time units.

    Scaled scenes: ``DEFAULT_DT_TAU`` (0.01). Physical scenes with friction and excitation: the
    same step in scaled time, ``0.01 * 2 h^2 / (mu g)^2`` seconds. Without friction (mu = 0):
    the horizon (the last output time or t0) over ``DEFAULT_STEPS_FREE``. Without excitation
    (h = 0) the body stays at rest and the step does not matter.
    """
    if scene.units == "scaled":
        return DEFAULT_DT_TAU
    if scene.scaling is not None:
        return DEFAULT_DT_TAU * scene.scaling.time_scale
    horizon = max([t for t in (scene.times[-1] if scene.times.size else 0.0, scene.t0)
                   if math.isfinite(t)] + [0.0])
    return horizon / DEFAULT_STEPS_FREE if horizon > 0 else 1.0


def _check_int(name: str, value, minimum: int, maximum: Optional[int] = None) -> int:
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
        raise ValueError(f"{name} must be an integer, got {value!r}")
    value = int(value)
    if value < minimum:
        raise ValueError(f"{name} must be >= {minimum}, got {value}")
    if maximum is not None and value > maximum:
        raise ValueError(f"{name} must be <= {maximum}, got {value}")
    return value


def _available_memory() -> int:
    try:
        return os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
    except (ValueError, OSError, AttributeError):  # pragma: no cover - non-POSIX
        return 1 << 62


def _check_memory(scene: Scene, threads: int) -> None:
    # Accumulators: per output time, count + 3 means + 35 central sums; one per thread for the
    # block sums (raw sums and centres), one for the chunk, one for the total, a few copies in
    # Python. Nothing grows with the number of paths.
    per_slot = (1 + 3 + 35) * 8 + (3 + 35 + 1) * 8
    need = scene.times.size * per_slot * (threads + 6)
    have = _available_memory()
    if need > have:
        raise ValueError(
            f"times: {scene.times.size} output times need about {need / 2**30:.1f} GiB of "
            f"accumulators, more than the {have / 2**30:.1f} GiB available"
        )


def make_plan(scene: Scene, *, paths: int, seed: int, dt: float, method: str) -> "_core.Plan":
    """The core's validated plan for a scene (used by simulate and by distributed runs)."""
    o = _core.Options()
    o.drift = scene.drift
    o.noise = scene.noise
    o.switch_off = scene.t0
    o.times = scene.times.tolist()
    o.dt = dt
    o.method = method
    obs = set(scene.observe)
    o.velocity = bool(obs & {"velocity", "kinetic_energy"}) or not (
        obs & {"displacement", "distance", "dissipated_energy"})
    o.displacement = "displacement" in obs
    o.distance = bool(obs & {"distance", "dissipated_energy"})
    o.stop = "stop" in obs
    o.seed = seed
    o.paths = paths
    return _core.Plan(o)


def validate_run(scene, paths, seed, dt, method, threads):
    """Check simulate's arguments; return them normalised (seed drawn if None)."""
    if not isinstance(scene, Scene):
        raise ValueError(f"scene must be a crandall.Scene, got {type(scene).__name__}")
    paths = _check_int("paths", paths, 1)
    if seed is None:
        # Recorded on the result so the run can be repeated.
        seed = int(np.random.SeedSequence().entropy % (1 << 64))
    seed = _check_int("seed", seed, 0, (1 << 64) - 1)
    if dt is None:
        dt = default_dt(scene)
    else:
        if isinstance(dt, bool) or not isinstance(dt, (int, float, np.integer, np.floating)):
            raise ValueError(f"dt must be a number, got {dt!r}")
        dt = float(dt)
        if not math.isfinite(dt) or dt <= 0:
            raise ValueError(f"dt must be finite and > 0, got {dt!r}")
    if method not in METHODS:
        raise ValueError(f"method must be one of {', '.join(METHODS)}, got {method!r}")
    if threads is None:
        threads = os.cpu_count() or 1
    threads = _check_int("threads", threads, 1, 1024)
    _check_memory(scene, threads)
    return paths, seed, dt, method, threads


def simulate(
    scene: Scene,
    *,
    paths: int,
    seed: Optional[int] = None,
    dt: Optional[float] = None,
    method: str = DEFAULT_METHOD,
    threads: Optional[int] = None,
) -> Result:
    """Simulate ``paths`` independent paths of a scene and return their statistics.

    Parameters
    ----------
    scene : Scene
        What to simulate (physical or scaled units).
    paths : int
        Number of independent paths, >= 1. Memory does not grow with it.
    seed : int, optional
        0 <= seed < 2**64. The result is a pure function of (seed, scene, paths, dt, method,
        crandall version): bitwise the same for any ``threads``. None draws a seed from the
        operating system and records it as ``Result.seed``.
    dt : float, optional
        Longest internal step, in the scene's time units, used where a time integral
        (displacement, distance, dissipated energy) is observed, and always by "euler". The
        exact method needs no internal step for velocity, kinetic energy and the stop: it steps
        from one output time to the next. Default: :func:`default_dt`.
    method : str
        One of ``crandall.METHODS`` (see ``crandall.methods``); default ``DEFAULT_METHOD``.
    threads : int, optional
        OpenMP threads; default: all cores.

    Returns
    -------
    Result

    Raises
    ------
    ValueError
        On any bad argument (the message names it). KeyboardInterrupt (Ctrl-C) stops the run
        within a fraction of a second.
    """
    paths, seed, dt, method, threads = validate_run(scene, paths, seed, dt, method, threads)
    plan = make_plan(scene, paths=paths, seed=seed, dt=dt, method=method)
    times_acc = stop_acc = None
    for chunk in range(plan.chunks):
        part = _core.run_chunk(plan, chunk, threads)
        if times_acc is None:
            times_acc, stop_acc = part.times, part.stop
        else:
            times_acc.merge(part.times)
            stop_acc.merge(part.stop)
    return Result(scene=scene, paths=paths, seed=seed, dt=dt, method=method,
                  moments=times_acc, stop_moments=stop_acc if "stop" in scene.observe else None,
                  steps_per_path=plan.steps_per_path)
