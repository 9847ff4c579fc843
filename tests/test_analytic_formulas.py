"""crandall.analytic: every shipped closed form checked against (a) numerical inversion of its
Laplace transform from the paper's recursion and (b) quadrature of the density of U1.

Expected values come from mpmath transcriptions of the formulas (written here from the paper
and docs/analytic.md, not from the package), from ``moment`` (Talbot inversion in 30 digits)
or from scipy quadrature; never from the function under test."""

import math

import mpmath
import numpy as np
import pytest
from scipy import integrate

import crandall.analytic as A

mp = mpmath.MPContext()
mp.dps = 50


def _r(t):
    return mp.sqrt(mp.mpf(t))


# --- the paper's printed formulas, transcribed -------------------------------------------------
def eq10r(t):
    t = mp.mpf(t)
    r = _r(t)
    return (2 * (1 + 2 * t) * mp.sqrt(t / mp.pi) * mp.exp(-t) - 4 * t**2 * mp.erfc(r)
            + (4 * t - 1) * mp.erf(r)) / 8


def eq10s(t):
    t = mp.mpf(t)
    r = _r(t)
    return (mp.erf(r) + 4 * t * (t + 1) * mp.erfc(r)
            - 2 * (1 + 2 * t) * mp.sqrt(t / mp.pi) * mp.exp(-t)) / 2


def _poly_erfc(t):
    return t**4 / 2 + mp.mpf(5) / 6 * t**3 - t**2 / 2 + mp.mpf(3) / 8 * t - mp.mpf(5) / 32


def eq10t(t):
    t = mp.mpf(t)
    return (mp.mpf(5) / 8 * t - mp.mpf(27) / 32
            + mp.exp(-t) * (1 - mp.sqrt(t / mp.pi) * (t**3 / 2 + mp.mpf(7) / 12 * t**2
                                                     - mp.mpf(13) / 24 * t + mp.mpf(5) / 16))
            + mp.erfc(_r(t)) * _poly_erfc(t))


def eq10u_printed_second_moment(t):
    """E[U3^2] as printed in eq10u (before subtracting u3bar^2)."""
    t = mp.mpf(t)
    return (t**2 / 4 + t / 8 - mp.mpf(11) / 32
            + mp.exp(-t) * (mp.mpf(1) / 2 + t * mp.sqrt(t / mp.pi)
                            * (mp.mpf(13) / 24 - mp.mpf(7) / 12 * t - t**2 / 2))
            + mp.erfc(_r(t)) * _poly_erfc(t))


def eq10u_corrected_second_moment(t):
    """docs/analytic.md: the e^-tau bracket gains -(5/16) sqrt(tau/pi)."""
    t = mp.mpf(t)
    return eq10u_printed_second_moment(t) - mp.mpf(5) / 16 * mp.sqrt(t / mp.pi) * mp.exp(-t)


def abs_mean(t):
    t = mp.mpf(t)
    return mp.mpf(1) / 2 - (t + mp.mpf(1) / 2) * mp.erfc(_r(t)) + mp.sqrt(t / mp.pi) * mp.exp(-t)


def density(y, t):
    y, t = abs(mp.mpf(y)), mp.mpf(t)
    return (mp.exp(-(y + 2 * t) ** 2 / (4 * t)) / mp.sqrt(4 * mp.pi * t)
            + mp.exp(-2 * y) * mp.erfc((y - 2 * t) / (2 * mp.sqrt(t))) / 2)


TAUS = [1e-3, 0.1, 0.7, 1.0, 2.5, 10.0, 60.0]


