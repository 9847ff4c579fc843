"""The one table every result's shown forms come from (``Table``), and the rows of a statistics
table (``StatisticsRows``).

A result builds its table once (``Result._statistics_table``, ``AccuracyResult``'s rows,
``TailResult._statistics_table``); the summary text (``results/render_text.py``), the HTML
(``_render.py``) and the pandas, CSV and xarray tables (``_frames.py``) render it and read
nothing else of the result.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Dict, List, Tuple

import numpy as np

from .common import FEW_MARK, MIN_CARRIERS, z_of

#: The layouts a table is shown in. "statistics": per quantity and output time (and at the
#: stop) the mean and the variance side by side, with their standard errors and biases;
#: "statistic_rows": the same table with one text row per statistic (estimate, standard error,
#: bias or "exact", total error; only the statistics that were estimated); "levels": per level
#: a tail probability, its standard error, relative error, interval and whether it is reliable.
LAYOUTS = ("statistics", "statistic_rows", "levels")

#: The columns of a statistics table, one row per quantity, statistic ("mean" or "var") and
#: slot (output time, or the stop), ordered by quantity, then statistic, then slot.
STATISTICS_COLUMNS = ("quantity", "units", "long_name", "at_stop", "time", "statistic",
                      "value", "std", "stderr", "bias", "error", "lower", "upper",
                      "estimated", "exact", "bound", "few")
#: The columns of a tail's table, one row per level.
LEVELS_COLUMNS = ("level", "units", "probability", "stderr", "rel_error", "lower", "upper",
                  "reliable")


@dataclass(frozen=True)
class Table:
    """A result's statistics, as every shown form of it reads them.

    Attributes
    ----------
    layout : str
        One of :data:`LAYOUTS`.
    name : str
        What the table is ("crandall result", "crandall tail").
    text_header, html_header : tuple of str
        The lines above the table in the text summary, and in HTML (each line escaped there).
    columns : dict of str to ndarray
        One array per column (:data:`STATISTICS_COLUMNS` or :data:`LEVELS_COLUMNS`), one
        entry per row.
    notes : tuple of str
        What the table's marks mean, below it (the standard errors not estimated, a stop time
        set by the scene).
    level : float
        The coverage of the interval columns ``lower`` and ``upper``.
    time_name, units_system : str
        The name of the time ("t" or "tau") and the scene's units ("SI" or "scaled").
    times : ndarray
        The output times (the rows' times at the stop are NaN).
    bias_pending : bool
        Whether the biases are not estimated yet (a run of their own makes them): shown "?".
    """

    layout: str
    name: str
    text_header: Tuple[str, ...]
    html_header: Tuple[str, ...]
    columns: Dict[str, np.ndarray]
    notes: Tuple[str, ...] = ()
    level: float = 0.95
    time_name: str = "t"
    units_system: str = "SI"
    times: np.ndarray = field(default_factory=lambda: np.zeros(0))
    bias_pending: bool = False

    def __post_init__(self):
        if self.layout not in LAYOUTS:
            raise ValueError(f"layout must be one of {', '.join(LAYOUTS)}, got {self.layout!r}")
        wanted = LEVELS_COLUMNS if self.layout == "levels" else STATISTICS_COLUMNS
        if tuple(self.columns) != wanted:
            raise ValueError(f"columns must be {', '.join(wanted)}, got "
                             f"{', '.join(self.columns)}")
        if len({len(c) for c in self.columns.values()}) > 1:
            raise ValueError("columns must have one entry per row")

    def __len__(self) -> int:
        return len(next(iter(self.columns.values())))

    def rows(self, **where) -> np.ndarray:
        """The indices of the rows whose columns have the values given, in the table's order."""
        keep = np.ones(len(self), dtype=bool)
        for key, value in where.items():
            keep &= self.columns[key] == value
        return np.flatnonzero(keep)

    def quantities(self) -> List[str]:
        """The quantities of a statistics table, in its order."""
        return list(dict.fromkeys(self.columns["quantity"].tolist()))


class StatisticsRows:
    """The rows of a statistics table, added per quantity and statistic."""

    def __init__(self, level: float = 0.95) -> None:
        self._z = z_of(level)
        self._columns: Dict[str, list] = {k: [] for k in STATISTICS_COLUMNS}

    def add(self, quantity: str, units: str, long_name: str, times, statistic: str, *,
            value, std, stderr, bias, error, estimated: bool, exact: bool, bound: bool,
            few) -> None:
        """One statistic of a quantity at each of ``times`` (``[nan]``: at the stop); the
        numbers are arrays over the times or floats."""
        times = np.asarray(times, dtype=float)
        n = times.size

        def each(x, dtype=float):
            return np.broadcast_to(np.asarray(x, dtype=dtype).reshape(-1), (n,))

        value, error = each(value), each(error)
        half = self._z * error
        c = self._columns
        c["quantity"] += [quantity] * n
        c["units"] += [units] * n
        c["long_name"] += [long_name] * n
        c["at_stop"] += [bool(np.isnan(times).all())] * n
        c["time"] += times.tolist()
        c["statistic"] += [statistic] * n
        for key, x in (("value", value), ("std", each(std)), ("stderr", each(stderr)),
                       ("bias", each(bias)), ("error", error), ("lower", value - half),
                       ("upper", value + half)):
            c[key] += list(x)
        c["estimated"] += [bool(estimated)] * n
        c["exact"] += [bool(exact)] * n
        c["bound"] += [bool(bound)] * n
        c["few"] += each(few, bool).tolist()

    def columns(self) -> Dict[str, np.ndarray]:
        out = {}
        for key, values in self._columns.items():
            if key in ("quantity", "units", "long_name", "statistic"):
                out[key] = np.array(values, dtype=object)
            elif key in ("at_stop", "estimated", "exact", "bound", "few"):
                out[key] = np.array(values, dtype=bool)
            else:
                out[key] = np.array(values, dtype=np.float64)
        return out


def few_note(columns: Dict[str, np.ndarray], time_name: str) -> str:
    """The note on the standard errors a statistics table marks FEW_MARK ("" if none)."""
    marked = []
    for n in dict.fromkeys(columns["quantity"].tolist()):
        for stat in ("mean", "var"):
            few = np.flatnonzero((columns["quantity"] == n) & (columns["statistic"] == stat)
                                & columns["few"])
            if few.size:
                at = ("at the stop" if columns["at_stop"][few[0]] else
                      f"{time_name} = " + ", ".join(f"{t:g}" for t in columns["time"][few]))
                marked.append(f"{'the variance of ' if stat == 'var' else ''}{n} ({at})")
    if not marked:
        return ""
    return (f"{FEW_MARK}: fewer than {MIN_CARRIERS} paths carry the spread "
            f"(Result.carriers), so the standard error is not estimated (more paths "
            "would give it): " + "; ".join(marked))
