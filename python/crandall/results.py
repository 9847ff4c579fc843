"""Statistics of a run: means, variances, standard errors, mixed moments, a summary."""

from __future__ import annotations

import contextlib
import math
import numbers
import statistics as _statistics
import warnings
from typing import Any, Callable, Dict, List, NamedTuple, Optional, Tuple, Union

import numpy as np

from . import _core, _dataset, _render, distributions
from .bins import Histograms
from .model import exact as model_exact
from .quantities import core_flags, find, names_for, quantity
from .scene import Scene
from .spec import RunSpec

__all__ = ["Result", "Accumulators", "StatisticsWarning", "MIN_CARRIERS"]


class StatisticsWarning(UserWarning):
    """A statistic could not be estimated from this run and is returned as NaN.

    Raised (as a warning) by :meth:`Result.var`, :meth:`Result.std`, :meth:`Result.stderr` and
    :meth:`Result.var_stderr` when they return NaN: a variance from fewer than 2 paths; a
    standard error of a variance whose fourth-moment term is negative (an extrapolated method
    at a step far too long for it) or overflows doubles; or a standard error that rests on the
    fourth moment (of a variance, of the kinetic energy's mean) where fewer than
    :data:`MIN_CARRIERS` paths carry the spread (:meth:`Result.carriers`).
    """


#: The fewest paths that must carry a quantity's spread (:meth:`Result.carriers`) for the
#: standard errors that rest on its fourth moment (a variance's; the kinetic energy's mean's)
#: to be reported. Fewer, and the few paths far from the mean decide the fourth moment: the
#: interval +- 1.96 standard errors of a variance covered 77-91 % of the law's value with 5
#: to 30 carrying paths and 49-75 % with fewer than 2, for sparse, normal and Laplace samples
#: alike, and 17 % on the simulated velocity after the switch-off where fewer than 2 carried
#: it, with z down to -78 870 (bench/few_carriers.py, docs/accumulators.md); from 30 on,
#: 90-96 %. 30 carrying
#: paths need about 100 paths of a normal quantity, a few hundred of a heavier-tailed one.
MIN_CARRIERS = 30

#: Exponents (velocity, displacement, distance) of the accumulators' moments, in their order.
MONOMIALS = tuple(tuple(e) for e in _core.monomial_exponents())
_EXPONENTS = list(MONOMIALS)
_INDEX = {e: i for i, e in enumerate(_EXPONENTS)}


def _sqrt(x: float) -> float:
    return math.sqrt(x) if x >= 0 else math.nan  # NaN (n/a) stays NaN


def _fmt(x: float, spec: str, few: bool = False) -> str:
    width = "".join(c for c in spec.split(".")[0] if c.isdigit())
    # few: a standard error not estimated because few paths carry the spread (FEW_MARK).
    text = FEW_MARK if few else "n/a" if math.isnan(x) else format(x, spec)
    return f"{text:>{width}}" if width else text


FEW_MARK = _render.FEW_MARK


def _shaken_before(scene, until: float) -> bool:
    """Whether the noise has acted before ``until``: model.noise_energy(scene, until) > 0,
    asked without squaring the intensity (which overflows for h near 1e300)."""
    if scene.pieces is None:
        return scene.noise > 0 and until > 0
    start = 0.0
    for end, noise in scene.pieces:
        if noise > 0 and until > start:
            return True
        start = end
    return False


def _e(v: int, power: int) -> int:
    exps = [0, 0, 0]
    exps[v] = power
    return _INDEX[tuple(exps)]


def _times_text(times) -> str:
    shown = ", ".join(f"{t:g}" for t in times[:8])
    return shown + (f", ... ({len(times)} times)" if len(times) > 8 else "")


