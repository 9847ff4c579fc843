"""The netCDF / xarray / pandas form of a result (the implementation of ``crandall.io``).

Knows a result only through its public interface (statistics, ``accumulators``, scene and
run fields), so that ``crandall.results`` can use it without an import cycle; ``crandall.io``
adds :func:`~crandall.io.load`, which builds a ``Result`` from :func:`read`. Needs xarray
and pandas (imported when used).
"""

from __future__ import annotations

import json
import math
import os
from typing import Any, Dict, Optional, Union

import numpy as np

from . import _core
from ._version import __version__
from ._files import check_moments, write_atomic
from .bins import Histograms, check_histograms, recorded
from .methods import METHODS
from .quantities import names_for as scene_names_for, quantity
from .scene import Scene
from .spec import RunSpec
from .errors import ParameterError
from ._frames import ACCURACY, STATISTICS, _require, _units

__all__ = ["to_xarray", "to_pandas", "save", "read", "sweep", "STATISTICS"]

_FORMAT = "crandall-result"


def _count_attr(n: int):
    # netCDF-3 integers have 32 bits: a larger count is written as its decimal text (exact),
    # as the seed always is.
    n = int(n)
    return n if n < 2**31 else str(n)


def to_xarray(result):
    """The result as an ``xarray.Dataset``; see :meth:`crandall.Result.to_xarray`."""
    return result.to_xarray()


def fixed_step_contents(result):
    """What a fixed-step result's file holds beyond its statistics: (variables, coordinates,
    attributes) of the dataset, the raw accumulators and the run's fields."""
    sc = result.scene
    data_vars = {}
    held = result.accumulators
    acc_times, acc_stop = held.times, held.stop
    accs = [("", acc_times, "slot")]
    if acc_stop is not None:
        accs.append(("stop_", acc_stop, "stop_slot"))
    if held.peaks is not None:
        accs.append(("peaks_", held.peaks, "slot"))
    if held.stop_peaks is not None:
        accs.append(("stop_peaks_", held.stop_peaks, "stop_peaks_slot"))
    if held.energy is not None:
        # The moments of (V^2, 0, 0): the kinetic energy's variance's standard error.
        accs.append(("energy_", held.energy, "slot"))
    for prefix, acc, dim in accs:
        if acc.slots == 0:
            continue
        data_vars[prefix + "counts"] = ((dim,), acc.counts, {"long_name": "paths per slot",
                                                             "units": "1"})
        what = ("(squared velocity, 0, 0)" if prefix == "energy_"
                else "(velocity, displacement, distance)")
        data_vars[prefix + "means"] = ((dim, "variable"), acc.means,
                                       {"long_name": f"means of {what}, SI or scaled as the "
                                                     "scene"})
        data_vars[prefix + "central"] = ((dim, "monomial"), acc.central,
                                         {"long_name": "central sums, powers as in exponents"})
    if held.histograms is not None:
        _histogram_vars(result, held.histograms, data_vars)
    spec = result.spec  # the run's fields, checked
    attrs = {
        "Conventions": "CF-1.10",
        "title": f"crandall result: {sc!r}",
        "format": _FORMAT,
        "crandall_version": __version__,
        "scene": json.dumps(sc.to_dict()),
        "units_system": sc.units,
        "paths": _count_attr(spec.paths),
        "seed": str(spec.seed),  # up to 2**64 - 1: more than netCDF-3 integers hold
        "dt": spec.dt,
        "method": spec.method,
        "steps_per_path": _count_attr(result.steps_per_path),
        "min_steps": _count_attr(spec.min_steps),
        "random_stream": int(result.random_stream),
        "slots": int(acc_times.slots),
        # Every field of the run's spec but the scene (above), so that a run option saved
        # here comes back in load's Result.spec; the attributes above repeat the usual ones
        # for netCDF tools.
        "run_spec": json.dumps({k: v for k, v in spec.to_dict().items() if k != "scene"}),
        "history": (f"crandall {__version__}: simulate(scene, paths={spec.paths}, "
                    f"seed={spec.seed}, method={spec.method!r}, dt={spec.dt!r}"
                    + ("" if spec.event_depth is None else
                       f", event_depth={spec.event_depth}") + ")"),
    }
    if result.cost["wall_time"] is not None:
        attrs["wall_time"] = float(result.cost["wall_time"])
    # The scene's parameters, one attribute each, for netCDF tools.
    attrs.update({k: v for k, v in _scene_attrs(sc).items() if k.startswith("scene_")})
    if sc.distributions:
        # For netCDF tools (the scene's JSON above is what load reads).
        attrs["scene_distributions"] = " ".join(sc.distributions)
        attrs["scene_bins"] = json.dumps(sc.bins)
    return data_vars, {}, attrs


