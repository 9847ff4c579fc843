"""Laplace transforms of the mixed moments m_jkl = E[U1^j U2^k U3^l] (paper section "Method of
moments", eq10g-eq10n, eq10i) and their numerical inversion.

The derivation of the boundary conditions used here is written out in docs/analytic.md
("Laplace recursion").

Representation. With s = sqrt(p + 1), the denominators z^2 +- 2iz + p of eq10g factor as
(z - i mu)(z + i(s + 1)) and (z + i mu)(z - i(s + 1)) with mu = s - 1. Analyticity of F+_kl in
the upper half plane removes the pole at i mu, so F+_kl is a finite sum of powers
(z - a)^-n, a = -i(s + 1); likewise F-_kl is a finite sum of powers (z - b)^-n, b = +i(s + 1).
Each F is stored as the list of its coefficients [c_1, c_2, ...] of w^-1, w^-2, ...
(w = z - a or z - b). The same arithmetic runs on numpy complex arrays (numerical transform),
on mpmath numbers (high-precision inversion) and on sympy expressions (exact transform).
"""

from __future__ import annotations

from typing import Any

import math
from functools import lru_cache

import numpy as np

from ..errors import ParameterError
from ._check import ArrayLike, Values, as_flag, as_order, as_real, as_time

__all__ = ["laplace_moment", "moment", "signed_moment"]


class _Ctx:
    """Field operations needed by the recursion: the imaginary unit and the number 1/2."""

    def __init__(self, I, half):
        self.I = I
        self.half = half


def _deriv(c):
    """Coefficients of d/dz of sum_n c[n-1] w^-n: -n c_n w^-(n+1)."""
    return [0] + [-(n + 1) * cn for n, cn in enumerate(c)]


def _add(a, b, sign=1):
    n = max(len(a), len(b))
    out = []
    for i in range(n):
        x = a[i] if i < len(a) else 0
        y = b[i] if i < len(b) else 0
        out.append(x + sign * y if not (isinstance(y, int) and y == 0) else x)
    return out


def _eval_neg_powers(r, d):
    """sum_n r[n-1] d^-n."""
    total = 0
    dinv = 1 / d
    pw = dinv
    for rn in r:
        total = total + rn * pw
        pw = pw * dinv
    return total


def _divide(q1, q0, r, d):
    """F = N(w) / (w (w - d)) where N(w) = q1 w + q0 + sum_n r[n-1] w^-n and N(d) = 0.

    N(w)/(w - d) = sum_m q_m (w^m - d^m)/(w - d): the w^1 term gives q1, the w^0 term 0, and
    w^-n gives -sum_{i=0}^{n-1} d^(-1-i) w^(i-n). Dividing by w lowers every power by one.
    Returns coefficients of w^-1, w^-2, ... . (q0 only enters through N(d) = 0.)
    """
    nmax = len(r)
    out = [0] * (nmax + 1)
    out[0] = q1
    if nmax:
        dinv = 1 / d
        dpows = [dinv]
        for _ in range(nmax - 1):
            dpows.append(dpows[-1] * dinv)
        for n in range(1, nmax + 1):
            rn = r[n - 1]
            if isinstance(rn, int) and rn == 0:
                continue
            # w^(i-n) / w = w^-(n-i+1): index n - i in the output list (w^-1 is index 0)
            for i in range(n):
                out[n - i] = out[n - i] - rn * dpows[i]
    return out


