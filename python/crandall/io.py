"""Results that keep: xarray, pandas, netCDF files.

A saved result holds the statistics (readable by any netCDF tool) and the raw accumulators
(counts, means and central sums of every output time), so :func:`load` gives back a
:class:`~crandall.Result` whose every statistic is bitwise the one saved. Files are netCDF-3
written by SciPy (xarray's ``engine="scipy"``): no system library needed.

Needs the ``io`` extra: ``pip install crandall[io]`` (xarray, pandas).
"""

from __future__ import annotations

import json
import math
import os
from typing import Union

import numpy as np

from . import _core
from .scene import STOP_QUANTITIES, Scene

__all__ = ["to_xarray", "to_pandas", "save", "load", "STATISTICS"]

#: The statistics a table holds, per quantity and time.
STATISTICS = ("mean", "var", "std", "stderr", "var_stderr")

_VARIABLES = ("velocity", "displacement", "distance")
_FORMAT = "crandall-result"


def _require(module: str):
    try:
        return __import__(module)
    except ImportError:  # pragma: no cover - depends on the environment
        raise ImportError(f"this needs {module}: pip install 'crandall[io]'") from None


def _stats(result, name):
    out = [result.mean(name), result.var(name), result.std(name), result.stderr(name)]
    if name == "kinetic_energy":
        out.append(np.full_like(np.asarray(out[0], dtype=float), np.nan))
    else:
        out.append(result.var_stderr(name))
    return np.stack([np.asarray(x, dtype=float) for x in out], axis=-1)


def _long_name(result, name):
    scaled = result.scene.units == "scaled"
    names = {"velocity": "velocity U1" if scaled else "velocity",
             "displacement": "displacement U2" if scaled else "displacement",
             "distance": "distance travelled U3" if scaled else "distance travelled",
             "kinetic_energy": "kinetic energy", "dissipated_energy": "energy dissipated by friction",
             "stop_time": "stop time"}
    base = name.replace("_at_stop", "")
    return names[base] + (" at the stop" if name.endswith("_at_stop") else "")


def to_xarray(result):
    """The result as an ``xarray.Dataset``; see :meth:`crandall.Result.to_xarray`."""
    xr = _require("xarray")
    sc = result.scene
    time_names = [n for n in result.names if n not in STOP_QUANTITIES]
    stop_names = [n for n in result.names if n in STOP_QUANTITIES]
    exps = [tuple(e) for e in _core.monomial_exponents()]
    data_vars = {}
    coords = {
        "statistic": ("statistic", list(STATISTICS)),
        "variable": ("variable", list(_VARIABLES)),
        "monomial": ("monomial", np.arange(len(exps), dtype=np.int32)),
        "exponents": (("monomial", "variable"), np.array(exps, dtype=np.int32),
                      {"long_name": "powers of (velocity, displacement, distance) of each "
                                    "central sum"}),
    }
    time_attrs = {"long_name": "scaled time tau" if sc.units == "scaled" else "time",
                  "units": "1" if sc.units == "scaled" else "s"}
    if time_names:
        coords["time"] = ("time", np.asarray(result.times, dtype=float), time_attrs)
        coords["observable"] = ("observable", time_names)
        coords["units"] = ("observable", [sc.units_of(n) or "1" for n in time_names])
        coords["long_name"] = ("observable", [_long_name(result, n) for n in time_names])
        table = np.stack([_stats(result, n) for n in time_names], axis=1)
        data_vars["statistics"] = (("time", "observable", "statistic"), table,
                                   {"long_name": "statistics over paths at each output time "
                                                 "(var: unbiased; stderr: of the mean; "
                                                 "var_stderr: of the variance)"})
    if stop_names:
        coords["stop_quantity"] = ("stop_quantity", stop_names)
        coords["stop_units"] = ("stop_quantity", [sc.units_of(n) or "1" for n in stop_names])
        table = np.stack([_stats(result, n) for n in stop_names], axis=0)
        data_vars["stop_statistics"] = (("stop_quantity", "statistic"), table,
                                        {"long_name": "statistics over paths at the stop"})
    accs = [("", result._moments, "slot")]
    if result._stop is not None:
        accs.append(("stop_", result._stop, "stop_slot"))
    for prefix, acc, dim in accs:
        if acc.slots == 0:
            continue
        data_vars[prefix + "counts"] = ((dim,), acc.counts, {"long_name": "paths per slot"})
        data_vars[prefix + "means"] = ((dim, "variable"), acc.means,
                                       {"long_name": "means of (velocity, displacement, "
                                                     "distance), SI or scaled as the scene"})
        data_vars[prefix + "central"] = ((dim, "monomial"), acc.central,
                                         {"long_name": "central sums, powers as in exponents"})
    from . import __version__

    attrs = {
        "title": f"crandall result: {sc!r}",
        "format": _FORMAT,
        "crandall_version": __version__,
        "scene": json.dumps(sc.to_dict()),
        "units_system": sc.units,
        "paths": int(result.paths),
        "seed": str(result.seed),  # up to 2**64 - 1: more than netCDF-3 integers hold
        "dt": float(result.dt),
        "method": result.method,
        "steps_per_path": int(result.steps_per_path),
        "slots": int(result._moments.slots),
    }
    for k, v in sc.params.items():
        attrs["scene_" + k] = float(v)
    return xr.Dataset(data_vars=data_vars, coords=coords, attrs=attrs)