def _scene_attrs(sc) -> Dict[str, Any]:
    attrs = {"Conventions": "CF-1.10", "title": f"crandall result: {sc!r}", "format": _FORMAT,
             "crandall_version": __version__, "scene": json.dumps(sc.to_dict()),
             "units_system": sc.units}
    for k, v in sc.params.items():
        if isinstance(v, dict):
            # An envelope or an excitation: its kind and parameters (and an envelope's pieces,
            # which it is simulated with).
            for kk, vv in v.items():
                if k == "envelope" and kk in ("h", "t0"):  # a function envelope's pieces
                    continue
                attrs[f"scene_{k}_{kk}"] = (vv if isinstance(vv, str) else
                                            int(vv) if isinstance(vv, bool) else float(vv))
            if k == "envelope":
                attrs["scene_h"] = np.asarray(sc.envelope.h, dtype=float)
                attrs["scene_t0"] = np.asarray(sc.envelope.t0, dtype=float)
            continue
        # A piecewise schedule's h and t0 are lists: a 1-D attribute.
        attrs["scene_" + k] = (np.asarray(v, dtype=float) if isinstance(v, (list, tuple))
                               else float(v))
    return attrs


#: The kind of file a run to an accuracy writes (attribute ``kind``; fixed-step files have none).
ACCURACY_KIND = "accuracy"


def accuracy_contents(result):
    """What a run to an accuracy's file holds beyond its statistics: (variables, coordinates,
    attributes) of the dataset, the estimates it is rebuilt from, bitwise (per statistic and
    slot (value, stderr, bias) before the quantity's factor, and whether it is exact), and
    the run's fields."""
    data_vars, coords = {}, {}
    rows, values, exact = [], [], []
    for name in result.names:
        for stat in result.stats_of(name):
            est = result._estimates[(name, stat)]
            for k in range(est.shape[0]):
                rows.append(f"{name}:{stat}:{k}")
                values.append(est[k])
                exact.append(int(result._exact[(name, stat)]))
    coords["estimate"] = ("estimate", rows)
    coords["estimate_field"] = ("estimate_field", ["value", "stderr", "bias"])
    data_vars["estimates"] = (("estimate", "estimate_field"), np.array(values, dtype=float),
                              {"long_name": "the multilevel estimates per statistic and slot "
                                            "(before the quantity's factor): value, standard "
                                            "error, bias"})
    data_vars["estimate_exact"] = (("estimate",), np.array(exact, dtype=np.int32),
                                   {"long_name": "1 where the statistic is exact (no bias)"})
    return data_vars, coords, _accuracy_attrs(result)


def _accuracy_attrs(result) -> Dict[str, Any]:
    attrs = _scene_attrs(result.scene)
    attrs.update({
        "kind": ACCURACY_KIND, "method": "mlmc", "seed": str(result.seed),
        "error_target": (math.nan if result.error_target is None
                         else float(result.error_target)),
        "rel_error_target": (math.nan if result.rel_error_target is None
                             else float(result.rel_error_target)),
        "levels": json.dumps(result.levels), "path_steps": str(result.cost["path_steps"]),
        "rounds": _count_attr(result.cost["rounds"]),
        "random_stream": int(result.random_stream), "slots": int(result.scene.times.size),
        "history": (f"crandall {__version__}: simulate(scene, "
                    + (f"error={result.error_target!r}" if result.error_target is not None
                       else f"rel_error={result.rel_error_target!r}")
                    + f", seed={result.seed})")})
    if result.cost["wall_time"] is not None:
        attrs["wall_time"] = float(result.cost["wall_time"])
    return attrs


