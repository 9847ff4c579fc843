"""Checkpoints of a long run: the merged accumulators of the finished chunks, kept on disk.

A run's result is the in-order merge of its chunks 0..n-1, and each chunk is bitwise the same
on any machine and thread count. So the merge of chunks 0..k-1, stored with the run's identity
(scene, paths, seed, dt, method, crandall version), is all a rerun needs to carry on at chunk
k and end with a result bitwise identical to an uninterrupted run.

The file is a NumPy ``.npz`` archive (no pickles). It is replaced atomically after each chunk
(``crandall._files.write_atomic``: temporary file, fsync, rename, fsync of the folder), so a
kill at any moment leaves either the previous or the new checkpoint, never a torn one. Where it
goes is checked before the first chunk (:func:`check_writable`), and every field is checked
when it is read back (:func:`load`): a damaged or edited checkpoint is a ValueError naming the
file and the field, never a wrong result.
"""

from __future__ import annotations

import json
import math
import os
from typing import Any, Dict, Optional, Tuple

import numpy as np

from . import _core
from ._version import __version__
from .spec import RunSpec
from ._files import check_file_writable, check_folder_writable, check_moments, write_atomic

__all__ = ["identity", "load", "save", "stored_seed", "check_writable", "make_folder"]

FORMAT = "crandall-checkpoint"
# 2: the stop slot holds the time after the switch-off; the identity has the random stream.
FORMAT_VERSION = 2

_ARRAYS = ("identity", "next_chunk", "times_counts", "times_means", "times_central",
           "stop_counts", "stop_means", "stop_central")


def identity(spec, **fields) -> Dict[str, Any]:
    """What makes two runs the same run (plain data, compared for equality).

    Parameters
    ----------
    spec : RunSpec or Scene
        The run; or, as before run specifications, its scene with the keywords ``paths``,
        ``seed``, ``dt``, ``method`` and optionally ``min_steps``.

    Returns
    -------
    dict
        The checkpoint format, crandall version and random stream, and ``spec.to_dict()``.
    """
    if not isinstance(spec, RunSpec):
        spec = RunSpec(spec, **fields)
    elif fields:
        raise ValueError(f"{sorted(fields)[0]}: give a RunSpec or a scene with its fields, "
                         "not both")
    return {"format": FORMAT, "format_version": FORMAT_VERSION, "crandall": __version__,
            "random_stream": int(_core.RANDOM_STREAM), **spec.to_dict()}


def check_writable(path) -> str:
    """Check, before a run, that its checkpoint can be written; create nothing.

    Called for a run that still has chunks to do (a complete checkpoint is only read, and
    may sit in a read-only place).

    Parameters
    ----------
    path : str or os.PathLike
        The checkpoint file (it may exist: it is then replaced after every chunk).

    Returns
    -------
    str
        The path as a string.

    Raises
    ------
    ValueError
        If the path is empty or a folder, or its folder is missing or not writable.
    """
    return check_file_writable(path, "checkpoint")


def make_folder(path) -> str:
    """Create the folder of a sweep's checkpoints if it is missing.

    An existing folder is not probed here: a sweep whose checkpoints are all complete only
    reads them, and the others are checked one by one (:func:`check_writable`).

    Raises
    ------
    ValueError
        Naming ``checkpoint_dir``, if it is a file or cannot be created.
    """
    if isinstance(path, (str, os.PathLike)) and os.path.isdir(path):
        return os.fspath(path)
    return check_folder_writable(path, "checkpoint_dir", create=True)


def _refuse(path, why: str) -> ValueError:
    return ValueError(f"checkpoint: {os.fspath(path)} is not a crandall checkpoint "
                      f"({why}); remove it or give another path")


def _is_int(value) -> bool:
    return isinstance(value, int) and not isinstance(value, bool)


def _check_identity(path, ident) -> None:
    """Every identity field present with the right type (before comparing with the run's)."""
    if not isinstance(ident, dict):
        raise _refuse(path, "identity is not a table")
    if ident.get("format") != FORMAT:
        raise _refuse(path, f"identity.format is {ident.get('format')!r}, not {FORMAT!r}")
    kinds = {"format_version": _is_int, "crandall": lambda v: isinstance(v, str),
             "scene": lambda v: isinstance(v, dict),
             "paths": lambda v: _is_int(v) and v >= 1,
             "seed": lambda v: _is_int(v) and 0 <= v < 1 << 64,
             "dt": lambda v: isinstance(v, float) and math.isfinite(v) and v > 0,
             "method": lambda v: isinstance(v, str)}
    for key, ok in kinds.items():
        if key not in ident:
            raise _refuse(path, f"identity.{key} is missing")
        if not ok(ident[key]):
            raise _refuse(path, f"identity.{key} is {ident[key]!r}")
    # Fields beyond these are compared with the run's identity by load, which names them.


