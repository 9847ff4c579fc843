"""Stop quantities keep full precision at any switch-off time.

The stop instant t0 + |X(t0)| / c cannot be resolved by a double when t0 is large (at t0 = 1e16
the spacing of doubles is 2): the core accumulates the time from the switch-off, and the
reported mean adds t0. The stop-time variance at tau0 = 1e16 used to come out 0.29 instead of
1/16.
"""

import math

import pytest

import crandall
from crandall.analytic import physical


@pytest.mark.parametrize("tau0", [1e3, 1e16, 1e200])
def test_stop_time_variance_at_huge_switch_off(tau0):
    # Stationary law at t0 (density e^{-2|u|}): |U1| ~ Exp(2), so tau_s - tau0 = |U1| / 2 has
    # mean 1/4 and variance 1/16. Tolerance: 4 standard errors (var_stderr, stderr).
    scene = crandall.Scene.scaled(tau0=tau0, times=[tau0], observe=["velocity", "stop"])
    r = crandall.simulate(scene, paths=200_000, seed=1)
    assert abs(r.var("stop_time") - 1 / 16) < 4 * r.var_stderr("stop_time")
    # The mean itself is t0 + 1/4, rounded to the doubles near t0.
    mean = r.mean("stop_time")
    assert abs(mean - (tau0 + 0.25)) <= max(4 * r.stderr("stop_time"), 2 * math.ulp(tau0))


def test_stop_time_variance_with_weak_noise_in_si():
    # h = 1e-9: the time to stop is ~1e-19 s after t0 = 2 s, far below the spacing of doubles
    # at 2 s; its variance (analytic layer, SI) was reported as 0.
    scene = crandall.Scene(mu=0.3, h=1e-9, t0=2.0, times=[1.0], observe=["velocity", "stop"])
    r = crandall.simulate(scene, paths=100_000, seed=3)
    expected = physical("stop_time_var", mu=0.3, h=1e-9, t0=2.0)
    assert abs(r.var("stop_time") - expected) < 4 * r.var_stderr("stop_time")
    assert r.mean("stop_time") == pytest.approx(2.0, rel=1e-15)
