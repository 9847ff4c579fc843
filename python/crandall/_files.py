"""Files crandall writes and reads back: atomic replacement, early checks, stored accumulators.

Every file crandall keeps (a checkpoint, a saved result, the command line's table, figures and
file list) is replaced atomically: written to a temporary file in the same folder, flushed to
disk (fsync), renamed over the old one (``os.replace``), and the folder itself fsynced so that
the rename survives a power cut. A kill at any moment leaves the previous file or the new one,
never a torn one. An error on the way names the file, whatever failed (a full disk).

Where a run will write is checked before it starts, so that a bad path fails in a second, not
after the simulation. What comes back from a file is checked field by field, so that a damaged
or edited file is a ValueError naming the file and the field, never a wrong number.
"""

from __future__ import annotations

import errno
import math
import os
import secrets
import tempfile
from typing import Callable, Dict, Optional

import numpy as np

from . import _core
from .errors import ParameterError
from .methods import EXTRAPOLATING_METHODS

__all__ = ["write_atomic", "check_file_writable", "check_folder_writable", "check_moments"]

_EXPONENTS = [tuple(e) for e in _core.monomial_exponents()]
# Central sums of (x - mean)^a (y - mean)^b (z - mean)^c with a, b, c all even are sums of
# non-negative terms.
_EVEN = [i for i, e in enumerate(_EXPONENTS) if all(p % 2 == 0 for p in e)]


def _fsync_folder(folder: str) -> None:
    try:
        fd = os.open(folder, os.O_RDONLY)
    except OSError:  # pragma: no cover - platforms without directory fds
        return
    try:
        os.fsync(fd)
    except OSError:  # pragma: no cover - some file systems refuse fsync on a directory
        pass
    finally:
        os.close(fd)


#: Flags of the temporary file: created, never an existing file or a link's target, not inherited
#: by child processes.
_CREATE = (os.O_WRONLY | os.O_CREAT | os.O_EXCL | getattr(os, "O_NOFOLLOW", 0)
           | getattr(os, "O_CLOEXEC", 0) | getattr(os, "O_BINARY", 0))


def _create_temporary(folder: str, stem: str):
    """A new file ``.STEM.XXXXXXXX.tmp`` in ``folder``, open for writing: (fd, its path).

    Created with mode 0666, so that the kernel applies the umask (and a folder's default ACL)
    as it does for open(): the file has its final mode from the start, and the umask is never
    read (reading it means setting it, which changes it for every thread for an instant).
    """
    for _ in range(100):
        tmp = os.path.join(folder, f".{stem}.{secrets.token_hex(4)}.tmp")
        try:
            return os.open(tmp, _CREATE, 0o666), tmp
        except FileExistsError:
            continue
    raise FileExistsError(errno.EEXIST, "no free temporary file name", folder)  # pragma: no cover


def _naming(exc: OSError, path: str) -> OSError:
    """``exc`` naming ``path``: a write or an fsync that fails (a full disk) knows only a
    descriptor, and a failed rename names the temporary file."""
    if exc.filename == path and exc.filename2 is None:
        return exc
    if exc.errno is None:
        return OSError(f"{exc}: {path}")
    # OSError(errno, ...) is the errno's own subclass again (PermissionError for EACCES).
    return OSError(exc.errno, exc.strerror or os.strerror(exc.errno), path)


def write_atomic(path, write: Callable) -> None:
    """Replace ``path`` atomically by what ``write(f)`` writes to a binary file ``f``.

    The file gets the mode open() would give it (0666 less the umask). An OSError on the way
    (a full disk, an I/O error) names ``path``; the previous file is left as it was and the
    temporary one removed.

    Parameters
    ----------
    path : str or os.PathLike
        The file to create or replace.
    write : callable
        Called once with a binary file open for writing.
    """
    path = os.fspath(path)
    folder = os.path.dirname(os.path.abspath(path))
    tmp = None
    try:
        fd, tmp = _create_temporary(folder, os.path.basename(path))
        with os.fdopen(fd, "wb") as f:
            write(f)
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, path)
    except BaseException as exc:
        if tmp is not None:
            try:
                os.unlink(tmp)
            except OSError:
                pass
        if isinstance(exc, OSError):
            named = _naming(exc, path)
            if named is not exc:
                raise named from exc
        raise
    _fsync_folder(folder)


