"""Checkpoints of a long run: one file format for every estimator (:mod:`crandall.driver`).

A checkpoint is a NumPy ``.npz`` archive (no pickles) holding the run's identity (JSON text:
the format, crandall version, random stream, the estimator's name and the run's spec) and the
estimator's state as named arrays (a JSON text ``state`` among them where the state is not
arrays). :func:`run_identity`, :func:`read` and :func:`write` are all an estimator uses: a file
of another estimator or another run is refused naming the field that differs.

A fixed-step run's state is the merge of its finished chunks. A run's result is the in-order merge of its chunks 0..n-1, and each chunk is bitwise the same
on any machine and thread count. So the merge of chunks 0..k-1, stored with the run's identity
(scene, paths, seed, dt, method, crandall version), is all a rerun needs to carry on at chunk
k and end with a result bitwise identical to an uninterrupted run.

The file is a NumPy ``.npz`` archive (no pickles). It is replaced atomically after each chunk
(``crandall._files.write_atomic``: temporary file, fsync, rename, fsync of the folder), so a
kill at any moment leaves either the previous or the new checkpoint, never a torn one. Where it
goes is checked before the first chunk (:func:`check_writable`), and every field is checked
when it is read back (:func:`read`, :func:`restore`): a damaged or edited checkpoint is a ValueError naming the
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
from .bins import check_histograms
from .engine import Chunk
from .spec import RunSpec
from ._files import (check_file_writable, check_folder_writable, check_moments,
                     refuse_other_run, refuse_other_version, write_atomic)
from .errors import ParameterError

__all__ = ["identity", "run_identity", "read", "write", "json_state", "read_json_state",
           "restore", "state", "stored_seed",
           "check_writable", "make_folder"]

FORMAT = "crandall-checkpoint"
# 2: the stop slot holds the time after the switch-off; the identity has the random stream.
# 3: the peaks' moments and the histograms' edges and counts, when the scene asks for them.
# 4: one format for every estimator (runs to an accuracy and tails too); the identity names
#    the estimator.
# The moments of V^2 (energy_*, when the scene observes the kinetic energy) are optional: a
# checkpoint written before crandall kept them resumes without them (the kinetic energy's
# variance then has no standard error).
FORMAT_VERSION = 4
#: The estimator of a fixed-step run (the identity's ``estimator`` field).
PATHS = "paths"
#: What each estimator's checkpoints are called in messages.
ESTIMATORS = {PATHS: "a fixed-step run (paths=)", "accuracy": "a run to an accuracy (error=)",
              "tail": "a tail run (crandall.tail)"}

_ARRAYS = ("identity", "next_chunk", "times_counts", "times_means", "times_central",
           "stop_counts", "stop_means", "stop_central")
_PEAK_ARRAYS = tuple(f"{p}_{k}" for p in ("peaks", "peaks_stop", "energy")
                     for k in ("counts", "means", "central"))
# Histograms: the recorded axes' indices, their edges end to end (edge_sizes says where one
# ends), their counts end to end (each axis has len(edges) + 2).
_HIST_ARRAYS = ("histogram_index", "histogram_edge_sizes", "histogram_edges",
                "histogram_counts")


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
        :func:`run_identity` of the fixed-step estimator and ``spec.to_dict()``.
    """
    if not isinstance(spec, RunSpec):
        spec = RunSpec(spec, **fields)
    elif fields:
        raise ParameterError(sorted(fields)[0], f"{sorted(fields)[0]}: give a RunSpec or a scene "
                                                "with its fields, not both")
    return run_identity(PATHS, spec.to_dict())


def run_identity(estimator: str, spec: Dict[str, Any]) -> Dict[str, Any]:
    """The identity of any estimator's run: the checkpoint format, crandall version, random
    stream and estimator, then the run's spec (plain data, compared field by field)."""
    if estimator not in ESTIMATORS:
        raise ParameterError("estimator", f"estimator: one of {', '.join(ESTIMATORS)}, got "
                                          f"{estimator!r}")
    out = {"format": FORMAT, "format_version": FORMAT_VERSION, "crandall": __version__,
           "random_stream": int(_core.RANDOM_STREAM), "estimator": estimator, **spec}
    scene = spec.get("scene")
    if (isinstance(scene, dict) and isinstance(scene.get("excitation"), dict)
            and scene["excitation"].get("kind") != "white" and "stop" in scene.get("observe", ())):
        # A filtered excitation's stop time counts the touches its last rest's search finds
        # down to this depth (docs/filtered.md, "Events and the stop"): a checkpoint whose
        # stop times were summed without it (or to another depth) is another run.
        out["touch_depth"] = int(_core.TOUCH_DEPTH)
    return out


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
    kinds = {"format_version": _is_int, "crandall": lambda v: isinstance(v, str)}
    # Before format 4 every checkpoint was a fixed-step run's. Other estimators' fields are
    # compared with the run's own (read names every one that differs).
    if ident.get("estimator", PATHS) == PATHS:
        kinds.update({"scene": lambda v: isinstance(v, dict),
                      "seed": lambda v: _is_int(v) and 0 <= v < 1 << 64,
                      "paths": lambda v: _is_int(v) and v >= 1,
                      "dt": lambda v: isinstance(v, float) and math.isfinite(v) and v > 0,
                      "method": lambda v: isinstance(v, str)})
    for key, ok in kinds.items():
        if key not in ident:
            raise _refuse(path, f"identity.{key} is missing")
        if not ok(ident[key]):
            raise _refuse(path, f"identity.{key} is {ident[key]!r}")
    # Fields beyond these are compared with the run's identity by read, which names them.


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
    if "identity" not in arrays:
        raise _refuse(path, "identity missing")
    raw = arrays.pop("identity")
    if raw.shape != () or raw.dtype.kind != "U":
        raise _refuse(path, "identity is not a text")
    try:
        ident = json.loads(str(raw))
    except ValueError:
        raise _refuse(path, "identity is not JSON") from None
    _check_identity(path, ident)
    return ident, arrays