def _table(K, L, s, ctx, sm1=None):
    """F+_kl, F-_kl for 0 <= k <= K, 0 <= l <= L, as coefficient lists, given s = sqrt(p+1)
    (and s - 1, if given: p / (s + 1) keeps its digits where s - 1 would cancel, |p| << 1).

    Also returns a = -i(s+1), b = +i(s+1).
    """
    I = ctx.I
    a = -I * (s + 1)
    b = I * (s + 1)
    mu_i = I * (s - 1 if sm1 is None else sm1)  # i mu; zero of z^2 + 2iz + p, upper half plane
    dp = mu_i - a  # = 2 i s, position of i mu in w = z - a
    dm = -mu_i - b  # = -2 i s, position of -i mu in v = z - b
    Fp, Fm = {}, {}
    for tot in range(K + L + 1):
        for k in range(max(0, tot - L), min(K, tot) + 1):
            l = tot - k
            rp, rm = [], []  # negative-power parts of the numerators (w^-1 ... )
            if k:
                rp = _add(rp, [k * c for c in _deriv(Fp[k - 1, l])])
                rm = _add(rm, [k * c for c in _deriv(Fm[k - 1, l])])
            if l:
                rp = _add(rp, [l * c for c in _deriv(Fp[k, l - 1])])
                rm = _add(rm, [l * c for c in _deriv(Fm[k, l - 1])], sign=-1)
            # r[0] is the w^-1 slot (always 0: derivatives start at w^-2)
            const_p = ctx.half if tot == 0 else 0
            const_m = -ctx.half if tot == 0 else 0
            Rp = const_p + _eval_neg_powers(rp, dp)  # R+(i mu)
            Rm = const_m + _eval_neg_powers(rm, dm)  # R-(-i mu)
            # G0 + i mu G1 + R+(i mu) = 0 and G0 - i mu G1 + R-(-i mu) = 0 (eq10k, eq10n)
            G1 = (Rm - Rp) / (2 * mu_i)
            G0 = -(Rp + Rm) / 2
            # numerator in w: G0 + G1 (a + w) + const + r(w)
            Fp[k, l] = _divide(G1, G0 + G1 * a + const_p, rp, dp)
            Fm[k, l] = _divide(G1, G0 + G1 * b + const_m, rm, dm)
    return Fp, Fm, a, b


def _moment_from_table(j, k, l, Fp, Fm, a, b, ctx, signed=False):
    """eq10i: m~_jkl = i^-(j+k+l) d^j/dz^j (F+_kl - F-_kl)(0); with signed=True the sum
    F+ + F-, which is the transform of E[sign(U1) U1^j U2^k U3^l] (eq10b and the lemma
    E[sign(X) e^{izX}] = (1/(pi i)) v.p. int E(s)/(s - z) ds of the appendix)."""

    def djat0(c, pole):
        # d^j/dz^j w^-n at z = 0 (w = -pole): (-1)^j n (n+1) ... (n+j-1) (-pole)^-(n+j)
        total = 0
        x = -pole
        xinv = 1 / x
        for n, cn in enumerate(c, start=1):
            if isinstance(cn, int) and cn == 0:
                continue
            rising = 1
            for i in range(j):
                rising *= n + i
            total = total + cn * ((-1) ** j * rising) * xinv ** (n + j)
        return total

    vp = djat0(Fp[k, l], a)
    vm = djat0(Fm[k, l], b)
    v = vp + vm if signed else vp - vm
    order = j + k + l
    # 1 / i^order
    return v * (ctx.I ** ((-order) % 4))


# Cost grows fast with the order of the recursion (k + l): ~2.5 s per tau for moment() at
# k + l = 12 and minutes in sympy beyond k + l = 4 (exact=True). Orders above these bounds are
# refused rather than left to run for hours.
MAX_ORDER = 24
MAX_KL = 12
MAX_KL_EXACT = 4


def _check_indices(j, k, l, exact=False):
    out = [as_order(v, name, MAX_ORDER) for name, v in (("j", j), ("k", k), ("l", l))]
    if sum(out) > MAX_ORDER:
        raise ParameterError("j, k, l", f"j + k + l must be <= {MAX_ORDER}, got j={out[0]}, "
                                        f"k={out[1]}, l={out[2]}")
    kl_max = MAX_KL_EXACT if exact else MAX_KL
    if out[1] + out[2] > kl_max:
        raise ParameterError("k, l", 
            f"k + l must be <= {kl_max}{' with exact=True' if exact else ''}, got k={out[1]}, "
            f"l={out[2]}"
        )
    return out


