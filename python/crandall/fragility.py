"""Fragility curves: P(Q > threshold) over a grid of intensities or frictions, a lognormal fit
and the annual rate of exceedance under a site's hazard curve (docs/fragility.md).

Each grid point is a :func:`crandall.tail` run (splitting by default), with its 95 % interval.
On the paper's scene (from rest, one intensity until t0) the scaling of eq8 is exact
(:data:`crandall.model.SCALING`): in scaled units P(Q > q) depends only on q over its scaled
unit and on tau0 = t0 (mu g)^2 / (2 h^2), so grid points (h, mu) with the same tau0 share one
scaled run at the union of their scaled thresholds. Where the scene holds an effect that
identity does not support (a start in motion, a piecewise schedule, an envelope), each grid
point is run on its own scene.
"""

from __future__ import annotations

import html
import json
import math
import numbers
import os
import re
import warnings
from dataclasses import dataclass, field, replace
from typing import Any, Dict, List, Optional, Sequence, Tuple, Union

import numpy as np

from ._files import write_atomic
from .errors import ParameterError
from .model import SCALING, holds
from .results import StatisticsWarning
from .scene import Scene
from .tail import TAIL_QUANTITIES, TailResult, tail

__all__ = ["fragility", "FragilityResult", "LognormalFit", "Hazard", "load", "AXES",
           "read_hazard_curve", "hazard_csv"]

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
    seed : int, optional
        The fragility's seed; run r gets a seed drawn from (seed, r), so the result is a pure
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
    if seed is None:
        seed = int(np.random.SeedSequence().entropy % (1 << 63))
    if not (isinstance(seed, (int, np.integer)) and not isinstance(seed, bool)
            and 0 <= seed < (1 << 64)):
        raise ParameterError("seed", f"seed must be an integer in [0, 2^64), got {seed!r}")
    seed = int(seed)
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
                           thresholds=thr, units=TAIL_QUANTITIES[quantity].unit, seed=seed,
                           scene=scene.to_dict(), method=method,
                           rel_error_target=float(rel_error), **out)


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
                           units=TAIL_QUANTITIES[quantity].unit, seed=seed,
                           scene=scene.to_dict(), method=method,
                           rel_error_target=float(rel_error), **out)


@dataclass
class LognormalFit:
    """Per threshold, the lognormal fragility curve P = Phi(s ln(x / median) / beta) (s = +1 over
    intensities, -1 over mu: P falls as the friction grows), fitted by
    :meth:`FragilityResult.fit_lognormal`. ``covariance[k]`` is that of (ln median, beta);
    ``chi2`` and ``dof`` the fit's weighted sum of squares and its degrees of freedom; ``points``
    how many grid points entered (NaN fits where fewer than 2 did)."""

    thresholds: np.ndarray
    median: np.ndarray
    median_stderr: np.ndarray
    median_low: np.ndarray
    median_high: np.ndarray
    beta: np.ndarray
    beta_stderr: np.ndarray
    beta_low: np.ndarray
    beta_high: np.ndarray
    covariance: np.ndarray
    chi2: np.ndarray
    dof: np.ndarray
    points: np.ndarray
    sign: float = 1.0

    def probability(self, x, k: int = 0) -> np.ndarray:
        """The fitted curve of threshold ``k`` at ``x``."""
        from scipy.special import ndtr

        x = np.asarray(x, dtype=float)
        return ndtr(self.sign * (np.log(x) - math.log(self.median[k])) / self.beta[k])

    def __str__(self) -> str:
        lines = [f"{'threshold':>12} {'median':>11} {'95% interval':>23} {'beta':>8} "
                 f"{'95% interval':>19} {'chi2/dof':>9}"]
        for k, d in enumerate(self.thresholds):
            dof = int(self.dof[k])
            fit = f"{self.chi2[k] / dof:9.2f}" if dof > 0 else f"{'-':>9}"
            lines.append(f"{d:12.6g} {self.median[k]:11.4g} [{self.median_low[k]:9.4g}, "
                         f"{self.median_high[k]:9.4g}] {self.beta[k]:8.4f} "
                         f"[{self.beta_low[k]:7.4f}, {self.beta_high[k]:7.4f}] {fit}")
        return "\n".join(lines)


