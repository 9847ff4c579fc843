"""Input validation shared by every function of crandall.analytic: each error is a ValueError
that names the parameter.

One rule for every numeric argument: a real number (int, float, a numpy integer or floating
scalar, or an array / nested sequence of them). Strings, bytes, bools (numpy bools too) and
complex numbers are refused rather than coerced: ``float("1.0")`` or ``float(True)`` would
silently turn a caller's mistake into a number. Only the Laplace variable ``p`` may be complex.
"""

from __future__ import annotations

import numbers
from typing import Union

import numpy as np
import numpy.typing as npt
from ..errors import ParameterError

#: What the closed forms take: a number or an array of numbers (evaluated elementwise).
ArrayLike = npt.ArrayLike
#: What they return: a float for a scalar input, an array of the inputs' shape otherwise.
Values = Union[float, np.ndarray]

__all__ = [
    "as_flag",
    "as_order",
    "as_real",
    "as_tau0",
    "as_time",
    "only_before_switch_off",
    "scalar_or_array",
]

_REFUSED = (str, bytes, bytearray, bool, np.bool_)


def _what(value):
    return type(value).__name__


def _refuse(name, value, kind):
    return ParameterError(name, f"{name} must be {kind}, got {_what(value)} {value!r:.80}")


def _scan(value, name, kind, complex_ok):
    """Refuse bools, strings and (unless complex_ok) complex numbers inside a sequence, where
    numpy would have converted them silently (np.asarray([True, 2]) is an integer array)."""
    stack = [value]
    while stack:
        v = stack.pop()
        if isinstance(v, (list, tuple)):
            stack.extend(v)
        elif isinstance(v, np.ndarray):
            continue  # checked by dtype below
        elif isinstance(v, _REFUSED) or (
            not complex_ok and isinstance(v, (complex, np.complexfloating))
        ):
            raise _refuse(name, v, kind)


def as_real(value, name, *, complex_ok=False):
    """``value`` as a float (or complex, if complex_ok) ndarray; no range check.

    Refuses str, bytes, bool, complex (unless complex_ok), None, ragged or non-numeric
    sequences and numbers beyond the range of a double, with a ValueError naming ``name``.
    """
    kind = "a real number or an array of real numbers"
    if complex_ok:
        kind = "a number or an array of numbers"
    if isinstance(value, _REFUSED) or value is None:
        raise _refuse(name, value, kind)
    if not complex_ok and isinstance(value, (complex, np.complexfloating)):
        raise _refuse(name, value, kind)
    if isinstance(value, (list, tuple)):
        _scan(value, name, kind, complex_ok)
    try:
        a = np.asarray(value)
    except (TypeError, ValueError, OverflowError) as exc:
        raise ParameterError(name, f"{name} must be {kind}") from exc
    allowed = "iuf" + ("c" if complex_ok else "")
    if a.dtype.kind == "O":
        # Python ints beyond 64 bits, fractions, decimals: real numbers numpy keeps as objects.
        for v in a.flat:
            if isinstance(v, _REFUSED) or not isinstance(
                v, numbers.Complex if complex_ok else numbers.Real
            ):
                raise _refuse(name, v, kind)
        try:
            a = a.astype(complex if complex_ok else float)
        except OverflowError as exc:
            raise ParameterError(name, f"{name} is beyond the range of a double") from exc
        except (TypeError, ValueError) as exc:
            raise ParameterError(name, f"{name} must be {kind}") from exc
    elif a.dtype.kind not in allowed:
        raise ParameterError(name, f"{name} must be {kind}, got an array of dtype {a.dtype}")
    return a.astype(complex if a.dtype.kind == "c" else float)


def as_time(value, name="tau", *, allow_zero=True):
    """A float array of finite scaled times >= 0 (> 0 if not allow_zero)."""
    t = as_real(value, name)
    if np.any(np.isnan(t)):
        raise ParameterError(name, f"{name} must not be NaN")
    if np.any(np.isinf(t)):
        raise ParameterError(name, f"{name} must be finite")
    if allow_zero:
        if np.any(t < 0):
            raise ParameterError(name, f"{name} must be >= 0, got {float(t.min())!r}")
    elif np.any(t <= 0):
        raise ParameterError(name, f"{name} must be > 0, got {float(t.min())!r}")
    return t


def as_tau0(value, name="tau0"):
    """Switch-off time: one real number >= 0, or +inf (noise never switched off)."""
    t0 = as_real(value, name)
    if t0.size != 1:
        raise ParameterError(name, f"{name} must be a single number (or numpy.inf), got shape "
                                   f"{t0.shape}")
    t0 = float(t0.reshape(()))
    if np.isnan(t0) or t0 < 0:
        raise ParameterError(name, f"{name} must be >= 0 (or numpy.inf), got {t0!r}")
    return t0


def as_flag(value, name):
    """A Python or numpy bool (no truthiness of other objects)."""
    if not isinstance(value, (bool, np.bool_)):
        raise ParameterError(name, f"{name} must be True or False, got {_what(value)} "
                                   f"{value!r:.80}")
    return bool(value)


def as_order(value, name, maximum):
    """A non-negative integer <= maximum (bools refused)."""
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, np.integer)):
        raise ParameterError(name, f"{name} must be a non-negative integer, got {_what(value)} "
                                   f"{value!r:.80}")
    if value < 0:
        raise ParameterError(name, f"{name} must be a non-negative integer, got {value!r}")
    if value > maximum:
        raise ParameterError(name, f"{name} must be <= {maximum}, got {value!r}")
    return int(value)


def only_before_switch_off(tau, tau0, func, tau_name="tau"):
    if np.any(tau > tau0):
        raise ParameterError(tau_name, 
            f"{tau_name} > tau0: {func} is only known in closed form for {tau_name} <= tau0 "
            f"(noise on); got max {tau_name} {float(np.max(tau))!r} > tau0 = {tau0!r}"
        )


def scalar_or_array(out):
    out = np.asarray(out, dtype=float)
    return out[()] if out.ndim == 0 else out
