"""Var U2(tau) and Var U3(tau) after the switch-off (docs/analytic.md, "Var U2 and Var U3
during the coast"): limits at the switch-off and at the stop, the expansion just after tau0
against numerically inverted moments, the pieces against mpmath, the whole against an
independent quadrature of the Markov formula with the full transition density, and (slow)
against simulation."""

import json
import math
from pathlib import Path

import mpmath
import numpy as np
import pytest
from scipy.integrate import quad
from scipy.special import erfc

import crandall
import crandall.analytic as A
from crandall.analytic import _data, coast_var

TAU0S = [1e-100, 1e-8, 1e-3, 0.05, 1.0, 5.0, 50.0, 139.0, 141.0, 1e3, 1e6]


@pytest.mark.parametrize("t0", TAU0S)
def test_limit_at_the_stop(t0):
    """tau -> infinity: the closed forms at the stop (eq14), reached continuously: the
    quadrature just before the switch to the closed form agrees with it."""
    far = t0 + 1e3 * max(1.0, math.sqrt(t0))
    assert A.displacement_var(far, t0) == A.displacement_at_stop_var(t0)
    assert A.distance_var(far, t0) == A.distance_at_stop_var(t0)
    just_before = t0 + coast_var._reach(t0) / 2 * (1 - 1e-9)
    np.testing.assert_allclose(A.displacement_var(just_before, t0), A.displacement_at_stop_var(t0),
                               rtol=1e-12)
    np.testing.assert_allclose(A.distance_var(just_before, t0), A.distance_at_stop_var(t0),
                               rtol=1e-12)


@pytest.mark.parametrize("t0", [1e-3, 0.05, 1.0, 5.0, 50.0])
def test_expansion_just_after_switch_off(t0):
    """tau -> tau0+: with g(a) = a delta - delta^2 for a > 2 delta (the rest costs O(delta^3)),

        Var U2(tau0 + delta) = m020 + 2 delta m110 + delta^2 (m200 - 2 E[sign(U1) U2]),
        Var U3(tau0 + delta) = Var U3 + 2 delta Cov(U3, |U1|) + delta^2 Var |U1|,

    every moment at tau0 by Talbot inversion of the Laplace recursion (A.moment,
    A.signed_moment), independent of the coast code. delta = 1e-5 * scale of |U1(tau0)|: the
    O(delta^3) remainder is below 1e-11 of the value; observed agreement 1e-12 or better."""
    d = 1e-5 * min(math.sqrt(t0), 1.0)
    m110 = A.moment(1, 1, 0, t0)
    s010 = A.signed_moment(0, 1, 0, t0)
    s101 = A.signed_moment(1, 0, 1, t0)
    m200, ea = A.velocity_var(t0), A.velocity_abs_mean(t0)
    u2 = A.displacement_var(t0) + 2 * d * m110 + d * d * (m200 - 2 * s010)
    u3 = A.distance_var(t0) + 2 * d * (s101 - A.distance_mean(t0) * ea) + d * d * (m200 - ea**2)
    np.testing.assert_allclose(A.displacement_var(t0 + d, t0), u2, rtol=1e-10)
    np.testing.assert_allclose(A.distance_var(t0 + d, t0), u3, rtol=1e-10)
    # and at tau = tau0 exactly, the noise-on values
    assert A.displacement_var(t0, t0) == A.displacement_var(t0)
    assert A.distance_var(t0, t0) == A.distance_var(t0)


@pytest.mark.parametrize("t0", [1e-3, 0.3, 5.0, 200.0])
def test_mixed_terms_reproduce_closed_moments(t0):
    """At c beyond every |U1(tau0)| with weight, g_c(a) = a^2/4: the functional must give
    A[y^2/4] = E[U1 |U1| U2]/4 (S210) and Cov(U3, U1^2/4) = (m201 - m001 m200)/4, moments
    known in closed form from the Laplace transform (docs/analytic.md, section 2)."""
    L = min(math.sqrt(t0), 1.0)
    out = coast_var._mixed(np.array([1e3]), t0, ("displacement", "distance"))
    ag, ad = out["displacement"], out["distance"]
    t = np.array([t0])
    np.testing.assert_allclose(t0 * L**3 * ag[0], _data.S210(t)[0] / 4, rtol=1e-13)
    cov = (_data.M201(t) - _data.M001(t) * _data.M200(t))[0] / 4
    np.testing.assert_allclose(t0 * L**3 * ad[0], cov, rtol=1e-13)