@dataclass
class Hazard:
    """The annual rate of exceeding each threshold, with its standard error and 95 % interval
    (:meth:`FragilityResult.hazard`)."""

    thresholds: np.ndarray
    rate: np.ndarray
    stderr: np.ndarray
    low: np.ndarray
    high: np.ndarray
    #: With ``use="estimates"``: the most the shaking outside the grid could add (its part
    #: below the grid is left out, above it counted with P at the grid's end); 0 for the fit.
    outside: Optional[np.ndarray] = None
    #: "fit" or "estimates" (:meth:`FragilityResult.hazard`).
    use: str = "fit"

    def __str__(self) -> str:
        lines = [f"annual rate of exceedance ({'the lognormal fit' if self.use == 'fit' else 'the grid estimates'})",
                 f"{'threshold':>12} {'rate / yr':>11} {'stderr':>10} {'95% interval':>23}"
                 + (f" {'outside grid, up to':>20}" if self.use == "estimates" else "")]
        for k, d in enumerate(self.thresholds):
            extra = f" {self.outside[k]:20.3g}" if self.use == "estimates" else ""
            lines.append(f"{d:12.6g} {self.rate[k]:11.4g} {self.stderr[k]:10.3g} "
                         f"[{self.low[k]:9.4g}, {self.high[k]:9.4g}]{extra}")
        return "\n".join(lines)


def _hazard_curve(curve) -> Tuple[np.ndarray, np.ndarray]:
    try:
        im, rate = curve
    except (TypeError, ValueError):
        raise ParameterError("curve", "curve must be two arrays (intensities, annual rates of "
                                      "exceeding each)") from None
    im = _grid("curve", im)
    try:
        rate = np.asarray(rate, dtype=float)
    except (TypeError, ValueError):
        raise ParameterError("curve", "curve: the rates must be numbers") from None
    if rate.shape != im.shape:
        raise ParameterError("curve", f"curve: {im.size} intensities but {rate.size} rates")
    if not (np.isfinite(rate).all() and (rate > 0).all()):
        raise ParameterError("curve", "curve: the rates must be finite and > 0")
    if im.size < 2 or (np.diff(rate) > 0).any():
        raise ParameterError("curve", "curve: at least two points, the rates non-increasing "
                                      "(a rate of exceedance falls as the intensity grows)")
    return im, rate


def read_hazard_curve(path: Union[str, "os.PathLike[str]"]) -> Tuple[np.ndarray, np.ndarray]:
    """A hazard curve from a text file: two columns, the intensity (increasing) and the annual
    rate of shaking stronger than it (non-increasing), separated by a comma, semicolon or
    blanks; blank lines, lines starting with ``#`` and one header line (the first line that
    is not numbers) skipped. Checked as :meth:`FragilityResult.hazard` checks a curve.

    Raises
    ------
    ParameterError
        Naming ``hazard``: an unreadable file, a line that is not two numbers, too few
        points, intensities not increasing or rates not non-increasing, not finite or <= 0.
    """
    p = os.fspath(path)
    try:
        with open(p, encoding="utf-8-sig") as f:
            lines = f.read().splitlines()
    except (OSError, UnicodeDecodeError) as exc:
        raise ParameterError("hazard", f"hazard: cannot read {p!r}: "
                                       f"{getattr(exc, 'strerror', None) or exc}") from None
    rows: List[Tuple[float, float]] = []
    header = False
    for number, line in enumerate(lines, 1):
        text = line.strip()
        if not text or text.startswith("#"):
            continue
        cells = [c for c in re.split(r"[,;\s]+", text) if c]
        try:
            values = [float(c) for c in cells]
        except ValueError:
            if not rows and not header:
                header = True
                continue
            raise ParameterError("hazard", f"hazard: {p!r} line {number} is not numbers: "
                                           f"{text[:60]!r}") from None
        if len(values) != 2:
            raise ParameterError("hazard", f"hazard: {p!r} line {number} has {len(values)} "
                                           f"columns; give two (intensity, annual rate)")
        rows.append((values[0], values[1]))
    if not rows:
        raise ParameterError("hazard", f"hazard: {p!r} holds no (intensity, rate) lines")
    im, rate = np.array(rows).T
    try:
        return _hazard_curve((im, rate))
    except ParameterError as exc:
        raise ParameterError("hazard", f"hazard: {p!r}: {exc}") from None