def _read_accuracy(ds) -> Dict[str, Any]:
    """The fields of a saved run to an accuracy (the keyword arguments of AccuracyResult),
    checked; raises _Invalid naming the field."""
    text = _attr(ds, "scene")
    try:
        scene = Scene.from_dict(json.loads(text))
    except (ValueError, TypeError, AttributeError) as exc:
        raise _Invalid(f"scene is not a valid scene ({exc})") from None
    targets = []
    for key in ("error_target", "rel_error_target"):
        v = _attr(ds, key)
        if isinstance(v, (bool, np.bool_)) or not isinstance(v, (float, int, np.floating,
                                                                  np.integer)):
            raise _Invalid(f"{key} is {v!r}, not a number")
        v = float(v)
        if not (math.isnan(v) or (math.isfinite(v) and v > 0)):
            raise _Invalid(f"{key} is {v!r}, must be > 0 (or NaN: not the target)")
        targets.append(None if math.isnan(v) else v)
    if (targets[0] is None) == (targets[1] is None):
        raise _Invalid("error_target and rel_error_target: exactly one must be given")
    try:
        levels = json.loads(_attr(ds, "levels"))
        if not isinstance(levels, list) or not levels:
            raise ValueError
        for i, lv in enumerate(levels):
            if set(lv) != {"level", "paths", "steps_per_path", "dt"} or lv["level"] != i \
                    or not isinstance(lv["paths"], int) or lv["paths"] < 1 \
                    or not isinstance(lv["steps_per_path"], int) or lv["steps_per_path"] < 1 \
                    or not isinstance(lv["dt"], float) or not (math.isfinite(lv["dt"]) and lv["dt"] > 0):
                raise ValueError
    except (ValueError, TypeError, AttributeError):
        raise _Invalid("levels is not a list of levels 0, 1, ... with their paths, steps "
                       "per path and step") from None
    if "estimates" not in ds or "estimate_exact" not in ds:
        raise _Invalid("estimates is missing")
    names = [str(x) for x in ds["estimate"].values]
    values = np.asarray(ds["estimates"].values, dtype=np.float64)
    exact = np.asarray(ds["estimate_exact"].values)
    if values.shape != (len(names), 3) or exact.shape != (len(names),) \
            or not np.all(np.isfinite(values)) or not np.all(np.isin(exact, (0, 1))):
        raise _Invalid("estimates are not one finite (value, stderr, bias) per statistic")
    held = set(scene_names_for(scene.observe))
    estimates: Dict[Any, list] = {}
    flags: Dict[Any, bool] = {}
    for label, row, ex in zip(names, values, exact):
        name, stat, k = (label.split(":") + ["", "", ""])[:3]
        if name not in held or stat not in ("mean", "var") or not k.isdigit() \
                or int(k) != len(estimates.get((name, stat), [])):
            raise _Invalid(f"estimate {label!r} is not a statistic of the scene in order")
        if row[1] < 0 or row[2] < 0:
            raise _Invalid(f"estimate {label!r} has a negative error")
        estimates.setdefault((name, stat), []).append(row)
        if flags.setdefault((name, stat), bool(ex)) != bool(ex):
            raise _Invalid(f"estimate_exact of {name}:{stat} differs between slots")
    for (name, stat), rows in estimates.items():
        want = 1 if quantity(name).at_stop else scene.times.size
        if len(rows) != want:
            raise _Invalid(f"estimates of {name}:{stat}: {len(rows)} slots, the scene has {want}")
    if not estimates:
        raise _Invalid("estimates holds no statistic")
    return dict(scene=scene, seed=_integer(_attr(ds, "seed"), "seed", 0, 2**64 - 1),
                error_target=targets[0], rel_error_target=targets[1],
                estimates={k: np.array(v) for k, v in estimates.items()}, exact=flags,
                levels=levels, path_steps=_integer(_attr(ds, "path_steps"), "path_steps", 0),
                rounds=_integer(_attr(ds, "rounds"), "rounds", 0),
                wall_time=_wall_time(ds), random_stream=_core.RANDOM_STREAM)


