"""The default step resolves every output time and the switch-off, in any units.

Scenes whose horizon is far shorter than the default step (0.01 in scaled time): with a
uniform grid of that step a path used to reach t0 in a handful of steps (one with "exact",
four with "richardson"), and the mean distance was off by up to 25 %. The default grid is
graded (``DEFAULT_MIN_STEPS`` steps at least before every output time and the switch-off).

Tolerances: 4.5 standard errors (var_stderr for variances) plus the measured worst relative
bias at DEFAULT_MIN_STEPS = 64 steps in the Brownian limit, where the relative bias is
largest and depends on the step count only (bench/resolution.py,
bench/results/resolution.json): richardson 1.4e-5 (distance variance), exact 5.9e-4 (mean
distance); taken as 1e-4 and 1e-3. The stop quantities are exact given the state at t0, whose
integrals carry the same bias.
"""

import math

import numpy as np
import pytest

import crandall
from crandall import analytic
from crandall.methods import DEFAULT_MIN_STEPS

BIAS = {"richardson": 1e-4, "exact": 1e-3}
Z = 4.5


def _si(mu, h, t0, times):
    scene = crandall.Scene(mu=mu, h=h, t0=t0, times=times)

    def ref(name, t=None):
        return analytic.physical(name, t, mu=mu, h=h, t0=t0)

    return scene, ref


def _scaled(tau0, times):
    scene = crandall.Scene.scaled(tau0=tau0, times=times)

    def ref(name, t=None):
        f = getattr(analytic, name)
        return f(tau0) if t is None else f(t, tau0)

    return scene, ref


SCENES = {
    # The reproducer: the default dt is 2.08 s, t0 is 0.1 s.
    "SI mu=0.01 h=1": lambda: _si(0.01, 1.0, 0.1, [0.05, 0.1, 1.0]),
    # Extreme units: tau0 = 5e-48.
    "SI mu=1e-12 h=1e12": lambda: _si(1e-12, 1e12, 0.1, [0.05, 0.1, 1.0]),
    "scaled tau0=1e-8": lambda: _scaled(1e-8, [0.5e-8, 1e-8, 1e-7]),
    "scaled tau0=1e-4": lambda: _scaled(1e-4, [0.5e-4, 1e-4, 1e-3]),
}


def _check(scene, ref, method, paths, seed):
    r = crandall.simulate(scene, paths=paths, seed=seed, method=method)
    bias = BIAS[method]
    on = scene.times[scene.times <= scene.t0]
    k = len(on)
    failures = []
    checks = [
        ("distance", "distance_mean", r.mean("distance")[:k], r.stderr("distance")[:k], on),
        ("distance var", "distance_var", r.var("distance")[:k], r.var_stderr("distance")[:k],
         on),
        ("displacement var", "displacement_var", r.var("displacement")[:k],
         r.var_stderr("displacement")[:k], on),
        ("distance at stop", "distance_at_stop_mean", r.mean("distance_at_stop"),
         r.stderr("distance_at_stop"), None),
        ("distance at stop var", "distance_at_stop_var", r.var("distance_at_stop"),
         r.var_stderr("distance_at_stop"), None),
    ]
    for label, name, sim, se, t in checks:
        expected = np.asarray(ref(name, t), dtype=float)
        tol = Z * np.asarray(se) + bias * np.abs(expected)
        z = (np.asarray(sim) - expected) / np.asarray(se)
        if not np.all(np.abs(np.asarray(sim) - expected) <= tol):
            failures.append(f"{label}: sim {sim} ref {expected} z {z}")
    assert not failures, f"{scene!r} {method}: " + "; ".join(failures)


def test_default_min_steps_is_the_measured_one():
    assert DEFAULT_MIN_STEPS == 64


@pytest.mark.parametrize("name", list(SCENES))
def test_default_step_resolves_short_horizons_exact(name):
    # The exact method's 25 % error in the mean distance (one step to t0/2) needs few paths.
    scene, ref = SCENES[name]()
    _check(scene, ref, "exact", paths=100_000, seed=4)


@pytest.mark.slow
@pytest.mark.parametrize("name", list(SCENES))
def test_default_step_resolves_short_horizons_richardson(name):
    # richardson on 4 steps: distance variance -1.7e-2 relative at t0/2, 5 to 6 standard
    # errors at this path count (var_stderr / var about 1.5e-3).
    scene, ref = SCENES[name]()
    _check(scene, ref, "richardson", paths=1_000_000, seed=4)


def test_default_grid_is_graded_and_explicit_dt_is_not():
    scene = crandall.Scene.scaled(tau0=1e-6, times=[1e-6, 5.0], observe=["distance"])
    r = crandall.simulate(scene, paths=10, seed=1)
    assert r.min_steps == DEFAULT_MIN_STEPS
    # 64 steps to t0 (rounded to richardson's groups of 4); t = 5 is in closed form.
    assert r.steps_per_path == 64
    r = crandall.simulate(scene, paths=10, seed=1, dt=0.01)
    assert r.min_steps == 0 and r.steps_per_path == 4
    noise_on = crandall.Scene.scaled(tau0=math.inf, times=[1e-3, 1.0], observe=["distance"])
    r = crandall.simulate(noise_on, paths=10, seed=1, method="exact")
    # 64 steps to 1e-3, then steps of at most min(0.01, 1 / 64) = 0.01: 100 more.
    assert r.steps_per_path == 64 + 100
