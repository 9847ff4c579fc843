"""Exact "erfc forms" and their numerically stable evaluation.

Every moment of (U1, U2, U3) for tau <= tau0 that the recursion produces inverts to a finite sum
of terms

    c * tau^(h/2) * pi^(-m/2) * exp(-k tau) * erfc(sqrt(tau))^q,        c rational,

(see docs/analytic.md, "Closed forms from the Laplace transform"). Sums and products of such
sums (variances, covariances) are of the same kind, so they are kept *exactly* here, with
``fractions.Fraction`` coefficients; cancellations that would be catastrophic in floating point
(the tau^2 terms of E[U3^2] - E[U3]^2, the constant terms of every variance at small tau) are
done in exact arithmetic once, at import.

Evaluation picks one of two exact rewritings per point:

* small tau (tau < switch): the Taylor series in r = sqrt(tau), whose rational-times-pi^(-m/2)
  coefficients are computed exactly at import; no cancellation of leading terms, because they
  vanish exactly;
* large tau: erfc(r) = erfcx(r) exp(-tau), so the form is P0(tau) + sum_K exp(-K tau) g_K(tau)
  with P0 an exact polynomial and g_K built from erfcx (no overflow, no 0 * inf).
"""

from __future__ import annotations

import math
from fractions import Fraction

import numpy as np
from scipy.special import erfcx



class Form:
    """Exact sum of c tau^(h/2) pi^(-m/2) e^(-k tau) erfc(sqrt tau)^q; keys (h, m, k, q)."""

    __slots__ = ("terms", "_cache")

    def __init__(self, terms=None):
        self.terms = {}
        for key, c in (terms or {}).items():
            c = Fraction(c)
            if c:
                self.terms[key] = self.terms.get(key, Fraction(0)) + c
        self.terms = {k: v for k, v in self.terms.items() if v}
        self._cache = None

    @classmethod
    def from_polys(cls, A=(), P=(), Q=(), R=()):
        """A(tau) + e^-tau P(tau) + sqrt(tau/pi) e^-tau Q(tau) + erfc(sqrt tau) R(tau).

        Each polynomial is given by its coefficients in increasing powers of tau."""
        t = {}
        for n, c in enumerate(A):
            t[(2 * n, 0, 0, 0)] = c
        for n, c in enumerate(P):
            t[(2 * n, 0, 1, 0)] = c
        for n, c in enumerate(Q):
            t[(2 * n + 1, 1, 1, 0)] = c
        for n, c in enumerate(R):
            t[(2 * n, 0, 0, 1)] = c
        return cls(t)

    def __add__(self, other):
        other = _as_form(other)
        t = dict(self.terms)
        for key, c in other.terms.items():
            t[key] = t.get(key, Fraction(0)) + c
        return Form(t)

    __radd__ = __add__

    def __neg__(self):
        return Form({k: -c for k, c in self.terms.items()})

    def __sub__(self, other):
        return self + (-_as_form(other))

    def __rsub__(self, other):
        return _as_form(other) - self

    def __mul__(self, other):
        other = _as_form(other)
        t = {}
        for (h1, m1, k1, q1), c1 in self.terms.items():
            for (h2, m2, k2, q2), c2 in other.terms.items():
                key = (h1 + h2, m1 + m2, k1 + k2, q1 + q2)
                t[key] = t.get(key, Fraction(0)) + c1 * c2
        return Form(t)

    __rmul__ = __mul__

    def __eq__(self, other):
        return isinstance(other, Form) and self.terms == other.terms

    def __hash__(self):  # pragma: no cover - forms are not used as keys
        return hash(frozenset(self.terms.items()))

    def __repr__(self):
        return f"Form({self.terms!r})"

    # ------------------------------------------------------------------ symbolic
    def to_sympy(self, tau=None):
        """The form as a sympy expression in ``tau`` (imports sympy)."""
        import sympy

        if tau is None:
            tau = sympy.Symbol("tau", positive=True)
        out = sympy.Integer(0)
        for (h, m, k, q), c in self.terms.items():
            out += (
                sympy.Rational(c.numerator, c.denominator)
                * tau ** sympy.Rational(h, 2)
                * sympy.pi ** sympy.Rational(-m, 2)
                * sympy.exp(-k * tau)
                * sympy.erfc(sympy.sqrt(tau)) ** q
            )
        return out

    def mp(self, tau, mp):
        """Evaluate with an mpmath context (reference evaluation)."""
        tau = mp.mpf(tau)
        r = mp.sqrt(tau)
        ec = mp.erfc(r)
        out = mp.mpf(0)
        for (h, m, k, q), c in self.terms.items():
            out += (
                mp.mpf(c.numerator) / c.denominator
                * r**h * mp.pi ** (-mp.mpf(m) / 2) * mp.exp(-k * tau) * ec**q
            )
        return out

    # ------------------------------------------------------------------ numeric
    def _prepare(self):
        if self._cache is None:
            self._cache = (_series_coefficients(self), _large_groups(self))
        return self._cache

    def __call__(self, tau, switch=1.0):
        """Evaluate at an array of tau >= 0 (validated by the caller)."""
        series, groups = self._prepare()
        tau = np.asarray(tau, dtype=float)
        out = np.empty(tau.shape)
        small = tau < switch
        if np.any(small):
            r = np.sqrt(tau[small])
            acc = np.zeros_like(r)
            for c in series[::-1]:
                acc = acc * r + c
            out[small] = acc
        big = ~small
        if np.any(big):
            out[big] = _eval_large(groups, tau[big])
        return out