@pytest.mark.parametrize("t0", [1e-99, 1e-60, 1e-40])
def test_tiny_tau0_scaling(t0):
    """Below tau0 = 1e-100 the variances are evaluated at 1e-100 and rescaled as
    tau0^2 F(c / sqrt tau0) (the drift's relative effect, O(sqrt tau0), is below 1e-50 there).
    Above, the direct evaluation must obey the same scaling to double precision."""
    c = np.array([1e-3, 0.3, 1.0, 3.0, 10.0]) * math.sqrt(t0)
    cs = c * math.sqrt(1e-100 / t0)
    for which in ("displacement", "distance"):
        direct = coast_var._evaluate(c, t0, which)
        scaled = (t0 / 1e-100) ** 2 * coast_var._evaluate(cs, 1e-100, which)
        np.testing.assert_allclose(scaled, direct, rtol=1e-14)
    # and a denormal tau0 goes through the scaled path without a warning
    assert 0 <= A.displacement_var(1e-160, 1e-320) <= A.displacement_at_stop_var(1e-320) + 1e-323


# --- the pieces against mpmath ------------------------------------------------------------------


def _p_mp(x, y, t):
    """Transition density of U1 from x in time t (noise on), transcribed (docs/analytic.md)."""
    return (mpmath.exp(-(y - x) ** 2 / (4 * t) - (abs(y) - abs(x)) - t) / mpmath.sqrt(4 * mpmath.pi * t)
            + mpmath.exp(-2 * abs(y)) * mpmath.erfc((abs(x) + abs(y) - 2 * t) / (2 * mpmath.sqrt(t))) / 2)


@pytest.mark.parametrize("x,t,K", [(0.3, 0.2, 0.0), (0.3, 0.2, 0.5), (1.5, 0.01, 1.4), (0.05, 3.0, 0.2),
                                   (4.0, 1.0, 0.0), (1e-3, 1e-4, 2e-3)])
def test_killed_moments_against_mpmath(x, t, K):
    """int p(x, y, t) sign(y) (|y| - K)_+^n dy over the whole line (the full transition
    density: paths that reach 0 forget their sign) equals the killed-process moment."""
    with mpmath.workdps(30):
        X, T, KK = mpmath.mpf(x), mpmath.mpf(t), mpmath.mpf(K)
        w = 12 * mpmath.sqrt(T)
        ref = []
        for n in (1, 2):
            f = lambda y, n=n: _p_mp(X, y, T) * mpmath.sign(y) * max(abs(y) - KK, 0) ** n
            pts = sorted({-X - w - KK - 30, -KK, 0, KK, X - w, X, X + w, X + w + KK + 30})
            ref.append(mpmath.quad(f, pts))
    m1, m2 = coast_var._killed_moments(np.array([x]), np.array([t]), K)
    np.testing.assert_allclose([m1[0], m2[0]], [float(r) for r in ref], rtol=1e-12)


@pytest.mark.parametrize("s", [1e-200, 1e-12, 1e-3, 0.049, 0.051, 0.3, 2.0, 20.0])
def test_excess_against_mpmath(s):
    """G(xi, s) = E[(|U1(s)| - E|U1(s)|) 1{|U1(s)| > xi}], the weight of the covariance,
    against 40-digit quadrature of the density (scaled by sqrt(s) so that s = 1e-200 is
    resolved), on either side of the switch at s = 0.05 between its two evaluations."""
    with mpmath.workdps(40):
        S = mpmath.mpf(s)
        r = mpmath.sqrt(S)
        f = lambda u: (mpmath.exp(-u * u / 4 - r * u - S) / mpmath.sqrt(mpmath.pi)
                       + r * mpmath.exp(-2 * r * u) * mpmath.erfc((u - 2 * r) / 2))  # density of |U1|/sqrt(s)
        m = mpmath.quad(lambda u: u * f(u), [0, 1, 10, mpmath.inf])
        for xf in (0.01, 0.3, 1.0, 3.0, 8.0):
            xi = xf * min(math.sqrt(s), 1.0)
            eta = mpmath.mpf(xi) / r
            if eta < m:
                g = mpmath.quad(lambda u: (m - u) * f(u), [0, eta])
            else:
                g = mpmath.quad(lambda u: (u - m) * f(u), [eta, eta + 1, eta + 10, mpmath.inf])
            got = coast_var._excess(np.array([xi]), np.array([s]), _data.S100(np.array([s])))[0]
            assert got == pytest.approx(float(g * r), rel=1e-12, abs=0), (s, xi)


