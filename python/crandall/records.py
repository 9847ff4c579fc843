"""Recorded ground motions and Newmark's sliding block on them (docs/records.md).

A :class:`Record` is a ground acceleration sampled every ``dt`` seconds (read from a
two-column time/acceleration text file, a single column with a given ``dt``, or a PEER NGA
``.AT2`` file). :func:`newmark` slides a rigid block on it:

- ``ky`` (in g): one-way downslope sliding above the yield acceleration ky g, the rigid block
  of SLAMMER and pySLAMMER;
- ``mu`` (and ``mu_static``): two-way sliding on a flat surface, crandall's own model with the
  record in place of white noise;
- ``kd`` and ``ku`` (in g): two-way sliding on an incline, downslope above kd g and upslope
  above ku g.

``method="exact"`` integrates the record joined by straight lines exactly (its error is the
record's, not the integrator's); ``method="slammer"`` is pySLAMMER 0.2.2's recursion, bit for
bit. Arrays of yields and ``polarity="both"`` (and a list of records) sweep every combination
in the compiled core, across threads; the numbers do not depend on the thread count.

g is standard gravity, 9.80665 m/s^2 (:data:`G`), as in the PEER files and pySLAMMER.
"""

from __future__ import annotations

import html
import json
import math
import os
import re
from typing import Any, Dict, List, Mapping, Optional, Sequence, Tuple, Union

import numpy as np

from . import _core
from ._files import write_atomic
from .errors import ParameterError

__all__ = ["G", "UNITS", "METHODS", "POLARITIES", "Record", "NewmarkResult", "newmark",
           "load_newmark"]

#: Standard gravity, m/s^2: the "g" of a record's units and of yields given in g.
G: float = _core.STANDARD_GRAVITY
#: A record's units and the factor that takes them to m/s^2 (applied after the scale factor).
UNITS: Dict[str, float] = {"g": G, "m/s2": 1.0, "cm/s2": 0.01}
METHODS = ("exact", "slammer")
POLARITIES = ("normal", "inverse", "both")
_SIGNS = {"normal": 1.0, "inverse": -1.0}
#: The file format of a saved Newmark result (its netCDF attribute ``crandall_newmark``).
FILE_FORMAT = 1

PathLike = Union[str, "os.PathLike[str]"]


def _positive(name: str, value: Any, *, allow_inf: bool = False) -> float:
    if isinstance(value, (bool, str)) or not isinstance(
            value, (int, float, np.integer, np.floating)):
        raise ParameterError(name, f"{name} must be a number, got {value!r}")
    v = float(value)
    if math.isnan(v) or v <= 0 or (math.isinf(v) and not allow_inf):
        raise ParameterError(name, f"{name} must be {'> 0' if allow_inf else 'finite and > 0'}, "
                                   f"got {value!r}")
    return v


def _samples(name: str, values: Any) -> np.ndarray:
    if isinstance(values, (str, bytes)):
        raise ParameterError(name, f"{name} must be a sequence of numbers, got a string")
    try:
        a = np.array(values, dtype=float)
    except (TypeError, ValueError):
        raise ParameterError(name, f"{name} must be a sequence of numbers") from None
    if a.ndim != 1:
        raise ParameterError(name, f"{name} must be one-dimensional, got shape {a.shape}")
    if a.size < 2:
        raise ParameterError(name, f"{name} needs at least 2 samples, got {a.size}")
    bad = np.flatnonzero(~np.isfinite(a))
    if bad.size:
        raise ParameterError(name, f"{name}: sample {bad[0]} is {a[bad[0]]!r} (every sample "
                                   f"must be finite; {bad.size} are not)")
    return a