def _read_arrays(path, f) -> Dict[str, np.ndarray]:
    # The file object is ours, so that a damaged file cannot leave it open.
    try:
        data = np.load(f, allow_pickle=False)
    except ValueError:
        # NumPy's own wording ("... allow_pickle=False") speaks of pickles; the file is simply
        # not an archive of arrays.
        raise _refuse(path, "not a NumPy .npz archive") from None
    except Exception as exc:  # noqa: BLE001 - whatever a damaged file makes the reader raise
        raise _refuse(path, f"unreadable or truncated: {exc}") from None
    if not isinstance(data, np.lib.npyio.NpzFile):
        raise _refuse(path, "a single NumPy array, not a .npz archive")
    arrays = {}
    with data:
        for key in data.files:
            try:
                arrays[key] = data[key]
            except Exception as exc:  # noqa: BLE001 - a damaged member fails only when read
                raise _refuse(path, f"{key} is unreadable or truncated: {exc}") from None
    return arrays


def _read(path) -> Tuple[Dict[str, Any], Dict[str, np.ndarray]]:
    if os.path.isdir(path):
        raise ValueError(f"checkpoint: {os.fspath(path)} is a folder; give a file path")
    try:
        with open(path, "rb") as f:
            arrays = _read_arrays(path, f)
    except OSError as exc:
        raise _refuse(path, f"unreadable: {exc.strerror or exc}") from None
    missing = [k for k in _ARRAYS if k not in arrays]
    if missing:
        raise _refuse(path, f"{', '.join(missing)} missing")
    extra = sorted(set(arrays) - set(_ARRAYS))
    if extra:
        raise _refuse(path, f"unknown fields {', '.join(extra)}")
    raw = arrays.pop("identity")
    if raw.shape != () or raw.dtype.kind != "U":
        raise _refuse(path, "identity is not a text")
    try:
        ident = json.loads(str(raw))
    except ValueError:
        raise _refuse(path, "identity is not JSON") from None
    _check_identity(path, ident)
    return ident, arrays


def stored_seed(path) -> Optional[int]:
    """The seed recorded in an existing checkpoint, or None if there is no file."""
    if not isinstance(path, (str, os.PathLike)) or not os.path.isfile(path):
        return None
    return int(_read(path)[0]["seed"])


def load(path, ident: Dict[str, Any], chunks: int):
    """Resume point of a run: (next chunk, merged times accumulator, merged stop accumulator).

    Returns ``(0, None, None)`` if there is no file. Raises ValueError if the file belongs to
    another run (the message names what differs) or is not a valid checkpoint of it (the
    message names the file and the field: identity, next_chunk, counts, means, central).
    """
    if not os.path.exists(path):
        return 0, None, None
    stored, arrays = _read(path)
    # Round-trip through JSON so that both sides compare as stored (inf, floats, lists).
    expected = json.loads(json.dumps(ident))
    for key, what in (("format_version", "checkpoint format"), ("random_stream", "random stream")):
        if stored.get(key) != expected.get(key):
            # Numbers of two streams (or two layouts) must never be merged into one result.
            raise ValueError(
                f"checkpoint: {os.fspath(path)} was written by crandall "
                f"{stored.get('crandall', '?')} with {what} {stored.get(key, 'unknown')!r}; "
                f"this crandall uses {what} {expected.get(key)!r}, so its chunks cannot be "
                "continued here; remove it to start again, or resume with that version")
    if stored != expected:
        diff = sorted(k for k in set(stored) | set(expected) if stored.get(k) != expected.get(k))
        details = "; ".join(f"{k}: checkpoint has {stored.get(k)!r}, this run {expected.get(k)!r}"
                            for k in diff)
        raise ValueError(f"checkpoint: {os.fspath(path)} belongs to a different run ({details}); "
                         "give another path or the same arguments")
    nc = arrays["next_chunk"]
    if nc.shape != () or nc.dtype.kind not in "iu":
        raise _refuse(path, f"next_chunk must be one integer, got {nc.dtype} of shape {nc.shape}")
    done = int(nc)
    if not 0 <= done <= chunks:
        raise _refuse(path, f"next_chunk is {done}, outside 0..{chunks} for this run's "
                            f"{chunks} chunks")
    paths = int(ident["paths"])
    # Chunks hold CHUNK_PATHS paths each, the last one the rest.
    done_paths = min(done * _core.CHUNK_PATHS, paths)
    scene = ident["scene"]
    slots = {"times_": len(scene.get("times", ())),
             "stop_": 1 if "stop" in scene.get("observe", ()) else 0}
    where = f"checkpoint: {os.fspath(path)} is not a crandall checkpoint of this run"
    for prefix, n in slots.items():
        check_moments(where, prefix, {k: arrays[prefix + k] for k in ("counts", "means",
                                                                      "central")},
                      slots=n, paths=float(done_paths), method=str(ident["method"]),
                      counted=f" of the {done} finished chunks (next_chunk is {done})")
    if done == 0:
        return 0, None, None
    moments = [_core.Moments(n, arrays[p + "counts"], arrays[p + "means"], arrays[p + "central"])
               for p, n in slots.items()]
    return done, moments[0], moments[1]


def save(path, ident: Dict[str, Any], next_chunk: int, times_acc, stop_acc) -> None:
    """Atomically replace the checkpoint with the merge of chunks 0..next_chunk-1."""
    arrays = {"identity": np.array(json.dumps(ident)), "next_chunk": np.array(next_chunk)}
    for prefix, acc in (("times", times_acc), ("stop", stop_acc)):
        arrays[prefix + "_counts"] = acc.counts
        arrays[prefix + "_means"] = acc.means
        arrays[prefix + "_central"] = acc.central
    write_atomic(path, lambda f: np.savez(f, **arrays))