def _fold(edges: np.ndarray, cells: np.ndarray, base: str = "velocity",
          folded_name: str = "kinetic energy"):
    """A symmetric axis folded at 0: the histogram of |x| (edges >= 0; cells [under = 0,
    bins..., over, NaN]). Bin [a, b) of x goes to the bin of |x| starting at a (a >= 0), at
    -b (b <= 0), or at 0 (a < 0 < b); both flows go to the overflow. ``base`` and
    ``folded_name`` name the two in the error of an axis that is not symmetric."""
    refuse = (f"name: the {base}'s bins are not symmetric about 0, so the {folded_name}'s "
              "distribution cannot be folded from them")
    atom = edges.size > 2 and edges[edges.size // 2] == distributions.ATOM
    if atom:
        # The atom edge just above 0 has no mirror below: the rest is symmetric.
        rest = np.delete(edges, edges.size // 2)
        if not np.array_equal(rest, -rest[::-1]):
            raise ValueError(refuse)
    elif not np.array_equal(edges, -edges[::-1]):
        raise ValueError(refuse)
    pos = edges[edges >= 0]
    if pos[0] != 0.0:
        pos = np.concatenate(([0.0], pos))
    n = edges.size - 1
    a, b = edges[:-1], edges[1:]
    start = np.where(a >= 0, a, np.where(b <= 0, -b, 0.0))
    if atom:
        # [-w, 0) folds onto (0, w]: beside the atom [0, ATOM) of exact zeros, not into it.
        start = np.where((a < 0) & (start == 0.0), distributions.ATOM, start)
    target = np.searchsorted(pos, start, side="left")
    folded = np.zeros(pos.size + 2, dtype=np.uint64)
    np.add.at(folded, 1 + target, np.asarray(cells[1:n + 1], dtype=np.uint64))
    folded[-2] = np.uint64(cells[0]) + np.uint64(cells[n + 1])
    folded[-1] = cells[n + 2]
    return pos, folded


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


#: A statistic: an array over the output times, or a float for a quantity at the stop.
Stat = Union[float, np.ndarray]


def z_of(level: float) -> float:
    """The two-sided standard normal quantile of a coverage ``level``."""
    return _statistics.NormalDist().inv_cdf(0.5 + 0.5 * float(level))


class Accumulators(NamedTuple):
    """The merged accumulators a result's statistics come from (``Result.accumulators``).

    Each is a ``crandall._core.Moments``: ``counts``, ``means`` (of velocity, displacement,
    distance) and ``central`` sums per slot, exactly as the run merged them; saving them
    (``crandall.io``) is what makes a loaded result bitwise the saved one. Read them only:
    the result's statistics are computed from the same objects.
    """

    #: One slot per output time.
    times: object
    #: One slot: the stop (time after the switch-off, and the integrals there); None when the
    #: scene does not observe "stop".
    stop: Optional[object]
    #: The peaks (max |U1|, max |U2|, 0) per output time; None unless the scene observes
    #: "peaks".
    peaks: Optional[object] = None
    #: The peaks over the whole path (one slot); None unless the scene observes "peaks" and
    #: "stop".
    stop_peaks: Optional[object] = None
    #: The histograms (``crandall.bins.Histograms``: axis indices, edges, uint64 counts);
    #: None unless the scene asks for distributions.
    histograms: Optional[Histograms] = None
    #: The moments of (V^2, 0, 0) per output time, from which the kinetic energy's variance
    #: gets its standard error (it needs E V^8); None unless the scene observes
    #: "kinetic_energy" (and in results saved before crandall kept them).
    energy: Optional[object] = None


class Result:
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
            raise ValueError("spec: the result's fields differ from its spec")
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
            raise ValueError(
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
            raise ValueError(f"name: the variance of {name} has no standard error "
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

    def _var_stderr_quiet(self, name: str) -> np.ndarray:
        """The variance's standard error for tables (NaN, without a warning, where it has none
        or cannot be estimated)."""
        if not self._has_var_stderr(name):
            return np.full(1 if quantity(name).at_stop else self.times.size, math.nan)
        with self._table():
            return np.atleast_1d(self.var_stderr(name))

    def _stderr_quiet(self, name: str) -> np.ndarray:
        """The mean's standard error for tables (NaN, without a warning, where it cannot be
        estimated)."""
        with self._table():
            return np.atleast_1d(self.stderr(name))

    def moment(self, j: int, k: int, l: int) -> np.ndarray:  # noqa: E741 - the paper's index
        """Mixed moment E[U1^j U2^k U3^l] over times, in the paper's scaled units (eq3, eq8).

        U1 is the scaled velocity, U2 the scaled displacement, U3 the scaled distance;
        j + k + l <= 4. The variables involved must have been observed (velocity is always
        simulated). Physical scenes need mu > 0 and h > 0 (the scaling of eq8).
        """
        for name, value in (("j", j), ("k", k), ("l", l)):
            if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < 0:
                raise ValueError(f"{name} must be an integer >= 0, got {value!r}")
        if j + k + l > 4:
            raise ValueError(f"j + k + l must be <= 4 (moments are kept to order 4), got {j + k + l}")
        recorded = core_flags(self.scene.observe)
        if k and not recorded["displacement"]:
            raise ValueError("k: the displacement (U2) was not observed in this scene")
        if l and not recorded["distance"]:
            raise ValueError("l: the distance (U3) was not observed in this scene")
        value = self._raw[:, _INDEX[(j, k, l)]].copy()
        if self.scene.units == "SI":
            s = self.scene.scaling
            if s is None:
                raise ValueError("moment: scaled units need mu > 0 and h > 0 with scales "
                                 "that fit in doubles (eq8; Scene.scaling is None)")
            value = s.to_scaled(s.to_scaled(value, "velocity", j), "length", k + l)
        return value

    # -- distributions ------------------------------------------------------------------

    @property
    def distributions(self) -> tuple:
        """The quantities whose distributions this result holds (``Scene(distributions=...)``)."""
        return tuple(self.scene.distributions) if self._histograms is not None else ()

    def _slot(self, name: str, q, time) -> int:
        if q.at_stop:
            if time is not None:
                raise ValueError(f"time: {name} is a value at the stop, with one distribution; "
                                 f"give no time (got time={time!r})")
            return self.times.size
        if time is None:
            raise ValueError(f"time: {name} has a distribution at every output time; give "
                             f"time, one of {_times_text(self.times)}")
        if isinstance(time, (bool, np.bool_)) or not isinstance(time, numbers.Real) \
                or not math.isfinite(float(time)):
            # Not finite: inf would pass the rounding test below (inf - t <= 1e-12 inf).
            raise ValueError(f"time: {time!r} is not an output time of this result; give one "
                             f"of {_times_text(self.times)}")
        t = float(time)
        hit = np.flatnonzero(self.times == t)
        if not hit.size:
            # A time typed again differs from the stored one by a rounding at most.
            hit = np.flatnonzero(np.abs(self.times - t) <= 1e-12 * np.maximum(np.abs(self.times), abs(t)))
        if not hit.size:
            raise ValueError(f"time: {time!r} is not an output time of this result; give one "
                             f"of {_times_text(self.times)}")
        return int(hit[0])

    def _binned(self, name: str, time):
        """(edges, cells, offset, shown edges) of a quantity's distribution: edges and cells
        [under, bins..., over, NaN] in the quantity's units less ``offset`` (the stop time's
        t0), and the edges to show (the user's, when given)."""
        if not isinstance(name, str) or name not in self.names:
            raise ValueError(f"name: {name!r} is not in this result; it holds "
                             f"{', '.join(self.names)}")
        if name not in self.distributions:
            asked = ", ".join(self.distributions) or "none"
            raise ValueError(f"name: the scene did not ask for the distribution of {name!r} "
                             f"(its distributions: {asked}); give Scene(..., "
                             "distributions=[...]) and run it again")
        q = quantity(name)
        slot = self._slot(name, q, time)
        found = self._histograms.find(slot, q.histogram_variable)
        if found is None:  # pragma: no cover - the scene's axes are all recorded
            raise ValueError(f"name: no histogram of {name!r} at this slot")
        edges, cells = np.asarray(found[0], dtype=np.float64), np.asarray(found[1])
        atom = edges == distributions.ATOM
        if q.power == 2:
            edges, cells = _fold(edges, cells)
            atom = edges == distributions.ATOM
            edges = edges * edges
        elif q.magnitude:
            edges, cells = _fold(edges, cells, "displacement at the stop", name.replace("_", " "))
            atom = edges == distributions.ATOM
        f = self._factor(name)
        if f == 0.0:
            raise ValueError(f"name: {name} is 0 on every path of this scene (its factor is "
                             "0: no friction, mu = 0), so it has no distribution to bin")
        if f != 1.0:
            edges = edges * f
        # The atom bin [0, ATOM) holds exact zeros, whatever the units: its upper edge stays
        # the least positive double (squared or scaled, it would underflow onto 0).
        edges[atom] = distributions.ATOM
        if not (np.diff(edges) > 0).all():
            raise ValueError(f"name: {name}'s bin edges are not distinct in doubles once "
                             f"converted to its units (factor {f!r}); choose units nearer 1")
        offset = q.offset(self.scene) if q.offset is not None else 0.0
        shown = edges + offset if offset else edges
        user = self.scene.bin_settings[1].get(name)
        if isinstance(user, tuple) and len(user) == len(edges):
            shown = np.asarray(user, dtype=np.float64)
        if cells[-1]:
            self._warn_nan(name, "the distribution", [math.nan],
                           f"{int(cells[-1])} paths gave NaN (left out of quantiles and "
                           "exceedances)", 3)
        return edges, cells, offset, shown

    def histogram(self, name: str, time: Optional[float] = None) -> Any:
        """The run's histogram of a quantity as a ``boost_histogram.Histogram``.

        Needs the ``hist`` extra (``pip install 'crandall[hist]'``) and a scene that asked for
        the distribution (``Scene(..., distributions=[name])``).

        Parameters
        ----------
        name : str
            A quantity in :attr:`distributions`.
        time : float, optional
            For a quantity over time, one of the output times :attr:`times`; none for a
            quantity at the stop.

        Returns
        -------
        boost_histogram.Histogram
            One ``Variable`` axis on the bins' edges in the quantity's units, with underflow
            and overflow; ``Int64`` counts, every path counted once (a NaN value, which no
            sane run gives, is left out: it warns). The kinetic energy's bins are the
            velocity's folded at 0, the dissipated energy's the distance's times m mu g.
            The automatic bins have an atom bin ``[0, 2^-1074)`` that holds exact zeros only
            (a stopped or unshaken body; its density is not a number to plot, its count is the
            probability of exactly 0); for the stop time, shown from t0, it joins the bin
            above it (t0 + 2^-1074 is t0 in doubles).
            With "richardson" or "richardson2" the histograms are of the finest grid's paths
            (counts cannot be extrapolated).

        Raises
        ------
        ValueError
            ``name`` not held or its distribution not asked for; ``time`` missing, given for a
            stop quantity, or not an output time.
        ImportError
            boost-histogram is not installed.
        """
        shown, cells, label = self.histogram_counts(name, time)
        return distributions.to_boost_histogram(shown, cells[1:-1], int(cells[0]),
                                                int(cells[-1]), label)

    def histogram_counts(self, name: str, time: Optional[float] = None):
        """The run's histogram of a quantity as plain arrays (what :meth:`histogram` gives as
        a ``boost_histogram.Histogram``, which the figures do without).

        Returns
        -------
        edges : numpy.ndarray
            The bins' edges in the quantity's units (as :meth:`histogram`'s axis).
        counts : numpy.ndarray
            Paths per cell: the underflow, one per bin, the overflow (``len(edges) + 1``).
        label : str
            The quantity, its unit and the time.
        """
        edges, cells, offset, shown = self._binned(name, time)
        atom = np.flatnonzero(edges == distributions.ATOM)
        if offset and atom.size and shown[atom[0]] == shown[atom[0] - 1]:
            # t0 + 2^-1074 is t0: the atom bin of the stop time cannot be shown apart once t0
            # is added, so it joins the bin above it here (quantiles and exceedances, taken
            # from the switch-off, keep it apart).
            j = int(atom[0])
            cells = np.array(cells, copy=True)
            cells[j + 1] += cells[j]
            cells = np.delete(cells, j)
            shown = np.delete(shown, j)
        if not (np.diff(shown) > 0).all():
            # The core bins the stop time from the switch-off; edges far finer than t0's
            # rounding collide once t0 is added back. Quantiles and exceedances are computed
            # from the switch-off and are not affected.
            raise ValueError(f"name: {name}'s bin edges plus t0 = {self.scene.t0!r} are not "
                             "distinct in doubles; use quantile or exceedance, or give "
                             "coarser bins")
        unit = self.scene.units_of(name)
        label = name + (f" [{unit}]" if unit else "") + (
            "" if time is None else f" at {self.scene.time_name} = {float(time):g}")
        return shown, np.asarray(cells[:-1]), label

    def quantile(self, name: str, q: float, time=None,
                 confidence: float = 0.95) -> distributions.Estimate:
        """The q-quantile of a quantity from the run's histogram, with a confidence interval.

        Parameters
        ----------
        name : str
            A quantity in :attr:`distributions`.
        q : float
            The probability, strictly between 0 and 1 (0.99: the value 99 % of paths stay at
            or below).
        time : float, optional
            One of :attr:`times` for a quantity over time; none for one at the stop.
        confidence : float
            The interval's coverage, strictly between 0 and 1 (default 0.95).

        Returns
        -------
        crandall.distributions.Estimate
            ``value``: the sample quantile, interpolated within its bin. ``low``, ``high``: a
            distribution-free interval for the law's quantile, coverage at least
            ``confidence`` for any law: the order statistics bracketing the quantile
            (binomial ranks), widened to the edges of the bins that hold them. The bin width
            limits the interval at each end by at most one bin (1/128 to 1/256 of the value
            with the default bins beyond the quantity's scale); once the sampling interval
            is a few bins wide it is the paths, not the bins, that limit it
            (docs/methods/histograms.md, "Intervals"). Infinite where the quantile lies
            beyond the bins (user edges that do not reach it). In the quantity's units.
            ``resolution``: the widths of the two bins at the interval's ends, the most the
            bins can have widened it; ``bin_limited``: whether that is at least half the
            interval (then finer ``bins`` would narrow it; more paths, not much).

        Raises
        ------
        ValueError
            As :meth:`histogram`, and ``q`` or ``confidence`` outside (0, 1).
        """
        if isinstance(q, (bool, np.bool_)) or not isinstance(q, numbers.Real) \
                or not 0.0 < float(q) < 1.0:
            raise ValueError(f"q must be a number strictly between 0 and 1, got {q!r}")
        edges, cells, offset, _ = self._binned(name, time)
        est = distributions.quantile(edges, cells[1:-2], int(cells[0]), int(cells[-2]),
                                     float(q), confidence)
        if not offset:
            return est
        return est._replace(value=est.value + offset, low=est.low + offset,
                            high=est.high + offset)

    def exceedance(self, name: str, level: float, time=None,
                   confidence: float = 0.95) -> distributions.Estimate:
        """P(quantity > level) from the run's histogram, with a confidence interval.

        Parameters
        ----------
        name : str
            A quantity in :attr:`distributions`.
        level : float
            The threshold, in the quantity's units (not NaN).
        time : float, optional
            One of :attr:`times` for a quantity over time; none for one at the stop.
        confidence : float
            The interval's coverage, strictly between 0 and 1 (default 0.95).

        Returns
        -------
        crandall.distributions.Estimate
            ``value``: the fraction of paths above ``level`` (the bin holding the level
            counted in proportion to its part above it). ``low``, ``high``: Clopper-Pearson
            bounds, coverage at least ``confidence``, taken at the fewest and the most paths
            that can be above the level given the bins: the bin holding the level is where
            the histogram limits the interval (a level on an edge still leaves that bin
            undecided). ``resolution``: the fraction of paths in that bin; ``bin_limited``:
            whether it is at least half the interval's width.

        Raises
        ------
        ValueError
            As :meth:`histogram`, and a bad ``level`` or ``confidence``.
        """
        if isinstance(level, (bool, np.bool_)) or not isinstance(level, numbers.Real) \
                or math.isnan(float(level)):
            raise ValueError(f"level must be a number (not NaN), got {level!r}")
        edges, cells, offset, _ = self._binned(name, time)
        return distributions.exceedance(edges, cells[1:-2], int(cells[0]), int(cells[-2]),
                                        float(level) - offset, confidence)

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
            raise ValueError(f"stat must be 'mean' or 'var', got {stat!r}")
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
                   "not estimated for the peaks (maxima over the grid: their shortfall is "
                   "measured in docs/distributions.md)" if quantity(name).peak else
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
        if self.kind == "accuracy" or self._bias_cache is not None:
            return False
        return _bias_needs_run is None or bool(_bias_needs_run(self))

    def estimate_bias(self) -> "Result":
        """Make the bias estimate now (a run of its own, with a progress bar where a person
        watches; see :meth:`bias`) and keep it; returns the result. Nothing to do when it is
        made already or needs no run."""
        if self.kind != "accuracy" and self._bias_cache is None:
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
        peaks.
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
            raise ValueError(f"level must be a number strictly between 0 and 1, got {level!r}")
        value = self.mean(name) if stat == "mean" else self.var(name) if stat == "var" else None
        if value is None:
            raise ValueError(f"stat must be 'mean' or 'var', got {stat!r}")
        half = z_of(level) * self.error(name, stat)
        return value - half, value + half

    # -- presentation -------------------------------------------------------------------

    def summary(self) -> str:
        """A readable table of the statistics."""
        sc = self.scene
        lines = [
            f"crandall result: {sc!r}",
            f"  paths={self.paths}  seed={self.seed}  method={self.method}  dt={self.dt:.6g}  "
            f"min_steps={self.min_steps}  steps/path={self.steps_per_path}  "
            f"random_stream={self.random_stream}",
        ]
        if self.paths < 2:
            lines.append("  (n/a: a variance needs at least 2 paths)")
        pending = self.bias_pending
        if pending:
            lines.append("  bias: not estimated yet (?): it takes a run of its own; "
                         "result.estimate_bias() makes it (so does result.bias(name))")
        else:
            lines.append("  bias: estimated discretisation bias (0: exact in law; "
                         "Result.bias, docs/methods/adaptive.md)")

        def bias_of(n, stat):
            if pending:
                return np.full(np.shape(self._stats(n)[0]), np.nan)
            return self._bias(n, stat, False)

        def shown(value, spec):
            return f"{'?':>{spec.split('.')[0] or 1}}" if pending else _fmt(value, spec)
        time_names = [n for n in self.names if not quantity(n).at_stop]
        if time_names and self.times.size:
            # One block per quantity: time, mean ± standard error, variance, standard deviation.
            for n in time_names:
                u = sc.units_of(n)
                lines.append(f"  {n}" + (f" [{u}]" if u else ""))
                lines.append(f"    {sc.time_name:>10}  {'mean':>13}  {'± stderr':>10}  "
                             f"{'bias':>9}  {'var':>12}  {'± stderr':>10}  {'var bias':>9}  "
                             f"{'std':>12}")
                mean, var, cnt = self._stats(n)
                bm, bv = bias_of(n, "mean"), bias_of(n, "var")
                se, vse = self._stderr_quiet(n), self._var_stderr_quiet(n)
                fm, fv = self._few(n, "mean"), self._few(n, "var")
                for i, t in enumerate(self.times):
                    lines.append(f"    {t:>10.4g}  {mean[i]:>13.6g}  "
                                 f"{_fmt(se[i], '10.2g', fm[i])}  "
                                 f"{shown(bm[i], '9.2g')}  "
                                 f"{_fmt(var[i], '12.6g')}  {_fmt(vse[i], '10.2g', fv[i])}  "
                                 f"{shown(bv[i], '9.2g')}  {_fmt(_sqrt(var[i]), '12.6g')}")
        stop_names = [n for n in self.names if quantity(n).at_stop]
        if stop_names:
            lines.append("  at the stop:")
            for n in stop_names:
                mean, var, cnt = self._stats(n)
                u = sc.units_of(n)
                lines.append(f"    {n:<26} mean {mean:.6g}"
                             f" ± {_fmt(self._stderr_quiet(n)[0], '.2g', self._few(n, 'mean')[0])}"
                             f" (bias {shown(bias_of(n, 'mean'), '.2g')})"
                             f"   var {_fmt(var, '.6g')}"
                             f" ± {_fmt(self._var_stderr_quiet(n)[0], '.2g', self._few(n, 'var')[0])}"
                             f" (bias {shown(bias_of(n, 'var'), '.2g')})"
                             + (f"   [{u}]" if u else ""))
        for note in (self._few_note(), self._scene_note()):
            if note:
                lines.append(f"  {note}")
        return "\n".join(lines)

    #: A stop time this close to the end of the noise (relative to it) is said to be set by
    #: the scene (:meth:`_scene_note`).
    SET_BY_SCENE = 1e-3

    def _scene_note(self) -> str:
        """The summary's note when the mean stop time is the end of the noise, t0, to within
        SET_BY_SCENE of it: the number then tells when the scene's shaking ends, not how the
        friction stops the body ("" otherwise)."""
        if "stop_time" not in self.names:
            return ""
        sc = self.scene
        t0 = float(sc.t0)
        mean = float(self._stats("stop_time")[0])
        if not (math.isfinite(t0) and t0 > 0 and math.isfinite(mean)):
            return ""
        after = mean - t0
        if not 0.0 <= after <= self.SET_BY_SCENE * t0:
            return ""
        unit = sc.units_of("stop_time")
        u = f" {unit}" if unit else ""
        return (f"stop_time is set by the scene: the noise ends at {sc.time_name}0 = "
                f"{t0:.6g}{u} and the paths come to rest {after:.2g}{u} after it on average "
                "(the shaking has died down so far by then that they stop at once): it "
                "tells when the scene's shaking ends, not how the friction stops the body")

    def _few_note(self) -> str:
        """The tables' note on the standard errors marked FEW_MARK ("" if none)."""
        marked = []
        for n in self.names:
            for stat in ("mean", "var"):
                few = self._few(n, stat)
                if few.any():
                    at = ("at the stop" if quantity(n).at_stop else
                          f"{self.scene.time_name} = " + ", ".join(
                              f"{t:g}" for t in self.times[few]))
                    marked.append(f"{'the variance of ' if stat == 'var' else ''}{n} ({at})")
        if not marked:
            return ""
        return (f"{FEW_MARK}: fewer than {MIN_CARRIERS} paths carry the spread "
                f"(Result.carriers), so the standard error is not estimated (more paths "
                "would give it): " + "; ".join(marked))

    def __str__(self) -> str:
        return self.summary()

    def _repr_html_(self) -> str:
        """The statistics as an HTML table (Jupyter shows it for a result)."""
        return _render.table_html(self)

    # -- export -------------------------------------------------------------------------

    def to_xarray(self) -> Any:
        """The statistics as an ``xarray.Dataset`` (needs ``crandall[io]``).

        Returns
        -------
        xarray.Dataset
            One variable per quantity and statistic, ``NAME_STAT`` with STAT one of mean,
            var, std, stderr, var_stderr, bias_mean, error_mean, bias_var, error_var (over
            ``time`` for a time-resolved quantity, a scalar at the stop), each with its own
            CF ``units`` (UDUNITS: ``m s-1``, ``m2``; ``"1"`` in scaled units) and
            ``long_name``; the file's ``Conventions`` is CF-1.10; the raw accumulators (``counts``, ``means``, ``central``; with the
            peaks ``peaks_*`` and ``stop_peaks_*``) from which :func:`crandall.load` rebuilds
            the result exactly; with distributions, ``histogram_NAME_edges`` and
            ``histogram_NAME_counts`` per binned quantity (over ``time`` for a quantity over
            time; cells underflow, one per bin, overflow, NaN; NaN-padded). Attributes: the scene (as
            JSON and one ``scene_*`` attribute per parameter), paths, seed (a string: it may
            not fit a netCDF-3 integer), dt, method, crandall version.
        """
        return _dataset.to_xarray(self)

    def to_pandas(self, *, tidy: bool = False) -> Any:
        """The statistics as a ``pandas.DataFrame``, one row per quantity and time.

        Parameters
        ----------
        tidy : bool, default False
            One row per quantity, time and statistic instead (the form ``crandall run``
            writes to result.csv), each value with its own unit.

        Returns
        -------
        pandas.DataFrame
            Columns ``quantity``, the time (``t`` or ``tau``; NaN for stop quantities),
            ``units`` (the mean's), ``mean``, ``var``, ``std``, ``stderr``, ``var_stderr``
            (NaN for the kinetic energy), ``bias_mean``, ``error_mean``, ``bias_var``,
            ``error_var``. With ``tidy``: ``quantity``, ``time`` (NaN for stop quantities),
            ``time_units``, ``statistic``, ``value`` and ``units``, units as UDUNITS strings
            (``m s-1``, ``m2``; ``1`` in scaled units).
        """
        return _dataset.to_pandas(self, tidy=tidy)

    def save(self, path) -> None:
        """Write the result to a netCDF file (replaced atomically); read it with
        :func:`crandall.load`.

        Parameters
        ----------
        path : str or os.PathLike
            Conventionally ending in ``.nc``.
        """
        # The file keeps the accumulators, and the result loaded from it warns where its
        # statistics are NaN: writing it warns of nothing.
        with self._table():
            _dataset.save(self, path)

    def __repr__(self) -> str:
        return (f"<crandall.Result {self.scene!r} paths={self.paths} seed={self.seed} "
                f"method={self.method!r}>")

    #: What made the result: "fixed_step" (``simulate(paths=...)``) or "accuracy"
    #: (``simulate(error=...)``, :class:`AccuracyResult`).
    kind = "fixed_step"


class AccuracyResult(Result):
    """Statistics of a run to a requested accuracy (``crandall.simulate(scene, error=...)``).

    A :class:`Result`: the same statistics (``mean``, ``var``, ``std``, ``stderr``,
    ``var_stderr``), accuracy (``bias``, ``error``, ``interval``, ``exact``), tables
    (``to_pandas``, ``to_xarray``, the same layout), files (``save``, ``crandall.load``,
    bitwise) and figures. Every statistic (the mean and the variance of each quantity at each
    output time, and at the stop) comes from the multilevel estimator with its standard
    error, its estimated discretisation bias and the total error sqrt(stderr^2 + bias^2),
    which the run brought below the target. ``stderr(name, "var")`` is the standard error of
    the variance (as ``var_stderr``). A statistic the run was not asked for (``statistics=``)
    raises ValueError naming ``stat``; in tables it is NaN.

    It holds no per-path accumulators: no histograms (a scene that asks for distributions is
    refused by ``simulate(error=...)``), no mixed moments (:meth:`moment`).

    Attributes
    ----------
    error_target, rel_error_target : float or None
        The target the run met (one of them).
    levels : list of dict
        Per level: ``level``, ``paths``, ``steps_per_path``, ``dt`` (its step).
    paths : int
        Paths over all levels.
    dt : float
        The finest level's step.
    """

    kind = "accuracy"
    method = "mlmc"

    def __init__(self, *, scene: Scene, seed: int, error_target: Optional[float],
                 rel_error_target: Optional[float],
                 estimates: Dict[Tuple[str, str], np.ndarray],
                 exact: Dict[Tuple[str, str], bool], levels: List[dict], path_steps: int,
                 rounds: int, wall_time: Optional[float] = None,
                 random_stream: Optional[int] = None) -> None:
        self.scene = scene
        self.seed = int(seed)
        self.error_target = None if error_target is None else float(error_target)
        self.rel_error_target = None if rel_error_target is None else float(rel_error_target)
        self.random_stream = int(_core.RANDOM_STREAM if random_stream is None else random_stream)
        self._estimates = {k: np.asarray(v, dtype=np.float64) for k, v in estimates.items()}
        self._exact = dict(exact)
        self.levels = [dict(lv) for lv in levels]
        self.paths = int(sum(lv["paths"] for lv in self.levels))
        self.dt = float(self.levels[-1]["dt"]) if self.levels else math.nan
        self.min_steps = 0
        self.steps_per_path = int(self.levels[-1]["steps_per_path"]) if self.levels else 0
        self._path_steps = int(path_steps)
        self._rounds = int(rounds)
        self._wall_time = None if wall_time is None else float(wall_time)
        self._histograms = None
        self._warned: set = set()

    # -- what the run holds --------------------------------------------------------------

    @property
    def spec(self):
        raise ValueError("spec: a run to an accuracy has no fixed-step specification; its "
                         "target, seed and scene are error_target, rel_error_target, seed "
                         "and scene")

    @property
    def accumulators(self):
        raise ValueError("accumulators: a run to an accuracy keeps its estimates, not "
                         "per-path accumulators")

    @property
    def names(self) -> tuple:
        """The quantities with at least one statistic in this result."""
        return tuple(n for n in names_for(self.scene.observe)
                     if any((n, s) in self._estimates for s in ("mean", "var")))

    def stats_of(self, name: str) -> tuple:
        """The statistics ("mean", "var") the run estimated for a quantity."""
        return tuple(s for s in ("mean", "var") if (name, s) in self._estimates)

    @property
    def cost(self) -> dict:
        """What the answer cost: ``wall_time`` (s), ``path_steps``, ``paths`` per level,
        ``rounds``."""
        return {"wall_time": self._wall_time, "path_steps": self._path_steps,
                "paths": [lv["paths"] for lv in self.levels], "rounds": self._rounds}

    def _get(self, name: str, stat: str, field: int, missing_nan: bool = False):
        if stat not in ("mean", "var"):
            raise ValueError(f"stat must be 'mean' or 'var', got {stat!r}")
        if name not in self.names:
            raise ValueError(f"name: {name!r} is not in this result; it holds "
                             f"{', '.join(self.names)}")
        q = quantity(name)
        if (name, stat) not in self._estimates:
            if missing_nan:
                out = np.full(1 if q.at_stop else self.times.size, math.nan)
                return float(out[0]) if q.at_stop else out
            raise ValueError(f"stat: the {stat} of {name} was not asked for (the run's "
                             f"statistics= named {', '.join(self.stats_of(name))} of it)")
        f = q.factor(self.scene)
        scale = f if stat == "mean" else f * f
        vals = self._estimates[(name, stat)][:, field] * scale
        if field == 0 and stat == "mean" and q.offset is not None:
            vals = vals + q.offset(self.scene)
        return float(vals[0]) if q.at_stop else vals

    # -- statistics -----------------------------------------------------------------------

    def mean(self, name: str) -> Stat:
        """The estimated mean of a quantity."""
        return self._get(name, "mean", 0)

    def var(self, name: str) -> Stat:
        """The estimated variance of a quantity."""
        return self._get(name, "var", 0)

    def std(self, name: str) -> Stat:
        """The square root of the estimated variance (0 where the estimate is below 0)."""
        return np.sqrt(np.maximum(self.var(name), 0.0))

    def stderr(self, name: str, stat: str = "mean") -> Stat:
        """The standard error of a statistic (statistical error only); of the mean unless
        ``stat="var"``."""
        return self._get(name, stat, 1)

    def var_stderr(self, name: str) -> Stat:
        """The standard error of the variance."""
        return self._get(name, "var", 1)

    def _bias(self, name: str, stat: str, warn: bool):
        return self._get(name, stat, 2, missing_nan=not warn)

    def bias(self, name: str, stat: str = "mean") -> Stat:
        """The estimated magnitude of the discretisation bias of a statistic: 0 exactly for
        the statistics exact in law (see :meth:`exact`), otherwise Giles' estimate from the
        finest levels."""
        return self._bias(name, stat, True)

    def bias_is_bound(self, name: str, stat: str = "mean") -> bool:
        """False: the levels' bias is an estimate, never a bound."""
        self._get(name, stat, 2)
        return False

    def _error(self, name: str, stat: str, warn: bool):
        return np.hypot(self._get(name, stat, 1, missing_nan=not warn),
                        self._get(name, stat, 2, missing_nan=not warn))

    def exact(self, name: str, stat: str = "mean") -> bool:
        """Whether the statistic is exact (its bias is 0, not estimated): exact in law at any
        step, or given by an identity (the mean distance through Ito's formula)."""
        self._get(name, stat, 0)
        return self._exact[(name, stat)]

    def moment(self, j: int, k: int, l: int) -> np.ndarray:  # noqa: E741 - the paper's index
        raise ValueError("moment: a run to an accuracy estimates means and variances only; "
                         "run mixed moments with paths=")

    def carriers(self, name: str) -> Stat:
        raise ValueError("carriers: a run to an accuracy keeps its levels' estimates, not the "
                         "central sums the carrying paths are counted from; run with paths=")

    def _few(self, name: str, stat: str) -> np.ndarray:
        # Its standard errors come from the levels' estimates (crandall.adaptive).
        return np.zeros(1 if quantity(name).at_stop else self.times.size, dtype=bool)

    def table(self, name: str) -> np.ndarray:
        """The tables' row(s) of a quantity: (mean, var, std, stderr, var_stderr, bias_mean,
        error_mean, bias_var, error_var), NaN for a statistic not estimated; shape (times, 9),
        or (9,) at the stop."""
        m = [self._get(name, "mean", k, True) for k in (0, 1, 2)]
        v = [self._get(name, "var", k, True) for k in (0, 1, 2)]
        cols = [m[0], v[0], np.sqrt(np.maximum(v[0], 0.0)), m[1], v[1],
                m[2], np.hypot(m[1], m[2]), v[2], np.hypot(v[1], v[2])]
        return np.stack([np.asarray(c, dtype=float) for c in cols], axis=-1)

    # -- presentation ---------------------------------------------------------------------

    def target_text(self) -> str:
        return (f"error <= {self.error_target:g}" if self.error_target is not None
                else f"rel_error <= {self.rel_error_target:g}")

    def summary(self) -> str:
        """A readable table: every statistic with its standard error, bias and total error."""
        sc = self.scene
        wall = self._wall_time
        lines = [f"crandall result: {sc!r}",
                 f"  {self.target_text()}  seed={self.seed}  method=mlmc  "
                 f"levels={len(self.levels)}  paths per level={self.cost['paths']}  "
                 f"path-steps={self._path_steps:.3g}"
                 + ("" if wall is None else f"  time={wall:.3g} s")]
        for n in self.names:
            q = quantity(n)
            u = sc.units_of(n)
            lines.append(f"  {n}" + (f" [{u}]" if u else ""))
            lines.append(f"    {'' if q.at_stop else sc.time_name:>10}  {'stat':>4}  "
                         f"{'estimate':>13}  {'stderr':>9}  {'bias':>9}  {'error':>9}")
            for stat in self.stats_of(n):
                vals = np.atleast_1d(self._get(n, stat, 0))
                ses = np.atleast_1d(self._get(n, stat, 1))
                bs = np.atleast_1d(self._get(n, stat, 2))
                ts = [None] if q.at_stop else list(self.times)
                for j, t in enumerate(ts):
                    tt = "stop" if t is None else f"{t:.4g}"
                    b = "exact" if self._exact[(n, stat)] else f"{bs[j]:.2g}"
                    lines.append(f"    {tt:>10}  {stat:>4}  {vals[j]:>13.6g}  {ses[j]:>9.2g}  "
                                 f"{b:>9}  {math.hypot(ses[j], bs[j]):>9.2g}")
        return "\n".join(lines)

    def __repr__(self) -> str:
        return (f"<crandall.Result {self.scene!r} {self.target_text()} seed={self.seed} "
                f"method='mlmc' paths={self.paths}>")
