"""The text of a result's table (``summary``, ``str``): reads the table (``results/table.py``)
and nothing else of the result."""

from __future__ import annotations

from typing import List

from .common import _fmt
from .table import Table


def text(table: Table) -> str:
    """The table as the text summary, in its layout."""
    return _LAYOUTS[table.layout](table)


def _quantity_line(table: Table, name: str, units: str) -> str:
    return f"  {name}" + (f" [{units}]" if units else "")


def _statistics(table: Table) -> str:
    """Per quantity over time a block (time, mean ± standard error, bias, variance ± standard
    error, bias, standard deviation), then one line per quantity at the stop."""
    c = table.columns
    lines: List[str] = list(table.text_header)
    pending = table.bias_pending

    def shown(value, spec):
        return f"{'?':>{spec.split('.')[0] or 1}}" if pending else _fmt(value, spec)

    names = table.quantities()
    at_stop = {n: bool(c["at_stop"][table.rows(quantity=n)[0]]) for n in names}
    for n in (n for n in names if not at_stop[n]):
        means, vars_ = table.rows(quantity=n, statistic="mean"), table.rows(quantity=n,
                                                                            statistic="var")
        lines.append(_quantity_line(table, n, c["units"][means[0]]))
        lines.append(f"    {table.time_name:>10}  {'mean':>13}  {'± stderr':>10}  "
                     f"{'bias':>9}  {'var':>12}  {'± stderr':>10}  {'var bias':>9}  "
                     f"{'std':>12}")
        for m, v in zip(means, vars_):
            lines.append(f"    {c['time'][m]:>10.4g}  {c['value'][m]:>13.6g}  "
                         f"{_fmt(c['stderr'][m], '10.2g', c['few'][m])}  "
                         f"{shown(c['bias'][m], '9.2g')}  "
                         f"{_fmt(c['value'][v], '12.6g')}  "
                         f"{_fmt(c['stderr'][v], '10.2g', c['few'][v])}  "
                         f"{shown(c['bias'][v], '9.2g')}  {_fmt(c['std'][v], '12.6g')}")
    stop = [n for n in names if at_stop[n]]
    if stop:
        lines.append("  at the stop:")
        for n in stop:
            (m,), (v,) = table.rows(quantity=n, statistic="mean"), table.rows(quantity=n,
                                                                              statistic="var")
            u = c["units"][m]
            lines.append(f"    {n:<26} mean {c['value'][m]:.6g}"
                         f" ± {_fmt(c['stderr'][m], '.2g', c['few'][m])}"
                         f" (bias {shown(c['bias'][m], '.2g')})"
                         f"   var {_fmt(c['value'][v], '.6g')}"
                         f" ± {_fmt(c['stderr'][v], '.2g', c['few'][v])}"
                         f" (bias {shown(c['bias'][v], '.2g')})"
                         + (f"   [{u}]" if u else ""))
    lines.extend(f"  {note}" for note in table.notes)
    return "\n".join(lines)


def _statistic_rows(table: Table) -> str:
    """Per quantity a block with a line per statistic estimated and time: the estimate, its
    standard error, its bias ("exact" where it is 0 by an identity) and its total error."""
    c = table.columns
    lines: List[str] = list(table.text_header)
    for n in table.quantities():
        rows = table.rows(quantity=n)
        at_stop = bool(c["at_stop"][rows[0]])
        lines.append(_quantity_line(table, n, c["units"][rows[0]]))
        lines.append(f"    {'' if at_stop else table.time_name:>10}  {'stat':>4}  "
                     f"{'estimate':>13}  {'stderr':>9}  {'bias':>9}  {'error':>9}")
        for i in rows:
            if not c["estimated"][i]:
                continue
            when = "stop" if at_stop else f"{c['time'][i]:.4g}"
            bias = "exact" if c["exact"][i] else f"{c['bias'][i]:.2g}"
            lines.append(f"    {when:>10}  {c['statistic'][i]:>4}  {c['value'][i]:>13.6g}  "
                         f"{c['stderr'][i]:>9.2g}  {bias:>9}  {c['error'][i]:>9.2g}")
    lines.extend(f"  {note}" for note in table.notes)
    return "\n".join(lines)


def _levels(table: Table) -> str:
    """Per level of a tail: the probability, its standard error, relative error, interval, and
    a mark where it is not reliable."""
    c = table.columns
    units = c["units"][0] if len(table) else ""
    unit = f" [{units}]" if units else ""
    lines = list(table.text_header)
    lines.append(f"{'level' + unit:>16} {'probability':>12} {'stderr':>10} {'rel.err':>8} "
                 f"{f'{100 * table.level:g}% interval':>25}")
    for i in range(len(table)):
        flag = "" if c["reliable"][i] else "  UNRELIABLE (see diagnostics)"
        lines.append(f"{c['level'][i]:16.6g} {c['probability'][i]:12.4g} "
                     f"{c['stderr'][i]:10.3g} {c['rel_error'][i]:8.3f} "
                     f"[{c['lower'][i]:.3g}, {c['upper'][i]:.3g}]{flag}")
    lines.extend(table.notes)
    return "\n".join(lines)


_LAYOUTS = {"statistics": _statistics, "statistic_rows": _statistic_rows, "levels": _levels}
