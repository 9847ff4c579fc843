"""HTML rendering of results for notebooks (``Result._repr_html_``, ``TailResult._repr_html_``).

Reads the statistics table a result already provides (the rows of ``to_pandas``: the
statistics and their accuracy per quantity and time, computed once) and lays it out; the text
summary (``Result.summary``) is the other renderer of the same statistics.
"""

from __future__ import annotations

import html
import math
from typing import List

import numpy as np

from . import _dataset
from .quantities import quantity

#: How tables (this one and Result.summary) show a standard error that is not estimated
#: because few paths carry the spread (Result.carriers), with a note below the table.
FEW_MARK = "n/a*"


def _num(x: float, spec: str = ".6g", few: bool = False) -> str:
    if few:
        # Not estimated because few paths carry the spread: marked, with the note below.
        return html.escape(FEW_MARK)
    return "n/a" if not np.isfinite(x) else format(float(x), spec)


def _header(result) -> str:
    sc = result.scene
    if result.kind == "accuracy":
        run = (f"{result.target_text()}, seed {result.seed}, multilevel: "
               f"{len(result.levels)} levels, paths per level {result.cost['paths']}")
    else:
        run = (f"{result.paths:,} paths, seed {result.seed}, method {result.method}, "
               f"dt {result.dt:.4g}")
    return (f"<p><b>crandall result</b>: {html.escape(repr(sc))}<br>"
            f"{html.escape(run)}</p>")


def table_html(result) -> str:
    """The result's statistics as an HTML table: per quantity and time, the mean with its
    standard error and bias, the variance with its standard error and bias. Like the text
    summary it warns of nothing: what is not a number is shown "n/a" (FEW_MARK, with a note,
    where few paths carry the spread)."""
    with result._table():
        return _table_html(result)


def _table_html(result) -> str:
    sc = result.scene
    rows: List[str] = []
    # Showing a result never runs paths: a bias that needs a run of its own is shown as not
    # estimated yet (Result.estimate_bias makes it).
    pending = result.bias_pending
    for name in result.names:
        stats = np.atleast_2d(_dataset._stats(result, name))
        acc = (np.full((stats.shape[0], len(_dataset.ACCURACY)), np.nan) if pending
               else np.atleast_2d(_dataset._accuracy(result, name)))
        times = [math.nan] if quantity(name).at_stop else list(result.times)
        unit = sc.units_of(name) or "1"
        few_mean, few_var = result._few(name, "mean"), result._few(name, "var")
        for t, s, a, fm, fv in zip(times, stats, acc, few_mean, few_var):
            mean, var, _, se, vse = s
            bias_mean, _, bias_var, _ = a
            when = "stop" if math.isnan(t) else _num(t, ".4g")
            bm, bv = ("?", "?") if pending else (_num(bias_mean, ".2g"), _num(bias_var, ".2g"))
            rows.append(
                f"<tr><td>{html.escape(name)}</td><td>{when}</td><td>{html.escape(unit)}</td>"
                f"<td>{_num(mean)} &plusmn; {_num(se, '.2g', fm)}</td><td>{bm}</td>"
                f"<td>{_num(var)} &plusmn; {_num(vse, '.2g', fv)}</td><td>{bv}</td></tr>")
    head = (f"<tr><th>quantity</th><th>{html.escape(sc.time_name)}</th><th>units</th>"
            "<th>mean &plusmn; stderr</th><th>bias</th><th>var &plusmn; stderr</th>"
            "<th>bias</th></tr>")
    note = result._few_note()
    pending_note = ("<p>bias ?: not estimated yet (a run of its own): "
                    "<code>result.estimate_bias()</code> makes it.</p>" if pending else "")
    return (_header(result) + "<table>" + head + "".join(rows) + "</table>"
            + (f"<p><small>{html.escape(note)}</small></p>" if note else "") + pending_note)


def tail_html(result) -> str:
    """A tail result's table as HTML: per level the probability, its standard error, relative
    error and 95 % interval, and whether it is reliable (the rows of ``TailResult.__str__``)."""
    lo, hi = result.interval()
    unit = f" [{result.units}]" if result.units else ""
    what = "replicas" if result.method == "splitting" else "paths"
    head = (f"<p><b>crandall tail</b>: P({html.escape(result.quantity)} &gt; level), "
            f"{html.escape(result.method)}, {result.samples:,} {what}, "
            f"{result.seconds:.1f} s</p>")
    rows = [f"<tr><th>level{html.escape(unit)}</th><th>probability</th><th>stderr</th>"
            "<th>rel. error</th><th>95 % interval</th><th>reliable</th></tr>"]
    for i, level in enumerate(result.levels):
        flag = "yes" if result.reliable[i] else "<b>no</b> (see diagnostics)"
        rows.append(f"<tr><td>{_num(level)}</td><td>{_num(result.probability[i], '.4g')}</td>"
                    f"<td>{_num(result.stderr[i], '.3g')}</td>"
                    f"<td>{_num(result.rel_error[i], '.3f')}</td>"
                    f"<td>[{_num(lo[i], '.3g')}, {_num(hi[i], '.3g')}]</td><td>{flag}</td></tr>")
    return head + "<table>" + "".join(rows) + "</table>"
