"""Results that keep: xarray, pandas, netCDF files.

A saved result holds the statistics (readable by any netCDF tool) and the raw accumulators
(counts, means and central sums of every output time), so :func:`load` gives back a
:class:`~crandall.Result` whose every statistic is bitwise the one saved. Files are netCDF-3
written by SciPy (xarray's ``engine="scipy"``): no system library needed.

Needs the ``io`` extra: ``pip install crandall[io]`` (xarray, pandas).
"""

from __future__ import annotations

import os
from typing import Union

from ._dataset import STATISTICS, save, sweep, to_pandas, to_xarray
from ._dataset import read as _read
from .records import load_newmark
from .results import AccuracyResult, Result
from .tail.result import FILE_ATTR, TailResult

__all__ = ["to_xarray", "to_pandas", "save", "load", "load_newmark", "sweep", "STATISTICS"]


def load(path: Union[str, "os.PathLike[str]"]) -> Union[Result, TailResult]:
    """Read a result written by :meth:`crandall.Result.save` (or by
    :meth:`crandall.TailResult.save`: a tail result).

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
        If the file cannot be read, is not a saved crandall result, or any field of it is
        missing, of the wrong type, inconsistent with the others (shapes, the scene's output
        times, counts against paths) or not finite: the message names the file and the field.
    """
    tail = _saved_tail(path)
    if tail is not None:
        return tail
    try:
        fields = _read(path)
    except ValueError as exc:
        if _is_newmark(path):
            raise ValueError(f"path: {os.fspath(path)} is a saved Newmark result: read it with "
                             "crandall.io.load_newmark") from exc
        raise
    if fields.pop("kind", None) == "accuracy":
        return AccuracyResult(**fields)
    return Result(**fields)


def _saved_tail(path):
    """The tail result saved in ``path`` (:meth:`crandall.TailResult.save`), or None for any
    other file (whose own reader then says what is wrong with it)."""
    try:
        import xarray as xr  # the io extra; without it the result reader says so

        with xr.open_dataset(os.fspath(path), engine="scipy") as ds:
            if FILE_ATTR not in ds.attrs:
                return None
            ds.load()
    except Exception:  # noqa: BLE001 - not a netCDF file: the result reader names the fault
        return None
    try:
        return TailResult._from_dataset(ds)
    except (KeyError, ValueError, TypeError) as exc:
        raise ValueError(f"path: {os.fspath(path)} is a damaged crandall tail result "
                         f"({type(exc).__name__}: {exc})") from exc


def _is_newmark(path) -> bool:
    try:
        import xarray as xr

        with xr.open_dataset(os.fspath(path), engine="scipy") as ds:
            return "crandall_newmark" in ds.attrs
    except Exception:  # noqa: BLE001 - any unreadable file is simply not one
        return False
