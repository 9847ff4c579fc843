"""Sweep of crandall.analytic over 1e-8 <= tau <= 1e6 (and |y| <= 1e3 for the density) against
50-digit mpmath evaluations of the formulas transcribed in test_analytic_formulas.py and
docs/analytic.md: relative error below 1e-10, no NaN, no inf, no negative variance, no warning
(pytest runs with filterwarnings = error)."""

import mpmath
import numpy as np
import pytest

import crandall.analytic as A
from test_analytic_formulas import abs_mean, density, eq10r, eq10s, eq10t, eq10u_corrected_second_moment, mp

TAUS = np.concatenate([[0.0], np.logspace(-8, 6, 57), [0.999999, 1.0, 1.000001]])


def var_u3(t):
    return eq10u_corrected_second_moment(t) - eq10r(t) ** 2


def half_int_var_u1(t):
    """docs/analytic.md: (1/2) int_0^tau0 Var U1."""
    t = mp.mpf(t)
    r = mp.sqrt(t)
    return (t / 4 - mp.mpf(1) / 8 + mp.sqrt(t / mp.pi) * mp.exp(-t) * (mp.mpf(1) / 4 - t / 3 - t**2 / 3)
            + mp.erfc(r) * (mp.mpf(1) / 8 - t / 4 + t**2 / 2 + t**3 / 3))


def var_u2_at_stop(t):
    """docs/analytic.md."""
    t = mp.mpf(t)
    r = mp.sqrt(t)
    return (mp.mpf(5) / 8 * t - mp.mpf(15) / 32 + mp.exp(-t) / 4
            + mp.sqrt(t / mp.pi) * mp.exp(-t) * (mp.mpf(7) / 16 - mp.mpf(11) / 24 * t - t**2 / 3)
            + mp.erfc(r) * (mp.mpf(7) / 32 - mp.mpf(3) / 8 * t + mp.mpf(5) / 8 * t**2 + t**3 / 3))


CASES = [
    (A.velocity_var, eq10s),
    (A.displacement_var, eq10t),
    (A.distance_mean, eq10r),
    (A.distance_var, var_u3),
    (A.distance_second_moment, eq10u_corrected_second_moment),
    (A.velocity_abs_mean, abs_mean),
    (A.distance_at_stop_var, half_int_var_u1),
    (A.displacement_at_stop_var, var_u2_at_stop),
    (A.stop_time_var, lambda t: (eq10s(t) - abs_mean(t) ** 2) / 4),
    (A.stop_time_mean, lambda t: mp.mpf(t) + abs_mean(t) / 2),
    (A.distance_at_stop_mean, lambda t: mp.mpf(t) / 2),
]


@pytest.mark.parametrize("func,ref", CASES, ids=[c[0].__name__ for c in CASES])
def test_sweep_against_mpmath(func, ref):
    got = func(TAUS)
    assert got.shape == TAUS.shape
    assert np.all(np.isfinite(got))
    assert np.all(got >= 0)
    expected = np.array([float(ref(t)) for t in TAUS])
    assert expected[0] == 0 and got[0] == 0
    np.testing.assert_allclose(got[1:], expected[1:], rtol=1e-10, atol=0)


def test_pdf_sweep_against_mpmath():
    ys = np.concatenate([[0.0], np.logspace(-6, 3, 19)])
    taus = np.logspace(-8, 6, 15)
    Y, T = np.meshgrid(ys, taus)
    got = A.velocity_pdf(Y, T)
    glog = A.velocity_logpdf(-Y, T)  # symmetric in y
    assert np.all(np.isfinite(got)) and np.all(got >= 0) and np.all(np.isfinite(glog))
    ref = np.array([[density(y, t) for y in ys] for t in taus], dtype=object)
    for idx in np.ndindex(Y.shape):
        r = ref[idx]
        assert abs(glog[idx] - float(mpmath.log(r))) <= 1e-12 * max(1.0, abs(float(mpmath.log(r))))
        if r > mpmath.mpf("1e-300"):
            assert abs(got[idx] / float(r) - 1) < 1e-10, (Y[idx], T[idx])
        else:
            assert got[idx] < 1e-290


def test_coast_after_switch_off_against_quadrature():
    """velocity_var and distance_mean for tau > tau0 against 30-digit quadrature of the coast
    averaged over the survival function of |U1(tau0)| (docs/analytic.md, After switch-off)."""
    q = mpmath.MPContext()
    q.dps = 30

    def surv(y, t):
        return (q.erfc((y + 2 * t) / (2 * q.sqrt(t))) + q.exp(-2 * y) * q.erfc((y - 2 * t) / (2 * q.sqrt(t)))) / 2

    def h(c, t):  # E[(|U1| - c)_+^2] = int_c^inf 2 (y - c) S(y) dy
        c, t = q.mpf(c), q.mpf(t)
        sc = min(q.sqrt(t), 1)
        return 2 * q.quad(lambda y: (y - c) * surv(y, t), [c, c + sc, c + 5 * sc, c + 30 * sc, q.inf])

    for t0 in [1e-6, 0.02, 0.3, 2.0, 50.0]:
        for frac in [0.0, 0.01, 0.2, 0.6, 1.0, 1.5]:
            delta = frac * (t0 + 2 * t0**0.5)
            tau = t0 + delta
            hv = h(2 * delta, t0)
            ev = float(eq10s(t0))
            vv = A.velocity_var(tau, t0)
            if hv > 1e-25 * ev:
                assert vv == pytest.approx(float(hv), rel=1e-10)
            else:
                assert abs(vv - float(hv)) < 1e-17 * ev
            dm = A.distance_mean(tau, t0)
            expected = eq10r(t0) + eq10s(t0) / 4 - hv / 4
            assert dm == pytest.approx(float(expected), rel=1e-10)
    # continuity at the switch-off and the stop (eq7)
    assert A.velocity_var(1.0, 1.0) == pytest.approx(float(eq10s(1.0)), rel=1e-13)
    assert A.distance_mean(1e4, 1.0) == pytest.approx(0.5, rel=1e-14)
    assert A.velocity_var(1e4, 1.0) == 0.0
