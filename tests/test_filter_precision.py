"""The filtered excitation's plan doubles against an independent high-precision reference.

The plan's transition Phi(h), its Van Loan covariance Q(h) and the noise tree's square root R(h)
(the skeleton's root) are computed in double-double arithmetic (cpp/src/filter.cpp) and rounded
to double. The reference here is mpmath at 60 digits by another route: Van Loan's block
exponential (mpmath's expm) for Phi and Q, and the Cholesky factor of Q for R (R is lower
triangular with R R^T = Q, so it is Q's Cholesky factor up to the signs of its columns).

Tolerance, 1 ulp: the double-double computation carries about 2^-100 of relative error
into the last rounding, so each entry is its correctly rounded value unless it lies within
that of a rounding boundary; 1 ulp leaves room for that and nothing else (the x87 long double
the plan used before missed it by up to 1e5 ulps in the root's small entries and by 8500 ulps
in a Clough-Penzien covariance entry that cancels). Clough-Penzien's Q has rank n = 4 of m = 6
(G and D are functions of the filter's state): only R's first n columns are determined, and
the entries of each of R's rows are checked in ulps of the row's scale sqrt(Q_ii), the rest of
the row within that too.
"""

import math

import mpmath
import pytest

from crandall import _core
from crandall.excitation import CloughPenzien, KanaiTajimi

# A plan with the default event_depth 8 builds its tree over 4 h down to h / 2^11
# (filter.hpp: kLevelsUp = 2, kSpreadDepth = 3): 14 levels, the step's own at index 2.
LEVELS, STEP_LEVEL = 14, 2


def _flat(excitation):
    a, b, c = excitation.matrices()
    return [x for row in a for x in row], list(b), list(c)


def _reference(a, b, c, h):
    """Phi, Q and the Cholesky columns of Q (up to its rank) at 60 digits."""
    with mpmath.workdps(60):
        n = len(b)
        m = n + 2
        abar = mpmath.zeros(m, m)
        for i in range(n):
            for j in range(n):
                abar[i, j] = a[i * n + j]
        for j in range(n):
            abar[n, j] = c[j]
        abar[n + 1, n] = 1
        big = mpmath.zeros(2 * m, 2 * m)
        for i in range(m):
            for j in range(m):
                big[i, j] = -abar[i, j]
                big[m + i, m + j] = abar[j, i]
                big[i, m + j] = (b[i] * b[j]) if i < n and j < n else 0
        e = mpmath.expm(big * mpmath.mpf(h))
        phi = e[m:, m:].T
        q = phi * e[:m, m:]
        q = (q + q.T) / 2
        chol = mpmath.zeros(m, m)
        rank = m
        for j in range(m):
            d = q[j, j] - sum(chol[j, k] ** 2 for k in range(j))
            if d <= q[j, j] * mpmath.mpf(10) ** -40:
                rank = j
                break
            chol[j, j] = mpmath.sqrt(d)
            for i in range(j + 1, m):
                chol[i, j] = (q[i, j] - sum(chol[i, k] * chol[j, k] for k in range(j))) / chol[j, j]
        return phi, q, chol, rank


def _ulps(got, want, scale=None):
    """|got - want| in ulps of want (or of scale)."""
    unit = math.ulp(float(abs(want) if scale is None else scale))
    return float(abs(mpmath.mpf(float(got)) - want)) / unit


@pytest.mark.parametrize("excitation, h", [
    (KanaiTajimi(0.5, 0.6), 0.15625),
    (KanaiTajimi(0.5, 0.6), 1e-3),
    (KanaiTajimi(15.6, 0.6), 0.02),
    (CloughPenzien(0.5, 0.6, 0.1, 0.6), 0.02),
    (CloughPenzien(15.6, 0.6, 1.6, 0.6), 0.5),
])
def test_plan_doubles_are_correctly_rounded(excitation, h):
    a, b, c = _flat(excitation)
    phi, q = _core.filter_transition(a, b, c, h)
    length, level_phi, root = _core.filter_root_levels(a, b, c, 4 * h, LEVELS)[STEP_LEVEL]
    assert length == h and (level_phi == phi).all()
    ref_phi, ref_q, chol, rank = _reference(a, b, c, h)
    m = len(b) + 2
    assert rank == (m if isinstance(excitation, KanaiTajimi) else len(b))
    worst = {"phi": 0.0, "q": 0.0, "root": 0.0}
    for i in range(m):
        scale = mpmath.sqrt(ref_q[i, i])
        for j in range(m):
            worst["phi"] = max(worst["phi"], _ulps(phi[i, j], ref_phi[i, j]))
            worst["q"] = max(worst["q"], _ulps(q[i, j], ref_q[i, j]))
            # R's column j has the sign of its diagonal; the Cholesky factor's diagonal is > 0.
            sign = 1.0 if j >= rank or root[j, j] >= 0 else -1.0
            want = chol[i, j] if j < rank else 0
            err = _ulps(sign * root[i, j], want, scale if rank < m else None)
            worst["root"] = max(worst["root"], err)
    assert max(worst.values()) <= 1.0, worst
