"""A fragility grid's points and their runs: the axes, a grid's values, each point's scene,
the plan that shares one scaled tail run among points with the same tau0 where the scaling of
eq8 holds, and the runs themselves."""

from __future__ import annotations

import math
import numbers
import warnings
from dataclasses import dataclass
from typing import Any, Dict, List, Optional, Sequence, Tuple

import numpy as np

from ..errors import ParameterError
from ..model import SCALING, holds
from ..scene import Scene
from ..tail import TailResult, tail


#: The grid's axis: the shaking's intensity h (an envelope's scale) or the friction mu. A grid
#: over both has ``axis="intensity"`` and ``by="mu"``: a curve over h for each mu.
AXES = ("intensity", "mu")


#: The direction in which P grows along an axis: +1 with the shaking's intensity (h, or a
#: record's PGA), -1 with a friction or yield (crandall.suites' axes too).
_SIGN = {"intensity": 1.0, "pga": 1.0, "mu": -1.0, "ky": -1.0, "kd": -1.0}


#: Each axis's label in tables and figures.
_LABEL = {"intensity": "intensity h [m s^-3/2]", "mu": "friction mu", "pga": "PGA [g]",
          "ky": "yield ky [g]", "kd": "downslope yield kd [g]"}


_SHORT = {"intensity": "h", "mu": "mu", "pga": "PGA", "ky": "ky", "kd": "kd"}


#: The scaled unit of each tail quantity (crandall.units.Scaling's kinds); the dissipated
#: energy m mu g S is the scene's mass times the energy scale (m c S = m (h^2/c)^2 2 U3 / 2).
_KIND = {"stop_time": "time", "velocity": "velocity", "speed": "velocity",
         "peak_speed_at_stop": "velocity", "distance_at_stop": "length",
         "displacement_at_stop": "length", "residual_displacement": "length",
         "peak_displacement_at_stop": "length", "dissipated_energy_at_stop": "energy"}


#: 97.5 % point of the standard normal (the 95 % intervals of the fit and the hazard).
_Z95 = 1.959963984540054


def _real(x) -> bool:
    return isinstance(x, numbers.Real) and not isinstance(x, bool)


def _grid(name: str, values) -> np.ndarray:
    """A grid of positive, finite, strictly increasing numbers (ParameterError naming it)."""
    if isinstance(values, (str, bytes)) or values is None:
        raise ParameterError(name, f"{name} must be a sequence of numbers, got {values!r}")
    try:
        items = list(np.atleast_1d(np.asarray(values, dtype=object)).ravel())
    except (TypeError, ValueError):
        raise ParameterError(name, f"{name} must be a sequence of numbers, got {values!r}") from None
    if not items:
        raise ParameterError(name, f"{name} must not be empty")
    for i, v in enumerate(items):
        if not _real(v):
            raise ParameterError(name, f"{name}[{i}] must be a real number, got {v!r}")
    arr = np.array([float(v) for v in items])
    bad = np.flatnonzero(~(np.isfinite(arr) & (arr > 0)))
    if bad.size:
        i = int(bad[0])
        raise ParameterError(name, f"{name} must be finite and > 0, got {name}[{i}] = {arr[i]!r}")
    if arr.size > 1 and not (np.diff(arr) > 0).all():
        raise ParameterError(name, f"{name} must be strictly increasing (sorted, no repeats)")
    return arr


def scene_intensity(scene: Scene) -> float:
    """The intensity a fragility grid over h replaces: h of a one-intensity scene, the largest
    piece's of a piecewise one (every piece scaled with it), a named envelope's ``h`` (its
    scale), a function envelope's largest piece."""
    env = scene.params.get("envelope")
    if env is not None:
        return float(max(env["h"]) if env["kind"] == "function" else env["h"])
    h = scene.params["h"]
    return float(max(h)) if isinstance(h, list) else float(h)


def point_scene(scene: Scene, axis: str, x: float) -> Scene:
    """The scene at one grid point: its intensity (see :func:`scene_intensity`) or its mu
    set to ``x``, everything else as given."""
    data = scene.to_dict()
    if axis == "mu":
        data["mu"] = float(x)
    elif "envelope" in data:
        env = dict(data["envelope"])
        if env["kind"] == "function":
            ref = max(env["h"])
            env["h"] = [v * x / ref for v in env["h"]]
        else:
            env["h"] = float(x)
        data["envelope"] = env
    elif isinstance(data["h"], list):
        ref = max(data["h"])
        data["h"] = [v * x / ref for v in data["h"]]
    else:
        data["h"] = float(x)
    return Scene.from_dict(data)


def _unit(scene: Scene, quantity: str) -> float:
    """The SI size of one scaled unit of ``quantity`` for ``scene`` (its Scaling)."""
    kind = _KIND[quantity]
    if kind == "energy":
        return scene.mass * scene.scaling.energy_scale
    return scene.scaling.scale(kind)


