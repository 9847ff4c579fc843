"""Scene files (TOML): reading and checking a ``[scene]`` and a ``[run]`` table.

:meth:`crandall.Scene.from_toml` builds the scene from what :func:`read` returns; every error
names the file and the key (``scene.times.step``, ``run.dt``).
"""

from __future__ import annotations

import math
import os
import sys
from dataclasses import dataclass
from typing import Any, Dict, Tuple

import numpy as np

from .methods import MAX_EVENT_DEPTH, METHODS, MIN_EVENT_DEPTH

__all__ = ["read", "locate", "shipped", "title", "SHIPPED_FOLDER", "SceneFile", "RUN_SETTINGS", "MAX_RANGE_TIMES", "SI_KEYS", "SCALED_KEYS",
           "COMMON_KEYS"]

if sys.version_info >= (3, 11):
    import tomllib as _toml
else:  # pragma: no cover - Python < 3.11
    import tomli as _toml

#: Keys of a scene file's [run] table, as ``simulate`` takes them.
RUN_SETTINGS = ("paths", "seed", "method", "dt", "event_depth")

#: Most output times a scene file's range may give (either form, {start, stop, num} or
#: {start, stop, step}); checked before the times are built.
MAX_RANGE_TIMES = 10_000_000

#: A scene's parameters besides times and observe, in SI and in scaled units.
SI_KEYS = ("mu", "h", "t0", "envelope", "g", "mass", "excitation", "mu_static")
SCALED_KEYS = ("tau0", "h")
#: Keys of either kind of scene: the initial state (velocity v0 and displacement u0, in the
#: scene's units), the output times and what to observe.
COMMON_KEYS = ("v0", "u0", "times", "observe", "distributions", "bins")
_RANGE_KEYS = ("start", "stop", "num", "step")


#: The scene files shipped with crandall (package data), each reachable by its name (the
#: file's stem): ``Scene.from_toml("crate")``, ``crandall run crate``; ``crandall scenes``
#: lists them.
SHIPPED_FOLDER = os.path.join(os.path.dirname(os.path.abspath(__file__)), "scenes")


def shipped() -> Dict[str, str]:
    """The shipped scene files: name -> path, sorted by name."""
    try:
        names = os.listdir(SHIPPED_FOLDER)
    except OSError:  # pragma: no cover - an installation without its package data
        return {}
    return {n[:-5]: os.path.join(SHIPPED_FOLDER, n) for n in sorted(names) if n.endswith(".toml")}


def locate(path) -> str:
    """The scene file that ``path`` names: the file itself when it exists; else, for a bare
    name (no folder; ``.toml`` optional), the shipped scene of that name. A path that is
    neither is returned as it is (reading it then fails naming it)."""
    text = os.fspath(path)
    if os.path.isfile(text) or os.path.dirname(text):
        return text
    name = text[:-5] if text.endswith(".toml") else text
    return shipped().get(name, text)


def title(path) -> str:
    """A scene file's ``title`` ("" if it has none), read as :func:`read` reads the file."""
    value = _load(path).get("title", "")
    return value if isinstance(value, str) else ""


def _load(path) -> Dict[str, Any]:
    try:
        with open(path, "rb") as f:
            return _toml.load(f)
    except OSError as exc:
        hint = ""
        if not os.path.dirname(os.fspath(path)):
            hint = ("; it is not the name of a shipped scene either (shipped: "
                    f"{', '.join(shipped()) or 'none'}; `crandall scenes` lists them)")
        raise ValueError(f"{os.fspath(path)}: cannot read the scene file: {exc.strerror}"
                         f"{hint}") from None
    except _toml.TOMLDecodeError as exc:
        raise ValueError(f"{os.fspath(path)}: not valid TOML: {exc}") from None


def _file_error(path, key: str, what: str) -> ValueError:
    return ValueError(f"{os.fspath(path)}: {key}: {what}")


def _real(path, key, value) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise _file_error(path, key, f"must be a number, got {value!r}")
    return float(value)