# Counts are stored as doubles (netCDF-3 has no 64-bit integers): exact below 2^53.
_EXACT_COUNT = 2.0 ** 53


def _histogram_vars(result, hist: Histograms, data_vars) -> None:
    """One pair of variables per binned quantity: ``histogram_NAME_edges`` and
    ``histogram_NAME_counts`` (over time for a quantity over time), padded with NaN where
    one time has fewer bins than another."""
    by_name: Dict[str, list] = {}
    for (index, slot, var, name), e, c in zip(recorded(result.scene), hist.edges, hist.counts):
        by_name.setdefault(name, []).append((slot, e, c))
    for name, items in by_name.items():
        if any(np.any(np.asarray(c, dtype=np.uint64) >= np.uint64(2 ** 53)) for _, _, c in items):
            raise ValueError(f"path: a count of {name}'s histogram is 2^53 or more, beyond "
                             "what the file's doubles hold exactly")
        width = max(e.size for _, e, _ in items)
        edges = np.full((len(items), width), np.nan)
        counts = np.full((len(items), width + 2), np.nan)
        for i, (_, e, c) in enumerate(items):
            edges[i, :e.size] = e
            counts[i, :c.size] = np.asarray(c, dtype=np.float64)
        unit = _units(result.scene.units_of(name), 1)
        note = " (time from the switch-off)" if name == "stop_time" else ""
        at_stop = name.endswith("_at_stop") or name == "stop_time"
        dims_e = (f"{name}_edge",) if at_stop else ("time", f"{name}_edge")
        dims_c = (f"{name}_cell",) if at_stop else ("time", f"{name}_cell")
        data_vars[f"histogram_{name}_edges"] = (
            dims_e, edges[0] if at_stop else edges,
            {"long_name": f"bin edges of {name}{note}, NaN-padded", "units": unit})
        data_vars[f"histogram_{name}_counts"] = (
            dims_c, counts[0] if at_stop else counts,
            {"long_name": f"paths per cell of {name}: underflow, one per bin [e_j, e_j+1), "
                          "overflow, NaN; NaN-padded", "units": "1"})


def _read_histograms(ds, scene, where: str, paths: int) -> Optional[Histograms]:
    axes = recorded(scene)
    present = [k for k in ds.data_vars if k.startswith("histogram_")]
    if not axes:
        if present:
            raise _Invalid(f"{present[0]} is present, but the scene asks for no distributions")
        return None
    index, edges, counts = [], [], []
    names = {name for _, _, _, name in axes}
    extra = sorted(set(present) - {f"histogram_{n}_{k}" for n in names
                                   for k in ("edges", "counts")})
    if extra:
        raise _Invalid(f"{extra[0]} is not a histogram of the scene's distributions")
    n_times = scene.times.size
    for i, slot, var, name in axes:
        for k in ("edges", "counts"):
            if f"histogram_{name}_{k}" not in ds:
                raise _Invalid(f"histogram_{name}_{k} is missing")
        e_all = np.asarray(ds[f"histogram_{name}_edges"].values, dtype=np.float64)
        c_all = np.asarray(ds[f"histogram_{name}_counts"].values, dtype=np.float64)
        at_stop = slot == n_times
        row = 0 if at_stop else slot
        if at_stop:
            e_all, c_all = e_all[None, :], c_all[None, :]
        if e_all.ndim != 2 or c_all.ndim != 2 or e_all.shape[0] != (1 if at_stop else n_times) \
                or c_all.shape != (e_all.shape[0], e_all.shape[1] + 2):
            raise _Invalid(f"histogram_{name}_edges/counts have shapes {e_all.shape}, "
                           f"{c_all.shape}: not one row per slot with len(edges) + 2 cells")
        e = e_all[row]
        e = e[~np.isnan(e)]
        c = c_all[row, :e.size + 2]
        if np.isnan(c).any() or (c < 0).any() or (c != np.floor(c)).any() \
                or (c >= _EXACT_COUNT).any() or not np.isnan(c_all[row, e.size + 2:]).all():
            raise _Invalid(f"histogram_{name}_counts of slot {slot} are not whole counts >= 0 "
                           "(one per edge plus 2)")
        index.append(i)
        edges.append(e)
        counts.append(c.astype(np.uint64))
    try:
        check_histograms(where, index, edges, counts, [a[0] for a in axes], paths=paths)
    except ValueError as exc:
        raise _Invalid(str(exc).split(": ", 1)[-1]) from None
    return Histograms(tuple(index), tuple(edges), tuple(counts))