def read(path, ident: Dict[str, Any]) -> Optional[Dict[str, np.ndarray]]:
    """The state (named arrays) that the checkpoint at ``path`` holds for the run ``ident``
    (:func:`run_identity`), or None if there is no file.

    Raises ValueError naming the file if it is not a checkpoint, was written with another
    format or random stream, by another estimator, or for another run (naming every field of
    the identity that differs).
    """
    if not os.path.exists(path):
        return None
    stored, arrays = _read(path)
    # Round-trip through JSON so that both sides compare as stored (inf, floats, lists).
    expected = json.loads(json.dumps(ident))
    refuse_other_version(path, stored, expected, (("format_version", "checkpoint format"),
                                                  ("random_stream", "random stream")))
    theirs, mine = stored.get("estimator"), expected.get("estimator")
    if theirs != mine:
        raise ValueError(f"checkpoint: {os.fspath(path)} is a checkpoint of "
                         f"{ESTIMATORS.get(theirs, repr(theirs))}, not of "
                         f"{ESTIMATORS.get(mine, repr(mine))} (field estimator); give another "
                         "path")
    refuse_other_run(path, stored, expected)
    return arrays


def write(path, ident: Dict[str, Any], arrays: Dict[str, np.ndarray]) -> None:
    """Atomically replace the checkpoint at ``path`` with the run ``ident`` and its state."""
    if "identity" in arrays:
        raise ParameterError("arrays", "arrays: 'identity' is the checkpoint's own field")
    out = {"identity": np.array(json.dumps(ident)), **arrays}
    write_atomic(path, lambda f: np.savez(f, **out))


def json_state(state: Dict[str, Any]) -> Dict[str, np.ndarray]:
    """A state kept as one JSON text (the array ``state``; floats as Python writes them, which
    read back exactly)."""
    return {"state": np.array(json.dumps(state))}


def read_json_state(path, arrays: Dict[str, np.ndarray], what: str) -> Dict[str, Any]:
    """:func:`json_state`'s table read back from :func:`read`'s arrays; a ValueError naming the
    file, ``what`` (the kind of run) and the field ``state`` if it is not one."""
    raw = arrays.get("state")
    try:
        if set(arrays) != {"state"} or raw.shape != () or raw.dtype.kind != "U":
            raise ValueError("not one text")
        st = json.loads(str(raw))
        if not isinstance(st, dict):
            raise ValueError("not a table")
    except ValueError as exc:
        raise ValueError(f"checkpoint: {os.fspath(path)} is not a checkpoint of {what} (field "
                         f"state: {exc})") from None
    return st


def stored_seed(path) -> Optional[int]:
    """The seed recorded in an existing checkpoint, or None if there is no file."""
    if not isinstance(path, (str, os.PathLike)) or not os.path.isfile(path):
        return None
    seed = _read(path)[0].get("seed")
    # Another estimator's checkpoint may have none: reading it as this run's refuses it.
    return seed if _is_int(seed) and 0 <= seed < 1 << 64 else None


