"""A result's summary, notes, HTML table, xarray and pandas tables, and its file."""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from .. import _dataset, _render
from ..quantities import quantity
from .common import _fmt, _sqrt, FEW_MARK, MIN_CARRIERS


class _Tables:
    """A result's text, HTML and tables: the summary and its notes, ``to_xarray``, ``to_pandas``
    and ``save``. A part of :class:`Result`."""

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