class Record:
    """A ground acceleration sampled every ``dt`` seconds, from t = 0.

    Parameters
    ----------
    acceleration : sequence of float
        The samples (at least 2, finite), in ``units``.
    dt : float
        The sampling interval, s (finite, > 0).
    units : {"g", "m/s2", "cm/s2"}
        The samples' units; "g" is standard gravity, 9.80665 m/s^2.
    name : str, optional
        What figures and tables call the record (default "record").
    scale : float
        A factor applied to the samples (default 1; see :meth:`scaled`).

    Raises
    ------
    ParameterError
        Naming the parameter: a sample that is not finite, fewer than 2 samples, dt not finite
        and > 0, unknown units, a scale that is not finite or is 0.
    """

    def __init__(self, acceleration: Any, dt: float, *, units: str = "g",
                 name: Optional[str] = None, scale: float = 1.0) -> None:
        self._raw = _samples("acceleration", acceleration)
        self._raw.setflags(write=False)
        self.dt = _positive("dt", dt)
        if units not in UNITS:
            raise ParameterError("units", f"units must be one of {', '.join(UNITS)}, got {units!r}")
        self.units = units
        if name is not None and not isinstance(name, str):
            raise ParameterError("name", f"name must be a string, got {name!r}")
        self.name = name if name else "record"
        if isinstance(scale, bool) or not isinstance(scale, (int, float, np.integer, np.floating)) \
                or not math.isfinite(scale) or scale == 0:
            raise ParameterError("scale", f"scale must be a finite number other than 0, got {scale!r}")
        self.scale = float(scale)
        self._si: Optional[np.ndarray] = None
        self._pga: Optional[float] = None

    # -- reading ---------------------------------------------------------------------------
    @classmethod
    def read(cls, path: PathLike, *, dt: Optional[float] = None, units: Optional[str] = None,
             name: Optional[str] = None) -> "Record":
        """Read a record from a file.

        - PEER NGA ``.AT2``: the header's NPTS and DT, the samples in g;
        - text with two columns (time, acceleration; separated by commas or blanks, lines
          starting with ``#`` skipped: pySLAMMER's CSV files): dt is the first time step,
          t[1] - t[0] (as pySLAMMER reads it), and the times must be evenly spaced;
        - text with one column: the samples, with ``dt`` given.

        ``units`` defaults to "g"; ``name`` to the file's name without its extension.

        Raises
        ------
        ParameterError
            Naming ``path`` (unreadable, no samples, a line that is not numbers, uneven
            times, an AT2 header without NPTS or DT, a sample count other than NPTS) or
            ``dt`` (missing for a single column, or given for a file that has its own).
        """
        p = os.fspath(path)
        stem = os.path.splitext(os.path.basename(p))[0]
        try:
            with open(p, encoding="utf-8-sig", errors="replace") as f:
                text = f.read()
        except OSError as exc:
            raise ParameterError("path", f"path: cannot read {p!r}: {exc.strerror or exc}") from None
        if p.lower().endswith(".at2"):
            if dt is not None:
                raise ParameterError("dt", f"dt: the AT2 file {p!r} gives its own DT")
            samples, step = _read_at2(p, text)
            return cls(samples, step, units=units or "g", name=name or stem)
        rows: List[List[float]] = []
        for number, line in enumerate(text.splitlines(), 1):
            line = line.strip()
            if not line or line.startswith("#"):
                continue
            try:
                rows.append([float(x) for x in re.split(r"[,\s;]+", line) if x])
            except ValueError:
                raise ParameterError("path", f"path: {p!r} line {number} is not numbers: "
                                             f"{line[:60]!r}") from None
        widths = {len(r) for r in rows}
        if not rows:
            raise ParameterError("path", f"path: {p!r} holds no samples")
        if len(widths) != 1 or widths.pop() not in (1, 2):
            raise ParameterError("path", f"path: {p!r} must have one column (acceleration) or "
                                         f"two (time, acceleration) on every line")
        table = np.array(rows, dtype=float)
        if table.shape[1] == 1:
            if dt is None:
                raise ParameterError("dt", f"dt: {p!r} has a single column; give dt=")
            return cls(table[:, 0], dt, units=units or "g", name=name or stem)
        if dt is not None:
            raise ParameterError("dt", f"dt: {p!r} has a time column; dt comes from it")
        t = table[:, 0]
        if t.size < 2:
            raise ParameterError("path", f"path: {p!r} needs at least 2 samples")
        step = float(t[1] - t[0])
        if not step > 0 or not np.allclose(np.diff(t), step, rtol=1e-6, atol=1e-9 * step):
            raise ParameterError("path", f"path: {p!r}: the times are not evenly spaced "
                                         f"(first step {step!r})")
        return cls(table[:, 1], step, units=units or "g", name=name or stem)

    # -- derived ---------------------------------------------------------------------------
    @property
    def acceleration(self) -> np.ndarray:
        """The samples times the scale factor, in the record's units."""
        return self._raw * self.scale

    @property
    def npts(self) -> int:
        return int(self._raw.size)

    @property
    def duration(self) -> float:
        """The time of the last sample, s."""
        return (self.npts - 1) * self.dt

    @property
    def time(self) -> np.ndarray:
        return np.arange(self.npts) * self.dt

    def si(self) -> np.ndarray:
        """The acceleration in m/s^2: (samples x scale) x the unit's factor, in that order
        (pySLAMMER's: its scaled record in g times 9.80665). Read-only (computed once)."""
        if self._si is None:
            si = (self._raw * self.scale) * UNITS[self.units]
            si.setflags(write=False)
            self._si = si
        return self._si

    @property
    def pga(self) -> float:
        """The peak ground acceleration |a| of the scaled record, in g."""
        if self._pga is None:
            si = self.si()
            self._pga = float(max(si.max(), -si.min())) / G
        return self._pga

    def scaled(self, factor: Optional[float] = None, *, pga: Optional[float] = None) -> "Record":
        """The record times ``factor``, or scaled to a peak ground acceleration ``pga`` (in g;
        as pySLAMMER: factor = pga / max |a|)."""
        if (factor is None) == (pga is None):
            raise ParameterError("factor, pga", "factor, pga: give one of them")
        if pga is not None:
            target = _positive("pga", pga)
            peak = float(np.max(np.abs(self._raw))) * (UNITS[self.units] / G)
            if peak == 0:
                raise ParameterError("pga", "pga: the record is zero everywhere; it cannot be "
                                            "scaled to a peak")
            scale = target / peak
        else:
            if isinstance(factor, bool) or not isinstance(
                    factor, (int, float, np.integer, np.floating)):
                raise ParameterError("factor", f"factor must be a number, got {factor!r}")
            scale = self.scale * float(factor)
        return Record(self._raw, self.dt, units=self.units, name=self.name, scale=scale)

    def __repr__(self) -> str:
        scale = "" if self.scale == 1.0 else f", scale={self.scale:.6g}"
        return (f"Record({self.name!r}: {self.npts} samples, dt={self.dt:g} s, "
                f"{self.duration:.2f} s, PGA {self.pga:.3f} g{scale})")

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, Record):
            return NotImplemented
        return (np.array_equal(self._raw, other._raw) and self.dt == other.dt
                and self.units == other.units and self.name == other.name
                and self.scale == other.scale)

    __hash__ = None  # type: ignore[assignment]