# --- the whole against the Markov formula, computed another way ----------------------------------

_RULE = {"n": 24, "s_panels": 3}  # Gauss-Legendre points per panel, panels in s


def _nodes(edges):
    x, w = np.polynomial.legendre.leggauss(_RULE["n"])
    a, b = edges[..., :-1, None], edges[..., 1:, None]
    shape = edges.shape[:-1] + (-1,)
    return (a + (b - a) * (1 + x) / 2).reshape(shape), ((b - a) / 2 * w).reshape(shape)


def _g(y, c):
    a = np.abs(y)
    return np.where(a <= c, a * a, c * (2 * a - c)) / 4


def _f0(x, s):
    """Density of U1(s) from rest (the paper's f), transcribed."""
    return (np.exp(-x * x / (4 * s) - np.abs(x) - s) / np.sqrt(4 * np.pi * s)
            + 0.5 * np.exp(-2 * np.abs(x)) * erfc((np.abs(x) - 2 * s) / (2 * np.sqrt(s))))


def _excess_over(y, c):
    return np.maximum(np.abs(y) - c, 0.0)


def _propagate(x, t, c, odd, phi=_g):
    """E_x[psi(U1(t))] with the full transition density on the line, psi(y) = sign(y) phi(|y|)
    (odd) or phi(|y|), by quadrature: the Gaussian part in z = (y - x) / (2 sqrt t), the erfc
    part (even in y, so absent for odd psi) in y."""
    rt = math.sqrt(t)
    fixed = [np.full(x.shape, z0) for z0 in (-12.0, -6.0, -3.0, -1.5, 0.0, 1.5, 3.0, 6.0, 12.0)]
    kinks = [-x / (2 * rt), (c - x) / (2 * rt), (-c - x) / (2 * rt)]
    z, wz = _nodes(np.sort(np.clip(np.stack(fixed + kinks, -1), -12, 12), -1))
    y = x[:, None] + 2 * rt * z
    psi = phi(y, c) * (np.sign(y) if odd else 1.0)
    out = np.sum(wz * np.exp(-z * z - (np.abs(y) - np.abs(x)[:, None]) - t) / math.sqrt(math.pi) * psi, -1)
    if not odd:
        lo = np.clip(2 * t - np.abs(x) - 8 * rt, 0, 30)
        hi = np.clip(2 * t - np.abs(x) + 8 * rt, 0, 30)
        yk = np.sort(np.stack([np.zeros(x.shape), lo, hi, np.full(x.shape, min(c, 30.0)),
                               np.full(x.shape, 30.0)], -1), -1)
        yy, wy = _nodes(yk)
        e = 0.5 * np.exp(-2 * yy) * erfc((np.abs(x)[:, None] + yy - 2 * t) / (2 * rt))
        out = out + 2 * np.sum(wy * e * phi(yy, c), -1)
    return out


def _markov(t0, c, odd, phi=_g):
    """E[U2(tau0) sign(X) phi(|X|)] (odd) or E[U3(tau0) phi(|X|)]: by the Markov property
    int_0^tau0 ds int dx f(x, s) h(x) E_x[psi(U1(tau0 - s))], h(x) = x or |x|."""
    th, wth = _nodes(np.linspace(0, 1, _RULE["s_panels"] + 1))  # 3 panels: as good as 8
    s = t0 * np.sin(np.pi * th / 2) ** 2  # sqrt behaviour at both ends
    ws = wth * t0 * np.pi * np.sin(np.pi * th / 2) * np.cos(np.pi * th / 2)
    total = 0.0
    for si, wsi in zip(s, ws):
        ti = t0 - si
        X = min(16 * math.sqrt(si), 24)
        rt = math.sqrt(ti)
        xk = [-X, -X / 2, -X / 4, -X / 8, -X / 16, 0, X / 16, X / 8, X / 4, X / 2, X,
              c - 4 * rt, c, c + 4 * rt, -c + 4 * rt, -c, -c - 4 * rt, 4 * rt, -4 * rt]
        x, wx = _nodes(np.unique(np.clip(xk, -X, X)))
        h = x if odd else np.abs(x)
        total += wsi * np.sum(wx * _f0(x, si) * h * _propagate(x, ti, c, odd, phi))
    return total


