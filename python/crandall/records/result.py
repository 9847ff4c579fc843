"""The result of :func:`newmark` (:class:`NewmarkResult`): one record's time histories or a
sweep's table, its summary and file, and :func:`load_newmark`, which reads a saved one back."""

from __future__ import annotations

import html
import json
import os
from typing import Any, Dict, List, Mapping, Optional, Sequence

import numpy as np

from .._files import write_atomic
from .record import FILE_FORMAT, G, PathLike


_FIELDS = ("displacement", "max_displacement", "min_displacement", "slips")


#: Most record samples (times cases) a sweep hands the core in one call: about 35 ms at the
#: exact method's 4 ns per sample, so Ctrl-C (seen between calls) stops a sweep promptly.
SWEEP_SAMPLES = 1 << 23


_LONG = {"displacement": "displacement at the record's end",
         "max_displacement": "largest displacement over the record",
         "min_displacement": "smallest displacement over the record",
         "slips": "slides started"}


class NewmarkResult:
    """What :func:`newmark` computed.

    Attributes
    ----------
    mode : str
        "one-way", "flat" or "incline".
    method : str
        "exact" or "slammer".
    yields : dict of ndarray
        The yield values, in g, one per case: ``ky``; ``mu`` and ``mu_static``; ``kd`` and ``ku``.
    polarities : tuple of str
    records : list of dict
        Each record's name, dt (s), npts, pga (g, scaled), scale and units.
    dims : tuple of str
        The dimensions of the arrays below, among "record", "yield", "polarity": those the call
        swept (a list of records, an array of yields, polarity "both"); () for one case, whose
        values are plain numbers.
    displacement, max_displacement, min_displacement : float or ndarray
        m, at the record's end, and the largest and smallest over the record.
    slips : int or ndarray
        How many slides started.
    time, velocity, sliding_displacement, acceleration : ndarray (one case only)
        At the samples: time (s), the sliding velocity (m/s) and displacement (m), and the
        ground acceleration as run (in g, with the polarity).
    events : ndarray (one case only)
        A row per slide: onset (s), stop (s; the record's end if still sliding), direction
        (+1 downslope or, flat, along the record's positive axis; -1 the other way) and stopped
        (1, or 0 if the slide lasts past the record's end).
    """

    def __init__(self, *, records: List[Dict[str, Any]], mode: str, method: str,
                 yields: Mapping[str, np.ndarray], polarities: Sequence[str],
                 dims: Sequence[str], table: np.ndarray, acceleration: Any,
                 history: Optional[Dict[str, np.ndarray]]) -> None:
        self.records = records
        self.mode = mode
        self.method = method
        self.yields = {k: np.asarray(v, dtype=float) for k, v in yields.items()}
        self.polarities = tuple(polarities)
        self.dims = tuple(dims)
        self.table = np.asarray(table, dtype=float)
        # The record as run, in g: given, or (m/s^2 samples, sign) made into it when first read.
        self._acceleration = acceleration
        self._history = history

    def _value(self, k: int) -> Any:
        v = self.table[..., k]
        squeeze = tuple(i for i, d in enumerate(("record", "yield", "polarity"))
                        if d not in self.dims)
        v = v.squeeze(axis=squeeze)
        if k == 3:
            v = v.astype(np.int64)
        return v.item() if v.ndim == 0 else v

    @property
    def displacement(self) -> Any:
        """At the record's end, m (float for one case, else an array over ``dims``)."""
        return self._value(0)

    @property
    def max_displacement(self) -> Any:
        """The largest displacement over the record, m (>= 0)."""
        return self._value(1)

    @property
    def min_displacement(self) -> Any:
        """The smallest displacement over the record, m (<= 0)."""
        return self._value(2)

    @property
    def slips(self) -> Any:
        """How many slides started (int for one case, else an array over ``dims``)."""
        return self._value(3)

    def _one(self, name: str) -> np.ndarray:
        if self._history is None:
            raise ValueError(f"{name}: a sweep keeps no histories; run newmark on one record, "
                             "one yield and one polarity for them")
        return self._history[name]

    @property
    def time(self) -> np.ndarray:
        self._one("velocity")
        return np.arange(self.records[0]["npts"]) * self.records[0]["dt"]

    @property
    def velocity(self) -> np.ndarray:
        return self._one("velocity")

    @property
    def sliding_displacement(self) -> np.ndarray:
        return self._one("displacement")

    @property
    def events(self) -> np.ndarray:
        return self._one("events")

    @property
    def acceleration(self) -> np.ndarray:
        self._one("velocity")
        if isinstance(self._acceleration, tuple):
            si, sign = self._acceleration
            self._acceleration = si * sign / G
        return self._acceleration

    @property
    def label(self) -> str:
        """The yields as a line of text ("ky = 0.1 g")."""
        parts = []
        for k, v in self.yields.items():
            text = f"{v[0]:g}" if v.size == 1 else f"{v.size} values {v.min():g}-{v.max():g}"
            parts.append(f"{k} = {text} g")
        return ", ".join(parts)

    def __repr__(self) -> str:
        names = ", ".join(r["name"] for r in self.records[:3]) + (
            ", ..." if len(self.records) > 3 else "")
        if not self.dims:
            return (f"NewmarkResult({names}, {self.mode}, {self.label}, {self.polarities[0]}, "
                    f"{self.method}: displacement {self.displacement:.6g} m, "
                    f"{self.slips} slips)")
        plural = {"record": "records", "yield": "yields", "polarity": "polarities"}
        shape = " x ".join(f"{self.table.shape[i]} {plural[d]}" for i, d in
                           enumerate(("record", "yield", "polarity")) if d in self.dims)
        return f"NewmarkResult({names}, {self.mode}, {self.label}, {self.method}: {shape})"

    def _repr_html_(self) -> str:
        esc = html.escape
        head = (f"<p><b>crandall Newmark block</b>: {esc(self.mode)}, {esc(self.label)}, "
                f"method {esc(self.method)}</p>")
        rows = []
        for r_i, rec in enumerate(self.records):
            for k in range(self.table.shape[1]):
                for p_i, pol in enumerate(self.polarities):
                    d, hi, lo, n = self.table[r_i, k, p_i]
                    ys = ", ".join(f"{v[k]:g}" for v in self.yields.values())
                    rows.append(f"<tr><td>{esc(rec['name'])}</td><td>{rec['pga']:.3f}</td>"
                                f"<td>{esc(ys)}</td><td>{esc(pol)}</td><td>{d:.6g}</td>"
                                f"<td>{hi:.6g}</td><td>{lo:.6g}</td><td>{int(n)}</td></tr>")
        shown = rows[:200]
        more = (f"<p>... {len(rows) - 200} more rows (<code>to_xarray()</code>)</p>"
                if len(rows) > 200 else "")
        return (head + "<table><tr><th>record</th><th>PGA (g)</th><th>"
                + esc(", ".join(self.yields)) + " (g)</th><th>polarity</th>"
                "<th>displacement (m)</th><th>max (m)</th><th>min (m)</th><th>slips</th></tr>"
                + "".join(shown) + "</table>" + more)

    def to_xarray(self):
        """An xarray Dataset: the summaries over (record, yield, polarity) (every dimension
        kept), the yields as coordinates along "yield", and for one case the histories over
        "time" and the events over "event". Needs xarray."""
        import xarray as xr

        coords: Dict[str, Any] = {
            "record": [r["name"] for r in self.records],
            "polarity": list(self.polarities),
        }
        for k, v in self.yields.items():
            coords[k] = ("yield", v, {"units": "g", "long_name": f"yield {k}"})
        data: Dict[str, Any] = {}
        for i, name in enumerate(_FIELDS):
            values = self.table[..., i]
            data[name] = (("record", "yield", "polarity"),
                          values.astype(np.int32) if name == "slips" else values,
                          {"units": "1" if name == "slips" else "m", "long_name": _LONG[name]})
        for field in ("dt", "pga", "scale"):
            data[f"record_{field}"] = ("record", [float(r[field]) for r in self.records],
                                       {"units": {"dt": "s", "pga": "g", "scale": "1"}[field]})
        data["record_npts"] = ("record", np.array([r["npts"] for r in self.records], np.int32))
        if self._history is not None:
            coords["time"] = ("time", self.time, {"units": "s"})
            data["velocity"] = ("time", self.velocity, {"units": "m/s",
                                                        "long_name": "sliding velocity"})
            data["sliding_displacement"] = ("time", self.sliding_displacement,
                                            {"units": "m", "long_name": "sliding displacement"})
            data["acceleration"] = ("time", self.acceleration,
                                    {"units": "g", "long_name": "ground acceleration as run"})
            ev = self.events
            for j, name in enumerate(("onset", "stop", "direction", "stopped")):
                data[f"event_{name}"] = ("event", ev[:, j],
                                         {"units": "s" if j < 2 else "1"})
        # (not "mode": SciPy's netCDF writer keeps attributes on its file object, whose own
        # "mode" an attribute of that name would overwrite)
        attrs = {"crandall_newmark": FILE_FORMAT, "sliding": self.mode, "method": self.method,
                 "dims": json.dumps(list(self.dims)),
                 "record_units": json.dumps([r["units"] for r in self.records]),
                 "history": "crandall.newmark"}
        return xr.Dataset(data, coords=coords, attrs=attrs)

    def save(self, path: PathLike) -> None:
        """Write the result to a netCDF file (replaced atomically); :func:`load_newmark` or
        :func:`crandall.load` reads it back, every number bitwise the same."""
        ds = self.to_xarray()
        data = bytes(ds.to_netcdf(engine="scipy", format="NETCDF3_64BIT"))
        write_atomic(path, lambda f: f.write(data))


