"""Statistics of a run: means, variances, standard errors, mixed moments, a summary."""

from __future__ import annotations

import math
import warnings
from typing import NamedTuple, Optional

import numpy as np

from . import _core, _dataset
from .quantities import core_flags, find, names_for, quantity
from .scene import Scene
from .spec import RunSpec

__all__ = ["Result", "Accumulators", "StatisticsWarning"]


class StatisticsWarning(UserWarning):
    """A statistic could not be estimated from this run and is returned as NaN.

    Raised (as a warning) by :meth:`Result.var`, :meth:`Result.std`, :meth:`Result.stderr` and
    :meth:`Result.var_stderr` when they return NaN: a variance from fewer than 2 paths, or a
    standard error of a variance whose fourth-moment term is negative (an extrapolated method
    at a step far too long for it) or overflows doubles.
    """

#: Exponents (velocity, displacement, distance) of the accumulators' moments, in their order.
MONOMIALS = tuple(tuple(e) for e in _core.monomial_exponents())
_EXPONENTS = list(MONOMIALS)
_INDEX = {e: i for i, e in enumerate(_EXPONENTS)}


def _sqrt(x: float) -> float:
    return math.sqrt(x) if x >= 0 else math.nan  # NaN (n/a) stays NaN


def _fmt(x: float, spec: str) -> str:
    width = "".join(c for c in spec.split(".")[0] if c.isdigit())
    text = "n/a" if math.isnan(x) else format(x, spec)
    return f"{text:>{width}}" if width else text


def _e(v: int, power: int) -> int:
    exps = [0, 0, 0]
    exps[v] = power
    return _INDEX[tuple(exps)]


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


