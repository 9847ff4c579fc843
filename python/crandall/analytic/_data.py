"""Exact closed forms (as :class:`Form`) of the moments the analytic layer ships.

Each table was produced by ``crandall.analytic.symbolic.moment_closed_form`` (partial fractions
of the recursion's transform in s = sqrt(p + 1)) and is checked against it, against numerical
Laplace inversion and against quadrature of the density in tests/test_analytic_*.py. Keeping
them as data means ``import crandall.analytic`` needs no sympy.

Layout: Form.from_polys(A, P, Q, R) = A(tau) + e^-tau P(tau) + sqrt(tau/pi) e^-tau Q(tau)
+ erfc(sqrt tau) R(tau), coefficients in increasing powers of tau.
"""

from fractions import Fraction as F

from ._forms import Form

# E[U3]: eq10r (printed form correct)
M001 = Form.from_polys(A=(F(-1, 8), F(1, 2)), Q=(F(1, 4), F(1, 2)), R=(F(1, 8), F(-1, 2), F(-1, 2)))
# E[U1^2] = Var U1: eq10s (printed form correct)
M200 = Form.from_polys(A=(F(1, 2),), Q=(-1, -2), R=(F(-1, 2), 2, 2))
# E[U2^2] = Var U2: eq10t (printed form correct)
M020 = Form.from_polys(
    A=(F(-27, 32), F(5, 8)),
    P=(1,),
    Q=(F(-5, 16), F(13, 24), F(-7, 12), F(-1, 2)),
    R=(F(-5, 32), F(3, 8), F(-1, 2), F(5, 6), F(1, 2)),
)
# E[U3^2]: eq10u *corrected*: the printed e^-tau bracket lacks the term -(5/16) sqrt(tau/pi)
M002 = Form.from_polys(
    A=(F(-11, 32), F(1, 8), F(1, 4)),
    P=(F(1, 2),),
    Q=(F(-5, 16), F(13, 24), F(-7, 12), F(-1, 2)),
    R=(F(-5, 32), F(3, 8), F(-1, 2), F(5, 6), F(1, 2)),
)
# E[U1^4]
M400 = Form.from_polys(A=(F(3, 2),), Q=(-3, -2, -28, -8), R=(F(-3, 2), 0, 12, 32, 8))
# E[U1^2 U3]
M201 = Form.from_polys(
    A=(F(1, 4), F(1, 4)),
    P=(-1,),
    Q=(F(3, 2), F(-3, 2), 4, 2),
    R=(F(3, 4), F(-5, 4), F(1, 2), -5, -2),
)
# E|U1| = E[sign(U1) U1]
S100 = Form.from_polys(A=(F(1, 2),), Q=(1,), R=(F(-1, 2), -1))
# E[sign(U1) U1^2 U2] = E[U1 |U1| U2]
S210 = Form.from_polys(
    A=(F(9, 16),),
    P=(F(-3, 2),),
    Q=(F(15, 8), F(-7, 4), 4, 2),
    R=(F(15, 16), F(-3, 2), F(3, 4), -5, -2),
)
# E[U1 U2] (= (1/2) d E[U2^2] / d tau)
M110 = Form.from_polys(A=(F(5, 16),), P=(F(-1, 2),), Q=(F(3, 8), F(-3, 4), -1),
                       R=(F(3, 16), F(-1, 2), F(5, 4), 1))
# E[|U1| U3] = E[sign(U1) U1 U3]
S101 = Form.from_polys(A=(F(1, 16), F(1, 4)), P=(F(-1, 4),), Q=(F(3, 8), F(-3, 4), -1),
                       R=(F(3, 16), F(-1, 2), F(5, 4), 1))
# (1/2) int_0^tau E[U1^2] dtau', inverse transform of m~_200 / (2 p)
HALF_INT_M200 = Form.from_polys(
    A=(F(-1, 8), F(1, 4)),
    Q=(F(1, 4), F(-1, 3), F(-1, 3)),
    R=(F(1, 8), F(-1, 4), F(1, 2), F(1, 3)),
)

# Derived exactly (Form arithmetic), never re-typed:
VAR_U3 = M002 - M001 * M001
# U3(tau_s) = U3(tau0) + U1(tau0)^2 / 4
VAR_U3_AT_STOP = VAR_U3 + (M400 - M200 * M200) * F(1, 16) + (M201 - M001 * M200) * F(1, 2)
MEAN_U3_AT_STOP = M001 + M200 * F(1, 4)
# U2(tau_s) = U2(tau0) + U1(tau0) |U1(tau0)| / 4, E[U2(tau_s)] = 0
VAR_U2_AT_STOP = M020 + S210 * F(1, 2) + M400 * F(1, 16)
# Cov(|U1|, U3) (= (1/2) d Var U3 / d tau)
COV_SPEED_U3 = S101 - S100 * M001
# tau_s - tau0 = |U1(tau0)| / 2
VAR_STOP_TIME = (M200 - S100 * S100) * F(1, 4)