@lru_cache(maxsize=256)
def _exact(j, k, l, signed):
    import sympy

    s = sympy.Symbol("s", positive=True)
    p = sympy.Symbol("p", positive=True)
    ctx = _Ctx(sympy.I, sympy.Rational(1, 2))
    Fp, Fm, a, b = _table(k, l, s, ctx)
    expr = _moment_from_table(j, k, l, Fp, Fm, a, b, ctx, signed=signed)
    expr = sympy.factor(sympy.cancel(sympy.expand(expr)))
    if sympy.simplify(sympy.im(expr)) != 0:  # pragma: no cover - guards the derivation
        raise RuntimeError("the exact transform came out complex")
    # write (s - 1)^-n as (s + 1)^n / p^n so that the result reads like eq10o-eq10pp
    num, den = sympy.fraction(expr)
    n = 0
    while sympy.rem(sympy.Poly(den, s), sympy.Poly(s - 1, s)).is_zero:
        den = sympy.quo(sympy.Poly(den, s), sympy.Poly(s - 1, s)).as_expr()
        n += 1
    rest = sympy.factor(num * (s + 1) ** n / den)
    expr = rest.subs(s, sympy.sqrt(p + 1)) / p**n
    return expr, p


def laplace_moment(j: int, k: int, l: int, p: ArrayLike,
                   exact: bool = False, *, signed: bool = False) -> Any:
    """Laplace transform of the mixed moment m_jkl(tau) = E[U1^j U2^k U3^l] (eq10g-eq10n, eq10i).

    Built by the paper's recursion on F+-_kl, with G_0,kl and G_1,kl fixed by analyticity:
    the numerator of F+_kl must vanish at z = i mu and that of F-_kl at z = -i mu,
    mu = sqrt(p + 1) - 1 (eq10k, eq10kk, eq10n). Reproduces eq10o-eq10pp exactly.

    Parameters
    ----------
    j, k, l : int
        Non-negative powers of the velocity U1, the displacement U2 and the distance U3 (eq3,
        scaled units, body at rest at tau = 0, noise on for all tau).
    p : complex or array_like or sympy symbol
        Laplace variable, Re p > 0. Ignored when ``exact=True`` (the symbol ``p`` is used).
    exact : bool
        If True return a sympy expression in the positive symbol ``p`` (requires sympy,
        imported only here).
    signed : bool, keyword-only
        If True, transform of E[sign(U1) U1^j U2^k U3^l] instead (the sum F+ + F- in eq10i).

    Returns
    -------
    complex ndarray, or sympy.Expr when ``exact=True``.

    Notes
    -----
    Numerical accuracy: the numerical transform is evaluated in double precision with
    s = sqrt(p + 1) on the principal branch and s - 1 formed as p / (s + 1); relative error
    ~1e-15 for the orders tested, down to |p| = 1e-12 (tests/test_analytic_inputs.py). Where the
    transform (~ p^-(order + 1) near 0) overflows a double, ValueError naming p. Use
    :func:`moment` (multi-precision) for time-domain values.

    Orders: j, k, l >= 0 with j + k + l <= 24 and k + l <= 12 (k + l <= 4 with exact=True):
    the recursion's cost grows quickly with k + l.
    """
    exact = as_flag(exact, "exact")
    signed = as_flag(signed, "signed")
    j, k, l = _check_indices(j, k, l, exact=exact)
    if exact:
        return _exact(j, k, l, signed)[0]
    p = as_real(p, "p", complex_ok=True)
    if np.any(~np.isfinite(p)):
        raise ParameterError("p", "p must be finite")
    if np.any(p.real <= 0):
        raise ParameterError("p", "p must have a positive real part")
    s = np.sqrt(p + 1)
    ctx = _Ctx(1j, 0.5)
    with np.errstate(all="ignore"):
        Fp, Fm, a, b = _table(k, l, s, ctx, sm1=p / (s + 1))
        out = np.asarray(_moment_from_table(j, k, l, Fp, Fm, a, b, ctx, signed=signed), complex)
    out = np.broadcast_to(out, p.shape).copy() if out.shape != p.shape else out
    if not np.all(np.isfinite(out)):
        # near p = 0 the transform grows like p^-(j/2 + k + l + 1) and leaves the double range
        bad = p[~np.isfinite(out)]
        raise ParameterError("p", 
            f"p too close to 0: the transform of order ({j}, {k}, {l}) overflows a double at "
            f"p = {complex(bad.flat[0])}; use exact=True or moment()"
        )
    return out


# ---------------------------------------------------------------------------------------------
# numerical inversion: fixed Talbot contour (Abate & Valko 2004) in multi-precision
# ---------------------------------------------------------------------------------------------

_DPS = 30
_TALBOT_M = 32


