"""The pandas and xarray forms of a result's table (``crandall.results.table.Table``): the
renderers ``to_pandas`` and ``to_xarray`` call (with ``to_csv``, the CSV ``crandall run``
writes). They read the table and nothing else of the result; ``_dataset.py`` adds what a
result's file holds beyond it. Need xarray and pandas (imported when used).
"""

from __future__ import annotations

import numpy as np

from . import _core
from .quantities import VARIABLES


#: The statistics a table holds, per quantity and time.
STATISTICS = ("mean", "var", "std", "stderr", "var_stderr")


def _require(module: str):
    try:
        return __import__(module)
    except ImportError:  # pragma: no cover - depends on the environment
        raise ImportError(f"this needs {module}: pip install 'crandall[io]'") from None


#: The accuracy of the statistics, after STATISTICS in to_pandas and in the datasets' variables.
ACCURACY = ("bias_mean", "error_mean", "bias_var", "error_var")
#: Per statistic: what it is, and the power of the quantity's unit it carries.
_STATISTIC_TEXT = {
    "mean": ("mean over paths", 1), "var": ("unbiased variance over paths", 2),
    "std": ("standard deviation over paths", 1), "stderr": ("standard error of the mean", 1),
    "var_stderr": ("standard error of the variance", 2),
    "bias_mean": ("estimated discretisation bias of the mean", 1),
    "error_mean": ("total error sqrt(stderr^2 + bias^2) of the mean", 1),
    "bias_var": ("estimated discretisation bias of the variance", 2),
    "error_var": ("total error of the variance", 2),
}
#: The quantities' units as UDUNITS strings, to the first and second power.
_UDUNITS = {"m/s": ("m s-1", "m2 s-2"), "m": ("m", "m2"), "s": ("s", "s2"), "J": ("J", "J2"),
            "m/s^2": ("m s-2", "m2 s-4")}


def _units(unit: str, power: int) -> str:
    """A CF ``units`` attribute: "1" for a scaled (dimensionless) quantity."""
    if not unit:
        return "1"
    pair = _UDUNITS.get(unit)
    if pair is not None:
        return pair[power - 1]
    return unit if power == 1 else f"({unit})^{power}"


def _table_values(table, name):
    """A quantity's statistics in the order STATISTICS + ACCURACY: shape (times, 9), or (9,)
    at the stop."""
    c = table.columns
    mean = table.rows(quantity=name, statistic="mean")
    var = table.rows(quantity=name, statistic="var")
    cols = [c["value"][mean], c["value"][var], c["std"][var], c["stderr"][mean],
            c["stderr"][var], c["bias"][mean], c["error"][mean], c["bias"][var],
            c["error"][var]]
    out = np.stack(cols, axis=-1)
    return out[0] if c["at_stop"][mean[0]] else out


