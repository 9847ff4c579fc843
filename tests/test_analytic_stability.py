"""Sweep of crandall.analytic over 1e-8 <= tau <= 1e6 (and |y| <= 1e3 for the density) against
50-digit mpmath evaluations of the formulas transcribed in test_analytic_formulas.py and
docs/analytic.md: relative error below 1e-10, no NaN, no inf, no negative variance, no warning
(pytest runs with filterwarnings = error)."""

import math

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


# --- the whole domain: 0 and 1e-300 <= tau, tau0 <= 1e300 (tau0 also inf) ------------------------
# References: the transcribed formulas above in mpmath with enough digits for the cancellations
# of the closed forms (about 4 |log10 tau| + 40: the O(1) terms cancel down to tau^3 at small
# tau, tau^2 down to tau at large tau), and, after the switch-off, mpmath quadrature of the
# survival function of |U1(tau0)| (a route the package does not use).
WIDE = np.concatenate([[0.0], 10.0 ** np.arange(-300, 301, 15)])


def _ref_at(ref, t):
    dps = 40 + 4 * (abs(int(math.log10(t))) if t > 0 else 0)
    with mp.workdps(dps):
        return ref(mp.mpf(float(t)))


def _close(got, ref, rtol=1e-10):
    """rtol where the value is a normal double, absolute 1e-300 where it underflows."""
    ref = float(ref)
    if abs(ref) > 1e-290:
        return abs(got - ref) <= rtol * abs(ref)
    return abs(got - ref) <= 1e-300


# E[U3^2] ~ tau^2/4 leaves the double range at tau ~ 2.7e154: its own test below
WIDE_CASES = [c for c in CASES if c[0] is not A.distance_second_moment]


@pytest.mark.parametrize("func,ref", WIDE_CASES, ids=[c[0].__name__ for c in WIDE_CASES])
def test_whole_domain_against_mpmath(func, ref):
    got = func(WIDE)
    assert np.all(np.isfinite(got)) and np.all(got >= 0)
    assert got[0] == 0
    for t, g in zip(WIDE[1:], got[1:]):
        assert _close(g, _ref_at(ref, t)), (func.__name__, t, g, float(_ref_at(ref, t)))


MONOTONE = [A.velocity_var, A.velocity_abs_mean, A.distance_mean, A.distance_second_moment,
            A.stop_time_mean, A.distance_at_stop_mean]


@pytest.mark.parametrize("func", MONOTONE, ids=[f.__name__ for f in MONOTONE])
def test_whole_domain_monotone(func):
    """U3 is non-decreasing pathwise; |U1| started at its lower boundary 0 is stochastically
    increasing in time (coupling); tau_s = tau0 + |U1(tau0)|/2; E U3(tau_s) = tau0/2."""
    taus = WIDE if func is not A.distance_second_moment else WIDE[WIDE < 1e154]
    got = func(taus)
    assert np.all(np.diff(got) >= 0)


def test_distance_second_moment_beyond_double_range():
    assert np.isfinite(A.distance_second_moment(2.6e154))
    with pytest.raises(ValueError, match="tau"):
        A.distance_second_moment(1e155)
    assert A.distance_second_moment(2.6e154) == pytest.approx((2.6e154 / 2) ** 2, rel=1e-14)


def test_large_and_small_tau_limits():
    assert A.velocity_var(1e300) == 0.5 and A.velocity_abs_mean(1e300) == 0.5
    assert A.distance_mean(1e300) == pytest.approx(0.5e300, rel=1e-15)
    assert A.distance_var(1e300) == pytest.approx(0.25e300, rel=1e-15)
    assert A.displacement_var(1e300) == pytest.approx(0.625e300, rel=1e-15)
    assert A.stop_time_var(1e300) == 1 / 16
    # Brownian limit at small tau: Var U1 = 2 tau, E|U1| = 2 sqrt(tau/pi)
    assert A.velocity_var(1e-300) == pytest.approx(2e-300, rel=1e-14)
    assert A.velocity_abs_mean(1e-300) == pytest.approx(2 * math.sqrt(1e-300 / math.pi), rel=1e-14)


# --- after the switch-off, both arguments over the whole domain ----------------------------------
TAU0S = np.concatenate([[0.0], 10.0 ** np.arange(-300, 301, 20), [np.inf]])