def to_pandas(result):
    """The result as a ``pandas.DataFrame``; see :meth:`crandall.Result.to_pandas`."""
    pd = _require("pandas")
    rows = []
    sc = result.scene
    for name in result.names:
        table = _stats(result, name)
        if name in STOP_QUANTITIES:
            rows.append((name, math.nan, sc.units_of(name), *table.tolist()))
        else:
            for t, stats in zip(result.times, table):
                rows.append((name, float(t), sc.units_of(name), *stats.tolist()))
    return pd.DataFrame(rows, columns=["quantity", sc.time_name, "units", *STATISTICS])


def save(result, path: Union[str, "os.PathLike[str]"]) -> None:
    """Write a result to a netCDF file; see :meth:`crandall.Result.save`."""
    ds = to_xarray(result)
    path = os.fspath(path)
    folder = os.path.dirname(os.path.abspath(path))
    tmp = os.path.join(folder, "." + os.path.basename(path) + ".tmp")
    try:
        ds.to_netcdf(tmp, engine="scipy", format="NETCDF3_64BIT")
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise


def load(path: Union[str, "os.PathLike[str]"]):
    """Read a result written by :meth:`crandall.Result.save`.

    Parameters
    ----------
    path : str or os.PathLike
        A netCDF file written by ``Result.save`` (or ``crandall run``).

    Returns
    -------
    Result
        Every statistic bitwise the saved one (the raw accumulators are stored).

    Raises
    ------
    ValueError
        If the file is not a saved crandall result.
    """
    xr = _require("xarray")
    from .results import Result

    try:
        with xr.open_dataset(path, engine="scipy") as opened:
            ds = opened.load()
    except (OSError, ValueError, TypeError) as exc:
        raise ValueError(f"path: cannot read {os.fspath(path)} as netCDF: {exc}") from None
    if ds.attrs.get("format") != _FORMAT:
        raise ValueError(f"path: {os.fspath(path)} is not a saved crandall result")
    scene = Scene.from_dict(json.loads(ds.attrs["scene"]))

    def acc(prefix, slots):
        if slots == 0 or prefix + "counts" not in ds:
            return _core.Moments(slots)
        return _core.Moments(slots, ds[prefix + "counts"].values,
                             ds[prefix + "means"].values, ds[prefix + "central"].values)

    moments = acc("", int(ds.attrs["slots"]))
    stop = acc("stop_", 1) if "stop" in scene.observe else None
    return Result(scene=scene, paths=int(ds.attrs["paths"]), seed=int(ds.attrs["seed"]),
                  dt=float(ds.attrs["dt"]), method=str(ds.attrs["method"]), moments=moments,
                  stop_moments=stop, steps_per_path=int(ds.attrs["steps_per_path"]))