def _markov_variances(t0, tau):
    c = 2 * (tau - t0)
    rho = lambda y: 2 * float(A.velocity_pdf(y, t0))
    g = lambda y: float(_g(np.array(y), c))
    kw = dict(points=[c], epsabs=0, epsrel=1e-13, limit=200)
    eg = quad(lambda y: rho(y) * g(y), 0, 40, **kw)[0]
    eg2 = quad(lambda y: rho(y) * g(y) ** 2, 0, 40, **kw)[0]
    t = np.array([t0])
    var2 = _data.M020(t)[0] + 2 * _markov(t0, c, True) + eg2
    var3 = _data.VAR_U3(t)[0] + 2 * (_markov(t0, c, False) - _data.M001(t)[0] * eg) + eg2 - eg**2
    return var2, var3


def _markov_covariances(t0, tau):
    """E[U1 U2](tau) = E[U2(tau0) sigma (a - c)_+] + E[g(a) (a - c)_+] and
    Cov(|U1|, U3)(tau) = Cov(U3(tau0), (a - c)_+) + Cov(g(a), (a - c)_+)."""
    c = 2 * (tau - t0)
    rho = lambda y: 2 * float(A.velocity_pdf(y, t0))
    g = lambda y: float(_g(np.array(y), c))
    ex = lambda y: max(y - c, 0.0)
    kw = dict(points=[c], epsabs=0, epsrel=1e-13, limit=200)
    eg = quad(lambda y: rho(y) * g(y), 0, 40, **kw)[0]
    eex = quad(lambda y: rho(y) * ex(y), 0, 40, **kw)[0]
    egex = quad(lambda y: rho(y) * g(y) * ex(y), 0, 40, **kw)[0]
    m001 = _data.M001(np.array([t0]))[0]
    cov2 = _markov(t0, c, True, _excess_over) + egex
    cov3 = _markov(t0, c, False, _excess_over) - m001 * eex + egex - eg * eex
    return cov2, cov3


def _check_markov(t0, tau, points, covariances=True):
    """Brute force: no killed process, no covariance rewriting, no repeated erfc integrals;
    Gauss-Legendre panels in (s, x, y). Its own error (from 24 to 32 to 40 points per panel):
    1e-12 at tau0 = 1 with 24 points, 9e-11 -> 2e-11 -> 4e-12 at tau0 = 0.05 (the layers of
    width sqrt(t) are the hardest part), while the shipped values stay put. Tolerance 1e-10
    relative (32 points at tau0 = 0.05); with 40 points the four values agree to 1e-14 at
    tau0 = 1 and 5, to 4e-12 at tau0 = 0.05."""
    _RULE["n"] = points
    try:
        var2, var3 = _markov_variances(t0, tau)
        if covariances:
            cov2, cov3 = _markov_covariances(t0, tau)
    finally:
        _RULE["n"] = 24
    np.testing.assert_allclose(A.displacement_var(tau, t0), var2, rtol=1e-10)
    np.testing.assert_allclose(A.distance_var(tau, t0), var3, rtol=1e-10)
    if not covariances:
        return
    np.testing.assert_allclose(A.velocity_displacement_cov(tau, t0), cov2, rtol=1e-10)
    np.testing.assert_allclose(A.velocity_abs_distance_cov(tau, t0), cov3, rtol=1e-10)


def test_against_markov_formula():
    _check_markov(1.0, 1.2, 24, covariances=False)


@pytest.mark.slow
@pytest.mark.parametrize("t0,tau,points", [(1.0, 1.2, 24), (5.0, 5.4, 24), (5.0, 7.0, 24),
                                           (0.05, 0.12, 32)])
def test_against_markov_formula_more_points(t0, tau, points):
    _check_markov(t0, tau, points)


# --- against simulation ------------------------------------------------------------------------

BIAS_FILE = Path(__file__).resolve().parents[1] / "bench" / "results" / "bias.json"


@pytest.mark.slow
def test_against_simulation():
    """The paper's scene (tau0 = 5) at three times during the coast, Richardson on the
    default grid (dt = 0.01), 2e6 paths, fixed seed.

    Tolerance: 5 standard errors of the simulated variance (var_stderr), combined in
    quadrature with the standard error of the measured bias, plus |bias|. The simulator's
    coast is closed form (coast.hpp), so its only bias is that of the state at tau0; the bias
    of Var U2(tau0) and Var U3(tau0) for Richardson at dt = 0.01 is taken from
    bench/results/bias.json (tau = 5; a few 1e-4 to 3e-3, consistent with 0)."""
    times = [5.5, 6.0, 7.0]
    r = crandall.simulate(crandall.Scene.scaled(tau0=5, times=times), paths=2_000_000, seed=2024,
                          method="richardson")
    assert r.dt == pytest.approx(0.01)
    runs = json.loads(BIAS_FILE.read_text())["runs"]
    run = next(x for x in runs if x["method"] == "richardson" and math.isclose(x["dt"], 0.01))
    for name, func, key in [("displacement", A.displacement_var, "displacement_var"),
                            ("distance", A.distance_var, "distance_var")]:
        q = run["quantities"][key]
        i = q["tau"].index(5.0)
        bias, bias_se = q["bias"][i], q["stderr"][i]
        sim, se = r.var(name), r.var_stderr(name)
        ref = func(np.array(times), 5.0)
        tol = 5 * np.hypot(se, bias_se) + abs(bias)
        assert np.all(np.abs(sim - ref) <= tol), (name, sim, ref, tol)


