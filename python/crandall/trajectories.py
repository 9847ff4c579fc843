"""A few sample paths of a scene, to look at (``crandall.paths``; docs/paths.md).

The velocity is the core's exact step (exact in law at every grid time, whatever the step),
continued on a grid of the scene's pieces (:func:`crandall._core.extend_paths`, the rare-event
estimators' path store); the displacement and the distance are the trapezoid rule on that
grid, as in a fixed-step run of method "exact". After the last shaken piece nothing is random:
the body decelerates at mu g to rest, and every quantity there is closed form at any time.
Statistics belong to :func:`crandall.simulate`; these paths are for drawing.
"""

from __future__ import annotations

import json
import math
from typing import Any, Optional, Sequence

import numpy as np

from . import _core
from . import streams as _streams
from ._resources import available_memory
from .driver import threads as resolve_threads
from .errors import ParameterError
from .model import TAIL_MODEL
from .scene import Scene
from .spec import MAX_SEED, as_seed, check_int, check_positive, check_scene, default_dt, draw_seed

__all__ = ["paths", "MAX_VALUES"]

#: The most values (paths x grid points) one call keeps: a picture needs far fewer.
MAX_VALUES = 50_000_000


def _grid(scene: Scene, horizon: float, dt: float, extra: np.ndarray) -> np.ndarray:
    """The grid times on [0, horizon]: the pieces' ends, the asked times, steps of at most dt."""
    ends = [e for e, _ in scene.pieces] if scene.pieces is not None else []
    cuts = np.unique(np.concatenate([[0.0, horizon], [e for e in ends if 0 < e < horizon],
                                     extra[(extra > 0) & (extra < horizon)]]))
    parts = [cuts[:1]]
    for a, b in zip(cuts[:-1], cuts[1:]):
        n = max(1, math.ceil((b - a) / dt - 1e-9))
        parts.append(a + (b - a) * np.arange(1, n + 1) / n)
    grid = np.concatenate(parts)
    grid[-1] = horizon
    return grid


def _noise_at(scene: Scene, starts: np.ndarray) -> np.ndarray:
    """The noise of the piece each step starts in."""
    if scene.pieces is None:
        return np.where(starts < scene.t0, scene.noise, 0.0)
    ends = np.array([e for e, _ in scene.pieces])
    noises = np.array([n for _, n in scene.pieces] + [0.0])
    return noises[np.searchsorted(ends, starts, side="right")]