def sweep(results):
    """Several results (a parameter sweep, simulate_many) as one ``xarray.Dataset``: every
    statistic variable of :func:`to_xarray` with a leading dimension ``scene``, and each scene
    parameter (mu, h, t0, ... as the scenes give them; a piecewise schedule as its JSON text)
    as a coordinate over ``scene``. The results must hold the same quantities at the same
    output times."""
    xr = _require("xarray")
    results = list(results)
    if not results:
        raise ParameterError("results", "results must not be empty")
    first = results[0]
    for i, r in enumerate(results[1:], 1):
        if r.names != first.names or not np.array_equal(r.times, first.times):
            raise ParameterError(f"results[{i}]", f"results[{i}]: a sweep's results must hold the "
                                                  "same quantities at the same output times")
    stats = [f"{n}_{s}" for n in first.names for s in STATISTICS + ACCURACY]
    parts = [r.to_xarray()[stats] for r in results]
    ds = xr.concat(parts, dim="scene", combine_attrs="override")
    keys = sorted({k for r in results for k in r.scene.params})
    coords = {}
    for k in keys:
        values = [r.scene.params.get(k) for r in results]
        if all(isinstance(v, (int, float)) for v in values):
            coords[k] = ("scene", np.array(values, dtype=float))
        else:
            coords[k] = ("scene", [json.dumps(v) for v in values])
    ds = ds.assign_coords(scene=np.arange(len(results)), **coords)
    ds.attrs = {"Conventions": "CF-1.10", "title": "crandall parameter sweep",
                "crandall_version": __version__, "units_system": first.scene.units,
                "seeds": " ".join(str(r.seed) for r in results)}
    return ds


def to_pandas(result, tidy: bool = False):
    """The result as a ``pandas.DataFrame``; see :meth:`crandall.Result.to_pandas`."""
    return result.to_pandas(tidy=tidy)


def save(result, path: Union[str, "os.PathLike[str]"]) -> None:
    """Write a result to a netCDF file, replaced atomically; see :meth:`crandall.Result.save`."""
    ds = _cf_file(to_xarray(result), result.scene)
    # CF: a coordinate variable has no fill value (xarray gives floats one by default).
    encoding = {name: {"_FillValue": None} for name in ds.coords
                if ds[name].dims == (name,) and ds[name].dtype.kind == "f"}
    data = bytes(ds.to_netcdf(engine="scipy", format="NETCDF3_64BIT", encoding=encoding))
    write_atomic(path, lambda f: f.write(data))


#: The nominal reference date of a saved SI file's time coordinate: CF gives a time coordinate
#: units "<unit> since <date>", while crandall's time counts from the start of the shaking.
NOMINAL_EPOCH = "1970-01-01 00:00:00"


def _cf_file(ds, scene):
    """The dataset as a file holds it, CF 1.10: in SI the time coordinate's units are seconds
    since a nominal date (the start of the shaking); in scaled units the coordinate is
    ``tau``, a dimensionless number that CF must not take for a time. :func:`read` undoes
    both."""
    if "time" not in ds.coords:
        return ds
    if scene.units == "scaled":
        return ds.rename({"time": "tau"})
    ds = ds.copy()
    ds["time"].attrs.update(units=f"s since {NOMINAL_EPOCH}", calendar="proleptic_gregorian",
                            long_name="time since the shaking starts (the reference date "
                                      "is nominal)")
    return ds


def _plain_file(ds):
    """A read file's time coordinate as :func:`to_xarray` gives it (see :func:`_cf_file`)."""
    if "tau" in ds.coords:
        ds = ds.rename({"tau": "time"})
        ds["time"].attrs.update(long_name="scaled time tau", units="1")
    elif "time" in ds.coords and "since" in str(ds["time"].attrs.get("units", "")):
        ds["time"].attrs.update(long_name="time", units="s")
        ds["time"].attrs.pop("calendar", None)
    return ds