def load_newmark(path: PathLike) -> NewmarkResult:
    """Read a result written by :meth:`NewmarkResult.save`.

    Raises
    ------
    ValueError
        If the file cannot be read or is not a saved Newmark result (naming the file).
    """
    import xarray as xr

    p = os.fspath(path)
    try:
        with xr.open_dataset(p, engine="scipy") as ds:
            ds = ds.load()
    except (OSError, ValueError, TypeError) as exc:
        raise ValueError(f"{p}: cannot read a netCDF file: {exc}") from None
    return _from_dataset(ds, p)


def _from_dataset(ds, p: str) -> NewmarkResult:
    if ds.attrs.get("crandall_newmark") != FILE_FORMAT:
        raise ValueError(f"{p}: not a saved crandall Newmark result (attribute crandall_newmark "
                         f"is {ds.attrs.get('crandall_newmark')!r}, expected {FILE_FORMAT})")
    try:
        mode = str(ds.attrs["sliding"])
        names = {"one-way": ("ky",), "flat": ("mu", "mu_static"), "incline": ("kd", "ku")}[mode]
        table = np.stack([np.asarray(ds[f].values, dtype=float) for f in _FIELDS], axis=-1)
        units = json.loads(ds.attrs["record_units"])
        records = [{"name": str(n), "dt": float(d), "npts": int(k), "pga": float(g),
                    "scale": float(s), "units": u}
                   for n, d, k, g, s, u in zip(ds["record"].values, ds["record_dt"].values,
                                               ds["record_npts"].values, ds["record_pga"].values,
                                               ds["record_scale"].values, units)]
        history = None
        acceleration = None
        if "velocity" in ds:
            history = {"velocity": np.asarray(ds["velocity"].values, dtype=float),
                       "displacement": np.asarray(ds["sliding_displacement"].values, dtype=float),
                       "events": np.stack([np.asarray(ds[f"event_{n}"].values, dtype=float)
                                           for n in ("onset", "stop", "direction", "stopped")],
                                          axis=1).reshape(-1, 4)}
            acceleration = np.asarray(ds["acceleration"].values, dtype=float)
        return NewmarkResult(
            records=records, mode=mode, method=str(ds.attrs["method"]),
            yields={k: np.asarray(ds[k].values, dtype=float) for k in names},
            polarities=[str(x) for x in ds["polarity"].values],
            dims=tuple(json.loads(ds.attrs["dims"])), table=table,
            acceleration=acceleration, history=history)
    except (KeyError, ValueError, TypeError) as exc:
        raise ValueError(f"{p}: a field of the saved Newmark result is missing or bad: "
                         f"{exc}") from None