def paths(scene: Scene, n: int, *, seed: Any = None, times: Optional[Sequence[float]] = None,
          points: int = 400, dt: Optional[float] = None, threads: Optional[int] = None):
    """``n`` sample paths of a scene, as an ``xarray.Dataset`` (needs ``crandall[io]``).

    Parameters
    ----------
    scene : Scene
        Any scene (SI or scaled units).
    n : int
        Paths, 1 to 100 000.
    seed : int, numpy SeedSequence or Generator, optional
        As :func:`crandall.simulate`'s: None draws one, which the dataset records
        (``attrs["seed"]``); the same seed gives the same paths on every machine and thread
        count. (These are not the paths of ``simulate`` with that seed.)
    times : sequence of float, optional
        The times to report, >= 0, increasing. Default: ``points`` times from 0 to the
        end of the shaking, then a quarter as many to the last stop among the paths (or the
        scene's last output time, if later).
    points : int, default 400
        Times across the shaking when ``times`` is not given (2 to 100 000).
    dt : float, optional
        The longest grid step while the noise acts (default: :func:`crandall.default_dt`, and
        no longer than the shaking over ``points``).
    threads : int, optional
        Threads (default: as ``simulate``); the paths do not depend on it.

    Returns
    -------
    xarray.Dataset
        Over (``path``, ``time``): ``velocity``, ``displacement``, ``distance``; over
        ``path``: ``stop_time`` (NaN where the body never stops: no friction or no end to
        the shaking), each with its units; attributes: the scene (JSON), seed, dt.
    """
    xr = _require_xarray()
    check_scene(scene, TAIL_MODEL, "crandall.paths")
    n = check_int("n", n, 1, 100_000)
    points = check_int("points", points, 2, 100_000)
    seed = as_seed(seed)
    if seed is None:
        seed = draw_seed()
    seed = check_int("seed", seed, 0, MAX_SEED)
    asked = None
    if times is not None:
        if isinstance(times, (str, bytes)):
            raise ParameterError("times", f"times must be a sequence of numbers, got {times!r}")
        try:
            asked = np.asarray(times, dtype=np.float64).ravel()
        except (TypeError, ValueError):
            raise ParameterError("times", f"times must be a sequence of numbers, got {times!r}") from None
        if asked.size == 0 or not np.isfinite(asked).all() or (asked < 0).any() \
                or (np.diff(asked) <= 0).any():
            raise ParameterError("times", "times must be finite, >= 0 and strictly increasing")
    c = scene.drift
    horizon = scene.t0  # the end of the last shaken piece (0: no noise at all)
    last = float(scene.times[-1]) if scene.times.size else 0.0
    if not math.isfinite(horizon):
        horizon = float(asked[-1]) if asked is not None else last
        if not horizon > 0:
            raise ParameterError("times", "times: the shaking never ends; give the times to "
                                          "draw (or output times in the scene)")
    if dt is None:
        dt = default_dt(scene)
        if horizon > 0:
            dt = min(dt, horizon / points)
    dt = check_positive("dt", dt)
    extra = asked if asked is not None else np.linspace(0.0, horizon, points)
    grid = _grid(scene, horizon, dt, extra) if horizon > 0 else np.array([0.0])
    need = n * grid.size * 3 * 8
    if n * grid.size > MAX_VALUES or need > available_memory() // 2:
        raise ParameterError("dt", f"dt: {n} paths on {grid.size} grid times need "
                                   f"{need / 2**30:.2g} GiB; give fewer paths, fewer times or a "
                                   "larger dt")
    states = np.empty((n, grid.size, 3))
    states[:, 0] = (scene.v0, scene.u0, 0.0)
    if grid.size > 1:
        lengths = np.diff(grid)
        _core.extend_paths(states, np.arange(n, dtype=np.int64), np.zeros(n, dtype=np.int64),
                           np.arange(n, dtype=np.uint64), lengths, _noise_at(scene, grid[:-1]),
                           np.full(lengths.size, c), _streams.paths_key(seed),
                           resolve_threads(threads)[0])
    v_end, u_end, s_end = states[:, -1, 0], states[:, -1, 1], states[:, -1, 2]
    can_stop = c > 0 and math.isfinite(scene.t0)
    stop = horizon + np.abs(v_end) / c if can_stop else np.full(n, np.nan)
    if asked is None:
        right = max(last, float(np.max(stop)) if can_stop else horizon)
        after = (np.linspace(horizon, right, max(2, points // 4))[1:] if right > horizon
                 else np.empty(0))
        out_times = np.concatenate([np.linspace(0.0, horizon, points) if horizon > 0
                                    else [0.0], after])
        out_times = np.unique(out_times)
    else:
        out_times = asked
    inside = out_times <= horizon
    values = np.empty((3, n, out_times.size))
    idx = np.searchsorted(grid, out_times[inside])
    for k in range(3):
        values[k][:, inside] = states[:, idx, k]
    if (~inside).any():
        # The coast: deceleration c to rest, in closed form (docs/exact-step.md).
        tau = out_times[~inside][None, :] - horizon
        speed = np.abs(v_end)[:, None]
        moving = np.minimum(tau, speed / c) if c > 0 else np.broadcast_to(tau, (n, tau.size))
        travelled = speed * moving - 0.5 * c * moving ** 2
        values[0][:, ~inside] = np.sign(v_end)[:, None] * np.maximum(speed - c * tau, 0.0) \
            if c > 0 else v_end[:, None]
        values[1][:, ~inside] = u_end[:, None] + np.sign(v_end)[:, None] * travelled
        values[2][:, ~inside] = s_end[:, None] + travelled
    unit = {name: scene.units_of(name) or "1" for name in ("velocity", "displacement",
                                                           "distance", "stop_time")}
    time_unit = "s" if scene.units == "SI" else "1"
    ds = xr.Dataset(
        {name: (("path", "time"), values[k], {"units": unit[name], "long_name": name})
         for k, name in enumerate(("velocity", "displacement", "distance"))},
        coords={"path": np.arange(n), "time": ("time", out_times, {"units": time_unit})},
        attrs={"scene": json.dumps(scene.to_dict()), "seed": str(seed), "dt": dt,
               "units_system": scene.units})
    ds["stop_time"] = ("path", stop, {"units": unit["stop_time"], "long_name": "stop time"})
    return ds


def _require_xarray():
    try:
        import xarray
    except ImportError:  # pragma: no cover - depends on the environment
        raise ImportError("paths need xarray: pip install 'crandall[io]'") from None
    return xarray
