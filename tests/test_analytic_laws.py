"""The law of U1(tau) (noise on and after the switch-off) and of the stop time: CDF, survival,
quantiles, atom. References: mpmath quadrature of the paper's density f(y, tau) as transcribed
in test_analytic_formulas.py (not the package's closed-form CDF), and the package's moment
functions, which come from the Laplace recursion (a route independent of the CDF code)."""

import math

import numpy as np
import pytest
from scipy import integrate

import crandall.analytic as A
from test_analytic_formulas import density, mp

POINTS = [(0.0, 0.3), (0.05, 1e-3), (0.3, 0.3), (1.0, 1.0), (-2.0, 1.0), (4.0, 20.0),
          (0.7, 1e-6 ** 0.5), (12.0, 0.5), (-30.0, 3.0), (1e-3, 5e-7)]


def _sf_mp(y, t):
    """P(U1(t) > y) = int_y^inf f, by mpmath quadrature split at the density's scales."""
    y, t = mp.mpf(y), mp.mpf(t)
    sc = min(mp.sqrt(t), mp.mpf(1) / 2)
    if y < 0:
        return 1 - _sf_mp(-y, t)
    pts = [y + k * sc for k in (0, 1, 4, 16, 64)] + [mp.inf]
    return mp.quad(lambda u: density(u, t), pts)


@pytest.mark.parametrize("y,tau", POINTS)
def test_velocity_sf_cdf_against_quadrature(y, tau):
    ref = _sf_mp(y, tau)
    assert A.velocity_sf(y, tau) == pytest.approx(float(ref), rel=1e-12)
    assert A.velocity_cdf(y, tau) == pytest.approx(float(1 - ref), rel=1e-12)
    # symmetry U1 -> -U1 (the cdf is computed from the sf at -y)
    assert A.velocity_cdf(-y, tau) == pytest.approx(float(ref), rel=1e-12)


def test_velocity_far_tail_keeps_relative_accuracy():
    for y, tau in [(40.0, 1.0), (3.0, 1e-2), (300.0, 10.0)]:
        ref = _sf_mp(y, tau)
        assert 0 < ref < 1e-30
        assert A.velocity_sf(y, tau) == pytest.approx(float(ref), rel=1e-11)
        assert A.velocity_cdf(-y, tau) == pytest.approx(float(ref), rel=1e-11)


@pytest.mark.parametrize("tau", [1e-300, 1e-8, 0.02, 1.0, 30.0, 1e300])
def test_velocity_quantile_inverts_cdf(tau):
    qs = np.array([1e-200, 1e-12, 1e-3, 0.1, 0.3, 0.5, 0.7, 0.9, 0.999, 1 - 1e-12])
    y = A.velocity_quantile(qs, tau)
    assert np.all(np.isfinite(y)) and np.all(np.diff(y) > 0) and y[5] == 0
    lower = qs < 0.5
    np.testing.assert_allclose(A.velocity_cdf(y[lower], tau), qs[lower], rtol=1e-12)
    np.testing.assert_allclose(A.velocity_sf(y[~lower], tau)[1:], (1 - qs[~lower])[1:], rtol=1e-11)
    # symmetry of the law: q and 1 - q are mirror images (both exact in double for these q)
    np.testing.assert_allclose(A.velocity_quantile(0.1, tau), -A.velocity_quantile(0.9, tau),
                               rtol=1e-12)


def test_velocity_quantile_against_mpmath_root():
    for q, tau in [(0.99, 1.0), (0.75, 0.01), (1e-6, 2.0)]:
        with mp.workdps(30):
            ref = mp.findroot(lambda y: 1 - _sf_mp(y, tau) - q, float(A.velocity_quantile(q, tau)) * 1.01)
        assert A.velocity_quantile(q, tau) == pytest.approx(float(ref), rel=1e-11)


@pytest.mark.parametrize("tau,tau0", [(0.5, np.inf), (3.0, np.inf), (0.2, 0.2), (1.2, 1.0),
                                      (2.0, 1.0), (0.02, 0.01), (7.0, 6.5)])
