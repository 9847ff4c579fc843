"""Stop law, eq7 and the at-stop variances, checked against moments from Laplace inversion and
quadrature of the density; units and bad input."""

import math

import mpmath

import numpy as np
import pytest
from scipy import integrate

import crandall.analytic as A
from crandall.units import Scaling

T0S = np.array([0.05, 0.9, 4.0])


def test_eq7_mean_distance_at_stop_is_half_tau0():
    t0 = np.logspace(-6, 5, 12)
    np.testing.assert_allclose(A.distance_at_stop_mean(t0), t0 / 2, rtol=1e-13)
    # from inverted moments as well: E U3(tau0) + E U1(tau0)^2 / 4
    inv = A.moment(0, 0, 1, T0S) + A.moment(2, 0, 0, T0S) / 4
    np.testing.assert_allclose(inv, T0S / 2, rtol=1e-12)


def test_distance_at_stop_var_martingale_identity_against_moments():
    # Var[U3 + U1^2/4] at tau0 from m_002, m_001, m_400, m_200, m_201, all inverted numerically
    m = {jkl: A.moment(*jkl, T0S) for jkl in [(0, 0, 2), (0, 0, 1), (4, 0, 0), (2, 0, 0), (2, 0, 1)]}
    var = (m[0, 0, 2] - m[0, 0, 1] ** 2 + (m[4, 0, 0] - m[2, 0, 0] ** 2) / 16
           + (m[2, 0, 1] - m[0, 0, 1] * m[2, 0, 0]) / 2)
    np.testing.assert_allclose(A.distance_at_stop_var(T0S), var, rtol=1e-10)
    # and (1/2) int_0^tau0 E U1^2 by quadrature of eq10s
    for t0 in T0S:
        q = integrate.quad(lambda s: float(A.velocity_var(s)), 0, t0, epsabs=0, epsrel=1e-13)[0]
        assert A.distance_at_stop_var(t0) == pytest.approx(q / 2, rel=1e-11)


def test_displacement_at_stop_var_against_moments():
    var = A.moment(0, 2, 0, T0S) + A.signed_moment(2, 1, 0, T0S) / 2 + A.moment(4, 0, 0, T0S) / 16
    np.testing.assert_allclose(A.displacement_at_stop_var(T0S), var, rtol=1e-10)
    big = np.array([1e4, 1e5])
    np.testing.assert_allclose(A.displacement_at_stop_var(big) - 5 / 8 * big, -15 / 32, atol=1e-9)


def test_stop_time_law_against_density():
    for t0 in [0.02, 1.0, 7.0]:
        upper = t0 + t0 + 10 * math.sqrt(t0) + 10
        mass = integrate.quad(lambda t: A.stop_time_pdf(t, t0), t0, upper, epsrel=1e-12, limit=200)[0]
        mean = integrate.quad(lambda t: t * A.stop_time_pdf(t, t0), t0, upper, epsrel=1e-12, limit=200)[0]
        second = integrate.quad(lambda t: (t - mean) ** 2 * A.stop_time_pdf(t, t0), t0, upper,
                                epsrel=1e-12, limit=200)[0]
        assert mass == pytest.approx(1.0, rel=1e-10)
        assert A.stop_time_mean(t0) == pytest.approx(mean, rel=1e-10)
        assert A.stop_time_var(t0) == pytest.approx(second, rel=1e-8)
    assert A.stop_time_pdf(0.5, 1.0) == 0.0
    # long switch-off: |U1| is exponential with mean 1/2, tau_s - tau0 exponential with mean 1/4
    assert A.stop_time_var(1e4) == pytest.approx(1 / 16, rel=1e-14)
    assert A.stop_time_mean(1e4) - 1e4 == pytest.approx(1 / 4, rel=1e-9)


def test_physical_units():
    mu, h, g = 0.3, 0.8, 9.81
    sc = Scaling(mu=mu, h=h, g=g)
    t = np.array([0.5, 2.0])
    tau = t / sc.time_scale
    assert np.allclose(A.physical("velocity_var", t, mu=mu, h=h, g=g),
                       sc.velocity_scale**2 * A.velocity_var(tau), rtol=1e-15)
    assert np.allclose(A.physical("distance_mean", t, mu=mu, h=h, g=g),
                       sc.length_scale * A.distance_mean(tau), rtol=1e-15)
    # eq7 in SI: mean dissipated energy mu g S = h^2 t0 / 2
    t0 = 3.0
    s_mean = A.physical("distance_at_stop_mean", mu=mu, h=h, g=g, t0=t0)
    assert mu * g * s_mean == pytest.approx(h**2 * t0 / 2, rel=1e-13)
    # long time: Var V -> h^4 / (2 mu^2 g^2)
    assert A.physical("velocity_var", 1e6, mu=mu, h=h, g=g) == pytest.approx(
        h**4 / (2 * (mu * g) ** 2), rel=1e-12)
    with pytest.raises(ValueError, match="name"):
        A.physical("energy", 1.0, mu=mu, h=h)
    with pytest.raises(ValueError, match="t0"):
        A.physical("stop_time_mean", mu=mu, h=h)