def _times_from_file(path, value):
    key = "scene.times"
    if isinstance(value, list):
        return [_real(path, f"{key}[{i}]", v) for i, v in enumerate(value)]
    if not isinstance(value, dict):
        raise _file_error(path, key, "must be a list of times or a table {start, stop, num} "
                                     f"or {{start, stop, step}}, got {value!r}")
    unknown = sorted(set(value) - set(_RANGE_KEYS))
    if unknown:
        raise _file_error(path, f"{key}.{unknown[0]}",
                          f"unknown key; a range has {', '.join(_RANGE_KEYS)}")
    for k in ("start", "stop"):
        if k not in value:
            raise _file_error(path, f"{key}.{k}", "missing (a range needs start and stop)")
    start = _real(path, f"{key}.start", value["start"])
    stop = _real(path, f"{key}.stop", value["stop"])
    if not math.isfinite(start) or not math.isfinite(stop) or stop < start:
        raise _file_error(path, f"{key}.stop",
                          f"need finite start <= stop, got start={start!r}, stop={stop!r}")
    if ("num" in value) == ("step" in value):
        raise _file_error(path, key, "a range needs exactly one of num or step")
    if "num" in value:
        num = value["num"]
        if isinstance(num, bool) or not isinstance(num, int) or num < 1:
            raise _file_error(path, f"{key}.num", f"must be an integer >= 1, got {num!r}")
        if num == 1 and stop != start:
            raise _file_error(path, f"{key}.num", "num = 1 needs start == stop")
        if num > MAX_RANGE_TIMES:
            raise _file_error(path, f"{key}.num",
                              f"gives {num} times; at most {MAX_RANGE_TIMES} are allowed")
        return np.linspace(start, stop, num).tolist()
    step = _real(path, f"{key}.step", value["step"])
    if not math.isfinite(step) or step <= 0:
        raise _file_error(path, f"{key}.step", f"must be finite and > 0, got {step!r}")
    # The stop is included when it lies on the grid (up to rounding).
    count = (stop - start) / step * (1 + 1e-12) + 1e-9 + 1.0
    if not count <= MAX_RANGE_TIMES:  # compared as a float: (stop - start) / step may be inf
        raise _file_error(path, f"{key}.step",
                          f"gives {count:.3g} times; at most {MAX_RANGE_TIMES} are allowed")
    n = int(math.floor(count))
    return (start + step * np.arange(n)).tolist()


@dataclass(frozen=True)
class SceneFile:
    """What a scene file holds, checked as far as it can be without building the scene."""

    path: str
    #: "SI" or "scaled".
    units: str
    #: Keyword arguments of ``Scene`` (SI) or ``Scene.scaled``.
    kwargs: Dict[str, Any]
    #: The keys the [scene] table may have for these units.
    allowed: Tuple[str, ...]
    #: The [run] table as written (checked by :meth:`run_settings`).
    run: Any

    def error_of(self, exc: ValueError) -> ValueError:
        """The scene constructor's error, placed at the key it came from."""
        name = getattr(exc, "name", None)
        key = f"scene.{name}" if name in self.allowed else "scene"
        return _file_error(self.path, key, str(exc))

    def run_settings(self) -> Dict[str, Any]:
        """The [run] table checked (keys among ``RUN_SETTINGS``)."""
        path, run = self.path, self.run
        if not isinstance(run, dict):
            raise _file_error(path, "run", "must be a table")
        settings: Dict[str, Any] = {}
        for k, v in run.items():
            if k not in RUN_SETTINGS:
                raise _file_error(path, f"run.{k}",
                                  f"unknown key; allowed: {', '.join(RUN_SETTINGS)}")
            if k in ("paths", "seed"):
                low = 1 if k == "paths" else 0
                if isinstance(v, bool) or not isinstance(v, int) or v < low or v >= 1 << 64:
                    raise _file_error(path, f"run.{k}", f"must be an integer >= {low}, got {v!r}")
            elif k == "dt":
                v = _real(path, "run.dt", v)
                if not math.isfinite(v) or v <= 0:
                    raise _file_error(path, "run.dt", f"must be finite and > 0, got {v!r}")
            elif k == "method":
                if v not in METHODS:
                    raise _file_error(path, "run.method", f"must be one of {', '.join(METHODS)}, "
                                                          f"got {v!r}")
            elif k == "event_depth":
                # Its range here; that the scene's excitation has an event search, at the run
                # (spec.check_event_depth), as for the argument.
                if (isinstance(v, bool) or not isinstance(v, int)
                        or not MIN_EVENT_DEPTH <= v <= MAX_EVENT_DEPTH):
                    raise _file_error(path, "run.event_depth", f"must be an integer from "
                                      f"{MIN_EVENT_DEPTH} to {MAX_EVENT_DEPTH}, got {v!r}")
            settings[k] = v
        return settings