def _run_seed(seed: int, run: int) -> int:
    """Run ``run``'s seed: a pure function of the fragility's seed and the run's index."""
    state = np.random.SeedSequence(entropy=seed, spawn_key=(run,)).generate_state(2, np.uint64)
    return int(state[0])


@dataclass
class _Run:
    """One tail run: the grid points it serves and, per point, the index of each threshold in
    its levels; ``scene``, ``time``, ``dt`` as handed to crandall.tail; ``scaled``: a run of the
    scaled scene through :data:`crandall.model.SCALING` (for one point or several)."""

    points: List[int]
    scene: Scene
    levels: np.ndarray
    index: Dict[int, np.ndarray]
    time: Optional[float]
    dt: Optional[float]
    scaled: bool


def plan(scene: Scene, quantity: str, thresholds: np.ndarray, scenes: Sequence[Scene], *,
         time: Optional[float] = None, dt: Optional[float] = None,
         share: bool = True) -> List[_Run]:
    """The tail runs a grid of point scenes needs. Where the scaling identity holds
    (:data:`crandall.model.SCALING`, asked of the user's scene with ``model.holds``), points of
    the same scaled duration tau0 = t0 (mu g)^2 / (2 h^2) (to 1e-12, relative) share one run of
    the scaled scene, at the union of their thresholds in scaled units (times and ``dt`` in
    scaled time too: the tail's default step, 0.01 in scaled time, is the SI default of every
    point); otherwise (or with ``share=False``) each point is one run on its own scene."""
    runs: List[_Run] = []
    if share and holds(scene, SCALING) and all(s.scaling is not None for s in scenes):
        groups: List[Tuple[float, List[int]]] = []
        for j, s in enumerate(scenes):
            tau0 = s.scaling.to_tau(s.t0)
            for key, members in groups:
                if abs(key - tau0) <= 1e-12 * max(abs(key), abs(tau0)):
                    members.append(j)
                    break
            else:
                groups.append((tau0, [j]))
        for tau0, members in groups:
            first = scenes[members[0]].scaling
            scaled_time = None if time is None else first.to_tau(time)
            scaled = Scene.scaled(tau0=tau0, observe=["velocity"],
                                  times=[scaled_time if scaled_time is not None else
                                         (tau0 if math.isfinite(tau0) else 1.0)])
            per = {j: thresholds / _unit(scenes[j], quantity) for j in members}
            levels = np.unique(np.concatenate(list(per.values())))
            index = {j: np.searchsorted(levels, v) for j, v in per.items()}
            runs.append(_Run(members, scaled, levels, index, scaled_time,
                             None if dt is None else first.to_tau(dt), True))
        return runs
    for j, s in enumerate(scenes):
        runs.append(_Run([j], s, thresholds.copy(), {j: np.arange(len(thresholds))}, time, dt,
                         False))
    return runs


def _run_points(scene: Scene, quantity: str, thr: np.ndarray, scenes: Sequence[Scene],
                labels: Sequence[str], *, rel_error: float, seed: int, threads, progress, time,
                dt, method: str, max_seconds: float, share: bool) -> Dict[str, Any]:
    """The tail runs of :func:`plan` for the point scenes ``scenes`` (named ``labels`` in the
    tail's warnings): the arrays over (point, threshold), each point's run, whether any run
    served several points, the runs' seconds and steps."""
    runs = plan(scene, quantity, thr, scenes, time=time, dt=dt, share=share)
    shape = (len(scenes), len(thr))
    prob, err, low, high = (np.full(shape, np.nan) for _ in range(4))
    reliable = np.zeros(shape, dtype=bool)
    which = np.zeros(len(scenes), dtype=np.int64)
    results: List[TailResult] = []
    for r, run in enumerate(runs):
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            res = tail(run.scene, quantity, run.levels, time=run.time, rel_error=rel_error,
                       seed=_run_seed(seed, r), dt=run.dt, threads=threads, progress=progress,
                       method=method, max_seconds=max_seconds)
        # The tail's warnings, said of the grid points they concern (a scaled run's levels
        # are in scaled units).
        where = (f"fragility at {'; '.join(labels[j] for j in run.points)}"
                 f"{' (a scaled run: its levels in scaled units)' if run.scaled else ''}")
        for w in caught:
            warnings.warn(f"{where}: {w.message}", w.category, stacklevel=4)
        lo, hi = res.interval()
        for j in run.points:
            k = run.index[j]
            prob[j], err[j], low[j], high[j] = (res.probability[k], res.stderr[k], lo[k], hi[k])
            reliable[j] = res.reliable[k]
            which[j] = r
        results.append(res)
    return dict(probability=prob, stderr=err, low=low, high=high, reliable=reliable, run=which,
                shared=any(len(run.points) > 1 for run in runs),
                seconds=float(sum(x.seconds for x in results)),
                steps=int(sum(x.steps for x in results)))