def table_xarray(table, data_vars=None, coords=None, attrs=None):
    """A statistics table (``crandall.results.table``) as an ``xarray.Dataset``: one variable
    per quantity and statistic, then the variables, coordinates and attributes given (what a
    result's file holds beyond its table)."""
    xr = _require("xarray")
    c = table.columns
    names = table.quantities()
    at_stop = {n: bool(c["at_stop"][table.rows(quantity=n)[0]]) for n in names}
    time_names = [n for n in names if not at_stop[n]]
    stop_names = [n for n in names if at_stop[n]]
    exps = [tuple(e) for e in _core.monomial_exponents()]
    variables = {}
    all_coords = {
        "variable": ("variable", list(VARIABLES)),
        "monomial": ("monomial", np.arange(len(exps), dtype=np.int32),
                     {"long_name": "index of a central sum (its powers: exponents)",
                      "units": "1"}),
        "exponents": (("monomial", "variable"), np.array(exps, dtype=np.int32),
                      {"long_name": "powers of (velocity, displacement, distance) of each "
                                    "central sum"}),
    }
    # CF: a time coordinate in SI is the standard name "time" on axis T; scaled time is a
    # dimensionless number, not a time CF knows, so it is only named.
    time_attrs = ({"long_name": "scaled time tau", "units": "1"}
                  if table.units_system == "scaled" else
                  {"long_name": "time", "standard_name": "time", "units": "s", "axis": "T"})
    if time_names:
        all_coords["time"] = ("time", np.asarray(table.times, dtype=float), time_attrs)
    # One variable per quantity and statistic, with its own units (CF: UDUNITS strings).
    for name in time_names + stop_names:
        values = _table_values(table, name)
        dims = () if at_stop[name] else ("time",)
        first = table.rows(quantity=name)[0]
        unit, long_name = c["units"][first], c["long_name"][first]
        for j, stat in enumerate(STATISTICS + ACCURACY):
            what, power = _STATISTIC_TEXT[stat]
            variables[f"{name}_{stat}"] = (
                dims, values[..., j],
                {"long_name": f"{what} of {long_name}", "units": _units(unit, power)})
    variables.update(data_vars or {})
    all_coords.update(coords or {})
    return xr.Dataset(data_vars=variables, coords=all_coords, attrs=dict(attrs or {}))


def table_pandas(table, tidy: bool = False):
    """A statistics table (``crandall.results.table``) as a ``pandas.DataFrame``: one row per
    quantity and time (columns STATISTICS + ACCURACY), or with ``tidy`` one per quantity,
    time and statistic; see :meth:`crandall.Result.to_pandas`."""
    pd = _require("pandas")
    rows = []
    c = table.columns
    if tidy:
        time_units = _units("s" if table.units_system == "SI" else "", 1)
        for name in table.quantities():
            values = _table_values(table, name)
            mean = table.rows(quantity=name, statistic="mean")
            unit = c["units"][mean[0]]
            for t, row in zip(c["time"][mean], np.reshape(values, (mean.size, -1))):
                for stat, value in zip(STATISTICS + ACCURACY, row.tolist()):
                    rows.append((name, float(t), time_units, stat, value,
                                 _units(unit, _STATISTIC_TEXT[stat][1])))
        return pd.DataFrame(rows, columns=["quantity", "time", "time_units", "statistic",
                                           "value", "units"])
    for name in table.quantities():
        values = np.reshape(_table_values(table, name), (-1, len(STATISTICS + ACCURACY)))
        mean = table.rows(quantity=name, statistic="mean")
        unit = c["units"][mean[0]]
        for t, row in zip(c["time"][mean], values):
            rows.append((name, float(t), unit, *row.tolist()))
    return pd.DataFrame(rows, columns=["quantity", table.time_name, "units", *STATISTICS,
                                       *ACCURACY])


def levels_pandas(table):
    """A tail's table (layout "levels") as a ``pandas.DataFrame``, one row per level."""
    pd = _require("pandas")
    c = table.columns
    pct = f"{100 * table.level:g}"
    return pd.DataFrame({"level": c["level"], "units": c["units"],
                         "probability": c["probability"], "stderr": c["stderr"],
                         "rel_error": c["rel_error"], f"lower_{pct}": c["lower"],
                         f"upper_{pct}": c["upper"], "reliable": c["reliable"]})


def levels_xarray(table, attrs=None):
    """A tail's table (layout "levels") as an ``xarray.Dataset`` over ``level``: probability,
    stderr, rel_error and reliable (0 or 1), the level's units, and the attributes given."""
    xr = _require("xarray")
    c = table.columns
    ds = xr.Dataset({name: ("level", np.asarray(c[name], dtype=np.float64))
                     for name in ("probability", "stderr", "rel_error")},
                    coords={"level": np.asarray(c["level"], dtype=np.float64)})
    ds["reliable"] = ("level", np.asarray(c["reliable"]).astype(np.int8))
    ds["level"].attrs["units"] = (c["units"][0] if len(table) else "") or "1"
    ds.attrs.update(attrs or {})
    return ds