# --- the two covariances the derivation gives with the variances -------------------------------


def test_shipped_covariance_tables_equal_generator_output():
    pytest.importorskip("sympy")
    from crandall.analytic.symbolic import moment_closed_form

    assert _data.M110 == moment_closed_form(1, 1, 0)
    assert _data.S101 == moment_closed_form(1, 0, 1, signed=True)


def test_covariances_noise_on_against_inversion():
    ts = np.array([1e-6, 0.05, 0.8, 4.0, 60.0])
    np.testing.assert_allclose(A.velocity_displacement_cov(ts), A.moment(1, 1, 0, ts), rtol=1e-11)
    cov = A.signed_moment(1, 0, 1, ts) - A.velocity_abs_mean(ts) * A.distance_mean(ts)
    np.testing.assert_allclose(A.velocity_abs_distance_cov(ts), cov, rtol=1e-10)
    # Brownian limits at small tau (U1 = sqrt(2) W): E[U1 U2] = tau^2; Var U3 = (3/4 - 16/(9 pi))
    # tau^3, so Cov(|U1|, U3) = (1/2) d Var U3 / d tau = (9/8 - 8/(3 pi)) tau^2
    t = 1e-12
    assert A.velocity_displacement_cov(t) == pytest.approx(t**2, rel=1e-5)
    assert A.distance_var(t) == pytest.approx((0.75 - 16 / (9 * math.pi)) * t**3, rel=1e-5)
    assert A.velocity_abs_distance_cov(t) == pytest.approx((9 / 8 - 8 / (3 * math.pi)) * t**2, rel=1e-5)


@pytest.mark.parametrize("t0", [1e-3, 0.05, 1.0, 5.0, 50.0, 1e3])
def test_covariances_are_half_the_derivatives_of_the_variances(t0):
    """dU2 = U1 dtau and dU3 = |U1| dtau: d Var U2 / d tau = 2 E[U1 U2] and d Var U3 / d tau =
    2 Cov(|U1|, U3), on both sides of tau0. Central differences with step h = 1e-4 of the
    time scale (tau while the noise is on, that of |U1(tau0)| during the coast): truncation
    ~ (h / scale)^2 (observed 1e-8 relative), so rtol 1e-6."""
    scale = min(math.sqrt(t0), 1.0)
    for tau in [t0 / 2, t0 + 0.3 * scale, t0 + 1.5 * scale]:
        h = 1e-4 * min(scale, tau)
        d2 = (A.displacement_var(tau + h, t0) - A.displacement_var(tau - h, t0)) / (2 * h)
        d3 = (A.distance_var(tau + h, t0) - A.distance_var(tau - h, t0)) / (2 * h)
        np.testing.assert_allclose(A.velocity_displacement_cov(tau, t0), d2 / 2, rtol=1e-6)
        np.testing.assert_allclose(A.velocity_abs_distance_cov(tau, t0), d3 / 2, rtol=1e-6)


@pytest.mark.parametrize("t0", [1e-100, 1e-8, 1e-3, 1.0, 5.0, 141.0, 1e6])
def test_covariances_at_switch_off_and_stop(t0):
    """Continuous at tau0: over delta the covariances change by about delta E[U1(tau0)^2],
    relative 2 delta / tau0 at small tau0 and O(delta) at large, so delta = 1e-13 min(tau0, 1)
    moves them by less than 1e-12; 0 once the body has stopped."""
    for func in (A.velocity_displacement_cov, A.velocity_abs_distance_cov):
        np.testing.assert_allclose(func(t0 + 1e-13 * min(t0, 1.0), t0), func(t0), rtol=1e-11)
        assert func(t0 + 1e3 * max(1.0, math.sqrt(t0)), t0) == 0.0