def _as_form(x):
    if isinstance(x, Form):
        return x
    return Form({(0, 0, 0, 0): Fraction(x)})


# ---------------------------------------------------------------------------- series at 0
_NSERIES = 72  # powers r^0 .. r^71; truncation below 1e-20 at r = 1 for the forms shipped


def _erfc_series(n):
    """erfc(r) = 1 - (2/sqrt pi) sum (-1)^j r^(2j+1) / (j! (2j+1)); coefficients as
    {power: {m: Fraction}} with m the power of pi^(-1/2)."""
    s = {0: {0: Fraction(1)}}
    j = 0
    while 2 * j + 1 < n:
        s[2 * j + 1] = {1: Fraction(-2 * (-1) ** j, math.factorial(j) * (2 * j + 1))}
        j += 1
    return s


def _exp_series(k, n):
    """exp(-k r^2)."""
    s = {}
    j = 0
    while 2 * j < n:
        s[2 * j] = {0: Fraction((-k) ** j, math.factorial(j))}
        j += 1
    return s


def _mul_series(a, b, n):
    out = {}
    for pa, ca in a.items():
        for pb, cb in b.items():
            pw = pa + pb
            if pw >= n:
                continue
            d = out.setdefault(pw, {})
            for ma, xa in ca.items():
                for mb, xb in cb.items():
                    d[ma + mb] = d.get(ma + mb, Fraction(0)) + xa * xb
    return out


def _series_coefficients(form, n=_NSERIES):
    import mpmath

    total = {}
    erfc_pows = {0: {0: {0: Fraction(1)}}}
    es = _erfc_series(n)
    for (h, m, k, q), c in form.terms.items():
        if q not in erfc_pows:
            cur = erfc_pows[max(erfc_pows)]
            for qq in range(max(erfc_pows) + 1, q + 1):
                cur = _mul_series(cur, es, n)
                erfc_pows[qq] = cur
        s = _mul_series(erfc_pows[q], _exp_series(k, n), n)
        for pw, d in s.items():
            if pw + h >= n:
                continue
            dd = total.setdefault(pw + h, {})
            for mm, x in d.items():
                dd[mm + m] = dd.get(mm + m, Fraction(0)) + c * x
    ctx = mpmath.MPContext()
    ctx.dps = 40
    isp = 1 / ctx.sqrt(ctx.pi)
    coef = np.zeros(n)
    for pw, d in total.items():
        v = ctx.mpf(0)
        for mm, x in d.items():
            v += ctx.mpf(x.numerator) / x.denominator * isp**mm
        coef[pw] = float(v)
    return coef


# ---------------------------------------------------------------------------- large tau
def _large_groups(form):
    """Group terms by total decay K = k + q (erfc(r) = erfcx(r) e^-tau)."""
    groups = {}
    for (h, m, k, q), c in form.terms.items():
        K = k + q
        groups.setdefault(K, []).append((h, m, q, float(c) * math.pi ** (-m / 2)))
    for K in groups:
        groups[K].sort()
    return groups


def _eval_large(groups, tau):
    r = np.sqrt(tau)
    ex = erfcx(r)
    out = np.zeros_like(tau)
    for K, terms in sorted(groups.items(), reverse=True):
        if K == 0:
            # exact polynomial part (all h even, q = 0): Horner in tau
            deg = max(h for h, _, _, _ in terms) // 2
            coef = np.zeros(deg + 1)
            for h, m, q, c in terms:
                coef[h // 2] += c
            acc = np.zeros_like(tau)
            for c in coef[::-1]:
                acc = acc * tau + c
            out += acc
            continue
        live = tau < 745.0 / K  # beyond, exp(-K tau) underflows and the group is 0
        if not np.any(live):
            continue
        tl, rl, el = tau[live], r[live], ex[live]
        g = np.zeros_like(tl)
        for h, m, q, c in terms:
            g += c * rl**h * el**q
        out[live] += np.exp(-K * tl) * g
    return out
