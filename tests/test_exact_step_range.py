"""The exact velocity step has the exact transition law for every step length.

One step of length t of dX = -2 sign(X) dt + sqrt(2) dW (the paper's eq3) from x has the density
(docs/exact-step.md)

    p(x, y, t) = (4 pi t)^(-1/2) exp(-(y - x)^2 / (4 t) - (|y| - |x|) - t)
                 + (1/2) e^(-2|y|) erfc((|x| + |y| - 2t) / (2 sqrt t)),

whose distribution function is integrated in closed form below (and checked against numerical
quadrature of the density). Long steps used to lose the law to cancellation: Var U1 came out
0.508 at tau = 1e15, 1.26 at 1e16, 0 beyond, NaN at 1e300; a physical scene with h = 1e-9
(steps of 4e16 scaled units) gave a distance 6 times too small.
"""

import math

import numpy as np
import pytest
from scipy import integrate, special

import crandall
from crandall import _core
from crandall.analytic import physical


def transition_cdf(y, x, t):
    """P(X_t <= y | X_0 = x) for the scaled velocity, in closed form.

    The Gaussian part is, after completing the square, N(x - 2t, 2t) on y > 0 times
    e^(|x| - x) and N(x + 2t, 2t) on y < 0 times e^(|x| + x). The reflected part integrates by
    parts: int_0^Y e^(-2u) g(u) du = (g(0) - e^(-2Y) g(Y)) / 2 - e^(2|x|) (erfc(a) - erfc(b)) / 2
    with g(u) = erfc((|x| + u - 2t) / (2 sqrt t)), a = (|x| + 2t) / (2 sqrt t), b = a + Y / (2 sqrt t).
    """
    y = np.asarray(y, dtype=float)
    ax, st, r = abs(x), math.sqrt(2.0 * t), 2.0 * math.sqrt(t)
    below = np.exp(ax + x + special.log_ndtr((np.minimum(y, 0.0) - x - 2.0 * t) / st))
    above = np.where(
        y > 0,
        np.exp(ax - x) * (special.ndtr((np.maximum(y, 0.0) - x + 2.0 * t) / st)
                          - special.ndtr((2.0 * t - x) / st)),
        0.0,
    )
    a = (ax + 2.0 * t) / r

    def g(u):
        return special.erfc((ax + u - 2.0 * t) / r)

    def half_mass(big_y):  # reflected mass on [0, Y]
        b = (big_y + ax + 2.0 * t) / r
        return 0.25 * (g(0.0) - np.exp(-2.0 * big_y) * g(big_y)) - 0.25 * math.exp(2.0 * ax) * (
            special.erfc(a) - special.erfc(b))

    total = 0.25 * g(0.0) - 0.25 * math.exp(2.0 * ax) * special.erfc(a)
    reflected = np.where(y > 0, total + half_mass(np.abs(y)), total - half_mass(np.abs(y)))
    return below + above + reflected


def transition_density(y, x, t):
    return (math.exp(-(y - x) ** 2 / (4 * t) - (abs(y) - abs(x)) - t) / math.sqrt(4 * math.pi * t)
            + 0.5 * math.exp(-2 * abs(y)) * math.erfc((abs(x) + abs(y) - 2 * t) / (2 * math.sqrt(t))))


@pytest.mark.parametrize("x", [0.0, 0.4, -1.3])
@pytest.mark.parametrize("t", [0.01, 0.3, 2.0, 10.0])
def test_closed_form_cdf_matches_quadrature_of_the_density(x, t):
    for y in (-3.0, -1.0, -0.2, 0.0, 0.1, 0.5, 2.0):
        points = [p for p in (0.0, x) if -40 < p < y] or None
        num = integrate.quad(transition_density, -40, y, args=(x, t), points=points,
                             limit=500, epsabs=1e-13)[0]
        assert abs(num - transition_cdf(y, x, t)) < 1e-12
    assert transition_cdf(1e3, x, t) == pytest.approx(1.0, abs=1e-14)


def ks_statistic(sample, cdf_values):
    n = sample.size
    i = np.arange(n)
    return max(np.max(np.abs(cdf_values - i / n)), np.max(np.abs((i + 1) / n - cdf_values)))


STEPS = [1e-300, 1e-12, 1e-9, 1e-6, 1e-3, 1.0, 1e3, 1e6, 1e9, 1e12, 1e15, 1e16, 1e17, 1e18,
         1e100, 1e300]
N = 40_000
# Kolmogorov's asymptotic critical value at level 1e-4 per case (Bonferroni over the 48 cases:
# about 0.5 % family-wise), sqrt(-ln(alpha / 2) / 2) / sqrt(n). The seed is fixed, so a correct
# step passes deterministically; a wrong law at n = 40000 fails by far (the old step had
# KS distances of 0.06 at t = 1e15 and 1 beyond 1e17).
KS_CRITICAL = math.sqrt(-math.log(1e-4 / 2) / 2) / math.sqrt(N)


