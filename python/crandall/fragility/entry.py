""":func:`fragility`: P(Q > threshold) over a grid of intensities or frictions, or both, and
:func:`run_grid`, the runs of one axis gathered into a :class:`FragilityResult`."""

from __future__ import annotations

from typing import Optional, Sequence

import numpy as np

from ..errors import ParameterError
from ..scene import Scene
from ..spec import MAX_SEED, as_seed, check_int, draw_seed
from ..tail import TAIL_QUANTITIES
from .grid import _grid, _run_points, point_scene
from .result import FragilityResult


def fragility(scene: Scene, quantity: str, thresholds, *, intensities=None, mu=None,
              rel_error: float = 0.1, seed=None, threads: Optional[int] = None,
              progress: Optional[bool] = None, time: Optional[float] = None,
              dt: Optional[float] = None, method: str = "splitting",
              max_seconds: float = 3600.0, share: bool = True) -> "FragilityResult":
    """P(quantity > threshold) over a grid of intensities h, of frictions mu, or of both, each
    grid point a :func:`crandall.tail` run with its 95 % interval.

    Parameters
    ----------
    scene : Scene
        A scene in SI units: the paper's (from rest, one intensity until t0), or one with a
        start in motion, a piecewise intensity or an envelope.
    quantity : str
        One of ``crandall.tail.TAIL_QUANTITIES`` ("distance_at_stop", "stop_time", ...).
    thresholds : sequence of float
        Strictly increasing, > 0, in the scene's units of the quantity.
    intensities, mu : sequence of float
        The grid: one of them, or both. ``intensities`` replaces the scene's h (a piecewise
        scene's largest piece, every piece scaled with it; a named envelope's ``h``, a
        function envelope's largest piece); ``mu`` replaces its friction. Strictly increasing,
        > 0. With both, the grid is their product: a curve over h for each mu
        (``result.by == "mu"``), whose points of one scaled duration share a run.
    rel_error : float, default 0.1
        Each run's target relative error (crandall.tail's).
    seed : int, numpy SeedSequence or Generator, optional
        The fragility's seed (as :func:`crandall.simulate` takes it); run r gets a seed drawn from (seed, r), so the result is a pure
        function of it (a seed is drawn and kept in ``result.seed`` when not given).
    threads, progress, time, dt, method, max_seconds
        As for :func:`crandall.tail` (``dt`` in seconds; on scaled runs converted to scaled
        time; ``max_seconds`` bounds each run).
    share : bool, default True
        Share runs through :data:`crandall.model.SCALING` where it holds (False: one run per
        grid point, e.g. to check the sharing).

    Returns
    -------
    FragilityResult
    """
    if not isinstance(scene, Scene):
        raise ParameterError("scene", f"scene must be a crandall.Scene, got {type(scene).__name__}")
    if scene.units != "SI":
        raise ParameterError("scene", "scene: a fragility grid replaces h or mu, which a scene "
                                      "in scaled units does not have; give an SI scene")
    if not isinstance(quantity, str) or quantity not in TAIL_QUANTITIES:
        raise ParameterError("quantity", f"quantity must be one a tail run estimates "
                                         f"({', '.join(TAIL_QUANTITIES)}); got {quantity!r}")
    if intensities is None and mu is None:
        raise ParameterError("intensities, mu", "intensities, mu: give one of them or both "
                                                "(the grid's axes)")
    hs = None if intensities is None else _grid("intensities", intensities)
    ms = None if mu is None else _grid("mu", mu)
    thr = _grid("thresholds", thresholds)
    if not isinstance(share, bool):
        raise ParameterError("share", f"share must be True or False, got {share!r}")
    seed = as_seed(seed)
    seed = check_int("seed", draw_seed() if seed is None else seed, 0, MAX_SEED)
    args = dict(rel_error=rel_error, seed=seed, threads=threads, progress=progress, time=time,
                dt=dt, method=method, max_seconds=max_seconds, share=share)
    if hs is None or ms is None:
        axis = "intensity" if ms is None else "mu"
        values = hs if ms is None else ms
        scenes = [point_scene(scene, axis, x) for x in values]
        return run_grid(scene, quantity, thr, scenes, axis, values, **args)
    scenes = [point_scene(point_scene(scene, "intensity", h), "mu", m) for h in hs for m in ms]
    labels = [f"(h, mu) = ({h:.4g}, {m:.4g})" for h in hs for m in ms]
    out = _run_points(scene, quantity, thr, scenes, labels, **args)
    shape = (len(hs), len(ms))
    for name in ("probability", "stderr", "low", "high", "reliable"):
        out[name] = out[name].reshape(shape + (len(thr),))
    out["run"] = out["run"].reshape(shape)
    return FragilityResult(quantity=quantity, axis="intensity", values=hs, by="mu", by_values=ms,
                           thresholds=thr, units=TAIL_QUANTITIES[quantity].si_unit, seed=seed,
                           scene=scene.to_dict(), method=method,
                           rel_error_target=float(rel_error), **out)


def run_grid(scene: Scene, quantity: str, thr: np.ndarray, scenes: Sequence[Scene], axis: str,
             values: np.ndarray, *, rel_error: float, seed: int, threads, progress, time, dt,
             method: str, max_seconds: float, share: bool) -> "FragilityResult":
    """The tail runs of :func:`plan` for the point scenes ``scenes`` (labelled ``values`` on
    ``axis``), gathered into a one-axis FragilityResult; ``scene`` is the user's scene, whose
    effects decide whether runs are shared. (:func:`fragility` builds the points from its
    axes; any (h, mu) points may be given here.)"""
    name = "h" if axis == "intensity" else "mu"
    out = _run_points(scene, quantity, thr, scenes, [f"{name} = {x:.4g}" for x in values],
                      rel_error=rel_error, seed=seed, threads=threads, progress=progress,
                      time=time, dt=dt, method=method, max_seconds=max_seconds, share=share)
    return FragilityResult(quantity=quantity, axis=axis, values=values, thresholds=thr,
                           units=TAIL_QUANTITIES[quantity].si_unit, seed=seed,
                           scene=scene.to_dict(), method=method,
                           rel_error_target=float(rel_error), **out)
