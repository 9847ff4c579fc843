"""The fixed-step ``Result``: statistics from the merged accumulators, in the scene's units; their
bias through the hook the engine layer installs (``set_bias_estimator``)."""

from __future__ import annotations

import contextlib
import math
import numbers
import warnings
from typing import Callable, Optional, Tuple

import numpy as np

from .. import _core
from ..bins import Histograms
from ..model import exact as model_exact
from ..quantities import core_flags, find, names_for, quantity
from ..scene import Scene
from ..spec import RunSpec
from ..errors import ParameterError
from .common import (_e, _EXPONENTS, _INDEX, _shaken_before, Accumulators, MIN_CARRIERS, Stat,
                     StatisticsWarning, z_of)
from .histograms import _Distributions
from .tables import _Tables


#: The engine layer's estimate of a fixed-step run's bias (crandall.bias.estimate, set when
#: that module is imported, as ``import crandall`` does): a result asks it on the first call of
#: :meth:`Result.bias` and keeps the answer, without importing an engine itself.
_bias_estimator: Optional[Callable] = None
#: ... and whether that estimate needs a run of its own (``needs_run(result)``): a result whose
#: bias does is printed without it, saying which call makes it (printing never computes).
_bias_needs_run: Optional[Callable] = None


def set_bias_estimator(estimate: Callable, needs_run: Optional[Callable] = None) -> None:
    """Install the function ``estimate(result, threads)`` that results ask for their bias, and
    ``needs_run(result)``, whether it runs paths of its own."""
    global _bias_estimator, _bias_needs_run
    _bias_estimator = estimate
    _bias_needs_run = needs_run


def _estimate_bias(result):
    if _bias_estimator is None:
        raise RuntimeError("no bias estimator is installed: import crandall (which imports "
                           "crandall.bias)")
    return _bias_estimator(result)