def _probe(folder: str, name: str, shown: str) -> None:
    """Create and remove a temporary file in ``folder``: the only reliable test of writing
    (``os.access`` ignores read-only mounts and answers yes to root)."""
    try:
        fd, tmp = tempfile.mkstemp(dir=folder, prefix=".crandall-probe-", suffix=".tmp")
    except OSError as exc:
        raise ParameterError(name, f"{name}: cannot write in {shown} "
                                   f"({exc.strerror or exc})") from None
    os.close(fd)
    os.unlink(tmp)


def _path_text(path, name: str, kind: str) -> str:
    """``path`` as a non-blank str (bytes paths refused), or a ParameterError naming ``name``."""
    if not isinstance(path, (str, os.PathLike)):
        raise ParameterError(name, f"{name} must be a path, got {path!r}")
    text = os.fspath(path)
    if not isinstance(text, str) or not text.strip():
        raise ParameterError(name, f"{name} must be a {kind} path, got {text!r}")
    return text


def check_file_writable(path, name: str) -> str:
    """Check, creating nothing, that the file ``path`` can be written (created or replaced).

    Parameters
    ----------
    path : str or os.PathLike
        The file.
    name : str
        The parameter the path came from, for the messages.

    Returns
    -------
    str
        The path as a string.

    Raises
    ------
    ValueError
        If ``path`` is not a path, is empty, is a folder, or its folder is missing or not
        writable.
    """
    text = _path_text(path, name, "file")
    if os.path.isdir(text):
        raise ParameterError(name, f"{name}: {text} is a folder; give a file path")
    if text.endswith(os.sep):
        raise ParameterError(name, f"{name}: {text} names a folder (it ends with {os.sep}); give "
                                   "a file path")
    if os.path.exists(text) and not os.path.isfile(text):
        raise ParameterError(name, f"{name}: {text} is not a regular file")
    folder = os.path.dirname(os.path.abspath(text))
    if not os.path.isdir(folder):
        what = "is not a folder" if os.path.exists(folder) else "does not exist"
        raise ParameterError(name, f"{name}: the folder {folder} of {text} {what}")
    _probe(folder, name, f"the folder {folder} of {text}")
    return text


def check_folder_writable(path, name: str, *, create: bool = False) -> str:
    """Check that ``path`` is (or, with ``create``, can become) a writable folder.

    With ``create`` the folder and its missing parents are made; otherwise nothing is left
    behind.

    Returns
    -------
    str
        The path as a string.

    Raises
    ------
    ValueError
        If ``path`` is not a path, is empty, exists as something other than a folder, cannot be
        created, or is not writable.
    """
    text = _path_text(path, name, "folder")
    if os.path.exists(text) and not os.path.isdir(text):
        raise ParameterError(name, f"{name} must be a directory: {text} is a file")
    if os.path.isdir(text):
        _probe(text, name, text)
        return text
    # The nearest existing ancestor must be a writable folder for the rest to be made.
    parent = os.path.dirname(os.path.abspath(text))
    while not os.path.exists(parent):
        parent = os.path.dirname(parent)
    if not os.path.isdir(parent):
        raise ParameterError(name, f"{name}: cannot create {text}: {parent} is a file")
    _probe(parent, name, parent)
    if create:
        try:
            os.makedirs(text, exist_ok=True)
        except OSError as exc:
            raise ParameterError(name, f"{name}: cannot create {text} "
                                       f"({exc.strerror or exc})") from None
    return text


