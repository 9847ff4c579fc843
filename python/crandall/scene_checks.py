"""The checks a :class:`crandall.Scene` runs on its values when made: numbers, the intensity's
schedule and envelope, the noise pieces, the output times, the observables, and the scaling
that holds when the scene has one."""

from __future__ import annotations

import math
import numbers
from typing import Mapping, Optional, Sequence

import numpy as np

from ._lazy import lazy_module
from .errors import ParameterError
from .quantities import OBSERVABLES
from .units import Scaling

#: Smooth envelopes (scipy's quadrature): loaded when a scene is given one.
envelopes = lazy_module("crandall.envelopes")


def _number(name: str, value, *, positive: bool = False, allow_inf: bool = False,
            signed: bool = False) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise ParameterError(name, f"{name} must be a real number, got {value!r}")
    value = float(value)
    if math.isnan(value):
        raise ParameterError(name, f"{name} must not be NaN")
    if math.isinf(value) and not (allow_inf and value > 0):
        raise ParameterError(name, f"{name} must be finite, got {value!r}")
    if (value < 0 and not signed) or (positive and value == 0):
        raise ParameterError(name, f"{name} must be {'> 0' if positive else '>= 0'}, got {value!r}")
    return value


def _schedule(h, t0, h_name: str, t0_name: str):
    """(h, t0) as given: two numbers (one intensity until t0; t0 may be inf), or two
    sequences of the same length (piece i acts on [t0[i-1], t0[i]) with intensity h[i], no
    noise after the last t0). Returns (intensities, ends) as tuples of floats, and whether
    the schedule was given as sequences."""
    seq_h = isinstance(h, (list, tuple, np.ndarray))
    seq_t = isinstance(t0, (list, tuple, np.ndarray))
    if not seq_h and not seq_t:
        return (_number(h_name, h),), (_number(t0_name, t0, allow_inf=True),), False
    if not (seq_h and seq_t):
        raise ParameterError(f"{h_name}, {t0_name}",
                             f"{h_name}, {t0_name}: give both as numbers, or both as sequences "
                             "of the same length (a piecewise intensity)")
    hs, ts = list(np.asarray(h, dtype=object).ravel()), list(np.asarray(t0, dtype=object).ravel())
    if len(hs) != len(ts) or not hs:
        raise ParameterError(f"{h_name}, {t0_name}",
                             f"{h_name}, {t0_name}: a piecewise intensity needs as many "
                             f"intensities as ends, at least one (got {len(hs)} and {len(ts)})")
    hs = [_number(f"{h_name}[{i}]", v) for i, v in enumerate(hs)]
    ts = [_number(f"{t0_name}[{i}]", v) for i, v in enumerate(ts)]
    for i, t in enumerate(ts):
        if t <= (ts[i - 1] if i else 0.0):
            raise ParameterError(t0_name, f"{t0_name}: the pieces' ends must be > 0 and strictly "
                                          f"increasing, got {t0_name}[{i}] = {t!r}")
    return tuple(hs), tuple(ts), True


def _envelope(envelope, h, t0):
    """The scene's envelope (an Envelope, or its plain data), None without one; refuses one
    given together with h or t0."""
    if envelope is None:
        return None
    if h is not None or t0 is not None:
        raise ParameterError("envelope", "envelope: give either h and t0 or envelope, not both "
                                         "(the envelope gives the pieces)")
    if isinstance(envelope, envelopes.Envelope):
        return envelope
    if isinstance(envelope, Mapping):
        try:
            return envelopes.Envelope.from_dict(envelope)
        except ValueError as exc:
            raise ParameterError("envelope", str(exc)) from None
    raise ParameterError("envelope", f"envelope must be a crandall.envelopes.Envelope or its "
                                     f"plain data, got {envelope!r}")


def _noise_pieces(pieces, noise: float):
    """The pieces the noise acts on, and the time it ends (the scene's ``t0``): pauses after
    the last piece of nonzero intensity are the coast after the switch-off, so they are
    dropped and the noise ends with that piece (a body that stops in a final pause is then
    located exactly there, not at the pause's end); with no noise at all it ends at 0. What
    is left of one piece at the reference intensity ``noise`` is the one-intensity scene
    (pieces None), with its bits and its closed forms. The scene's plain data keep the
    schedule as given."""
    last = max((i for i, (_, n) in enumerate(pieces) if n > 0), default=-1)
    kept = tuple(pieces[:last + 1])
    end = kept[-1][0] if kept else 0.0
    if not kept or (len(kept) == 1 and kept[0][1] == noise):
        return None, end
    return kept, end


