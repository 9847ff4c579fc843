"""exp, log, log1p, log erfc and what the tail estimators build from them (logaddexp, tanh,
log cosh, the sign-drift velocity's log transition density), with the same bits on every CPU.

NumPy's ufuncs dispatch SIMD kernels by CPU (AVX-512F float64 exp and log, for one), and libm
picks its code by CPU too (glibc's exp and log1p with or without FMA), so their last bit can
differ between machines, and a tail estimate's with it. These call the core's own functions
(``_core.det_exp`` and the like: cpp/include/crandall/detfunc.hpp, fdlibm's algorithms with
+, -, *, / only), and otherwise only NumPy's +, -, *, /, sqrt, abs, max, min, copysign and
where, all exact or correctly rounded. Accuracy (cpp/tests/test_detfunc.cpp against long
double, tests/test_tail_detmath.py against mpmath): exp, log and log1p within 0.89 ulp.
"""

from __future__ import annotations

import numpy as np

from .. import _core


def exp(x) -> np.ndarray:
    """exp(x) elementwise (float64; a scalar gives a 0-d array)."""
    return _core.det_exp(x)


def log(x) -> np.ndarray:
    """log(x) elementwise; -inf at 0, ValueError below."""
    return _core.det_log(x)


def log1p(x) -> np.ndarray:
    """log(1 + x) elementwise; -inf at -1, ValueError below."""
    return _core.det_log1p(x)


def log_erfc(x) -> np.ndarray:
    """log(erfc(x)) elementwise, without underflow for large x."""
    return _core.det_log_erfc(x)


def scalar(f, x) -> float:
    """f(x) for one number, as a float (a constant's: math.log(DEFENSIVE) and the like)."""
    return float(f(float(x)))


#: log 2.
LN2 = scalar(log, 2.0)


def logaddexp(a, b) -> np.ndarray:
    """log(exp(a) + exp(b)) elementwise, as NumPy's logaddexp computes it: max + log1p(exp(-|a
    - b|)), max + log 2 where a == b (both infinite included)."""
    a, b = np.broadcast_arrays(np.asarray(a, dtype=float), np.asarray(b, dtype=float))
    hi, lo = np.maximum(a, b), np.minimum(a, b)
    with np.errstate(invalid="ignore"):
        d = lo - hi  # <= 0; NaN where both are the same infinity (replaced below)
    out = hi + log1p(exp(np.where(a == b, 0.0, d)))
    return np.where(a == b, hi + LN2, out)


def logaddexp_reduce(a) -> np.ndarray:
    """logaddexp over the first axis of ``a``, folded in order from the first row."""
    a = np.asarray(a, dtype=float)
    out = a[0]
    for row in a[1:]:
        out = logaddexp(out, row)
    return out


def tanh(x) -> np.ndarray:
    """tanh(x) = sign(x) (1 - e) / (1 + e), e = exp(-2 |x|): within a few ulps of 1 in absolute
    terms (its relative error grows as |x| falls below 1/2, where 1 - e cancels)."""
    x = np.asarray(x, dtype=float)
    e = exp(-2.0 * np.abs(x))
    return np.copysign((1.0 - e) / (1.0 + e), x)


def log_cosh(x) -> np.ndarray:
    """log(cosh(x)) = |x| + log1p(exp(-2 |x|)) - log 2."""
    ax = np.abs(np.asarray(x, dtype=float))
    return ax + log1p(exp(-2.0 * ax)) - LN2


def log_transition_density(x, x0, t, c, sigma) -> np.ndarray:
    """crandall.analytic.schedule.log_transition_density (the sign-drift diffusion's log
    propagator, its formula there) with these functions: log 2 + log_ndtr(-z sqrt 2) there is
    log erfc(z) here."""
    x, x0 = np.asarray(x, dtype=float), np.asarray(x0, dtype=float)
    s2 = sigma * sigma
    ax, a0 = np.abs(x), np.abs(x0)
    first = (-0.5 * log(2 * np.pi * s2 * t) - (x - x0) ** 2 / (2 * s2 * t)
             - c * (ax - a0) / s2 - c * c * t / (2 * s2))
    if c == 0:
        return first
    z = (ax + a0 - c * t) / np.sqrt(2 * s2 * t)
    second = log(abs(c) / (2 * s2)) - 2 * c * ax / s2 + log_erfc(z)
    if c > 0:
        return logaddexp(first, second)
    return first + log1p(-exp(second - first))
