"""The kernel against the plain NumPy reference of tests/reference_kernel.py.

The kernel returns moments only: the reference's paths give the same statistics computed in
NumPy, to about 1e-12 relative (the sums run in another order; each path's numbers are the
same operations on the same draws, so only the summation differs).
"""

import math

import numpy as np
import pytest

import crandall
import reference_kernel as ref

TIMES = [0.25, 0.5, 1.0, 1.5]  # the last after the switch-off: reached by the coast
TAU0 = 1.0
PATHS = 64
# 64 paths: the sums' rounding is ~64 ulp at worst; the spread of a statistic sets its scale.
RTOL = 1e-12


def close(got, want, scale, what):
    got, want = np.asarray(got, float), np.asarray(want, float)
    tol = RTOL * (np.abs(want) + scale)
    assert np.all(np.abs(got - want) <= tol), (what, got, want)


@pytest.mark.parametrize("method", ["exact", "richardson", "richardson2"])
def test_kernel_statistics_are_the_reference_paths(method):
    scene = crandall.Scene.scaled(tau0=TAU0, times=TIMES,
                                  observe=["velocity", "displacement", "distance", "stop"])
    r = crandall.simulate(scene, paths=PATHS, seed=99, dt=0.1, method=method, threads=1)
    paths = ref.run(seed=99, paths=PATHS, times=TIMES, t0=TAU0, dt=0.1, method=method)
    assert r.steps_per_path == paths["steps"]
    for name, key in (("velocity", "x"), ("displacement", "u"), ("distance", "s")):
        mean, var = ref.mean_and_var(paths[key], method)
        close(r.var(name), var, 0.0, f"{method} var {name}")
        close(r.mean(name), mean, np.sqrt(var), f"{method} mean {name}")
    for i, name in enumerate(("stop_time", "displacement_at_stop", "distance_at_stop")):
        mean, var = ref.mean_and_var(paths["stop"][:, i], method)
        if name == "stop_time":
            mean = mean + TAU0  # the kernel keeps the time from the switch-off
        close(r.var(name), var, 0.0, f"{method} var {name}")
        close(r.mean(name), mean, math.sqrt(var), f"{method} mean {name}")


def test_the_comparison_can_fail():
    # The extrapolation matters at this tolerance: the fine grid alone (the richardson run's
    # grid 0, as "exact" would report it) is 20 % off in the variance of the distance.
    scene = crandall.Scene.scaled(tau0=TAU0, times=TIMES,
                                  observe=["velocity", "displacement", "distance", "stop"])
    r = crandall.simulate(scene, paths=PATHS, seed=99, dt=0.1, method="richardson", threads=1)
    paths = ref.run(seed=99, paths=PATHS, times=TIMES, t0=TAU0, dt=0.1, method="richardson")
    _, fine_only = ref.mean_and_var(paths["s"][:1], "exact")
    with pytest.raises(AssertionError):
        close(r.var("distance"), fine_only, 0.0, "fine grid only")