@pytest.mark.parametrize("t", STEPS)
def test_one_exact_step_has_the_transition_law(t):
    # Below t ~ 1e-20 the spread sqrt(2t) of a step from 0.4 is below the spacing of doubles
    # there; such steps start at the same multiples of sqrt(t) instead.
    unit = math.sqrt(t) if t < 1e-20 else 1.0
    for j, x in enumerate((0.0, 0.4 * unit, -1.3 * unit)):
        y = np.sort(_core.exact_steps(np.full(N, x), t, 2.0, math.sqrt(2.0), 1000 + 7 * j))
        assert np.all(np.isfinite(y))
        d = ks_statistic(y, transition_cdf(y, x, t))
        assert d < KS_CRITICAL, f"x={x} t={t}: KS {d:.4g} >= {KS_CRITICAL:.4g}"


@pytest.mark.parametrize("drift, noise, h", [(2.943, 1e-9, 0.01), (2.943, 1e-12, 1e-4),
                                             (1e-3, 50.0, 1e-6), (7.0, 0.5, 1e250)])
def test_exact_step_in_physical_units(drift, noise, h):
    # dX = -c sign(X) dt + sigma dW is the scaled equation under X = (sigma^2 / c) U and
    # t = (2 sigma^2 / c^2) tau: a step of h is a scaled step of c^2 h / (2 sigma^2).
    tau, v = drift**2 * h / (2 * noise**2), noise**2 / drift
    for j, x in enumerate((0.0, 0.4, -1.3)):
        y = np.sort(_core.exact_steps(np.full(N, x * v), h, drift, noise, 77 + j)) / v
        d = ks_statistic(y, transition_cdf(y, x, tau))
        assert d < KS_CRITICAL, f"x={x} tau={tau}: KS {d:.4g}"


@pytest.mark.parametrize("horizon", [1e15, 1e16, 1e17, 1e300])
def test_velocity_variance_at_long_horizons(horizon):
    # Stationary law: Var U1 = 1/2. Tolerance: 4 standard errors of the variance estimate
    # (var_stderr, from the fourth central moment).
    r = crandall.simulate(crandall.Scene.scaled(tau0=math.inf, times=[horizon], observe="velocity"),
                          paths=200_000, seed=1)
    assert abs(r.var("velocity")[0] - 0.5) < 4 * r.var_stderr("velocity")[0]


def test_step_beyond_the_double_range_is_refused():
    with pytest.raises(ValueError, match="range of doubles"):
        crandall.simulate(crandall.Scene.scaled(tau0=math.inf, times=[1e305], observe="velocity"),
                          paths=10, seed=1)


@pytest.mark.parametrize("h", [1e-9, 1e-10, 1e-12])
def test_physical_scene_with_weak_noise(h):
    # At h = 1e-9 a step of dt = 0.01 s is 4.3e16 scaled units: every step forgets the last, so
    # the velocity at t = 1 s has exactly the stationary law (Var V as in the analytic layer),
    # and the trapezoid rule on steps from X = 0 gives E S = dt sum_k E|V_k| with E|V_0| = 0 and
    # E|V_k| stationary: (1 - 1 / (2n)) times the analytic mean for n = 100 steps (the
    # analytic transient is below 1e-16 of it). Tolerances: 4 standard errors.
    scene = crandall.Scene(mu=0.3, h=h, t0=2.0, times=[1.0], observe=["velocity", "distance"])
    r = crandall.simulate(scene, paths=100_000, seed=1, dt=0.01, method="exact")
    var_v = physical("velocity_var", 1.0, mu=0.3, h=h, t0=2.0)
    assert abs(r.var("velocity")[0] - var_v) < 4 * r.var_stderr("velocity")[0]
    mean_s = physical("distance_mean", 1.0, mu=0.3, h=h, t0=2.0) * (1 - 1 / 200)
    assert abs(r.mean("distance")[0] - mean_s) < 4 * r.stderr("distance")[0]


def test_physical_scene_with_weak_noise_default_method():
    # The default method extrapolates over the grids of steps dt, 2 dt and 4 dt (weights w_j
    # solving sum w_j = 1, sum w_j 2^(j p) = 0 for p = 1.5, 2; docs/methods/richardson.md). On
    # grid j the trapezoid bias of E S is -E|V| 2^j dt / 2 (the first step starts at 0), so the
    # extrapolated mean is the analytic one times 1 - sum_j w_j 2^j / (2 n), n = 100.
    p = np.array([1.5, 2.0])
    a = np.vstack([np.ones(3), [[2.0 ** (j * q) for j in range(3)] for q in p]])
    w = np.linalg.solve(a, [1.0, 0.0, 0.0])
    h = 1e-9
    scene = crandall.Scene(mu=0.3, h=h, t0=2.0, times=[1.0],
                           observe=["velocity", "distance", "stop"])
    r = crandall.simulate(scene, paths=100_000, seed=2, dt=0.01)
    var_v = physical("velocity_var", 1.0, mu=0.3, h=h, t0=2.0)
    assert abs(r.var("velocity")[0] - var_v) < 4 * r.var_stderr("velocity")[0]
    factor = 1 - sum(w[j] * 2.0**j for j in range(3)) / 200
    mean_s = physical("distance_mean", 1.0, mu=0.3, h=h, t0=2.0) * factor
    assert abs(r.mean("distance")[0] - mean_s) < 4 * r.stderr("distance")[0]