def check_moments(where: str, field: str, arrays: Dict[str, np.ndarray], *, slots: int,
                  paths: Optional[float], method: str, counted: str = "") -> None:
    """Check stored accumulators (``counts``, ``means``, ``central``) before trusting them.

    Parameters
    ----------
    where : str
        The file, for the messages.
    field : str
        Prefix of the three fields' names in the file (``"times_"``, ``"stop_"``, ``""``).
    arrays : dict
        ``counts``, ``means``, ``central`` (missing ones are reported).
    slots : int
        Number of slots the run's scene implies (its output times, or 1 for the stop).
    paths : float or None
        The paths every slot must hold; None: any count >= 0, the same in every slot.
    method : str
        The run's method: even central sums must be >= 0 unless it extrapolates.
    counted : str
        Where ``paths`` comes from, for the message.

    Raises
    ------
    ValueError
        Naming ``where`` and the field that is wrong.
    """
    shapes = {"counts": (slots,), "means": (slots, 3), "central": (slots, len(_EXPONENTS))}
    for key, shape in shapes.items():
        if key not in arrays:
            raise ValueError(f"{where}: {field}{key} is missing")
        a = arrays[key]
        if not isinstance(a, np.ndarray) or a.dtype.kind not in "fiu":
            raise ValueError(f"{where}: {field}{key} must be an array of numbers, got "
                             f"{getattr(a, 'dtype', type(a).__name__)}")
        if a.shape != shape:
            raise ValueError(f"{where}: {field}{key} has shape {a.shape}, expected {shape} "
                             f"({slots} slot{'s' * (slots != 1)})")
        if not np.isfinite(a).all():
            raise ValueError(f"{where}: {field}{key} holds non-finite values (NaN or inf)")
    counts = arrays["counts"].astype(float)
    central = arrays["central"].astype(float)
    if paths is not None:
        bad = np.flatnonzero(counts != paths)
        if bad.size:
            raise ValueError(f"{where}: {field}counts is {counts[bad[0]]:g} at slot {bad[0]}, "
                             f"expected the {paths:g} paths{counted}")
    elif slots and ((counts < 0).any() or (counts != counts[0]).any()
                    or counts[0] != math.floor(counts[0])):
        raise ValueError(f"{where}: {field}counts must be one whole number >= 0 for every slot")
    # The (0, 0, 0) central sum is the count itself.
    if (central[:, 0] != counts).any():
        raise ValueError(f"{where}: {field}central disagrees with {field}counts "
                         "(its first column is the count)")
    if method not in EXTRAPOLATING_METHODS and (central[:, _EVEN] < 0).any():
        raise ValueError(f"{where}: {field}central has negative even-order central sums "
                         "(sums of squares cannot be negative)")


def refuse_other_version(path, stored: Dict, expected: Dict, keys) -> None:
    """Refuse a checkpoint written with another format or random stream (``keys``: pairs of
    identity field and what it is called): numbers of two streams or two layouts must never
    be merged into one result."""
    for key, what in keys:
        if stored.get(key) != expected.get(key):
            raise ValueError(
                f"checkpoint: {os.fspath(path)} was written by crandall "
                f"{stored.get('crandall', '?')} with {what} {stored.get(key, 'unknown')!r}; "
                f"this crandall uses {what} {expected.get(key)!r}, so it cannot be continued "
                "here; remove it to start again, or resume with that version")


def refuse_other_run(path, stored: Dict, expected: Dict) -> None:
    """Refuse a checkpoint of another run, naming every identity field that differs."""
    if stored != expected:
        diff = sorted(k for k in set(stored) | set(expected)
                      if stored.get(k) != expected.get(k))
        details = "; ".join(f"{k}: checkpoint has {stored.get(k)!r}, this run "
                            f"{expected.get(k)!r}" for k in diff)
        raise ValueError(f"checkpoint: {os.fspath(path)} belongs to a different run "
                         f"({details}); give another path or the same arguments")