def test_moments_of_the_law(tau, tau0):
    """E U1^2 = int_0^inf 2y P(|U1| > y) dy and E|U1| = int_0^inf P(|U1| > y) dy, from the survival
    function, against velocity_var (recursion / coast formulas) and velocity_abs_mean."""
    surv = lambda y: 2 * A.velocity_sf(y, tau, tau0)  # P(|U1| > y), y > 0
    sc = min(math.sqrt(min(tau, tau0)), 0.5)
    pts = [0, sc, 4 * sc, 16 * sc, 64 * sc, 400 * sc]
    m2 = sum(integrate.quad(lambda y: 2 * y * surv(y), a, b, epsabs=0, epsrel=1e-13)[0]
             for a, b in zip(pts[:-1], pts[1:]))
    m1 = sum(integrate.quad(surv, a, b, epsabs=0, epsrel=1e-13)[0] for a, b in zip(pts[:-1], pts[1:]))
    assert m2 == pytest.approx(A.velocity_var(tau, tau0), rel=1e-9)
    if tau <= tau0:
        assert m1 == pytest.approx(A.velocity_abs_mean(tau), rel=1e-9)


@pytest.mark.parametrize("tau,tau0", [(1.2, 1.0), (2.0, 1.0), (0.02, 0.01), (1.0 + 1e-9, 1.0)])
def test_after_switch_off_atom_plus_density(tau, tau0):
    atom = A.velocity_atom(tau, tau0)
    assert atom == pytest.approx(A.stop_time_cdf(tau, tau0), rel=1e-14)
    # the CDF jumps by the atom at 0
    assert A.velocity_cdf(0.0, tau, tau0) - A.velocity_cdf(-1e-300, tau, tau0) == pytest.approx(
        atom, rel=1e-9, abs=1e-16)
    # total mass: atom + continuous part = 1; the continuous part is f shifted (eq13a)
    sc = min(math.sqrt(tau0), 0.5)
    cont = 2 * sum(integrate.quad(lambda y: A.velocity_pdf(y, tau, tau0), a, b, epsrel=1e-13)[0]
                   for a, b in [(0, sc), (sc, 8 * sc), (8 * sc, 100 * sc)])
    assert atom + cont == pytest.approx(1.0, rel=1e-11)
    delta = tau - tau0
    with mp.workdps(40):
        ref_atom = 1 - 2 * _sf_mp(2 * mp.mpf(delta), tau0)
        assert atom == pytest.approx(float(ref_atom), rel=1e-9)
    assert A.velocity_pdf(0.3, tau, tau0) == pytest.approx(float(density(0.3 + 2 * delta, tau0)),
                                                           rel=1e-12)
    # quantiles: inside the atom 0, outside the shifted quantile of U1(tau0)
    q = A.velocity_sf(0.0, tau, tau0)  # P(U1(tau) > 0)
    assert A.velocity_quantile(0.5, tau, tau0) == 0.0
    if q > 1e-3:
        y = A.velocity_quantile(1 - q / 2, tau, tau0)
        assert y > 0
        assert A.velocity_sf(y, tau, tau0) == pytest.approx(q / 2, rel=1e-10)


def test_velocity_atom_limits():
    assert A.velocity_atom(0.0, 1.0) == 1.0 and A.velocity_atom(5.0, 0.0) == 1.0
    assert A.velocity_atom(0.7, 1.0) == 0.0
    assert A.velocity_atom(1e300, 1.0) == 1.0
    # just after the switch-off: P(|X| <= 2 delta) ~ 4 delta f(0; tau0), kept relative
    d = 1e-12
    assert A.velocity_atom(1.0 + d, 1.0) == pytest.approx(
        4 * (1.0 + d - 1.0) * float(density(0, 1.0)), rel=1e-6)


@pytest.mark.parametrize("tau0", [1e-300, 1e-6, 0.05, 1.0, 8.0, 1e300])
def test_stop_time_law(tau0):
    qs = np.array([1e-100, 1e-8, 0.05, 0.5, 0.95, 0.999999])
    t = A.stop_time_quantile(qs, tau0)
    assert np.all(t >= tau0) and np.all(np.diff(t) >= 0)
    # round trip where t - tau0 is resolved by doubles (a stop time is an absolute time: a
    # quantile tau0 + 1e-100 rounds to tau0 when tau0 = 1)
    ok = (t - tau0) > 1e-6 * tau0
    lo = (qs < 0.5) & ok
    np.testing.assert_allclose(A.stop_time_cdf(t[lo], tau0), qs[lo], rtol=1e-9)
    hi = (qs >= 0.5) & ok
    np.testing.assert_allclose(A.stop_time_sf(t[hi], tau0), 1 - qs[hi], rtol=1e-9)
    # the smallest q: P(|X| <= y) = 2 f(0; tau0) y + O(y^2), so t - tau0 = q / (4 f(0; tau0))
    # to within one ulp of tau0
    expected = qs[0] / (4 * float(density(0, tau0)))
    assert abs((t[0] - tau0) - expected) <= 1e-9 * expected + 2 * np.spacing(tau0)
    assert A.stop_time_cdf(tau0 * (1 - 1e-15) if tau0 > 0 else -1.0, tau0) == 0.0