def _check_real(items) -> None:
    for i, v in enumerate(items):
        if isinstance(v, (list, tuple, np.ndarray)):
            continue  # nested: refused later as not one-dimensional
        if isinstance(v, (bool, np.bool_)) or not isinstance(v, numbers.Real):
            kind = ("booleans" if isinstance(v, (bool, np.bool_)) else
                    "complex numbers" if isinstance(v, numbers.Complex) else
                    "strings" if isinstance(v, (str, bytes)) else type(v).__name__)
            raise ParameterError("times", f"times must be real numbers, got {kind} (times[{i}] = {v!r})")


def _times(times, t0: float, observe: Sequence[str]) -> np.ndarray:
    if times is None:
        times = []
    if isinstance(times, (str, bytes)):
        raise ParameterError("times", f"times must be a sequence of numbers, got a string {times!r}")
    if not isinstance(times, np.ndarray):
        # Element by element: NumPy would turn [True, 2.0] into [1.0, 2.0] silently.
        try:
            times = list(times)  # also takes a generator once
        except TypeError:
            times = [times]
        _check_real(times)
    try:
        raw = np.asarray(times)
    except (TypeError, ValueError) as exc:
        raise ParameterError("times", f"times must be a sequence of numbers: {exc}") from None
    if raw.dtype.kind == "O":
        _check_real(raw.ravel())  # an object array would convert "1" to 1.0
    elif raw.dtype.kind not in "iuf":
        what = {"b": "booleans", "c": "complex numbers", "U": "strings", "S": "bytes",
                "M": "datetimes", "m": "timedeltas"}.get(raw.dtype.kind, str(raw.dtype))
        raise ParameterError("times", f"times must be real numbers, got {what}")
    try:
        arr = np.array(np.atleast_1d(raw), dtype=float, copy=True)
    except (TypeError, ValueError) as exc:
        raise ParameterError("times", f"times must be a sequence of numbers: {exc}") from None
    # ``arr`` is a copy: the scene's times are made read-only, the caller's array stays as it was.
    if arr.ndim != 1:
        raise ParameterError("times", f"times must be one-dimensional, got shape {arr.shape}")
    if np.isnan(arr).any():
        raise ParameterError("times", "times must not contain NaN")
    if not np.isfinite(arr).all():
        raise ParameterError("times", "times must be finite")
    if (arr < 0).any():
        raise ParameterError("times", f"times must be >= 0, got {arr[arr < 0][0]!r}")
    if arr.size > 1 and not (np.diff(arr) > 0).all():
        raise ParameterError("times", "times must be strictly increasing (sorted, no repeats)")
    if arr.size == 0 and tuple(observe) != ("stop",):
        raise ParameterError("times", "times must not be empty (only a scene observing just 'stop' may omit them)")
    return arr


def _observe(observe) -> tuple:
    if isinstance(observe, str):
        observe = (observe,)
    if isinstance(observe, (bytes, bytearray, dict)):
        raise ParameterError("observe", f"observe must be a name or a list of names, got {observe!r}")
    try:
        names = list(observe)
    except TypeError:
        raise ParameterError("observe", f"observe must be a name or a list of names, got {observe!r}") from None
    for n in names:
        if not isinstance(n, str):
            raise ParameterError("observe", f"observe: names must be strings, got {n!r}")
    unknown = [n for n in names if n not in OBSERVABLES]
    if unknown:
        raise ParameterError("observe", 
            f"observe: unknown observable {unknown[0]!r}; choose from {', '.join(OBSERVABLES)}"
        )
    if not names:
        raise ParameterError("observe", "observe must name at least one observable")
    if "residual" in names and not {"stop", "displacement"} <= set(names):
        raise ParameterError("observe", "observe: 'residual' (the magnitude of the displacement "
                                        "at the stop) needs 'stop' and 'displacement'")
    return tuple(n for n in OBSERVABLES if n in names)


def _scaling(mu: float, h: float, g: float) -> Optional[Scaling]:
    if mu == 0 or h == 0:
        return None
    try:
        return Scaling(mu, h, g)
    except ValueError:
        # Scales beyond doubles (e.g. mu = 1e-300, h = 1: a time scale of 1e598 s). The scene
        # is still simulated, in its own units; only the scaled view is unavailable.
        return None