# --- (a) Laplace: the recursion reproduces the printed transforms --------------------------------
def test_exact_transforms_reproduce_eq10o_to_eq10pp():
    sympy = pytest.importorskip("sympy")
    p = sympy.Symbol("p", positive=True)
    s = sympy.sqrt(p + 1)
    printed = {
        (1, 0, 0): sympy.Integer(0),
        (0, 1, 0): sympy.Integer(0),
        (0, 0, 1): 1 / (p**2 * (s + 1)),
        (2, 0, 0): 2 / (p * (s + 1) ** 2),
        (0, 2, 0): (4 * s + 1) / (p**2 * (p + 1) * (s + 1) ** 3),
        (0, 0, 2): (9 * p - 4 * s + 8) / (2 * p**3 * (p + 1) * (s + 1) ** 2),
        (0, 0, 0): 1 / p,
    }
    for (j, k, l), expected in printed.items():
        got = A.laplace_moment(j, k, l, None, exact=True)
        assert sympy.simplify(got - expected) == 0, (j, k, l, got)


def test_numerical_transform_matches_exact():
    sympy = pytest.importorskip("sympy")
    ps = np.array([0.3, 1.0, 2.0 + 3.0j, 10.0 - 1.0j])
    for jkl in [(0, 0, 2), (2, 0, 1), (1, 1, 1), (0, 3, 0), (4, 0, 0)]:
        expr = A.laplace_moment(*jkl, None, exact=True)
        psym = list(expr.free_symbols)
        ref = [complex(expr.subs(psym[0], sympy.nsimplify(x)).evalf(30)) if psym else complex(expr)
               for x in ps]
        got = A.laplace_moment(*jkl, ps)
        np.testing.assert_allclose(got, ref, rtol=1e-11, atol=1e-300)


def test_odd_moments_vanish():
    # U -> -U symmetry: E[U1^j U2^k U3^l] = 0 when j + k is odd
    for jkl in [(1, 0, 0), (0, 1, 0), (1, 0, 1), (0, 1, 2), (2, 1, 0), (3, 0, 1)]:
        assert np.all(A.laplace_moment(*jkl, [0.5, 2.0 + 1j]) == 0)


@pytest.mark.parametrize(
    "func,transcribed,jkl",
    [
        (A.distance_mean, eq10r, (0, 0, 1)),
        (A.velocity_var, eq10s, (2, 0, 0)),
        (A.displacement_var, eq10t, (0, 2, 0)),
        (A.distance_second_moment, eq10u_corrected_second_moment, (0, 0, 2)),
    ],
)
def test_closed_forms_equal_inverse_laplace(func, transcribed, jkl):
    inv = A.moment(*jkl, np.array(TAUS))
    ref = np.array([float(transcribed(t)) for t in TAUS])
    np.testing.assert_allclose(inv, ref, rtol=1e-12)
    np.testing.assert_allclose(func(np.array(TAUS)), inv, rtol=1e-12)


def test_printed_eq10u_is_wrong_and_correction_is_right():
    for t in [0.1, 1.0, 3.0]:
        inv = A.moment(0, 0, 2, t)
        printed = float(eq10u_printed_second_moment(t))
        assert abs(printed / inv - 1) > 1e-3  # the typo is not a rounding effect
        assert abs(float(eq10u_corrected_second_moment(t)) / inv - 1) < 1e-12


def test_distance_var_is_second_moment_minus_mean_squared():
    ts = np.array(TAUS)
    inv = A.moment(0, 0, 2, ts) - A.moment(0, 0, 1, ts) ** 2
    np.testing.assert_allclose(A.distance_var(ts), inv, rtol=1e-11)


def test_abs_mean_equals_inverse_of_signed_transform_and_derivative_of_eq10r():
    ts = np.array(TAUS)
    np.testing.assert_allclose(A.velocity_abs_mean(ts), A.signed_moment(1, 0, 0, ts), rtol=1e-12)
    for t in TAUS:
        d = mp.diff(eq10r, mp.mpf(t))
        assert abs(float(abs_mean(t) / d) - 1) < 1e-20


def test_symbolic_closed_form_generator_against_inversion():
    pytest.importorskip("sympy")
    from crandall.analytic.symbolic import moment_closed_form

    ts = np.array([0.05, 0.8, 4.0])
    for jkl, signed in [((0, 0, 1), False), ((2, 0, 2), False), ((1, 1, 1), False),
                        ((0, 2, 1), False), ((2, 1, 0), True)]:
        form = moment_closed_form(*jkl, signed=signed)
        inv = (A.signed_moment if signed else A.moment)(*jkl, ts)
        np.testing.assert_allclose(form(ts), inv, rtol=1e-11)