def restore(path, ident: Dict[str, Any], arrays: Dict[str, np.ndarray], chunks: int,
            histograms=((), ())):
    """A fixed-step run's state read back (:func:`read`'s arrays): (next chunk, merged
    accumulators as an ``engine.Chunk``, or None when no chunk is done).

    ``histograms``: the run's recorded axes, ``(indices, edges)``; a checkpoint whose edges
    differ (bit for bit) is refused: counts on other bins cannot be merged.

    Raises ValueError if the arrays are not a valid state of the run (the message names the
    file and the field: next_chunk, counts, means, central, the peaks' and the histograms'
    fields).
    """
    missing = [k for k in _ARRAYS[1:] if k not in arrays]
    if missing:
        raise _refuse(path, f"{', '.join(missing)} missing")
    extra = sorted(set(arrays) - set(_ARRAYS) - set(_PEAK_ARRAYS) - set(_HIST_ARRAYS))
    if extra:
        raise _refuse(path, f"unknown fields {', '.join(extra)}")
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
    observe = scene.get("observe", ())
    stop = "stop" in observe
    peaks = "peaks" in observe
    # The stop's moments: a second slot for |U(t_s)| with "residual" (the core's option).
    slots = {"times_": len(scene.get("times", ())),
             "stop_": (2 if "residual" in observe else 1) if stop else 0}
    if peaks:
        # The peaks' moments: the same layout; an unused third variable stays 0.
        slots["peaks_"] = len(scene.get("times", ()))
        if stop:
            slots["peaks_stop_"] = 1
    if "kinetic_energy" in observe and "energy_counts" in arrays:
        # The moments of (V^2, 0, 0) per output time (absent from checkpoints written before
        # crandall kept them: the run then goes on without them).
        slots["energy_"] = len(scene.get("times", ()))
    indices, edges = histograms
    expected = set(_ARRAYS) | {p + k for p in slots for k in ("counts", "means", "central")}
    if indices:
        expected |= set(_HIST_ARRAYS)
    where = f"checkpoint: {os.fspath(path)} is not a crandall checkpoint of this run"
    present = set(arrays) | {"identity"}
    if present != expected:
        odd = sorted((present - expected) | (expected - present))[0]
        raise ValueError(f"{where}: {odd} is {'missing' if odd in expected else 'unexpected'} "
                         "for this scene's observables and distributions")
    for prefix, n in slots.items():
        check_moments(where, prefix, {k: arrays[prefix + k] for k in ("counts", "means",
                                                                      "central")},
                      slots=n, paths=float(done_paths), method=str(ident["method"]),
                      counted=f" of the {done} finished chunks (next_chunk is {done})")
    counts = None
    if indices:
        counts = _read_histograms(where, arrays, indices, edges, done_paths)
    if done == 0:
        return 0, None
    moments = {p: _core.Moments(n, arrays[p + "counts"], arrays[p + "means"],
                                arrays[p + "central"]) for p, n in slots.items()}
    return done, Chunk(moments["times_"], moments["stop_"], moments.get("peaks_"),
                       moments.get("peaks_stop_"), counts, moments.get("energy_"))


def _read_histograms(where, arrays, indices, edges, paths):
    index = arrays["histogram_index"]
    sizes = arrays["histogram_edge_sizes"]
    flat_edges = arrays["histogram_edges"]
    flat_counts = arrays["histogram_counts"]
    for name, a, kind in (("histogram_index", index, "iu"), ("histogram_edge_sizes", sizes, "iu"),
                          ("histogram_edges", flat_edges, "f"),
                          ("histogram_counts", flat_counts, "u")):
        if a.ndim != 1 or a.dtype.kind not in kind:
            raise ValueError(f"{where}: {name} must be a 1-D array of "
                             f"{'unsigned integers' if kind == 'u' else 'numbers'}")
    if sizes.size != index.size or (sizes < 2).any() \
            or int(sizes.sum()) != flat_edges.size \
            or int(sizes.sum()) + 2 * sizes.size != flat_counts.size:
        raise ValueError(f"{where}: histogram_edge_sizes do not match histogram_edges and "
                         "histogram_counts")
    cuts = np.cumsum(sizes)[:-1]
    stored_edges = np.split(flat_edges, cuts)
    counts = tuple(np.array(c, dtype=np.uint64)
                   for c in np.split(flat_counts, np.cumsum(sizes + 2)[:-1]))
    check_histograms(where, index, stored_edges, counts, indices, paths=paths)
    for i, (a, b) in enumerate(zip(stored_edges, edges)):
        if a.shape != b.shape or not np.array_equal(a.view(np.uint64), np.asarray(b).view(np.uint64)):
            raise ValueError(f"{where}: histogram_edges of axis {indices[i]} differ from this "
                             "run's bins (written by another crandall or SciPy?); remove it to "
                             "start again")
    return counts


def state(next_chunk: int, acc, histograms=((), ())) -> Dict[str, np.ndarray]:
    """A fixed-step run's state as named arrays: the merge of chunks 0..next_chunk-1
    (``acc``, an ``engine.Chunk``, None if none) and the histogram axes ``(indices, edges)``."""
    arrays = {"next_chunk": np.array(next_chunk)}
    if acc is None:
        return arrays
    parts = [("times", acc.times), ("stop", acc.stop), ("peaks", acc.peaks),
             ("peaks_stop", acc.peaks_stop), ("energy", acc.energy)]
    for prefix, moments in parts:
        if moments is None:
            continue
        arrays[prefix + "_counts"] = moments.counts
        arrays[prefix + "_means"] = moments.means
        arrays[prefix + "_central"] = moments.central
    indices, edges = histograms
    if indices:
        arrays["histogram_index"] = np.asarray(indices, dtype=np.int64)
        arrays["histogram_edge_sizes"] = np.array([len(e) for e in edges], dtype=np.int64)
        arrays["histogram_edges"] = np.concatenate(edges).astype(np.float64)
        arrays["histogram_counts"] = np.concatenate(acc.counts).astype(np.uint64)
    return arrays
