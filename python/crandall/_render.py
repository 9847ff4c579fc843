"""HTML rendering of results for notebooks (``Result._repr_html_``, ``TailResult._repr_html_``).

Reads the table a result builds once (``crandall.results.table.Table``: the statistics and
their accuracy per quantity and time, or a tail's levels) and nothing else of the result; the
text summary (``results/render_text.py``) and the pandas and xarray tables (``_frames.py``)
are the other renderers of the same table.
"""

from __future__ import annotations

import html
import math
from typing import List

import numpy as np


#: How tables (this one and Result.summary) show a standard error that is not estimated
#: because few paths carry the spread (Result.carriers), with a note below the table.
FEW_MARK = "n/a*"


def _num(x: float, spec: str = ".6g", few: bool = False) -> str:
    if few:
        # Not estimated because few paths carry the spread: marked, with the note below.
        return html.escape(FEW_MARK)
    return "n/a" if not np.isfinite(x) else format(float(x), spec)


def _header(table) -> str:
    return (f"<p><b>{html.escape(table.name)}</b>: "
            + "<br>".join(html.escape(line) for line in table.html_header) + "</p>")


def _notes(table) -> str:
    return "".join(f"<p><small>{html.escape(note)}</small></p>" for note in table.notes)


def html_table(table) -> str:
    """A result's table (``crandall.results.table``) as HTML, in its layout."""
    return _LAYOUTS[table.layout](table)


def _statistics(table) -> str:
    """Per quantity and time, the mean with its standard error and bias, the variance with its
    standard error and bias. Like the text summary it warns of nothing: what is not a number
    is shown "n/a" (FEW_MARK, with a note, where few paths carry the spread); a bias not
    estimated yet "?"."""
    c = table.columns
    rows: List[str] = []
    pending = table.bias_pending
    for name in table.quantities():
        means = table.rows(quantity=name, statistic="mean")
        vars_ = table.rows(quantity=name, statistic="var")
        for m, v in zip(means, vars_):
            t = c["time"][m]
            when = "stop" if math.isnan(t) else _num(t, ".4g")
            unit = c["units"][m] or "1"
            bm, bv = (("?", "?") if pending else
                      (_num(c["bias"][m], ".2g"), _num(c["bias"][v], ".2g")))
            rows.append(
                f"<tr><td>{html.escape(name)}</td><td>{when}</td><td>{html.escape(unit)}</td>"
                f"<td>{_num(c['value'][m])} &plusmn; {_num(c['stderr'][m], '.2g', c['few'][m])}"
                f"</td><td>{bm}</td>"
                f"<td>{_num(c['value'][v])} &plusmn; {_num(c['stderr'][v], '.2g', c['few'][v])}"
                f"</td><td>{bv}</td></tr>")
    head = (f"<tr><th>quantity</th><th>{html.escape(table.time_name)}</th><th>units</th>"
            "<th>mean &plusmn; stderr</th><th>bias</th><th>var &plusmn; stderr</th>"
            "<th>bias</th></tr>")
    pending_note = ("<p>bias ?: not estimated yet (a run of its own): "
                    "<code>result.estimate_bias()</code> makes it.</p>" if pending else "")
    return (_header(table) + "<table>" + head + "".join(rows) + "</table>" + _notes(table)
            + pending_note)


def _levels(table) -> str:
    """Per level of a tail: the probability, its standard error, relative error and
    interval, and whether it is reliable."""
    c = table.columns
    units = c["units"][0] if len(table) else ""
    unit = f" [{units}]" if units else ""
    rows = [f"<tr><th>level{html.escape(unit)}</th><th>probability</th><th>stderr</th>"
            f"<th>rel. error</th><th>{100 * table.level:g} % interval</th><th>reliable</th>"
            "</tr>"]
    for i in range(len(table)):
        flag = "yes" if c["reliable"][i] else "<b>no</b> (see diagnostics)"
        rows.append(f"<tr><td>{_num(c['level'][i])}</td>"
                    f"<td>{_num(c['probability'][i], '.4g')}</td>"
                    f"<td>{_num(c['stderr'][i], '.3g')}</td>"
                    f"<td>{_num(c['rel_error'][i], '.3f')}</td>"
                    f"<td>[{_num(c['lower'][i], '.3g')}, {_num(c['upper'][i], '.3g')}]</td>"
                    f"<td>{flag}</td></tr>")
    return _header(table) + "<table>" + "".join(rows) + "</table>" + _notes(table)


#: The HTML of each layout (results/table.LAYOUTS): a run to an accuracy's table, one text row
#: per statistic, is the same table in HTML.
_LAYOUTS = {"statistics": _statistics, "statistic_rows": _statistics, "levels": _levels}