@pytest.mark.parametrize(
    "call,param",
    [
        (lambda: A.velocity_var(-1.0), "tau"),
        (lambda: A.displacement_var([0.1, np.nan]), "tau"),
        (lambda: A.distance_var(np.inf), "tau"),
        (lambda: A.distance_mean(1.0, tau0=-2.0), "tau0"),
        (lambda: A.displacement_var(2.0, tau0=-1.0), "tau0"),
        (lambda: A.distance_var(2.0, tau0=[1.0, 2.0]), "tau0"),
        (lambda: A.velocity_abs_mean(2.0, tau0=1.0), "tau0"),
        (lambda: A.velocity_pdf(1.0, 0.0), "tau"),
        (lambda: A.velocity_pdf(np.nan, 1.0), "y"),
        (lambda: A.stop_time_pdf(1.0, 0.0), "tau0"),
        (lambda: A.stop_time_mean(-1.0), "tau0"),
        (lambda: A.distance_at_stop_var(np.nan), "tau0"),
        (lambda: A.laplace_moment(-1, 0, 0, 1.0), "j"),
        (lambda: A.laplace_moment(0, 1.5, 0, 1.0), "k"),
        (lambda: A.moment(0, 0, -2, 1.0), "l"),
        (lambda: A.laplace_moment(0, 0, 1, -1.0), "p"),
        (lambda: A.moment(2, 0, 0, -1.0), "tau"),
    ],
)
def test_bad_input_names_the_parameter(call, param):
    with pytest.raises(ValueError, match=rf"\b{param}\b"):
        call()


def test_moment_accuracy_over_the_range():
    # closed form (eq10s, checked elsewhere against mpmath) vs inversion, wide tau range
    t = np.array([1e-8, 1e-4, 1e2, 1e6])
    np.testing.assert_allclose(A.moment(2, 0, 0, t), A.velocity_var(t), rtol=1e-8)
    np.testing.assert_allclose(A.moment(0, 0, 2, t), A.distance_second_moment(t), rtol=1e-8)
    assert A.moment(0, 0, 0, 0.0) == 1.0 and A.moment(2, 0, 0, 0.0) == 0.0


def test_physical_just_after_a_late_switch_off_keeps_the_elapsed_time():
    # mu = 10, h = 1e-3: a time scale of 2e-10 s, so t0 = 1e6 s is tau0 = 4.8e15, where one
    # ulp of tau0 is 1 while one ulp of t0 (1.2e-10 s) is 0.56 in scaled time: t - t0 must be
    # taken in seconds. Independent reference: tau0 >> 1, so V(t0) has the stationary law,
    # |V(t0)| ~ Exponential(lam), lam = 2 mu g / h^2 (density of dV = -mu g sign V dt + h dW),
    # and the coast gives Var V(t0 + d) = E[(|V(t0)| - mu g d)_+^2] = (2 / lam^2) exp(-lam mu g d),
    # evaluated in 40 digits.
    mu, h, g, t0 = 10.0, 1e-3, 9.81, 1e6
    with mpmath.workdps(40):
        c = mpmath.mpf(mu) * mpmath.mpf(g)
        lam = 2 * c / mpmath.mpf(h) ** 2
        t = t0
        for _ in range(4):
            t = math.nextafter(t, math.inf)
            d = mpmath.mpf(t) - mpmath.mpf(t0)
            want = float(2 / lam ** 2 * mpmath.exp(-lam * c * d))
            got = A.physical("velocity_var", t, mu=mu, h=h, g=g, t0=t0)
            assert got == pytest.approx(want, rel=1e-9, abs=0)

    # The same elapsed time reaches the integrals: just after the switch-off they have moved
    # by a part in 1e15 at most from their values at t0, never by a whole ulp of tau0.
    t = math.nextafter(t0, math.inf)
    for name in ("distance_mean", "displacement_var", "distance_var"):
        at = A.physical(name, t0, mu=mu, h=h, g=g, t0=t0)
        after = A.physical(name, t, mu=mu, h=h, g=g, t0=t0)
        assert after == pytest.approx(at, rel=1e-12, abs=0)