def test_shipped_tables_equal_generator_output():
    pytest.importorskip("sympy")
    from crandall.analytic import _data
    from crandall.analytic.symbolic import moment_closed_form

    assert _data.M001 == moment_closed_form(0, 0, 1)
    assert _data.M200 == moment_closed_form(2, 0, 0)
    assert _data.M020 == moment_closed_form(0, 2, 0)
    assert _data.M002 == moment_closed_form(0, 0, 2)
    assert _data.M400 == moment_closed_form(4, 0, 0)
    assert _data.M201 == moment_closed_form(2, 0, 1)
    assert _data.S100 == moment_closed_form(1, 0, 0, signed=True)
    assert _data.S210 == moment_closed_form(2, 1, 0, signed=True)


# --- (b) the density ------------------------------------------------------------------------------
@pytest.mark.parametrize("t", [0.01, 0.5, 3.0, 20.0])
def test_density_moments(t):
    def q(g):
        # symmetric density: twice the half line, split at the bulk
        pts = [0.0, 2 * t + 10 * math.sqrt(t) + 10]
        return 2 * integrate.quad(lambda y: g(y) * A.velocity_pdf(y, t), *pts,
                                  epsabs=0, epsrel=1e-13, limit=200)[0]

    assert q(lambda y: 1.0) == pytest.approx(1.0, rel=1e-11)
    assert q(lambda y: y * y) == pytest.approx(float(A.velocity_var(t)), rel=1e-10)
    assert q(lambda y: abs(y)) == pytest.approx(float(A.velocity_abs_mean(t)), rel=1e-10)
    assert q(lambda y: y**4) == pytest.approx(float(A.moment(4, 0, 0, t)), rel=1e-10)


def test_density_matches_paper_form():
    for y, t in [(0.0, 0.3), (0.7, 0.3), (-2.0, 5.0), (30.0, 2.0), (1e-3, 1e-4)]:
        assert A.velocity_pdf(y, t) == pytest.approx(float(density(y, t)), rel=1e-13)


# --- long-time limits, as limits ------------------------------------------------------------------
def test_long_time_limits():
    big = np.array([1e3, 1e4, 1e5])
    np.testing.assert_allclose(A.velocity_var(big), 0.5, rtol=1e-14)
    # Var U2 - (5/8) tau -> -27/32, so Var U2 / tau -> 5/8 with error 27/(32 tau)
    np.testing.assert_allclose(A.displacement_var(big) - 5 / 8 * big, -27 / 32, atol=1e-9)
    np.testing.assert_allclose(A.distance_mean(big) - big / 2, -1 / 8, atol=1e-10)
    np.testing.assert_allclose(A.distance_var(big) - big / 4, -23 / 64, atol=1e-9)
    # and the limits of the transforms at p -> 0 say the same thing
    p = np.array([1e-6])
    assert (p**2 * A.laplace_moment(0, 2, 0, p)).real[0] == pytest.approx(5 / 8, rel=1e-5)
    assert (p * A.laplace_moment(2, 0, 0, p)).real[0] == pytest.approx(1 / 2, rel=1e-5)


def test_small_time_limits_are_brownian():
    t = np.array([1e-8, 1e-7])
    np.testing.assert_allclose(A.velocity_var(t), 2 * t, rtol=1e-3)
    np.testing.assert_allclose(A.displacement_var(t), 2 / 3 * t**3, rtol=1e-3)
    np.testing.assert_allclose(A.distance_mean(t), 4 / 3 * t**1.5 / math.sqrt(math.pi), rtol=1e-3)
    np.testing.assert_allclose(A.velocity_abs_mean(t), 2 * np.sqrt(t / math.pi), rtol=1e-3)
