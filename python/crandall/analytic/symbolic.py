"""Exact closed forms of every mixed moment, by inverting the recursion's transform (sympy).

``laplace_moment(j, k, l, exact=True)`` is a rational function of s = sqrt(p + 1) whose poles
lie at s = 1 (p = 0), s = -1 and s = 0 (p = -1). Its partial fractions in s invert term by term
(docs/analytic.md, "Closed forms from the Laplace transform"):

    L^-1[ G(sqrt(p + 1)) ](tau) = e^-tau L^-1[ G(sqrt p) ](tau),
    L^-1[ (sqrt p)^-n ] = tau^(n/2 - 1) / Gamma(n/2),
    L^-1[ (sqrt p + alpha)^-n ] = 1/(Gamma(n) 2 sqrt(pi) tau^(3/2)) * I_n(alpha),
    I_n(alpha) = int_0^inf u^n e^(-alpha u - u^2/(4 tau)) du,

with I_0 = sqrt(pi tau) e^(alpha^2 tau) erfc(alpha sqrt tau), I_1 = 2 tau (1 - alpha I_0),
I_(n+1) = 2 tau (n I_(n-1) - alpha I_n). This module needs sympy; nothing imports it at
``import crandall.analytic`` time.
"""

from __future__ import annotations

from typing import Any

from fractions import Fraction
from functools import lru_cache

from ._forms import Form
from ._laplace import _check_indices, _Ctx, _moment_from_table, _table

__all__ = ["moment_closed_form", "laplace_moment_in_s", "invert_in_s"]


@lru_cache(maxsize=128)
def laplace_moment_in_s(j: int, k: int, l: int, signed: bool = False) -> Any:
    """Exact transform of m_jkl (or of E[sign(U1) U1^j U2^k U3^l]) as a rational function of
    the positive symbol ``s`` = sqrt(p + 1). Returns (expr, s)."""
    import sympy

    j, k, l = _check_indices(j, k, l, exact=True)
    s = sympy.Symbol("s", positive=True)
    ctx = _Ctx(sympy.I, sympy.Rational(1, 2))
    Fp, Fm, a, b = _table(k, l, s, ctx)
    expr = _moment_from_table(j, k, l, Fp, Fm, a, b, ctx, signed=signed)
    return sympy.factor(sympy.cancel(sympy.expand(expr))), s


def _I(nmax, alpha, tau):
    import sympy

    I0 = sympy.sqrt(sympy.pi * tau) * sympy.exp(alpha**2 * tau) * sympy.erfc(alpha * sympy.sqrt(tau))
    out = [I0, 2 * tau - 2 * tau * alpha * I0]
    for n in range(1, nmax):
        out.append(2 * tau * (n * out[n - 1] - alpha * out[n]))
    return out


def invert_in_s(G, s):
    """Inverse Laplace transform of a rational function G of s = sqrt(p + 1) with poles at
    s in {1, -1, 0} only, as an exact :class:`Form`."""
    import sympy

    tau = sympy.Symbol("tau", positive=True)
    if G == 0:
        return Form()
    res = sympy.Integer(0)
    for term in sympy.Add.make_args(sympy.apart(sympy.together(G), s)):
        num, den = sympy.fraction(sympy.together(term))
        if num.has(s):
            raise ValueError(f"unexpected polynomial part {term}")
        c, facs = sympy.factor_list(den)
        sf = [(f, m) for f, m in facs if f.has(s)]
        for f, m in facs:
            if not f.has(s):
                c *= f**m
        if len(sf) != 1:
            raise ValueError(f"unexpected term {term}")
        f, n = sf[0]
        a1, a0 = sympy.Poly(f, s).all_coeffs()
        alpha = a0 / a1
        if alpha not in (0, 1, -1):
            raise ValueError(f"pole at s = {-alpha} is not one of 0, 1, -1")
        c *= a1**n
        if alpha == 0:
            res += num / c * tau ** (sympy.Rational(n, 2) - 1) / sympy.gamma(sympy.Rational(n, 2))
        else:
            res += (
                num / c / sympy.factorial(n - 1)
                / (2 * sympy.sqrt(sympy.pi) * tau ** sympy.Rational(3, 2))
                * _I(n, alpha, tau)[n]
            )
    expr = sympy.expand(sympy.exp(-tau) * res)
    expr = sympy.expand(expr.subs(sympy.erfc(-sympy.sqrt(tau)), 2 - sympy.erfc(sympy.sqrt(tau))))
    return _sympy_to_form(expr, tau)


def _sympy_to_form(expr, tau):
    import sympy

    terms = {}
    E = sympy.erfc(sympy.sqrt(tau))
    for term in sympy.Add.make_args(sympy.expand(expr)):
        coeff = Fraction(1)
        h = m = k = q = 0
        for f in sympy.Mul.make_args(term):
            base, ex = f.as_base_exp()
            if f.is_Rational:
                coeff *= Fraction(int(f.p), int(f.q))
            elif base == tau:
                h += int(2 * ex)
            elif base == sympy.pi:
                m += int(-2 * ex)
            elif base == E:
                q += int(ex)
            elif isinstance(f, sympy.exp) or base == sympy.E:
                arg = f.args[0] if isinstance(f, sympy.exp) else ex
                kk = sympy.simplify(-arg / tau)
                k += int(kk)
            else:
                raise ValueError(f"cannot read factor {f} of {term}")
        key = (h, m, k, q)
        terms[key] = terms.get(key, Fraction(0)) + coeff
    return Form(terms)


@lru_cache(maxsize=128)
def moment_closed_form(j: int, k: int, l: int, signed: bool = False) -> Any:
    """Exact closed form of m_jkl(tau) = E[U1^j U2^k U3^l] for tau <= tau0 (or of
    E[sign(U1) U1^j U2^k U3^l] with ``signed=True``), as a :class:`Form`; call ``.to_sympy()``
    for a sympy expression or evaluate it at numpy arrays of tau. Requires sympy."""
    G, s = laplace_moment_in_s(j, k, l, signed)
    return invert_in_s(G, s)