def hazard_csv(hazards: Sequence[Hazard], units: str = "", by: Optional[str] = None,
               by_values: Optional[np.ndarray] = None) -> str:
    """The annual rates as CSV text: a row per threshold (and value of ``by``, a column before
    it, for the hazards of a grid over two axes): threshold, rate, stderr, the 95 % interval
    and, with ``use="estimates"``, the most the shaking outside the grid could add."""
    unit = f" [{units}]" if units else ""
    cols = ([by] if by else []) + [f"threshold{unit}", "rate [1/yr]", "stderr [1/yr]",
                                   "low [1/yr]", "high [1/yr]", "outside [1/yr]"]
    out = ["# annual rate of exceeding each threshold, 95 % intervals; through "
           + ("the lognormal fit" if hazards[0].use == "fit" else "the grid estimates"),
           ",".join(cols)]
    for j, hz in enumerate(hazards):
        lead = [] if by is None else [repr(float(by_values[j]))]
        for k, d in enumerate(hz.thresholds):
            extra = hz.outside[k] if hz.outside is not None else 0.0
            out.append(",".join(lead + [repr(float(v)) for v in
                                        (d, hz.rate[k], hz.stderr[k], hz.low[k], hz.high[k],
                                         extra)]))
    return "\n".join(out) + "\n"


#: The hazard integral's largest sub-grid step in ln x (the trapezoid rule's relative error
#: is then about 1e-5 for a power law of exponent 2.5: tests/test_fragility.py).
_HAZARD_STEP = 0.002


def _sub_grid(lx, lr, lo, hi, extra=()):
    """ln x on [lo, hi] in steps of at most _HAZARD_STEP through every point of ``lx`` and
    ``extra`` inside, and lambda there (interpolated linearly in (ln x, ln lambda))."""
    knots = np.unique(np.concatenate([[lo, hi], lx[(lx > lo) & (lx < hi)],
                                      np.asarray(extra, dtype=float)[(np.asarray(extra) > lo)
                                                                     & (np.asarray(extra) < hi)]]))
    pieces = [np.linspace(a, b, max(1, int(math.ceil((b - a) / _HAZARD_STEP))) + 1)[:-1]
              for a, b in zip(knots[:-1], knots[1:])]
    sub = np.concatenate(pieces + [knots[-1:]])
    return sub, np.exp(np.interp(sub, lx, lr))


