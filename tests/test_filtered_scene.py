"""A filtered excitation through the public API: the scene reaches the core, the frictionless
velocity is minus the ground's (its variance Van Loan's, computed here with SciPy), static
friction holds a body whose ground never exceeds it, the white-noise limit at large omega,
and what the white-noise machinery refuses."""

import math

import numpy as np
import pytest

import crandall
from crandall import KanaiTajimi, ParameterError, Scene

scipy_linalg = pytest.importorskip("scipy.linalg")


def _kt(**kw):
    return KanaiTajimi(omega=kw.pop("omega", 2.0), zeta=0.6, **kw)


def _van_loan_ground_velocity_var(omega, zeta, h, t):
    """Var of the ground velocity G(t) = int_0^t a_g from rest: the (G, G) entry of the
    augmented system's covariance by Van Loan's block exponential (SciPy's expm)."""
    a = np.array([[0.0, 1.0, 0.0], [-omega ** 2, -2 * zeta * omega, 0.0],
                  [-omega ** 2, -2 * zeta * omega, 0.0]])
    b = np.array([0.0, -1.0, 0.0]) * h
    m = np.zeros((6, 6))
    m[:3, :3], m[:3, 3:], m[3:, 3:] = -a, np.outer(b, b), a.T
    e = scipy_linalg.expm(m * t)
    phi = e[3:, 3:].T
    return (phi @ e[:3, 3:])[2, 2]


def test_without_friction_the_velocity_is_minus_the_ground_velocity():
    # mu = 0: V(t) = -G(t), Gaussian with Van Loan's variance. 20,000 paths: the sample
    # variance's standard error is the run's var_stderr; 4 of them (and the bias estimate's
    # scale does not enter: nothing is located).
    sc = Scene(mu=0.0, g=1.0, excitation=_kt(h=1.0), t0=math.inf, times=[0.5, 2.0, 5.0],
               observe=["velocity"])
    r = crandall.simulate(sc, paths=20000, seed=11)
    expected = [_van_loan_ground_velocity_var(2.0, 0.6, 1.0, t) for t in sc.times]
    assert np.all(np.abs(r.var("velocity") - expected) <= 4 * r.var_stderr("velocity")), (
        r.var("velocity"), expected)
    assert np.all(np.abs(r.mean("velocity")) <= 4 * r.stderr("velocity"))


def test_static_friction_above_the_ground_keeps_the_body_at_rest():
    # mu_static g far above any acceleration the ground reaches in 2 s (its sd is 1.4): no
    # path ever slides, exactly.
    sc = Scene(mu=0.5, mu_static=50.0, g=1.0, excitation=_kt(h=1.0), t0=2.0, times=[1.0, 2.0])
    r = crandall.simulate(sc, paths=2000, seed=3)
    for name in ("velocity", "distance", "distance_at_stop", "displacement_at_stop"):
        assert np.all(np.asarray(r.mean(name)) == 0.0) and np.all(np.asarray(r.var(name)) == 0.0)


def test_the_default_method_is_exact_and_the_white_noise_methods_are_refused():
    sc = Scene(mu=1.0, g=1.0, excitation=_kt(h=1.0), t0=1.0, times=[0.5])
    r = crandall.simulate(sc, paths=100, seed=1)
    assert r.method == "exact" and not r.exact("velocity")
    for method in ("richardson", "richardson2", "euler", "refine"):
        with pytest.raises(ParameterError, match="runs with 'exact'") as exc:
            crandall.simulate(sc, paths=100, seed=1, method=method)
        assert exc.value.name == "method"


def test_the_default_step_resolves_the_filter():
    slow = Scene(mu=1.0, g=1.0, excitation=_kt(omega=0.5, h=1.0), t0=10.0, times=[5.0])
    fast = Scene(mu=1.0, g=1.0, excitation=_kt(omega=40.0, h=1.0), t0=10.0, times=[5.0])
    white = Scene(mu=1.0, g=1.0, h=1.0, t0=10.0, times=[5.0])
    # 0.1 t* (t* = 2 h^2 / (mu g)^2 = 2 s), at most 1 / omega.
    assert crandall.default_dt(slow) == pytest.approx(0.2)
    assert crandall.default_dt(white) == pytest.approx(0.02)
    assert crandall.default_dt(fast) == pytest.approx(1.0 / 40.0)


def test_a_filtered_result_saves_and_loads(tmp_path):
    pytest.importorskip("xarray")
    sc = Scene(mu=1.0, mu_static=1.2, g=1.0, excitation=_kt(h=1.0), t0=2.0, times=[1.0, 2.0])
    r = crandall.simulate(sc, paths=500, seed=2)
    r.save(tmp_path / "r.nc")
    back = crandall.load(tmp_path / "r.nc")
    assert back.scene == sc and back.scene.excitation == sc.excitation
    assert np.array_equal(back.mean("distance"), r.mean("distance"))
    assert np.array_equal(back.var_stderr("kinetic_energy"), r.var_stderr("kinetic_energy"))