@pytest.mark.parametrize("tau0", [0.01, 0.7, 5.0])
def test_stop_time_law_against_density_and_moments(tau0):
    with mp.workdps(30):
        for s in [1e-6, 0.01, 0.2, 1.0]:
            t = tau0 + s * min(math.sqrt(tau0), 0.5)
            ref = 1 - 2 * _sf_mp(2 * (mp.mpf(t) - tau0), tau0)  # P(|X| <= 2(t - tau0))
            assert A.stop_time_cdf(t, tau0) == pytest.approx(float(ref), rel=1e-9)
    sc = min(math.sqrt(tau0), 0.5)
    pts = [tau0 + k * sc for k in (0, 0.5, 2, 8, 32, 200)]
    e1 = tau0 + sum(integrate.quad(lambda t: A.stop_time_sf(t, tau0), a, b, epsabs=0,
                                   epsrel=1e-13)[0] for a, b in zip(pts[:-1], pts[1:]))
    e2 = sum(integrate.quad(lambda t: 2 * (t - tau0) * A.stop_time_sf(t, tau0), a, b, epsabs=0,
                            epsrel=1e-13)[0] for a, b in zip(pts[:-1], pts[1:]))
    assert e1 == pytest.approx(A.stop_time_mean(tau0), rel=1e-10)
    assert e2 - (e1 - tau0) ** 2 == pytest.approx(A.stop_time_var(tau0), rel=1e-8)


def test_law_inputs_refused_by_name():
    for bad in ["0.5", True, 1j, None]:
        with pytest.raises(ValueError, match=r"\bq\b"):
            A.velocity_quantile(bad, 1.0)
        with pytest.raises(ValueError, match=r"\by\b"):
            A.velocity_cdf(bad, 1.0)
        with pytest.raises(ValueError, match=r"\btau0\b"):
            A.stop_time_cdf(1.0, bad)
    for q in [0.0, 1.0, -0.1, math.nan, 2.0]:
        with pytest.raises(ValueError, match=r"\bq\b"):
            A.stop_time_quantile(q, 1.0)
    with pytest.raises(ValueError, match=r"\btau0\b"):
        A.velocity_pdf(0.1, 2.0, 0.0)


# --- against simulation: the kernel's exact velocity step from rest ------------------------------
# Kolmogorov-Smirnov at a fixed seed; the level of each test is 1e-3 (a correct CDF fails it
# with probability 1e-3 for a random seed; the seed is fixed, so the outcome is reproducible).
from scipy import stats  # noqa: E402

from crandall import _core  # noqa: E402

N_SIM = 20_000


def _u1(tau, seed):
    return _core.exact_steps(np.zeros(N_SIM), float(tau), 2.0, math.sqrt(2.0), seed)


@pytest.mark.parametrize("tau", [0.05, 1.0, 4.0])
def test_velocity_cdf_against_exact_steps(tau):
    x = _u1(tau, 700 + int(100 * tau))
    assert stats.kstest(x, lambda y: A.velocity_cdf(y, tau)).pvalue > 1e-3
    # quantiles: the fraction of samples below the 5 % and 95 % quantiles, binomial 4.5 SE
    for q in (0.05, 0.95):
        frac = np.mean(x <= A.velocity_quantile(q, tau))
        assert abs(frac - q) < 4.5 * math.sqrt(q * (1 - q) / N_SIM)


@pytest.mark.parametrize("tau0,delta", [(0.3, 0.1), (2.0, 0.25)])
def test_coast_law_and_stop_time_against_exact_steps(tau0, delta):
    x = _u1(tau0, 900 + int(10 * tau0))
    stop = tau0 + np.abs(x) / 2  # eq14
    assert stats.kstest(stop, lambda t: A.stop_time_cdf(t, tau0)).pvalue > 1e-3
    u = np.sign(x) * np.maximum(np.abs(x) - 2 * delta, 0.0)  # the coast, eq13a
    atom = float(A.velocity_atom(tau0 + delta, tau0))
    frac0 = np.mean(u == 0)
    assert abs(frac0 - atom) < 4.5 * math.sqrt(atom * (1 - atom) / N_SIM)
    moving = u[u != 0]
    # conditional law of the moving part: (CDF - atom jump) / (1 - atom)
    def cond_cdf(y):
        c = A.velocity_cdf(y, tau0 + delta, tau0)
        return np.where(y < 0, c, c - atom) / (1 - atom)
    assert stats.kstest(moving, cond_cdf).pvalue > 1e-3