def _read_at2(path: str, text: str) -> Tuple[np.ndarray, float]:
    lines = text.splitlines()
    header = "\n".join(lines[:4])
    npts = re.search(r"NPTS\s*=\s*(\d+)", header, re.I)
    dt = re.search(r"DT\s*=\s*([0-9.eE+-]+)", header, re.I)
    if npts and dt:
        return _at2_values(path, lines, int(npts.group(1)), dt.group(1))
    # The older PEER layout: "  5590   .0050   NPTS, DT" on the fourth line.
    older = re.match(r"\s*(\d+)\s+([0-9.eE+-]+)\s+NPTS", lines[3], re.I) if len(lines) >= 4 \
        else None
    if older is None:
        raise ParameterError("path", f"path: {path!r} is not a PEER NGA AT2 file (its 4th "
                                     "line must give NPTS= and DT=)")
    return _at2_values(path, lines, int(older.group(1)), older.group(2))


def _at2_values(path: str, lines: List[str], npts: int, dt: str) -> Tuple[np.ndarray, float]:
    try:
        values = [float(x) for line in lines[4:] for x in line.replace(",", " ").split()]
        step = float(dt)
    except ValueError:
        raise ParameterError("path", f"path: {path!r}: a sample is not a number") from None
    if len(values) != npts:
        raise ParameterError("path", f"path: {path!r} holds {len(values)} samples, its header "
                                     f"says NPTS={npts}")
    return np.array(values, dtype=float), step


# -- the block -------------------------------------------------------------------------------

def _yield_values(name: str, value: Any, *, allow_inf: bool = False) -> np.ndarray:
    """A yield (in g) as a 1-D array of checked values."""
    if isinstance(value, (int, float)) and not isinstance(value, bool):
        return np.array([_positive(name, value, allow_inf=allow_inf)])
    if isinstance(value, (str, bytes)):
        raise ParameterError(name, f"{name} must be a number or a sequence of numbers")
    arr = np.asarray(value, dtype=object)
    if arr.ndim > 1 or arr.size == 0:
        raise ParameterError(name, f"{name} must be a number or a non-empty 1-D sequence")
    return np.array([_positive(name, v, allow_inf=allow_inf) for v in arr.reshape(-1)])