class _Invalid(ValueError):
    pass


def _integer(value, field: str, minimum: int, maximum: Optional[int] = None) -> int:
    """An integer attribute: a netCDF integer, or its decimal text (for large values)."""
    if isinstance(value, str):
        text = value.strip()
        if not text.isdigit():
            raise _Invalid(f"{field} is {value!r}, not a whole number")
        n = int(text)
    elif isinstance(value, (int, np.integer)) and not isinstance(value, (bool, np.bool_)):
        n = int(value)
    else:
        raise _Invalid(f"{field} is {value!r}, not a whole number")
    if n < minimum or (maximum is not None and n > maximum):
        bounds = f">= {minimum}" + ("" if maximum is None else f" and <= {maximum}")
        raise _Invalid(f"{field} is {n}, must be {bounds}")
    return n


def _attr(ds, field: str):
    if field not in ds.attrs:
        raise _Invalid(f"attribute {field} is missing")
    return ds.attrs[field]


def _check_fields(ds, where: str) -> Dict[str, Any]:
    """Every field load needs, checked; raises _Invalid naming the field."""
    text = _attr(ds, "scene")
    if not isinstance(text, str):
        raise _Invalid(f"scene is {text!r}, not JSON text")
    try:
        scene = Scene.from_dict(json.loads(text))
    except (ValueError, TypeError, AttributeError) as exc:
        raise _Invalid(f"scene is not a valid scene ({exc})") from None
    out: Dict[str, Any] = {"scene": scene}
    out["paths"] = _integer(_attr(ds, "paths"), "paths", 1)
    out["seed"] = _integer(_attr(ds, "seed"), "seed", 0, 2**64 - 1)
    dt = _attr(ds, "dt")
    if (isinstance(dt, (bool, np.bool_)) or not isinstance(dt, (float, int, np.floating,
                                                                   np.integer))
            or not math.isfinite(dt) or dt <= 0):
        raise _Invalid(f"dt is {dt!r}, must be a finite number > 0")
    out["dt"] = float(dt)
    method = _attr(ds, "method")
    if method not in METHODS:
        raise _Invalid(f"method is {method!r}, not one of {', '.join(METHODS)}")
    out["method"] = str(method)
    out["steps_per_path"] = _integer(_attr(ds, "steps_per_path"), "steps_per_path", 0)
    out["min_steps"] = _integer(_attr(ds, "min_steps"), "min_steps", 0)
    slots = _integer(_attr(ds, "slots"), "slots", 0)
    if slots != scene.times.size:
        raise _Invalid(f"slots is {slots}, but the scene has {scene.times.size} output times")
    if "time" in ds.coords:
        stored = np.asarray(ds["time"].values)
        if stored.shape != scene.times.shape or not np.array_equal(stored, scene.times):
            raise _Invalid("time does not match the scene's output times")
    peaks = "peaks" in scene.observe
    for prefix, n, needed in (("", slots, slots > 0),
                              ("stop_", 2 if "residual" in scene.observe else 1,
                               "stop" in scene.observe),
                              ("peaks_", slots, peaks and slots > 0),
                              ("stop_peaks_", 1, peaks and "stop" in scene.observe),
                              ("energy_", slots, "kinetic_energy" in scene.observe
                               and slots > 0)):
        names = [prefix + k for k in ("counts", "means", "central")]
        if prefix == "energy_" and needed and not any(k in ds for k in names):
            # Saved before crandall kept the moments of V^2: the kinetic energy's variance
            # then has no standard error.
            out[prefix + "moments"] = None
            continue
        if not needed:
            extra = [k for k in names if k in ds]
            if extra:
                raise _Invalid(f"{extra[0]} is present, but the scene has no such slots")
            out[prefix + "moments"] = (_core.Moments(n) if prefix in ("", "peaks_") and
                                       (prefix == "" or peaks) else None)
            continue
        arrays = {k: ds[prefix + k].values for k in ("counts", "means", "central")
                  if prefix + k in ds}
        check_moments(where, prefix, arrays, slots=n, paths=float(out["paths"]),
                      method=out["method"], counted=" of the attribute paths")
        out[prefix + "moments"] = _core.Moments(n, arrays["counts"], arrays["means"],
                                                arrays["central"])
    out["histograms"] = _read_histograms(ds, scene, where, out["paths"])
    out["spec"] = _read_spec(ds, out)
    return out