def test_coast_grid_sane():
    """Every (tau, tau0) of the grid: finite; 0 <= Var U1 <= 1/2 (its stationary value, reached
    from below while the noise is on); 0 <= E U3 <= min(tau, tau0)/2 (E|U1| <= 1/2 while the
    noise is on, E U3(tau_s) = tau0/2, eq7); Var U1 non-decreasing then non-increasing in tau,
    E U3 non-decreasing; tau0 = 0 gives 0 (no noise, no motion)."""
    for t0 in TAU0S:
        vv = A.velocity_var(WIDE, t0)
        dm = A.distance_mean(WIDE, t0)
        assert np.all(np.isfinite(vv)) and np.all(np.isfinite(dm)), t0
        assert np.all(vv >= 0) and np.all(vv <= 0.5), t0
        assert np.all(dm >= 0), t0
        assert np.all(dm <= np.minimum(WIDE, t0) / 2 * (1 + 1e-15)), t0
        on = WIDE <= t0
        assert np.all(np.diff(vv[on]) >= 0) and np.all(np.diff(vv[~on]) <= 0), t0
        assert np.all(np.diff(dm) >= 0), t0
        if t0 == 0:
            assert np.all(vv == 0) and np.all(dm == 0)


@pytest.mark.parametrize("t0", [1e-300, 1e-100, 1e-8, 0.3, 5.0, 1e8, 1e100, 1e298])
def test_stop_values_at_large_tau(t0):
    """tau -> inf at fixed tau0: the body has stopped, Var U1 = 0 and E U3 = tau0/2 (eq7)."""
    assert A.velocity_var(1e300, t0) == 0.0
    assert A.distance_mean(1e300, t0) == pytest.approx(t0 / 2, rel=1e-14)
    assert A.distance_at_stop_mean(t0) == pytest.approx(t0 / 2, rel=1e-14)


def test_reported_cases():
    assert A.velocity_var(1e100, 5.0) == 0.0
    assert A.distance_mean(1e100, 5.0) == pytest.approx(2.5, rel=1e-15)
    # just after a tiny switch-off: E U3(tau0) + delta E|U1(tau0)| to first order
    t0, tau = 1.9e-54, 6.57e-39
    expected = (4 / 3) * t0**1.5 / math.sqrt(math.pi) + (tau - t0) * 2 * math.sqrt(t0 / math.pi)
    assert A.distance_mean(tau, t0) == pytest.approx(expected, rel=1e-12)


def _coast_refs(delta, t0):
    """Var U1(tau0 + delta) = H(2 delta) and E U3(tau0 + delta) - E U3(tau0) = (H(0) - H(2 delta))/4,
    H(c) = E[(|U1(tau0)| - c)_+^2] = int_c^inf 2 (y - c) S(y) dy in closed form (docs/analytic.md):
    4 t i2erfc(v) - sqrt(t) i1erfc(v) - erfc(v)/4 + e^(-2c) erfc(w)/4, v, w = (c +- 2t)/(2 sqrt t),
    checked against quadrature of S in test_coast_after_switch_off_against_quadrature. Here it is
    evaluated with enough digits to absorb every cancellation (the package avoids them instead,
    by other formulas in double precision)."""
    t0, delta = mp.mpf(t0), mp.mpf(delta)
    extra = max(0, -int(mp.log10(t0))) + max(0, int(mp.log10(mp.sqrt(t0) / delta)))
    with mp.workdps(60 + extra):

        def H(c):
            rt = mp.sqrt(t0)
            v, w = (c + 2 * t0) / (2 * rt), (c - 2 * t0) / (2 * rt)
            i0 = mp.erfc(v)
            i1 = mp.exp(-v * v) / mp.sqrt(mp.pi) - v * i0
            i2 = (i0 - 2 * v * i1) / 4
            return 4 * t0 * i2 - rt * i1 - i0 / 4 + mp.exp(-2 * c) * mp.erfc(w) / 4

        h = H(2 * delta)
        return h, (eq10s(t0) - h) / 4


@pytest.mark.parametrize("t0", [1e-300, 1e-120, 1e-20, 1e-3, 0.04, 0.06, 1.0, 7.0, 80.0, 1e6])
def test_coast_whole_range_against_mpmath(t0):
    scale = min(math.sqrt(t0), 0.5)
    fracs = [1e-200, 1e-30, 1e-6, 0.01, 0.3, 1.0, 3.0, 12.0]
    e2 = float(_ref_at(eq10s, t0))
    with mp.workdps(30):
        on_u3 = _ref_at(eq10r, t0)
        for f in fracs:
            tau = t0 + f * scale
            if tau == t0:
                continue
            h, k = _coast_refs(mp.mpf(tau) - mp.mpf(t0), t0)  # the delta the function sees
            vv = A.velocity_var(tau, t0)
            # relative 1e-10 down to 1e-25 E[U1(tau0)^2]; below (Gaussian far tail) absolute
            assert _close(vv, h, 1e-10) or abs(vv - float(h)) < 1e-17 * e2, (t0, f, vv, float(h))
            assert _close(A.distance_mean(tau, t0), on_u3 + k, 1e-10), (t0, f)