def _mode(ky, mu, mu_static, kd, ku):
    """The sliding mode and its yields (in g) per case: (mode, {name: array}, rows in g)."""
    given = [n for n, v in (("ky", ky), ("mu", mu), ("kd", kd), ("ku", ku)) if v is not None]
    if not given:
        raise ParameterError("ky", "ky: missing (give ky for one-way sliding, mu for two-way "
                                   "on a flat surface, or kd and ku for an incline)")
    if ky is not None and len(given) > 1 or mu is not None and len(given) > 1:
        raise ParameterError(", ".join(given), f"{', '.join(given)}: give ky, mu or (kd, ku), "
                                               "one of them")
    if mu_static is not None and mu is None:
        raise ParameterError("mu_static", "mu_static goes with mu (two-way on a flat surface)")
    if ky is not None:
        k = _yield_values("ky", ky)
        rows = np.full((k.size, 4), np.inf)
        rows[:, 0] = rows[:, 2] = k
        return "one-way", {"ky": k}, rows, np.ndim(ky) == 0
    if mu is not None:
        m = _yield_values("mu", mu)
        ms = m if mu_static is None else _yield_values("mu_static", mu_static)
        try:
            m, ms = np.broadcast_arrays(m, ms)
        except ValueError:
            raise ParameterError("mu, mu_static", "mu, mu_static: lengths differ") from None
        if np.any(ms < m):
            i = int(np.flatnonzero(ms < m)[0])
            raise ParameterError("mu_static", f"mu_static must be >= mu, got {ms[i]!r} < {m[i]!r}")
        scalar = np.ndim(mu) == 0 and (mu_static is None or np.ndim(mu_static) == 0)
        return ("flat", {"mu": m.copy(), "mu_static": ms.copy()},
                np.stack([m, m, ms, ms], axis=1), scalar)
    if kd is None or ku is None:
        missing = "kd" if kd is None else "ku"
        raise ParameterError(missing, f"{missing}: missing (an incline needs both kd and ku)")
    d = _yield_values("kd", kd)
    u = _yield_values("ku", ku, allow_inf=True)
    try:
        d, u = np.broadcast_arrays(d, u)
    except ValueError:
        raise ParameterError("kd, ku", "kd, ku: lengths differ") from None
    return ("incline", {"kd": d.copy(), "ku": u.copy()}, np.stack([d, u, d, u], axis=1),
            np.ndim(kd) == 0 and np.ndim(ku) == 0)


def _records(record, dt, units) -> Tuple[List[Record], bool]:
    if isinstance(record, Record):
        if dt is not None:
            raise ParameterError("dt", "dt: the record has its own (give dt with a plain array)")
        return [record], True
    if isinstance(record, (list, tuple)) and record and all(isinstance(r, Record) for r in record):
        if dt is not None:
            raise ParameterError("dt", "dt: the records have their own")
        return list(record), False
    if dt is None:
        raise ParameterError("dt", "dt: missing (a plain array of samples needs dt=, or give "
                                   "a crandall.Record)")
    return [Record(record, dt, units=units, name="record")], True


