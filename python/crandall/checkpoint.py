"""Checkpoints of a long run: the merged accumulators of the finished chunks, kept on disk.

A run's result is the in-order merge of its chunks 0..n-1, and each chunk is bitwise the same
on any machine and thread count. So the merge of chunks 0..k-1, stored with the run's identity
(scene, paths, seed, dt, method, crandall version), is all a rerun needs to carry on at chunk
k and end with a result bitwise identical to an uninterrupted run.

The file is a NumPy ``.npz`` archive (no pickles). It is replaced atomically after each chunk:
written to a temporary file in the same folder, flushed to disk (fsync), then renamed over the
old one (``os.replace``), so a kill at any moment leaves either the previous or the new
checkpoint, never a torn one.
"""

from __future__ import annotations

import json
import os
import tempfile
from typing import Any, Dict, Optional, Tuple

import numpy as np

from . import _core

__all__ = ["identity", "load", "save", "stored_seed"]

FORMAT = "crandall-checkpoint"
FORMAT_VERSION = 1


def identity(scene, *, paths: int, seed: int, dt: float, method: str,
             min_steps: int = 0) -> Dict[str, Any]:
    """What makes two runs the same run (plain data, compared for equality)."""
    from . import __version__

    return {"format": FORMAT, "format_version": FORMAT_VERSION, "crandall": __version__,
            "scene": scene.to_dict(), "paths": int(paths), "seed": int(seed),
            "dt": float(dt), "method": str(method), "min_steps": int(min_steps)}


def _read(path) -> Tuple[Dict[str, Any], Dict[str, np.ndarray]]:
    try:
        with np.load(path, allow_pickle=False) as data:
            arrays = {k: data[k] for k in data.files}
        ident = json.loads(str(arrays.pop("identity")))
        if not isinstance(ident, dict) or ident.get("format") != FORMAT:
            raise ValueError("no crandall identity")
    except (OSError, ValueError, KeyError, EOFError) as exc:
        raise ValueError(f"checkpoint: {os.fspath(path)} is not a crandall checkpoint "
                         f"({exc}); remove it or give another path") from None
    return ident, arrays


def stored_seed(path) -> Optional[int]:
    """The seed recorded in an existing checkpoint, or None if there is no file."""
    if not os.path.exists(path):
        return None
    return int(_read(path)[0]["seed"])


def _moments(arrays, prefix):
    counts = arrays[prefix + "_counts"]
    return _core.Moments(counts.shape[0], counts, arrays[prefix + "_means"],
                         arrays[prefix + "_central"])


def load(path, ident: Dict[str, Any], chunks: int):
    """Resume point of a run: (next chunk, merged times accumulator, merged stop accumulator).

    Returns ``(0, None, None)`` if there is no file. Raises ValueError if the file belongs to
    another run (the message names what differs) or is not a checkpoint.
    """
    if not os.path.exists(path):
        return 0, None, None
    stored, arrays = _read(path)
    # Round-trip through JSON so that both sides compare as stored (inf, floats, lists).
    expected = json.loads(json.dumps(ident))
    if stored != expected:
        diff = sorted(k for k in set(stored) | set(expected) if stored.get(k) != expected.get(k))
        details = "; ".join(f"{k}: checkpoint has {stored.get(k)!r}, this run {expected.get(k)!r}"
                            for k in diff)
        raise ValueError(f"checkpoint: {os.fspath(path)} belongs to a different run ({details}); "
                         "give another path or the same arguments")
    done = int(arrays["next_chunk"])
    if not 0 <= done <= chunks:
        raise ValueError(f"checkpoint: {os.fspath(path)} claims {done} of {chunks} chunks")
    if done == 0:
        return 0, None, None
    return done, _moments(arrays, "times"), _moments(arrays, "stop")


def save(path, ident: Dict[str, Any], next_chunk: int, times_acc, stop_acc) -> None:
    """Atomically replace the checkpoint with the merge of chunks 0..next_chunk-1."""
    path = os.fspath(path)
    folder = os.path.dirname(os.path.abspath(path))
    arrays = {"identity": np.array(json.dumps(ident)), "next_chunk": np.array(next_chunk)}
    for prefix, acc in (("times", times_acc), ("stop", stop_acc)):
        arrays[prefix + "_counts"] = acc.counts
        arrays[prefix + "_means"] = acc.means
        arrays[prefix + "_central"] = acc.central
    fd, tmp = tempfile.mkstemp(dir=folder, prefix="." + os.path.basename(path) + ".",
                               suffix=".tmp")
    try:
        with os.fdopen(fd, "wb") as f:
            np.savez(f, **arrays)
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, path)
    except BaseException:
        try:
            os.unlink(tmp)
        except OSError:
            pass
        raise
    # Make the rename itself durable.
    try:
        dir_fd = os.open(folder, os.O_RDONLY)
    except OSError:  # pragma: no cover - platforms without directory fds
        return
    try:
        os.fsync(dir_fd)
    except OSError:  # pragma: no cover
        pass
    finally:
        os.close(dir_fd)