class Result(_Distributions, _Tables):
    """Statistics of a simulated scene, in the scene's units.

    Time-resolved quantities ("velocity", "displacement", "distance", "kinetic_energy",
    "dissipated_energy", and with "peaks" observed "peak_speed", "peak_displacement") give
    arrays over :attr:`times`; stop quantities ("stop_time", "displacement_at_stop",
    "distance_at_stop", "dissipated_energy_at_stop", "peak_speed_at_stop",
    "peak_displacement_at_stop") give floats. Variances are the unbiased sample variances;
    ``stderr`` is the standard error of the mean. The peaks are maxima over the grid points:
    the peak speed falls short of the path's by about 0.09 scaled units at the default step
    (docs/distributions.md).

    When the scene asked for distributions (``Scene(distributions=...)``),
    :meth:`quantile`, :meth:`exceedance` and :meth:`histogram` answer from the run's own
    histograms, with confidence intervals.

    With few paths:

    - A variance needs at least 2 paths: with 1 path ``var``, ``std``, ``stderr`` and
      ``var_stderr`` are NaN, with a :class:`StatisticsWarning`, and the summary shows "n/a".
    - The extrapolating methods ("richardson", "richardson2") combine the raw moments of coupled
      grids linearly (docs/methods/richardson.md); with a handful of paths the combined second
      central moment can come out negative although every grid's is >= 0. The variance is then
      reported as 0 (the extrapolated value truncated at 0): it is an estimate of a quantity
      >= 0 whose statistical error, at that path count, is larger than the value.

    Attributes
    ----------
    dt : float
        Longest internal step, in the scene's time units.
    min_steps : int
        The graded grid's resolution: the step before an output time or the switch-off t is at
        most t / min_steps (0: steps of dt only). See :func:`crandall.simulate`.
    """

    def __init__(self, *, moments, stop_moments, steps_per_path: int,
                 scene: Optional[Scene] = None, paths: Optional[int] = None,
                 seed: Optional[int] = None, dt: Optional[float] = None,
                 method: Optional[str] = None, min_steps: int = 0,
                 random_stream: Optional[int] = None, peaks=None, stop_peaks=None,
                 histograms: Optional[Histograms] = None,
                 wall_time: Optional[float] = None, spec: Optional[RunSpec] = None,
                 energy=None) -> None:
        # The run's spec (given, or made from the fields): what Result.spec, saved files and
        # the bias estimate read, so that every run option travels with the result.
        if spec is None:
            spec = RunSpec(scene, paths, seed, dt, method, min_steps)
        elif any(v is not None and v != getattr(spec, k) for k, v in (
                ("scene", scene), ("paths", paths), ("seed", seed), ("dt", dt),
                ("method", method))) or min_steps not in (0, spec.min_steps):
            raise ParameterError("spec", "spec: the result's fields differ from its spec")
        self._spec = spec
        self.scene = spec.scene
        self.paths = spec.paths
        self.seed = spec.seed
        self.dt = spec.dt
        self.method = spec.method
        self.min_steps = spec.min_steps
        #: Version of the random stream that drew the paths (docs/random-numbers.md): the same
        #: seed gives the same numbers only within one stream version.
        self.random_stream = int(_core.RANDOM_STREAM if random_stream is None else random_stream)
        self.steps_per_path = int(steps_per_path)
        self._moments = moments
        self._stop = stop_moments
        self._peaks = peaks
        self._stop_peaks = stop_peaks
        self._histograms = histograms
        self._energy = energy if energy is not None and energy.slots else None
        self._wall_time = None if wall_time is None else float(wall_time)
        self._bias_cache = None
        self._warned: set = set()
        self._raw = moments.raw() if moments.slots else np.zeros((0, len(_EXPONENTS)))
        self._stop_raw = stop_moments.raw() if stop_moments is not None else None

    @property
    def spec(self) -> RunSpec:
        """The run's specification (scene, paths, seed, dt, method, min_steps, and any other
        run option): what a checkpoint of the run records and its saved file stores.
        ``min_steps > 0`` is the default graded grid, which ``simulate`` repeats with
        ``dt=None``."""
        return self._spec

    @property
    def accumulators(self) -> Accumulators:
        """The raw accumulators of the run (see :class:`Accumulators`)."""
        return Accumulators(self._moments, self._stop, self._peaks, self._stop_peaks,
                            self._histograms, self._energy)

    @property
    def times(self) -> np.ndarray:
        """Output times, in the scene's time units (s, or scaled tau)."""
        return self.scene.times

    @property
    def names(self) -> tuple:
        """The quantities this result holds."""
        return names_for(self.scene.observe)

    # -- statistics ---------------------------------------------------------------------

    def _source(self, name: str):
        if name not in self.names:
            raise ParameterError("name", 
                f"name: {name!r} is not in this result; it holds {', '.join(self.names)}"
            )
        q = quantity(name)
        # (accumulators, raw moments, variable, slot of a stop quantity or None).
        if q.peak:
            # Power 1: the raw moments are never needed.
            if q.at_stop:
                return self._stop_peaks, None, q.variable, 0
            return self._peaks, None, q.variable, None
        if q.magnitude:
            # |U(t_s)|: the first variable of the stop's second slot (the core's residual).
            return self._stop, self._stop_raw, 0, 1
        if q.at_stop:
            return self._stop, self._stop_raw, q.variable, 0
        return self._moments, self._raw, q.variable, None

    def _factor(self, name: str) -> float:
        return quantity(name).factor(self.scene)

    def _has_var_stderr(self, name: str) -> bool:
        """Whether the variance of ``name`` has a standard error here: a quantity's own fourth
        moments give it (power 1), and the kinetic energy's comes from the moments of V^2 the
        run kept (:attr:`Accumulators.energy`)."""
        known = find(name)
        return known is None or known.has_var_stderr or (
            self._energy is not None and known.power == 2 and not known.at_stop)

    def _stats(self, name: str):
        acc, raw, v, slot = self._source(name)
        n = acc.counts
        f = self._factor(name)
        with np.errstate(invalid="ignore", divide="ignore"):
            q = quantity(name)
            if q.power == 2:
                m2, m4 = raw[:, _e(v, 2)], raw[:, _e(v, 4)]
                mean = f * m2
                spread = (m4 - m2 * m2) * n
            else:
                mean = f * acc.means[:, v]
                if q.offset is not None:
                    mean = mean + q.offset(self.scene)
                spread = acc.central[:, _e(v, 2)]
            # An extrapolated second moment may be negative with few paths: truncated at 0
            # (see the class docstring). Fewer than 2 paths: undefined (NaN).
            var = np.where(n >= 2, f * f * np.maximum(spread, 0.0) / (n - 1), np.nan)
        if slot is not None:
            return float(mean[slot]), float(var[slot]), float(n[slot])
        return mean, var, n

    #: Per output time, whether noise has acted by then (:meth:`_shaken`, computed once).
    _shaken_times: Optional[np.ndarray] = None

    #: Set while a table computes its statistics (:meth:`_table`): NaNs are shown there as
    #: "n/a", and the warning is kept for the first call that returns them.
    _quiet = False

    @contextlib.contextmanager
    def _table(self):
        """Statistics for a table: without warnings, and without using up the one that a
        later call of the statistic itself gives."""
        before, self._quiet = self._quiet, True
        try:
            yield
        finally:
            self._quiet = before

    def _warn_nan(self, name: str, what: str, values, reason: str, stacklevel: int) -> None:
        if self._quiet or not np.isnan(np.asarray(values, dtype=float)).any():
            return
        # Once per result and reason: a table of every statistic would repeat it dozens of
        # times.
        key = (what, reason) if reason.startswith("fewer") or "2 paths" in reason else (
            what, name, reason)
        if key in self._warned:
            return
        self._warned.add(key)
        warnings.warn(f"{what} of {name} is NaN: {reason}", StatisticsWarning,
                      stacklevel=stacklevel + 1)

    def _var(self, name: str):
        _, var, n = self._stats(name)
        if np.any(np.asarray(n) < 2):
            self._warn_nan(name, "the variance", var, "a variance needs at least 2 paths", 3)
        return var, n

    def mean(self, name: str) -> Stat:
        """Sample mean of a quantity (array over times, or a float for stop quantities)."""
        return self._stats(name)[0]

    def var(self, name: str) -> Stat:
        """Unbiased sample variance of a quantity (NaN, with a warning, for 1 path)."""
        return self._var(name)[0]

    def std(self, name: str) -> Stat:
        """Sample standard deviation of a quantity."""
        return np.sqrt(self._var(name)[0])

    def stderr(self, name: str) -> Stat:
        """Standard error of the mean of a quantity: sqrt(var / paths).

        For the kinetic energy it rests on the velocity's fourth moment, as a variance's
        does: NaN, with a :class:`StatisticsWarning`, where fewer than :data:`MIN_CARRIERS`
        paths carry the velocity's spread (:meth:`carriers`).
        """
        var, n = self._var(name)
        se = np.sqrt(var / n)
        few = self._few(name, "mean")
        if few.any():
            se = np.where(few, math.nan, se) if np.ndim(se) else math.nan
            self._warn_nan(name, "the standard error of the mean", se,
                           self._few_reason(name, few), 2)
        return se

    def carriers(self, name: str) -> Stat:
        """The effective number of paths that carry a quantity's spread, per output time (a
        float at the stop): (sum d^2)^2 / sum d^4, with d each path's deviation of the
        quantity's core variable from its mean (the velocity's for the kinetic energy), from
        the accumulators' central sums.

        k paths equally far from the mean and the others at it give k; a normal sample of n
        paths about n / 3, a Laplace one n / 6. It is Kish's effective sample size with the
        squared deviations as weights: how many paths the variance's sum rests on. 0 where
        no path departs from the mean (every path at rest, or a quantity the noise has not
        reached).

        The standard errors that rest on the fourth moment (:meth:`var_stderr`; the kinetic
        energy's :meth:`stderr`) are NaN, with a :class:`StatisticsWarning`, where fewer than
        :data:`MIN_CARRIERS` paths carry the spread and the scene's noise has acted by then
        (so the quantity is random): those few paths decide the fourth moment, and the error
        is not estimated. Long after the switch-off, when almost every path is at rest, the
        velocity is such a quantity: more paths, not a finer step, give it an error.
        """
        acc, _, v, slot = self._source(name)
        rows = slice(None) if slot is None else slice(slot, slot + 1)
        c2 = acc.central[rows, _e(v, 2)]
        c4 = acc.central[rows, _e(v, 4)]
        with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
            # c4 < 0 only from an extrapolated combination (var_stderr says so): not a count.
            k = np.where(c4 > 0, c2 * c2 / c4, np.where((c2 == 0) & (c4 == 0), 0.0, math.nan))
        return float(k[0]) if slot is not None else k

    def _shaken(self, name: str) -> np.ndarray:
        """Per slot of ``name``: whether noise has acted by then, so that the quantity is
        random (a positive probability of any motion). Elsewhere a constant sample is the
        quantity's exact law, and its standard error 0 is right."""
        sc = self.scene
        if quantity(name).at_stop:
            return np.array([_shaken_before(sc, sc.t0)])
        if self._shaken_times is None:  # once: a table asks for every quantity
            self._shaken_times = np.array(
                [_shaken_before(sc, min(float(t), sc.t0)) for t in self.times], dtype=bool)
        return self._shaken_times

    def _few(self, name: str, stat: str) -> np.ndarray:
        """Per slot of ``name``: whether the standard error of ``stat`` rests on the fourth
        moment of fewer than MIN_CARRIERS paths (:meth:`carriers`) of a random quantity."""
        q = quantity(name)
        rows = 1 if q.at_stop else self.times.size
        # A quantity's variance rests on its fourth moment; the kinetic energy's mean and
        # variance both rest on the velocity's (order 4 and 8) moments.
        if q.power == 1 and stat != "var":
            return np.zeros(rows, dtype=bool)
        k = np.atleast_1d(self.carriers(name))
        _, _, n = self._stats(name)
        return (k < MIN_CARRIERS) & (np.atleast_1d(n) >= 2) & self._shaken(name)

    def _few_reason(self, name: str, few: np.ndarray) -> str:
        k = np.atleast_1d(self.carriers(name))[few]

        def count(x: float) -> str:
            return "none" if not x > 0 else f"about {x:.2g}"

        if quantity(name).at_stop:
            where = f"at the stop ({count(k[0])})"
        else:
            shown = [f"{t:g} ({count(x)})" for t, x in zip(self.times[few], k)]
            where = (f"at {self.scene.time_name} = " + ", ".join(shown[:4])
                     + (f" and {len(shown) - 4} more times" if len(shown) > 4 else ""))
        # (Not worded "fewer ...": _warn_nan says such reasons once for every quantity.)
        text = (f"its spread is carried by fewer than {MIN_CARRIERS} paths {where} "
                "(Result.carriers): its fourth moment, and with it the error, rests on those "
                "few paths")
        if not (k > 0).all():
            text += ("; where none does, every path has the same value (at rest) and the rare "
                     "ones that still move were not drawn")
        least = float(np.min(k[k > 0])) if (k > 0).any() else 0.0
        return text + ("; run more paths" + (
            f" (about {math.ceil(MIN_CARRIERS / least):d} times as many)" if least else ""))

    def var_stderr(self, name: str) -> Stat:
        """Standard error of the sample variance, sqrt((m4 - m2^2) / n) from central moments.

        The kinetic energy's comes from the moments of V^2 the run keeps for it (the 8th
        moment of the velocity); a result loaded from a file saved before crandall kept them
        has none.

        NaN, with a :class:`StatisticsWarning`, where it cannot be estimated: fewer than 2
        paths; a fourth-moment term m4 - m2^2 that is negative beyond rounding (impossible for
        a sample, so only from an extrapolated method whose step is far too long for the
        scene: the combination of the grids is then no distribution's moments); fourth
        moments that overflow doubles; or a random quantity whose spread fewer than
        :data:`MIN_CARRIERS` paths carry (:meth:`carriers`: the velocity long after the
        switch-off, when almost every path is at rest), whose fourth moment those few paths
        decide. 0 only where the quantity is constant and the noise has not acted on it.
        """
        if not self._has_var_stderr(name):
            raise ParameterError("name", f"name: the variance of {name} has no standard error "
                                         "here (needs moments of order 8)")
        acc, _, v, slot = self._source(name)
        if quantity(name).power == 2:
            # The kinetic energy f V^2: the variance of W = V^2 from W's own moments.
            acc, v = self._energy, 0
        n = acc.counts
        f = self._factor(name)
        rows = slice(None) if slot is None else slice(slot, slot + 1)
        n = n[rows]
        few = self._few(name, "var")
        with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
            m2 = acc.central[rows, _e(v, 2)] / n
            m4 = acc.central[rows, _e(v, 4)] / n
            d = m4 - m2 * m2
            # Rounding can leave a two-point law's m4 - m2^2 = 0 slightly negative.
            tiny = 1e-12 * m2 * m2
            ok = (n >= 2) & np.isfinite(d) & (d >= -tiny)
            se = np.where(ok & ~few, f * f * np.sqrt(np.maximum(d, 0.0) / n), np.nan)
        if np.isnan(se).any():
            reasons = []
            if np.any(n < 2):
                reasons.append("fewer than 2 paths")
            if np.any((n >= 2) & ~np.isfinite(d)):
                reasons.append("its fourth moments overflow doubles")
            if np.any((n >= 2) & np.isfinite(d) & (d < -tiny)):
                reasons.append(f"the {self.method} combination's fourth-moment term "
                               "m4 - m2^2 is negative (the step is too long for the "
                               "extrapolation; use a smaller dt)")
            if few.any():
                reasons.append(self._few_reason(name, few))
            self._warn_nan(name, "the standard error of the variance", se, "; ".join(reasons), 2)
        return float(se[0]) if slot is not None else se

    def moment(self, j: int, k: int, l: int) -> np.ndarray:  # noqa: E741 - the paper's index
        """Mixed moment E[U1^j U2^k U3^l] over times, in the paper's scaled units (eq3, eq8).

        U1 is the scaled velocity, U2 the scaled displacement, U3 the scaled distance;
        j + k + l <= 4. The variables involved must have been observed (velocity is always
        simulated). Physical scenes need mu > 0 and h > 0 (the scaling of eq8).
        """
        for name, value in (("j", j), ("k", k), ("l", l)):
            if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < 0:
                raise ParameterError(name, f"{name} must be an integer >= 0, got {value!r}")
        if j + k + l > 4:
            raise ParameterError("j, k, l", "j + k + l must be <= 4 (moments are kept to order "
                                            f"4), got {j + k + l}")
        recorded = core_flags(self.scene.observe)
        if k and not recorded["displacement"]:
            raise ParameterError("k", "k: the displacement (U2) was not observed in this scene")
        if l and not recorded["distance"]:
            raise ParameterError("l", "l: the distance (U3) was not observed in this scene")
        value = self._raw[:, _INDEX[(j, k, l)]].copy()
        if self.scene.units == "SI":
            s = self.scene.scaling
            if s is None:
                raise ValueError("moment: scaled units need mu > 0 and h > 0 with scales "
                                 "that fit in doubles (eq8; Scene.scaling is None)")
            value = s.to_scaled(s.to_scaled(value, "velocity", j), "length", k + l)
        return value

    # -- accuracy -----------------------------------------------------------------------

    @property
    def cost(self) -> dict:
        """What the run cost: ``wall_time`` (s, of the call that ran it; None for a result
        loaded from a file written before it was recorded) and ``path_steps`` (paths times
        steps per path on the finest grid)."""
        return {"wall_time": self._wall_time, "path_steps": self.paths * self.steps_per_path}

    def exact(self, name: str, stat: str = "mean") -> bool:
        """Whether the statistic is exact in law at any step (its bias is 0, not estimated):
        every statistic of the velocity, the kinetic energy and the stop time (of a scene for
        which the exact step's identity holds: crandall.model), unless the scene is an
        envelope's pieces (their piece error is in :meth:`bias`)."""
        self._check_stat(name, stat)
        return model_exact(name, self.scene)

    def _check_stat(self, name: str, stat: str) -> None:
        if stat not in ("mean", "var"):
            raise ParameterError("stat", f"stat must be 'mean' or 'var', got {stat!r}")
        self._source(name)

    def _bias(self, name: str, stat: str, warn: bool):
        self._check_stat(name, stat)
        if self._bias_cache is None:
            self._bias_cache = _estimate_bias(self)
        values, _ = self._bias_cache[(name, stat)]
        if warn and np.isnan(values).any():
            env = self.scene.envelope
            why = ("the envelope's function is not kept (its scene came back from plain data: "
                   "a saved result, a checkpoint), so the error of its pieces is unknown; run "
                   "the envelope from envelopes.from_function(...) again"
                   if env is not None and env.function is None else
                   "not estimated for the peaks under white noise (maxima over the grid: "
                   "their shortfall is measured in docs/distributions.md)"
                   if quantity(name).peak else
                   "a bias estimate needs at least 2 paths" if self.paths < 2 else
                   f"not estimated for method {self.method!r} (no coupled grids; "
                   "use 'exact' or 'richardson', or simulate(error=...))")
            self._warn_nan(name, f"the bias of the {stat}", values, why, 3)
        return float(values[0]) if quantity(name).at_stop else values

    @property
    def bias_pending(self) -> bool:
        """Whether the bias estimate is still to be made by a run of its own (coupled grids,
        or an envelope's pieces): :meth:`estimate_bias`, or the first call of :meth:`bias`,
        makes it. Until then the summary and the HTML table show no bias (printing never
        runs paths)."""
        if self._bias_cache is not None:
            return False
        return _bias_needs_run is None or bool(_bias_needs_run(self))

    def estimate_bias(self) -> "Result":
        """Make the bias estimate now (a run of its own, with a progress bar where a person
        watches; see :meth:`bias`) and keep it; returns the result. Nothing to do when it is
        made already or needs no run."""
        if self._bias_cache is None:
            self._bias_cache = _estimate_bias(self)
        return self

    def bias(self, name: str, stat: str = "mean") -> Stat:
        """The estimated magnitude of the discretisation bias of a statistic (``stat``: "mean"
        or "var"), in the quantity's units (squared for "var").

        0 for the statistics exact in law (:meth:`exact`). For a scene given as an envelope
        (``Scene(envelope=...)``) it also holds the error of the pieces, estimated by a run
        with twice the pieces (:mod:`crandall.bias`), for every statistic. Otherwise estimated on coupled
        grids by a separate run of the same scene and grid (as many paths as the run, at most
        65 536, of a stream of its own; run on the first call, then kept): see :mod:`crandall.bias` and
        docs/methods/adaptive.md. Where the grids' difference is not resolved the value is its
        bound. NaN, with a :class:`StatisticsWarning`, for "euler" and "refine" and for the
        peaks under white noise (a filtered excitation's coupled grids record the peaks, whose
        grid error is then estimated like the other statistics').
        """
        return self._bias(name, stat, True)

    def bias_is_bound(self, name: str, stat: str = "mean") -> bool:
        """Whether :meth:`bias` is a bound (the coupled grids' difference was not resolved)."""
        self._bias(name, stat, False)
        return bool(self._bias_cache[(name, stat)][1])

    def _error(self, name: str, stat: str, warn: bool):
        b = self._bias(name, stat, warn)
        if stat == "mean":
            se = self.stderr(name)
        else:
            if self._has_var_stderr(name):
                se = self.var_stderr(name)
            else:
                se = np.full(np.shape(b), np.nan)
                if warn:
                    self._warn_nan(name, f"the total error of the variance", se,
                                   "its variance has no standard error here (it would need "
                                   "moments of order 8)", 4)
        return np.hypot(se, b)

    def error(self, name: str, stat: str = "mean") -> Stat:
        """The total error of a statistic, sqrt(stderr^2 + bias^2), with ``stderr`` the
        standard error of the mean (:meth:`stderr`) or of the variance (:meth:`var_stderr`)."""
        return self._error(name, stat, True)

    def interval(self, name: str, stat: str = "mean", level: float = 0.95) -> Tuple[Stat, Stat]:
        """The interval estimate +- z :meth:`error` of a statistic, z the two-sided normal
        quantile of ``level`` (1.96 for 0.95): (low, high), arrays over the times or floats
        at the stop. Its coverage rests on the error estimate (the bias is an estimate, not a
        bound; bench/calibration.py measures the coverage)."""
        if isinstance(level, (bool, np.bool_)) or not isinstance(level, numbers.Real) \
                or not 0.0 < float(level) < 1.0:
            raise ParameterError("level", "level must be a number strictly between 0 and 1, got "
                                          f"{level!r}")
        value = self.mean(name) if stat == "mean" else self.var(name) if stat == "var" else None
        if value is None:
            raise ParameterError("stat", f"stat must be 'mean' or 'var', got {stat!r}")
        half = z_of(level) * self.error(name, stat)
        return value - half, value + half

    def __repr__(self) -> str:
        return (f"<crandall.Result {self.scene!r} paths={self.paths} seed={self.seed} "
                f"method={self.method!r}>")

    #: What made the result: "fixed_step" (``simulate(paths=...)``) or "accuracy"
    #: (``simulate(error=...)``, :class:`AccuracyResult`).
    kind = "fixed_step"