@lru_cache(maxsize=8)
def _talbot_nodes(M, dps):
    import mpmath

    ctx = mpmath.MPContext()
    ctx.dps = dps
    r = ctx.mpf(2) * M / 5
    nodes = []
    for kk in range(M):
        if kk == 0:
            delta = r
            gamma = ctx.exp(delta) / 2
        else:
            th = kk * ctx.pi / M
            cot = ctx.cot(th)
            delta = r * th * (cot + 1j)
            gamma = ctx.exp(delta) * (1 + 1j * (th + (th * cot - 1) * cot))
        nodes.append((delta, gamma))
    return ctx, r, nodes


def _dps_for(t):
    """Working digits at scaled time t: at large t the nodes p = delta / t are small and the
    recursion subtracts O(1) quantities to form O(p) ones (s - 1, the analyticity conditions),
    losing about log10(t) digits per level; rounded up to a multiple of 10 to reuse nodes."""
    extra = 2 * max(0, math.ceil(math.log10(t))) if t > 1 else 0
    return _DPS + 10 * math.ceil(extra / 10)


def _invert(j, k, l, tau, signed):
    out = np.empty(tau.shape, dtype=float)
    for idx, t in np.ndenumerate(tau):
        if t == 0.0:
            out[idx] = 1.0 if (j == k == l == 0 and not signed) else 0.0
            continue
        ctx, r, nodes = _talbot_nodes(_TALBOT_M, _dps_for(float(t)))
        c = _Ctx(ctx.mpc(0, 1), ctx.mpf(1) / 2)
        t = ctx.mpf(float(t))
        total = ctx.mpf(0)
        for delta, gamma in nodes:
            p = delta / t
            s = ctx.sqrt(p + 1)
            Fp, Fm, a, b = _table(k, l, s, c, sm1=p / (s + 1))
            val = _moment_from_table(j, k, l, Fp, Fm, a, b, c, signed=signed)
            total += ctx.re(gamma * val)
        value = 2 * total / (5 * t)  # r / M = 2 / 5
        if abs(value) > ctx.mpf("1.7976931348623157e308"):
            raise ParameterError("tau", 
                f"tau too large: m_({j},{k},{l}) = {ctx.nstr(value, 5)} at tau = {float(t)!r} "
                f"is beyond the range of a double"
            )
        out[idx] = float(value)
    return out


def _tau_array(tau, name="tau"):
    return as_time(tau, name)


def moment(j: int, k: int, l: int, tau: ArrayLike) -> Values:
    """Mixed moment m_jkl(tau) = E[U1^j U2^k U3^l] by numerical inversion of
    :func:`laplace_moment`.

    Parameters
    ----------
    j, k, l : int
        Non-negative powers of U1 (velocity), U2 (displacement), U3 (distance), eq3.
    tau : float or array_like
        Scaled time (eq8), 0 <= tau < inf, noise on throughout (tau <= tau0).

    Returns
    -------
    ndarray of float, same shape as tau; scaled units (U1^j U2^k U3^l).

    Notes
    -----
    Fixed Talbot contour with 32 nodes (Abate & Valko 2004), transform evaluated by the
    recursion in 30-digit arithmetic (mpmath), 30 + 2 log10(tau) digits for tau > 1 (the small
    nodes p = delta / tau cost that many digits). Stated accuracy: relative error 1e-8 over
    1e-8 <= tau <= 1e6 (tested); observed below 1e-12 for the orders tested (j + k + l <= 4),
    and to rounding against the closed forms at tau = 1e-300 and 1e300. A value beyond the
    double range raises ValueError naming tau. Orders: j + k + l <= 24, k + l <= 12.
    Cost: 32 evaluations of the recursion per tau, ~15 ms per tau for low orders: this is a
    reference, not a fast path. tau = 0 returns the initial value exactly.
    """
    j, k, l = _check_indices(j, k, l)
    t = _tau_array(tau)
    out = _invert(j, k, l, t, False)
    return out[()] if t.ndim == 0 else out


def signed_moment(j: int, k: int, l: int, tau: ArrayLike) -> Values:
    """E[sign(U1) U1^j U2^k U3^l](tau) by numerical inversion of
    ``laplace_moment(j, k, l, p, signed=True)``; same accuracy and domain as :func:`moment`."""
    j, k, l = _check_indices(j, k, l)
    t = _tau_array(tau)
    out = _invert(j, k, l, t, True)
    return out[()] if t.ndim == 0 else out