def test_coast_small_tau0_random_points():
    """tau0 < 0.05 (where H is evaluated as a sum of positive terms) at random points of a fixed
    seed, against the closed form in mpmath with enough digits."""
    rng = np.random.default_rng(20261121)
    for _ in range(40):
        t0 = float(10 ** rng.uniform(-300, math.log10(0.05)))
        scale = math.sqrt(t0)
        tau = t0 + scale * float(10 ** rng.uniform(-12, 1.3))
        h, k = _coast_refs(mp.mpf(tau) - mp.mpf(t0), t0)
        e2 = float(_ref_at(eq10s, t0))
        vv = A.velocity_var(tau, t0)
        assert _close(vv, h, 1e-12) or abs(vv - float(h)) < 1e-17 * e2, (t0, tau)
        with mp.workdps(40):
            assert _close(A.distance_mean(tau, t0), _ref_at(eq10r, t0) + k, 1e-12), (t0, tau)


# --- Var U2 and Var U3 during the coast, both arguments over the whole domain --------------------
COAST_TAU0S = [0.0, 5e-324, 1e-310, 1e-300, 1e-200, 1e-100, 1e-20, 1e-8, 1e-3, 0.049, 0.051, 1.0, 5.0, 139.9,
               140.1, 1e4, 1e100, 1e300]
COAST_FRACS = np.array([0, 1e-300, 1e-30, 1e-8, 1e-3, 0.1, 0.3, 0.6, 1, 2, 4, 12, 50])


@pytest.mark.parametrize("t0", COAST_TAU0S)
def test_coast_variances_sane(t0):
    """Var U2(tau), Var U3(tau) for tau >= tau0: finite; equal to the noise-on value at tau0;
    non-decreasing in tau (proved in docs/analytic.md: d/d delta Var = 2 E[U2(tau) sigma
    (a - 2 delta)_+] >= 0, resp. 2 Cov(U3(tau), (a - 2 delta)_+) >= 0); hence between the
    value at tau0 and the value at the stop, which they reach. Slack: 1e-12 of the stop value
    (the quadrature is accurate to ~1e-13 there, the closed forms to ~1e-15)."""
    scale = min(math.sqrt(t0), 1.0)
    taus = np.unique(np.concatenate([t0 + scale * COAST_FRACS, [1e300]]))
    for func, on, stop in [(A.displacement_var, A.displacement_var(t0), A.displacement_at_stop_var(t0)),
                           (A.distance_var, A.distance_var(t0), A.distance_at_stop_var(t0))]:
        got = func(taus, t0)
        assert np.all(np.isfinite(got)) and np.all(got >= 0), (func.__name__, t0)
        slack = 1e-12 * stop
        assert got[0] == on and got[-1] == stop, (func.__name__, t0)
        assert np.all(np.diff(got) >= -slack), (func.__name__, t0, got)
        assert np.all((got >= on - slack) & (got <= stop + slack)), (func.__name__, t0)
        if t0 == 0:
            assert np.all(got == 0)


@pytest.mark.parametrize("t0", COAST_TAU0S)
def test_coast_covariances_sane(t0):
    """E[U1 U2] and Cov(|U1|, U3) for tau >= tau0: finite, >= 0 (sums of non-negative terms,
    docs/analytic.md), within Cauchy-Schwarz of the variances, 0 at the stop."""
    scale = min(math.sqrt(t0), 1.0)
    taus = np.unique(np.concatenate([t0 + scale * COAST_FRACS, [1e300]]))
    for func, var in [(A.velocity_displacement_cov, A.displacement_var),
                      (A.velocity_abs_distance_cov, A.distance_var)]:
        got = func(taus, t0)
        assert np.all(np.isfinite(got)) and np.all(got >= 0), (func.__name__, t0)
        bound = np.sqrt(A.velocity_var(taus, t0)) * np.sqrt(var(taus, t0))  # no underflow
        assert np.all(got <= bound * (1 + 1e-9) + 1e-300), (func.__name__, t0)
        if taus[-1] > t0:
            assert got[-1] == 0


def test_coast_variances_never_switched_off():
    taus = np.array([0.0, 1e-8, 1.0, 1e6])
    assert np.array_equal(A.displacement_var(taus, np.inf), A.displacement_var(taus))
    assert np.array_equal(A.distance_var(taus, np.inf), A.distance_var(taus))