@dataclass
class FragilityResult:
    """P(quantity > threshold) over a grid of intensities or frictions, or both.

    Attributes
    ----------
    quantity, axis, values, thresholds, units
        The quantity; the grid's axis ("intensity": h in m s^-3/2, or "mu") and its values;
        the thresholds and their unit.
    by, by_values
        A grid over two axes: the second one ("mu") and its values, a curve over ``axis`` for
        each (None for a grid over one axis). :meth:`section` gives the curve of one.
    probability, stderr, low, high : ndarray, shape (len(values), [len(by_values),] len(thresholds))
        The tail estimates, their standard errors and 95 % intervals (crandall.tail's).
    reliable : ndarray of bool
        crandall.tail's flag (False: not a clean estimate; left out of the fit).
    run : ndarray of int, shape (len(values), [len(by_values)])
        The tail run each grid point came from (points of one run share it: the scaling
        identity, :data:`crandall.model.SCALING`); ``runs`` counts the distinct ones.
    shared : bool
        Whether any run served several points.
    seed, scene, seconds, steps, method
        The fragility's seed, the user's scene (plain data), the runs' total wall time and
        exact steps, the tail method.
    """

    #: The axes a result of this class may have (crandall.suites' records have theirs).
    _axes = AXES
    #: The netCDF attribute that marks a saved result of this class.
    _file_attr = "crandall_fragility"
    #: What the tables say of the intervals.
    _intervals = "95 % intervals (the tail's)"

    quantity: str
    axis: str
    values: np.ndarray
    thresholds: np.ndarray
    probability: np.ndarray
    stderr: np.ndarray
    low: np.ndarray
    high: np.ndarray
    reliable: np.ndarray
    units: str = ""
    run: Optional[np.ndarray] = None
    shared: bool = False
    seed: Optional[int] = None
    scene: Dict[str, Any] = field(default_factory=dict)
    seconds: float = 0.0
    steps: int = 0
    method: str = "splitting"
    rel_error_target: float = 0.1
    by: Optional[str] = None
    by_values: Optional[np.ndarray] = None

    def __post_init__(self) -> None:
        self.values = np.asarray(self.values, dtype=float)
        self.thresholds = np.asarray(self.thresholds, dtype=float)
        for name in ("probability", "stderr", "low", "high"):
            setattr(self, name, np.asarray(getattr(self, name), dtype=float))
        self.reliable = np.asarray(self.reliable, dtype=bool)
        if self.axis not in self._axes:
            raise ValueError(f"axis must be one of {', '.join(self._axes)}, got {self.axis!r}")
        if (self.by is None) != (self.by_values is None):
            raise ValueError("by, by_values: give both (a grid over two axes) or neither")
        grid: Tuple[int, ...] = (len(self.values),)
        if self.by is not None:
            if self.by not in self._axes or self.by == self.axis:
                raise ValueError(f"by must be one of {', '.join(self._axes)} other than the "
                                 f"axis, got {self.by!r}")
            self.by_values = np.asarray(self.by_values, dtype=float)
            grid += (len(self.by_values),)
        if self.run is None:
            self.run = np.arange(int(np.prod(grid))).reshape(grid)
        self.run = np.asarray(self.run, dtype=np.int64)
        if self.run.shape != grid:
            raise ValueError(f"run: shape {self.run.shape}, expected {grid}")
        shape = grid + (len(self.thresholds),)
        for name in ("probability", "stderr", "low", "high", "reliable"):
            if getattr(self, name).shape != shape:
                raise ValueError(f"{name}: shape {getattr(self, name).shape}, expected {shape}")

    @property
    def axis_label(self) -> str:
        return _LABEL[self.axis]

    @property
    def runs(self) -> int:
        """How many distinct runs (tail runs; for records, newmark sweeps) made the grid."""
        return int(np.unique(self.run).size)

    def sections(self) -> List["FragilityResult"]:
        """The curves over ``axis``, one per value of ``by`` (``[self]`` for one axis)."""
        if self.by is None:
            return [self]
        return [self.section(j) for j in range(len(self.by_values))]

    def section(self, j: int) -> "FragilityResult":
        """The curve over ``axis`` at ``by_values[j]`` of a grid over two axes: a one-axis
        result of the same class, its scene's ``by`` set to that value (``shared`` and
        ``seconds`` remain the whole grid's)."""
        if self.by is None:
            raise ValueError("section: this result is over one axis")
        if not (isinstance(j, (int, np.integer)) and -len(self.by_values) <= j < len(self.by_values)):
            raise ParameterError("j", f"j must be an index into by_values "
                                      f"(0 ... {len(self.by_values) - 1}), got {j!r}")
        scene = dict(self.scene)
        if scene and self.by in scene:
            scene[self.by] = float(self.by_values[j])
        sliced = {name: getattr(self, name)[:, j] for name in
                  ("probability", "stderr", "low", "high", "reliable", "run")}
        return replace(self, by=None, by_values=None, scene=scene,
                       **sliced, **self._section_extra(int(j)))

    def _section_extra(self, j: int) -> Dict[str, Any]:
        """The fields a subclass slices for :meth:`section` (none here)."""
        return {}

    @property
    def _by_label(self) -> str:
        return "" if self.by is None else _SHORT[self.by]

    # -- the lognormal fit -----------------------------------------------------------------

    def fit_lognormal(self) -> Union[LognormalFit, List[LognormalFit]]:
        """The lognormal fragility curve of each threshold by maximum likelihood: a
        :class:`LognormalFit`; over two axes, a list of them, the curve over ``axis`` for each
        value of ``by`` (``[s.fit_lognormal() for s in self.sections()]``).

        Model: P(x) = Phi(s (ln x - ln median) / beta), s = +1 over intensities, -1 over mu.

        Likelihood: at grid point i the tail's estimate p_i is the mean of many independent
        replicas (or weighted paths), so it is close to normal with the reported standard
        error se_i; its logarithm, by the delta method, close to normal with standard
        deviation se_i / p_i (the relative error, about the run's target at every point). The
        fit maximises

            L = prod_i exp(-(ln Phi(s (ln x_i - ln median) / beta) - ln p_i)^2 / (2 (se_i / p_i)^2)),

        a weighted least squares on ln p. The logarithm, not p itself: p spans decades and a
        relative error is what a tail run controls, so a misfit by a factor 10 weighs the
        same at 1e-9 and at 1e-2, where on p it would weigh 1e7 times less at 1e-9. Points
        left out: p = 0, se = 0 (no noise to weigh), and those the tail did not flag reliable.

        Uncertainty: the inverse of the Gauss-Newton information J^T J at the optimum (J the
        Jacobian of the weighted residuals in (ln median, beta)), multiplied by chi2 / dof
        when that exceeds 1 (the Birge ratio: a curve that is not quite lognormal, which the
        estimates' own errors would not explain, widens the parameters' errors instead of
        hiding behind them). The 95 % intervals: exp(ln median +- 1.96 se) and
        beta +- 1.96 se (clipped at 0).
        """
        if self.by is not None:
            return [s.fit_lognormal() for s in self.sections()]
        return self._fit()

    def _fit(self) -> LognormalFit:
        from scipy.optimize import least_squares
        from scipy.special import log_ndtr, ndtri

        sign = _SIGN[self.axis]
        lx = np.log(self.values)
        n = len(self.thresholds)
        out = {k: np.full(n, np.nan) for k in ("median", "median_stderr", "median_low",
                                              "median_high", "beta", "beta_stderr", "beta_low",
                                              "beta_high", "chi2")}
        cov_all = np.full((n, 2, 2), np.nan)
        dof = np.zeros(n, dtype=np.int64)
        points = np.zeros(n, dtype=np.int64)
        for k in range(n):
            p, se = self.probability[:, k], self.stderr[:, k]
            use = self.reliable[:, k] & (p > 0) & (se > 0) & np.isfinite(p) & np.isfinite(se)
            points[k] = int(use.sum())
            if points[k] < 2:
                continue
            x, lp, sd = lx[use], np.log(p[use]), se[use] / p[use]

            def residuals(theta):
                return (log_ndtr(sign * (x - theta[0]) / theta[1]) - lp) / sd

            # Start: the probit line, Phi^-1(p) = s (ln x - ln median) / beta.
            zq = ndtri(np.clip(p[use], 1e-300, 1 - 1e-12))
            slope, icept = np.polyfit(x, zq, 1) if len(x) > 1 else (1.0, 0.0)
            slope = sign * slope
            if not (np.isfinite(slope) and slope > 0):
                start = [float(np.mean(x)), 1.0]
            else:
                start = [float(sign * -icept / slope) if sign > 0 else float(icept / slope),
                         1.0 / slope]
            fit = least_squares(residuals, start, bounds=([-np.inf, 1e-9], [np.inf, np.inf]),
                                method="trf", x_scale="jac", xtol=1e-14, ftol=1e-14, gtol=1e-14)
            jac = fit.jac
            chi2 = float(np.sum(fit.fun ** 2))
            dof[k] = len(x) - 2
            try:
                cov = np.linalg.inv(jac.T @ jac)
            except np.linalg.LinAlgError:
                cov = np.full((2, 2), np.inf)
            if dof[k] > 0:
                cov = cov * max(1.0, chi2 / dof[k])
            a, b = fit.x
            sa, sb = math.sqrt(max(cov[0, 0], 0.0)), math.sqrt(max(cov[1, 1], 0.0))
            if not (np.isfinite(a) and abs(a) + _Z95 * sa < 700.0):
                # No lognormal curve rising along the axis fits (the estimates fall where it
                # should rise, or stay flat): the median runs off beyond doubles. NaN, said.
                warnings.warn(f"fit_lognormal: no lognormal curve fits the estimates at "
                              f"threshold {self.thresholds[k]:g} (its median runs off to "
                              f"exp({a:.3g})): left NaN", StatisticsWarning, stacklevel=3)
                continue
            out["median"][k] = math.exp(a)
            out["median_stderr"][k] = math.exp(a) * sa
            out["median_low"][k], out["median_high"][k] = math.exp(a - _Z95 * sa), math.exp(a + _Z95 * sa)
            out["beta"][k], out["beta_stderr"][k] = b, sb
            out["beta_low"][k], out["beta_high"][k] = max(b - _Z95 * sb, 0.0), b + _Z95 * sb
            out["chi2"][k] = chi2
            cov_all[k] = cov
        return LognormalFit(thresholds=self.thresholds.copy(), covariance=cov_all, dof=dof,
                            points=points, sign=sign, **out)

    # -- the hazard ------------------------------------------------------------------------

    def hazard(self, curve, fit: Optional[LognormalFit] = None,
               use: str = "fit") -> Union[Hazard, List[Hazard]]:
        """The annual rate of exceeding each threshold at a site whose hazard curve is
        ``curve = (im, rate)``: ``rate[i]`` the annual rate of shaking stronger than
        ``im[i]`` (the intensity of this result's grid: h in m s^-3/2, or a record suite's
        PGA in g; increasing, the rates non-increasing). A :class:`Hazard`; over two axes a
        list of them, one per value of ``by`` (``fit``, if given, a list of fits as
        :meth:`fit_lognormal` returns).

            lambda_D(d) = int P(D > d | x) |d lambda(x)|

        lambda interpolated linearly in (ln x, ln lambda) between the curve's points (exact
        for a power law), on a sub-grid of steps of at most 0.002 in ln x (the trapezoid rule
        on P against the falls of lambda). Two ways of taking P:

        ``use="fit"`` (default): the fitted lognormal curve (:meth:`fit_lognormal`, or
        ``fit``), over the hazard curve's range; shaking beyond its last point counts with P
        at that point, shaking below its first not at all. Uncertainty: the fit's
        covariance of (ln median, beta) by the delta method (central differences). Where
        the curve is not lognormal (chi2 / dof well above 1) this is the fitted curve's rate.

        ``use="estimates"``: the grid's own estimates, ln P interpolated linearly in ln x
        between grid points (reliable, P > 0), over the part of the hazard curve inside the
        grid; shaking above that part counts with P at its upper end, shaking below it not
        at all (both lower bounds, with P growing with h: ``Hazard.outside`` is the most
        they could add, (1 - P(b)) lambda(b) + P(a) (lambda(im[0]) - lambda(a)) for the part
        [a, b]). Uncertainty: each estimate's standard error, through the integral's
        derivative in it (central differences), added linearly within one tail run (the
        estimates of one run are correlated, by an unknown amount: the sum is the bound)
        and in quadrature across runs (independent).

        The 95 % interval is rate * exp(+-1.96 stderr / rate).
        """
        if _SIGN[self.axis] < 0:
            raise ParameterError("curve", f"curve: a hazard curve is one of the intensity; this "
                                          f"fragility is over {self.axis}")
        if use not in ("fit", "estimates"):
            raise ParameterError("use", f"use must be 'fit' or 'estimates', got {use!r}")
        if self.by is not None:
            fits = [None] * len(self.by_values) if fit is None else list(fit)
            if len(fits) != len(self.by_values):
                raise ParameterError("fit", f"fit: one per value of {self.by} "
                                            f"({len(self.by_values)}), got {len(fits)}")
            return [s.hazard(curve, fit=f, use=use) for s, f in zip(self.sections(), fits)]
        im, rate = _hazard_curve(curve)
        lx, lr = np.log(im), np.log(rate)
        n = len(self.thresholds)
        out, err = np.full(n, np.nan), np.full(n, np.nan)
        outside = np.zeros(n)
        if use == "fit":
            fit = self.fit_lognormal() if fit is None else fit
            from scipy.special import ndtr

            sub_x, lam = _sub_grid(lx, lr, lx[0], lx[-1])
            drop = lam[:-1] - lam[1:]

            def integral(lnmed, beta):
                p = ndtr(fit.sign * (sub_x - lnmed) / beta)
                return float(np.sum(0.5 * (p[:-1] + p[1:]) * drop) + p[-1] * lam[-1])

            for k in range(n):
                if not np.isfinite(fit.median[k]):
                    continue
                a, b = math.log(fit.median[k]), fit.beta[k]
                out[k] = integral(a, b)
                ha, hb = 1e-6 * max(1.0, abs(a)), 1e-6 * b
                grad = np.array([(integral(a + ha, b) - integral(a - ha, b)) / (2 * ha),
                                 (integral(a, b + hb) - integral(a, b - hb)) / (2 * hb)])
                err[k] = math.sqrt(max(float(grad @ fit.covariance[k] @ grad), 0.0))
        else:
            gx = np.log(self.values)
            for k in range(n):
                p, se = self.probability[:, k], self.stderr[:, k]
                use_k = self.reliable[:, k] & (p > 0) & np.isfinite(p) & np.isfinite(se)
                if use_k.sum() < 2:
                    continue
                px, lp, sk, runs = gx[use_k], np.log(p[use_k]), se[use_k], self.run[use_k]
                lo_x, hi_x = max(px[0], lx[0]), min(px[-1], lx[-1])
                if not hi_x > lo_x:
                    continue
                sub_x, lam = _sub_grid(lx, lr, lo_x, hi_x, extra=px)
                drop = lam[:-1] - lam[1:]

                def integral(logp):
                    q = np.exp(np.interp(sub_x, px, logp))
                    return float(np.sum(0.5 * (q[:-1] + q[1:]) * drop) + q[-1] * lam[-1])

                out[k] = integral(lp)
                grad = np.zeros(len(lp))
                for i in range(len(lp)):
                    h = 1e-6
                    up, down = lp.copy(), lp.copy()
                    up[i] += h
                    down[i] -= h
                    # d/dP_i = d/d(ln P_i) / P_i
                    grad[i] = (integral(up) - integral(down)) / (2 * h) / math.exp(lp[i])
                var = 0.0
                for r in np.unique(runs):
                    var += float(np.sum(np.abs(grad[runs == r]) * sk[runs == r])) ** 2
                err[k] = math.sqrt(var)
                p_lo = math.exp(np.interp(lo_x, px, lp))
                p_hi = math.exp(np.interp(hi_x, px, lp))
                lam_lo = math.exp(np.interp(lo_x, lx, lr))
                outside[k] = (max(1.0 - p_hi, 0.0) * lam[-1]
                              + p_lo * (rate[0] - lam_lo))
        with np.errstate(divide="ignore", invalid="ignore"):
            spread = np.exp(_Z95 * err / out)
        return Hazard(self.thresholds.copy(), out, err, out / spread, out * spread, outside, use)

    # -- tables, files ---------------------------------------------------------------------

    def _header(self) -> str:
        """The table's first line (what made the estimates)."""
        unit = f" [{self.units}]" if self.units else ""
        over = _SHORT[self.axis] + ("" if self.by is None else f" and {self._by_label}")
        return (f"P({self.quantity} > threshold{unit}) over {over}, {self.method}, "
                f"{self.runs} tail runs for {self.run.size} points, {self.seconds:.1f} s")

    def __str__(self) -> str:
        name = _SHORT[self.axis]
        by = "" if self.by is None else f"{self._by_label:>10} "
        lines = [f"{self._header()}; {self._intervals}",
                 f"{name:>10} {by}{'threshold':>12} {'probability':>12} {'rel.err':>8} "
                 f"{'95% interval':>23}"]
        for i in np.ndindex(self.run.shape):
            x = f"{self.values[i[0]]:10.4g} " + ("" if self.by is None
                                                 else f"{self.by_values[i[1]]:10.4g} ")
            for k, d in enumerate(self.thresholds):
                p, s = self.probability[i + (k,)], self.stderr[i + (k,)]
                rel = s / p if p > 0 else math.inf
                flag = "" if self.reliable[i + (k,)] else "  UNRELIABLE"
                lines.append(f"{x}{d:12.6g} {p:12.4g} {rel:8.3f} "
                             f"[{self.low[i + (k,)]:9.3g}, {self.high[i + (k,)]:9.3g}]{flag}")
        return "\n".join(lines)

    def _repr_html_(self) -> str:
        """The table as HTML: one row per grid value, a column per threshold (estimate and its
        95 % interval); over two axes a table per value of ``by``."""
        name = html.escape(_SHORT[self.axis])
        unit = f" [{html.escape(self.units)}]" if self.units else ""
        head = "".join(f"<th>&gt; {d:.4g}{unit}</th>" for d in self.thresholds)
        tables = []
        for j, sec in enumerate(self.sections()):
            rows = []
            for i, x in enumerate(sec.values):
                cells = []
                for k in range(len(sec.thresholds)):
                    flag = "" if sec.reliable[i, k] else " <b>unreliable</b>"
                    cells.append(f"<td>{sec.probability[i, k]:.4g}<br><small>"
                                 f"[{sec.low[i, k]:.3g}, {sec.high[i, k]:.3g}]</small>{flag}</td>")
                rows.append(f"<tr><th>{x:.4g}</th>{''.join(cells)}</tr>")
            caption = ("" if self.by is None else
                       f"<caption>{html.escape(self._by_label)} = {self.by_values[j]:.4g}</caption>")
            tables.append(f"<table>{caption}<tr><th>{name}</th>{head}</tr>{''.join(rows)}</table>")
        return (f"<div><p>{html.escape(self._header())}; {html.escape(self._intervals)}</p>"
                f"{''.join(tables)}</div>")

    def to_xarray(self):
        """An xarray Dataset over (``axis``, [``by``,] threshold): probability, stderr, low,
        high, reliable, run; the quantity, seed, scene (JSON) and the rest as attributes."""
        import xarray as xr

        grid = (self.axis,) if self.by is None else (self.axis, self.by)
        dims = grid + ("threshold",)
        coords = {self.axis: self.values, "threshold": self.thresholds}
        if self.by is not None:
            coords[self.by] = self.by_values
        ds = xr.Dataset(
            {name: (dims, getattr(self, name)) for name in ("probability", "stderr", "low", "high")},
            coords=coords)
        ds["reliable"] = (dims, self.reliable.astype(np.int8))
        ds["run"] = (grid, self.run)
        ds.attrs.update({self._file_attr: 1}, quantity=self.quantity, axis=self.axis,
                        by=self.by or "", units=self.units, shared=int(self.shared),
                        seed=str(self.seed) if self.seed is not None else "",
                        scene=json.dumps(self.scene), seconds=self.seconds, steps=self.steps,
                        method=self.method, rel_error_target=self.rel_error_target)
        return ds

    @classmethod
    def _from_dataset(cls, ds) -> Dict[str, Any]:
        """The fields of a result read from its Dataset (a subclass adds its own)."""
        a = ds.attrs
        axis = str(a["axis"])
        by = str(a.get("by", "")) or None
        return dict(
            quantity=str(a["quantity"]), axis=axis, values=ds[axis].values,
            by=by, by_values=None if by is None else ds[by].values,
            thresholds=ds["threshold"].values, probability=ds["probability"].values,
            stderr=ds["stderr"].values, low=ds["low"].values, high=ds["high"].values,
            reliable=ds["reliable"].values.astype(bool), units=str(a["units"]),
            run=ds["run"].values, shared=bool(int(a["shared"])),
            seed=int(a["seed"]) if str(a["seed"]) else None, scene=json.loads(str(a["scene"])),
            seconds=float(a["seconds"]), steps=int(a["steps"]), method=str(a["method"]),
            rel_error_target=float(a["rel_error_target"]))

    @classmethod
    def load(cls, path: Union[str, "os.PathLike[str]"]) -> "FragilityResult":
        """Read a file written by :meth:`save` (of this class or a subclass: the file says
        which)."""
        return load(path)

    def save(self, path: Union[str, "os.PathLike[str]"]) -> None:
        """Write a netCDF file (netCDF-3 by SciPy, as crandall's results), replaced
        atomically; :func:`load` reads it back."""
        ds = self.to_xarray()
        encoding = {name: {"_FillValue": None} for name in ds.coords}
        data = bytes(ds.to_netcdf(engine="scipy", format="NETCDF3_64BIT", encoding=encoding))
        write_atomic(path, lambda f: f.write(data))


def _kinds() -> Dict[str, type]:
    """Each class of saved fragility by its netCDF attribute (FragilityResult and its
    subclasses, e.g. crandall.suites.RecordFragilityResult)."""
    out, todo = {}, [FragilityResult]
    while todo:
        cls = todo.pop()
        out[cls._file_attr] = cls
        todo.extend(cls.__subclasses__())
    return out


def load(path: Union[str, "os.PathLike[str]"]) -> FragilityResult:
    """Read a file written by :meth:`FragilityResult.save` (or a subclass's: the result is of
    the class that wrote it)."""
    import xarray as xr

    with xr.open_dataset(os.fspath(path), engine="scipy") as ds:
        ds.load()
        for attr, cls in _kinds().items():
            if attr in ds.attrs:
                return cls(**cls._from_dataset(ds))
        raise ValueError(f"path: {os.fspath(path)} is not a saved crandall fragility")