def read(path) -> SceneFile:
    """Read and check a scene file (see :meth:`crandall.Scene.from_toml` for its form).

    Raises
    ------
    ValueError
        If the file cannot be read or parsed, or a key is missing, unknown or has a bad
        value: the message names the file, the key and what is wrong.
    """
    data = _load(path)
    unknown = sorted(set(data) - {"title", "description", "scene", "run"})
    if unknown:
        raise _file_error(path, unknown[0], "unknown key; a scene file has title, description, "
                                            "[scene] and [run]")
    if "scene" not in data or not isinstance(data["scene"], dict):
        raise _file_error(path, "scene", "missing: a scene file needs a [scene] table")
    sc = dict(data["scene"])
    units = sc.pop("units", "SI")
    if units not in ("SI", "scaled"):
        raise _file_error(path, "scene.units", f"must be 'SI' or 'scaled', got {units!r}")
    allowed = (SI_KEYS if units == "SI" else SCALED_KEYS) + COMMON_KEYS
    for k in sc:
        if k not in allowed:
            other = "SI" if units == "scaled" else "scaled"
            hint = (f" (it belongs to units = '{other}')"
                    if k in (SI_KEYS if units == "scaled" else SCALED_KEYS) else "")
            raise _file_error(path, f"scene.{k}", f"unknown key for units = '{units}'{hint}; "
                                                  f"allowed: {', '.join(allowed)}")
    required = ("mu", "h", "t0", "times") if units == "SI" else ("tau0", "times")
    if units == "SI" and "envelope" in sc:
        # A smooth envelope in place of h and t0 (crandall.envelopes): the scene checks it.
        required = ("mu", "envelope", "times")
    elif units == "SI" and isinstance(sc.get("excitation"), dict) and "h" in sc["excitation"]:
        # A filtered excitation given with its own intensity (crandall.excitation).
        required = ("mu", "t0", "times")
    for k in required:
        if k not in sc:
            raise _file_error(path, f"scene.{k}", "missing")
    kwargs: Dict[str, Any] = {}
    for k, v in sc.items():
        if k == "times":
            kwargs[k] = _times_from_file(path, v)
        elif k == "observe":
            if isinstance(v, str):
                v = [v]
            if not isinstance(v, list) or not all(isinstance(x, str) for x in v):
                raise _file_error(path, "scene.observe", f"must be a list of names, got {v!r}")
            kwargs[k] = v
        elif k == "distributions":
            if isinstance(v, str):
                v = [v]
            if not (isinstance(v, bool) or (isinstance(v, list)
                                            and all(isinstance(x, str) for x in v))):
                raise _file_error(path, "scene.distributions",
                                  f"must be true, false or a list of names, got {v!r}")
            kwargs[k] = v
        elif k == "excitation":
            if not isinstance(v, dict):
                raise _file_error(path, "scene.excitation", "must be a table {kind, its "
                                                            f"parameters}}, got {v!r}")
            kwargs[k] = v
        elif k == "envelope":
            if not isinstance(v, dict):
                raise _file_error(path, "scene.envelope", "must be a table {kind, its "
                                                          f"parameters, pieces}}, got {v!r}")
            kwargs[k] = v
        elif k == "bins":
            # Checked by the scene (ints, lists of edges, a table of them); errors come back
            # named scene.bins.
            kwargs[k] = v
        elif k in ("h", "t0", "tau0") and isinstance(v, list):
            # A piecewise intensity: the intensities and the pieces' ends.
            kwargs[k] = [_real(path, f"scene.{k}[{i}]", x) for i, x in enumerate(v)]
        else:
            kwargs[k] = _real(path, f"scene.{k}", v)
    return SceneFile(os.fspath(path), units, kwargs, allowed, data.get("run", {}))
