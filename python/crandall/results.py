"""Statistics of a run: means, variances, standard errors, mixed moments, a summary."""

from __future__ import annotations

import math
from typing import Optional

import numpy as np

from . import _core
from .scene import STOP_QUANTITIES, Scene

__all__ = ["Result"]

_EXPONENTS = [tuple(e) for e in _core.monomial_exponents()]
_INDEX = {e: i for i, e in enumerate(_EXPONENTS)}
# Which simulated variable (0 velocity, 1 displacement, 2 distance) carries each quantity.
_VARIABLE = {"velocity": 0, "displacement": 1, "distance": 2, "dissipated_energy": 2,
             "kinetic_energy": 0}
_STOP_VARIABLE = {"stop_time": 0, "displacement_at_stop": 1, "distance_at_stop": 2,
                  "dissipated_energy_at_stop": 2}


def _e(v: int, power: int) -> int:
    exps = [0, 0, 0]
    exps[v] = power
    return _INDEX[tuple(exps)]


class Result:
    """Statistics of a simulated scene, in the scene's units.

    Time-resolved quantities ("velocity", "displacement", "distance", "kinetic_energy",
    "dissipated_energy") give arrays over :attr:`times`; stop quantities ("stop_time",
    "displacement_at_stop", "distance_at_stop", "dissipated_energy_at_stop") give floats.
    Variances are the unbiased sample variances; ``stderr`` is the standard error of the mean.
    """

    def __init__(self, *, scene: Scene, paths: int, seed: int, dt: float, method: str,
                 moments, stop_moments, steps_per_path: int) -> None:
        self.scene = scene
        self.paths = int(paths)
        self.seed = int(seed)
        self.dt = float(dt)
        self.method = method
        self.steps_per_path = int(steps_per_path)
        self._moments = moments
        self._stop = stop_moments
        self._raw = moments.raw() if moments.slots else np.zeros((0, len(_EXPONENTS)))
        self._stop_raw = stop_moments.raw() if stop_moments is not None else None

    @property
    def times(self) -> np.ndarray:
        """Output times, in the scene's time units (s, or scaled tau)."""
        return self.scene.times

    @property
    def names(self) -> tuple:
        """The quantities this result holds."""
        obs = self.scene.observe
        out = [n for n in obs if n != "stop"]
        if "stop" in obs:
            out += [q for q, need in STOP_QUANTITIES.items() if need is None or need in obs]
        return tuple(out)

    # -- statistics ---------------------------------------------------------------------

    def _source(self, name: str):
        if name not in self.names:
            raise ValueError(
                f"name: {name!r} is not in this result; it holds {', '.join(self.names)}"
            )
        if name in _STOP_VARIABLE:
            return self._stop, self._stop_raw, _STOP_VARIABLE[name], True
        return self._moments, self._raw, _VARIABLE[name], False

    def _factor(self, name: str) -> float:
        base = name.replace("_at_stop", "")
        if base == "dissipated_energy":
            return self.scene.mass * self.scene.drift
        if base == "kinetic_energy":
            return 0.5 * self.scene.mass
        return 1.0

    def _stats(self, name: str):
        acc, raw, v, scalar = self._source(name)
        n = acc.counts
        f = self._factor(name)
        if name == "kinetic_energy":
            m2, m4 = raw[:, _e(v, 2)], raw[:, _e(v, 4)]
            mean = f * m2
            var = f * f * np.maximum(m4 - m2 * m2, 0.0) * n / np.maximum(n - 1, 1)
        else:
            mean = f * acc.means[:, v]
            if name == "stop_time":
                # The core keeps the time from the switch-off to the stop (exact at any t0).
                mean = mean + self.scene.t0
            var = f * f * acc.central[:, _e(v, 2)] / np.maximum(n - 1, 1)
        if scalar:
            return float(mean[0]), float(var[0]), float(n[0])
        return mean, var, n

    def mean(self, name: str):
        """Sample mean of a quantity (array over times, or a float for stop quantities)."""
        return self._stats(name)[0]

    def var(self, name: str):
        """Unbiased sample variance of a quantity."""
        return self._stats(name)[1]

    def std(self, name: str):
        """Sample standard deviation of a quantity."""
        return np.sqrt(self._stats(name)[1])

    def stderr(self, name: str):
        """Standard error of the mean of a quantity: sqrt(var / paths)."""
        _, var, n = self._stats(name)
        return np.sqrt(var / n)

    def var_stderr(self, name: str):
        """Standard error of the sample variance, sqrt((m4 - m2^2) / n) from central moments.

        Not available for the kinetic energy (it would need 8th moments of the velocity).
        """
        if name == "kinetic_energy":
            raise ValueError("name: the variance of kinetic_energy has no standard error "
                             "here (needs moments of order 8)")
        acc, _, v, scalar = self._source(name)
        n = acc.counts
        f = self._factor(name)
        m2 = acc.central[:, _e(v, 2)] / n
        m4 = acc.central[:, _e(v, 4)] / n
        se = f * f * np.sqrt(np.maximum(m4 - m2 * m2, 0.0) / n)
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
        obs = self.scene.observe
        if k and "displacement" not in obs:
            raise ValueError("k: the displacement (U2) was not observed in this scene")
        if l and not ({"distance", "dissipated_energy"} & set(obs)):
            raise ValueError("l: the distance (U3) was not observed in this scene")
        value = self._raw[:, _INDEX[(j, k, l)]].copy()
        if self.scene.units == "SI":
            s = self.scene.scaling
            if s is None:
                raise ValueError("moment: scaled units need mu > 0 and h > 0 (eq8)")
            value /= s.velocity_scale**j * s.length_scale ** (k + l)
        return value

    # -- presentation -------------------------------------------------------------------

    def summary(self) -> str:
        """A readable table of the statistics."""
        sc = self.scene
        lines = [
            f"crandall result: {sc!r}",
            f"  paths={self.paths}  seed={self.seed}  method={self.method}  dt={self.dt:.6g}  "
            f"steps/path={self.steps_per_path}",
        ]
        time_names = [n for n in self.names if n not in STOP_QUANTITIES]
        if time_names and self.times.size:
            # One block per quantity: time, mean ± standard error, variance, standard deviation.
            for n in time_names:
                u = sc.units_of(n)
                lines.append(f"  {n}" + (f" [{u}]" if u else ""))
                lines.append(f"    {sc.time_name:>10}  {'mean':>13}  {'± stderr':>10}  "
                             f"{'var':>12}  {'std':>12}")
                mean, var, cnt = self._stats(n)
                for i, t in enumerate(self.times):
                    se = math.sqrt(var[i] / cnt[i])
                    lines.append(f"    {t:>10.4g}  {mean[i]:>13.6g}  {se:>10.2g}  "
                                 f"{var[i]:>12.6g}  {math.sqrt(var[i]):>12.6g}")
        stop_names = [n for n in self.names if n in STOP_QUANTITIES]
        if stop_names:
            lines.append("  at the stop:")
            for n in stop_names:
                mean, var, cnt = self._stats(n)
                u = sc.units_of(n)
                lines.append(f"    {n:<26} mean {mean:.6g} ± {math.sqrt(var / cnt):.2g}"
                             f"   var {var:.6g}" + (f"   [{u}]" if u else ""))
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
        from . import io

        return io.to_xarray(self)

    def to_pandas(self):
        """The statistics as a ``pandas.DataFrame``, one row per quantity and time.

        Returns
        -------
        pandas.DataFrame
            Columns ``quantity``, the time (``t`` or ``tau``; NaN for stop quantities),
            ``units``, ``mean``, ``var``, ``std``, ``stderr``, ``var_stderr`` (NaN for the
            kinetic energy).
        """
        from . import io

        return io.to_pandas(self)

    def save(self, path) -> None:
        """Write the result to a netCDF file (replaced atomically); read it with
        :func:`crandall.load`.

        Parameters
        ----------
        path : str or os.PathLike
            Conventionally ending in ``.nc``.
        """
        from . import io

        io.save(self, path)

    def __repr__(self) -> str:
        return (f"<crandall.Result {self.scene!r} paths={self.paths} seed={self.seed} "
                f"method={self.method!r}>")