def newmark(record: Any, *, ky: Any = None, mu: Any = None, mu_static: Any = None,
            kd: Any = None, ku: Any = None, method: str = "exact", polarity: str = "normal",
            dt: Optional[float] = None, units: str = "g",
            threads: Optional[int] = None) -> "NewmarkResult":
    """Newmark's rigid sliding block on a recorded ground motion.

    Parameters
    ----------
    record : Record, list of Record, or sequence of float
        The ground acceleration; a plain sequence needs ``dt`` (and ``units``, default g).
    ky : float or sequence, optional
        One-way downslope sliding (SLAMMER's rigid block): the yield acceleration, in g. The
        sliding velocity W (ground minus block, positive downslope) obeys dW/dt = a - ky g
        while W > 0, and the block starts when a exceeds ky g.
    mu, mu_static : float or sequence, optional
        Two-way sliding on a flat surface: the body's velocity relative to the foundation V
        obeys dV/dt = -a - mu g sign V; at rest it sticks while |a| <= mu_static g
        (default mu_static = mu; >= mu).
    kd, ku : float or sequence, optional
        Two-way sliding on an incline, yield accelerations (in g) downslope and upslope (from a
        slope angle theta and friction mu: kd = mu cos theta - sin theta, ku = mu cos theta +
        sin theta); ku may be ``math.inf`` (no upslope sliding: one-way).
    method : {"exact", "slammer"}
        "exact": the record joined by straight lines, integrated exactly; "slammer":
        pySLAMMER 0.2.2's recursion, bit for bit (one-way only).
    polarity : {"normal", "inverse", "both"}
        The record as given, negated, or both.
    dt, units
        For a plain sequence: its sampling interval (s) and units ("g", "m/s2", "cm/s2").
    threads : int, optional
        The core's threads for a sweep (default: every core; the numbers do not depend on it).

    Returns
    -------
    NewmarkResult
        Displacements in m, positive downslope for one-way and inclines; for a flat surface
        the body's displacement relative to the foundation, positive in the direction of the
        record's positive acceleration.

    Raises
    ------
    ParameterError
        Naming the parameter: a yield that is missing, not a number, <= 0, NaN or infinite
        (ku may be infinite); mu_static < mu; several modes at once; an unknown method or
        polarity; "slammer" with a two-way mode; a record with a sample that is not finite, dt
        not finite and > 0, dt given with a Record; bad threads.
    """
    if method not in METHODS:
        raise ParameterError("method", f"method must be one of {', '.join(METHODS)}, got {method!r}")
    if polarity not in POLARITIES:
        raise ParameterError("polarity", f"polarity must be one of {', '.join(POLARITIES)}, "
                                         f"got {polarity!r}")
    if threads is None:
        nthreads = 0
    elif isinstance(threads, bool) or not isinstance(threads, (int, np.integer)) or threads < 1:
        raise ParameterError("threads", f"threads must be an integer >= 1, got {threads!r}")
    else:
        nthreads = int(threads)
    mode, yields, rows_g, scalar_yield = _mode(ky, mu, mu_static, kd, ku)
    if method == "slammer" and mode != "one-way":
        raise ParameterError("method", "method: 'slammer' is pySLAMMER's one-way rigid block: "
                                       "give ky (mu, kd and ku need method='exact')")
    records, single_record = _records(record, dt, units)
    polarities = ("normal", "inverse") if polarity == "both" else (polarity,)
    signs = [_SIGNS[p] for p in polarities]
    accelerations = [r.si() for r in records]
    if method == "slammer":  # ky in g: the recursion multiplies by g itself, as pySLAMMER
        core_rows = np.zeros_like(rows_g)
        core_rows[:, 0] = rows_g[:, 0]
    else:
        core_rows = rows_g * G   # (inf stays inf: one-way)
    dims = tuple(d for d, many in (("record", not single_record), ("yield", not scalar_yield),
                                   ("polarity", polarity == "both")) if many)
    history = None
    if not dims:
        a, r, s = accelerations[0], core_rows[0].tolist(), signs[0]
        try:
            if method == "exact":
                out = _core.newmark_exact(a, records[0].dt, s, *r)
            else:
                out = _core.newmark_slammer(a, records[0].dt, s, float(r[0]))
        except ValueError as exc:
            raise ParameterError("record", f"record: {exc}") from None
        summary, velocity, displacement, events = out
        table = np.array(summary, dtype=float).reshape(1, 1, 1, 4)
        history = {"velocity": velocity, "displacement": displacement, "events": events}
    else:
        # In calls of at most SWEEP_SAMPLES samples (about 35 ms), so that Ctrl-C stops a
        # long sweep between two of them (each case is independent: the same numbers).
        per_yield = sum(len(a) for a in accelerations) * len(signs)
        per_call = max(1, SWEEP_SAMPLES // max(per_yield, 1))
        dts = [r.dt for r in records]
        try:
            table = np.concatenate(
                [_core.newmark_sweep(accelerations, dts, core_rows[i:i + per_call], signs,
                                     method, nthreads)
                 for i in range(0, len(core_rows), per_call)], axis=1)
        except ValueError as exc:
            raise ParameterError("record", f"record: {exc}") from None
    # Finite summaries bound the histories: the displacement lies between its extremes, and a
    # velocity that overflowed would have taken the displacement with it.
    if not np.isfinite(table).all():
        raise ParameterError("record", "record: the displacement overflows doubles (samples "
                                       "or yields far beyond a ground motion's)")
    if mode == "flat":  # the body relative to the foundation: -W
        table = np.stack([-table[..., 0], -table[..., 2], -table[..., 1], table[..., 3]], axis=-1)
        if history is not None:
            ev = history["events"].copy()
            ev[:, 2] = -ev[:, 2]
            history = {"velocity": -history["velocity"],
                       "displacement": -history["displacement"], "events": ev}
    return NewmarkResult(
        records=[{"name": r.name, "dt": r.dt, "npts": r.npts, "pga": r.pga, "scale": r.scale,
                  "units": r.units} for r in records],
        mode=mode, method=method, yields=yields, polarities=polarities, dims=dims,
        table=table,
        acceleration=None if history is None else (accelerations[0], signs[0]),
        history=history)


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