def _read_spec(ds, fields: Dict[str, Any]) -> RunSpec:
    """The run's spec: from ``run_spec`` (files of this version on) or, in older files, the
    separate attributes; either way checked as any spec and against those attributes."""
    plain = {k: fields[k] for k in ("paths", "seed", "dt", "method", "min_steps")}
    if "run_spec" in ds.attrs:
        try:
            stored = json.loads(ds.attrs["run_spec"])
            if not isinstance(stored, dict) or "scene" in stored:
                raise ValueError("not a spec without its scene")
            spec = RunSpec.from_dict({**stored, "scene": fields["scene"]})
        except (ValueError, TypeError) as exc:
            raise _Invalid(f"run_spec is not a run's specification ({exc})") from None
        for k, v in plain.items():
            if getattr(spec, k) != v:
                raise _Invalid(f"run_spec has {k}={getattr(spec, k)!r}, the attribute {k} "
                               f"{v!r}")
        return spec
    try:
        return RunSpec(fields["scene"], **plain)
    except ValueError as exc:
        raise _Invalid(str(exc)) from None


def read(path: Union[str, "os.PathLike[str]"]) -> Dict[str, Any]:
    """The fields of a saved result, checked: the keyword arguments of ``Result``.

    See :func:`crandall.io.load`, which builds the result from them.
    """
    xr = _require("xarray")
    name = os.fspath(path)
    try:
        # The file object is ours, so that a damaged file cannot leave it open.
        with open(path, "rb") as f, xr.open_dataset(f, engine="scipy",
                                                    decode_times=False) as opened:
            ds = _plain_file(opened.load())
    except MemoryError:  # pragma: no cover
        raise
    except Exception as exc:  # noqa: BLE001 - whatever a damaged file makes the reader raise
        raise ValueError(f"path: cannot read {name} as netCDF: {exc}") from None
    if ds.attrs.get("format") != _FORMAT:
        why = ("attribute format is missing" if "format" not in ds.attrs
               else f"attribute format is {ds.attrs['format']!r}, not {_FORMAT!r}")
        raise ValueError(f"path: {name} is not a saved crandall result ({why})")
    stream = ds.attrs.get("random_stream")
    if stream != _core.RANDOM_STREAM:
        # Another stream's numbers (or a file from before streams were recorded, whose stop
        # statistics are laid out differently) are never read as this version's.
        raise ValueError(
            f"path: {name} was written by crandall {ds.attrs.get('crandall_version', '?')} with "
            f"random stream {stream if stream is not None else 'unknown (before version 2)'}; "
            f"this crandall reads stream {_core.RANDOM_STREAM} only: load it with that version")
    where = f"path: {name} is not a valid saved crandall result"
    if ds.attrs.get("kind") == ACCURACY_KIND:
        try:
            return dict(kind=ACCURACY_KIND, **_read_accuracy(ds))
        except _Invalid as exc:
            raise ValueError(f"{where}: {exc}") from None
    try:
        f = _check_fields(ds, where)
    except _Invalid as exc:
        raise ValueError(f"{where}: {exc}") from None
    return dict(spec=f["spec"], moments=f["moments"], stop_moments=f["stop_moments"],
                steps_per_path=f["steps_per_path"],
                random_stream=_core.RANDOM_STREAM, peaks=f["peaks_moments"],
                stop_peaks=f["stop_peaks_moments"], histograms=f["histograms"],
                wall_time=_wall_time(ds), energy=f["energy_moments"])


def _wall_time(ds):
    """The run's wall time if the file records it (files from before it did: None)."""
    value = ds.attrs.get("wall_time")
    if isinstance(value, (int, float, np.floating, np.integer)) and math.isfinite(value) \
            and value >= 0:
        return float(value)
    return None