class Result:
    """Statistics of a simulated scene, in the scene's units.

    Time-resolved quantities ("velocity", "displacement", "distance", "kinetic_energy",
    "dissipated_energy") give arrays over :attr:`times`; stop quantities ("stop_time",
    "displacement_at_stop", "distance_at_stop", "dissipated_energy_at_stop") give floats.
    Variances are the unbiased sample variances; ``stderr`` is the standard error of the mean.

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

    def __init__(self, *, scene: Scene, paths: int, seed: int, dt: float, method: str,
                 moments, stop_moments, steps_per_path: int, min_steps: int = 0,
                 random_stream: Optional[int] = None) -> None:
        self.scene = scene
        self.paths = int(paths)
        self.seed = int(seed)
        self.dt = float(dt)
        self.method = method
        self.min_steps = int(min_steps)
        #: Version of the random stream that drew the paths (docs/random-numbers.md): the same
        #: seed gives the same numbers only within one stream version.
        self.random_stream = int(_core.RANDOM_STREAM if random_stream is None else random_stream)
        self.steps_per_path = int(steps_per_path)
        self._moments = moments
        self._stop = stop_moments
        self._warned: set = set()
        self._raw = moments.raw() if moments.slots else np.zeros((0, len(_EXPONENTS)))
        self._stop_raw = stop_moments.raw() if stop_moments is not None else None

    @property
    def spec(self) -> RunSpec:
        """The run's specification (scene, paths, seed, dt, method, min_steps): what a
        checkpoint of the run records. ``min_steps > 0`` is the default graded grid, which
        ``simulate`` repeats with ``dt=None``."""
        return RunSpec(self.scene, self.paths, self.seed, self.dt, self.method, self.min_steps)

    @property
    def accumulators(self) -> Accumulators:
        """The raw accumulators of the run (see :class:`Accumulators`)."""
        return Accumulators(self._moments, self._stop)

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
        if q.at_stop:
            return self._stop, self._stop_raw, q.variable, True
        return self._moments, self._raw, q.variable, False

    def _factor(self, name: str) -> float:
        return quantity(name).factor(self.scene)

    def _stats(self, name: str):
        acc, raw, v, scalar = self._source(name)
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
        if scalar:
            return float(mean[0]), float(var[0]), float(n[0])
        return mean, var, n

    def _warn_nan(self, name: str, what: str, values, reason: str, stacklevel: int) -> None:
        if not np.isnan(np.asarray(values, dtype=float)).any():
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

    def mean(self, name: str):
        """Sample mean of a quantity (array over times, or a float for stop quantities)."""
        return self._stats(name)[0]

    def var(self, name: str):
        """Unbiased sample variance of a quantity (NaN, with a warning, for 1 path)."""
        return self._var(name)[0]

    def std(self, name: str):
        """Sample standard deviation of a quantity."""
        return np.sqrt(self._var(name)[0])

    def stderr(self, name: str):
        """Standard error of the mean of a quantity: sqrt(var / paths)."""
        var, n = self._var(name)
        return np.sqrt(var / n)

    def var_stderr(self, name: str):
        """Standard error of the sample variance, sqrt((m4 - m2^2) / n) from central moments.

        Not available for the kinetic energy (it would need 8th moments of the velocity).

        NaN, with a :class:`StatisticsWarning`, where it cannot be estimated: fewer than 2
        paths; a fourth-moment term m4 - m2^2 that is negative beyond rounding (impossible for
        a sample, so only from an extrapolated method whose step is far too long for the
        scene: the combination of the grids is then no distribution's moments); or fourth
        moments that overflow doubles. Never 0 unless the quantity is constant (m2 = m4 = 0).
        """
        known = find(name)
        if known is not None and not known.has_var_stderr:
            raise ValueError(f"name: the variance of {name} has no standard error "
                             "here (needs moments of order 8)")
        acc, _, v, scalar = self._source(name)
        n = acc.counts
        f = self._factor(name)
        with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
            m2 = acc.central[:, _e(v, 2)] / n
            m4 = acc.central[:, _e(v, 4)] / n
            d = m4 - m2 * m2
            # Rounding can leave a two-point law's m4 - m2^2 = 0 slightly negative.
            tiny = 1e-12 * m2 * m2
            ok = (n >= 2) & np.isfinite(d) & (d >= -tiny)
            se = np.where(ok, f * f * np.sqrt(np.maximum(d, 0.0) / n), np.nan)
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
            self._warn_nan(name, "the standard error of the variance", se, "; ".join(reasons), 2)
        return float(se[0]) if scalar else se

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
        time_names = [n for n in self.names if not quantity(n).at_stop]
        if time_names and self.times.size:
            # One block per quantity: time, mean ± standard error, variance, standard deviation.
            for n in time_names:
                u = sc.units_of(n)
                lines.append(f"  {n}" + (f" [{u}]" if u else ""))
                lines.append(f"    {sc.time_name:>10}  {'mean':>13}  {'± stderr':>10}  "
                             f"{'var':>12}  {'std':>12}")
                mean, var, cnt = self._stats(n)
                for i, t in enumerate(self.times):
                    lines.append(f"    {t:>10.4g}  {mean[i]:>13.6g}  "
                                 f"{_fmt(_sqrt(var[i] / cnt[i]), '10.2g')}  "
                                 f"{_fmt(var[i], '12.6g')}  {_fmt(_sqrt(var[i]), '12.6g')}")
        stop_names = [n for n in self.names if quantity(n).at_stop]
        if stop_names:
            lines.append("  at the stop:")
            for n in stop_names:
                mean, var, cnt = self._stats(n)
                u = sc.units_of(n)
                lines.append(f"    {n:<26} mean {mean:.6g} ± {_fmt(_sqrt(var / cnt), '.2g')}"
                             f"   var {_fmt(var, '.6g')}" + (f"   [{u}]" if u else ""))
        return "\n".join(lines)

    def __str__(self) -> str:
        return self.summary()

    # -- export -------------------------------------------------------------------------

    def to_xarray(self):
        """The statistics as an ``xarray.Dataset`` (needs ``crandall[io]``).

        Returns
        -------
        xarray.Dataset
            ``statistics`` (time x observable x statistic: mean, var, std, stderr,
            var_stderr) for the time-resolved quantities, with their units in the coordinate
            ``units`` (``"1"`` in scaled units); ``stop_statistics`` (stop_quantity x statistic)
            for the stop; the raw accumulators (``counts``, ``means``, ``central``) from
            which :func:`crandall.load` rebuilds the result exactly. Attributes: the scene (as
            JSON and one ``scene_*`` attribute per parameter), paths, seed (a string: it may
            not fit a netCDF-3 integer), dt, method, crandall version.
        """
        return _dataset.to_xarray(self)

    def to_pandas(self):
        """The statistics as a ``pandas.DataFrame``, one row per quantity and time.

        Returns
        -------
        pandas.DataFrame
            Columns ``quantity``, the time (``t`` or ``tau``; NaN for stop quantities),
            ``units``, ``mean``, ``var``, ``std``, ``stderr``, ``var_stderr`` (NaN for the
            kinetic energy).
        """
        return _dataset.to_pandas(self)

    def save(self, path) -> None:
        """Write the result to a netCDF file (replaced atomically); read it with
        :func:`crandall.load`.

        Parameters
        ----------
        path : str or os.PathLike
            Conventionally ending in ``.nc``.
        """
        _dataset.save(self, path)

    def __repr__(self) -> str:
        return (f"<crandall.Result {self.scene!r} paths={self.paths} seed={self.seed} "
                f"method={self.method!r}>")
