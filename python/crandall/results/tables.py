"""A result's statistics table (built once: ``_statistics_table``) and its shown forms: the summary
and its notes, the HTML table, the xarray and pandas tables, and its file."""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from .. import _dataset, _frames, _render
from ..quantities import quantity
from . import render_text
from .table import few_note, StatisticsRows, Table


class _Tables:
    """A result's text, HTML and tables: the summary and its notes, ``to_xarray``, ``to_pandas``
    and ``save``. A part of :class:`Result`."""

    # -- the table every shown form renders --------------------------------------------

    #: How the text summary lays the table out (:data:`crandall.results.table.LAYOUTS`).
    _layout = "statistics"

    def _statistics_table(self, estimate_bias: bool = True) -> Table:
        """The result's statistics table, which every shown form renders (the summary, HTML,
        pandas, CSV and xarray). ``estimate_bias=False``: a bias that takes a run of its own
        is left out (NaN, ``bias_pending``) instead of made (showing never runs paths)."""
        pending = bool(self.bias_pending and not estimate_bias)
        rows = StatisticsRows()
        for name in self.names:
            self._statistics_rows(rows, name, pending)
        sc = self.scene
        columns = rows.columns()
        notes = tuple(n for n in (few_note(columns, sc.time_name), *self._table_notes()) if n)
        return Table(self._layout, "crandall result",
                     (f"crandall result: {sc!r}", *self._run_lines(pending)),
                     (repr(sc), self._run_brief()), columns, notes, time_name=sc.time_name,
                     units_system=sc.units, times=np.asarray(self.times, dtype=float),
                     bias_pending=pending)

    def _statistics_rows(self, rows: StatisticsRows, name: str, pending: bool) -> None:
        """A quantity's rows: its mean and variance at each output time (or at the stop)."""
        q = quantity(name)
        times = [math.nan] if q.at_stop else self.times
        mean, var, std, se = self.mean(name), self.var(name), self.std(name), self.stderr(name)
        vse = (self.var_stderr(name) if self._has_var_stderr(name)
               else np.full(np.shape(mean), math.nan))
        for stat, value, stderr in (("mean", mean, se), ("var", var, vse)):
            if pending:
                bias = error = np.full(np.shape(mean), math.nan)
                bound = False
            else:
                bias, error = self._bias(name, stat, False), self._error(name, stat, False)
                bound = bool(self._bias_cache[(name, stat)][1])
            rows.add(name, self.scene.units_of(name), q.long_name_in(self.scene.units), times,
                     stat, value=value, std=std, stderr=stderr, bias=bias, error=error,
                     estimated=True, exact=self.exact(name, stat), bound=bound,
                     few=self._few(name, stat))

    def _run_lines(self, pending: bool) -> tuple:
        """The summary's lines on the run, below the scene."""
        lines = [f"  paths={self.paths}  seed={self.seed}  method={self.method}  "
                 f"dt={self.dt:.6g}  min_steps={self.min_steps}  "
                 f"steps/path={self.steps_per_path}  random_stream={self.random_stream}"]
        if self.paths < 2:
            lines.append("  (n/a: a variance needs at least 2 paths)")
        if pending:
            lines.append("  bias: not estimated yet (?): it takes a run of its own; "
                         "result.estimate_bias() makes it (so does result.bias(name))")
        else:
            lines.append("  bias: estimated discretisation bias (0: exact in law; "
                         "Result.bias, docs/methods/adaptive.md)")
        return tuple(lines)

    def _run_brief(self) -> str:
        """The run in a line (the HTML table's heading)."""
        return (f"{self.paths:,} paths, seed {self.seed}, method {self.method}, "
                f"dt {self.dt:.4g}")

    def _table_notes(self) -> tuple:
        """The table's notes beyond the marked standard errors."""
        return (self._scene_note(),)

    # -- presentation -------------------------------------------------------------------

    def summary(self) -> str:
        """A readable table of the statistics."""
        with self._table():
            return render_text.text(self._statistics_table(estimate_bias=False))

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

    def __str__(self) -> str:
        return self.summary()

    def _repr_html_(self) -> str:
        """The statistics as an HTML table (Jupyter shows it for a result)."""
        with self._table():
            return _render.html_table(self._statistics_table(estimate_bias=False))

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
        return _frames.table_xarray(self._statistics_table(), *self._file_contents())

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
        return _frames.table_pandas(self._statistics_table(), tidy=tidy)

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

    def _file_contents(self) -> tuple:
        """What a saved result holds beyond its statistics table, from which
        :func:`crandall.load` rebuilds it: (variables, coordinates, attributes) of the
        dataset."""
        return _dataset.fixed_step_contents(self)
