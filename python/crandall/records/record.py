"""A recorded ground motion (:class:`Record`): its samples and step, read from a text file, a
single column with a given ``dt`` or a PEER NGA ``.AT2`` file, in g or m/s^2."""

from __future__ import annotations

import math
import os
import re
from typing import Any, Dict, List, Optional, Tuple, Union

import numpy as np

from .. import _core
from ..errors import ParameterError


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
