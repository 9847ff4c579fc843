"""The velocity's law across an intensity schedule and from any start
(crandall.analytic.schedule): against the closed forms where the schedule is the paper's (one
intensity, split into pieces; a switch-off as a pause), and against simulation for an
aftershock scene and a start in motion.

Tolerances: the quadrature's error is O(h^2) at the grid of velocity_law (measured 3e-5
relative on the paper's scene at tau = 5); the closed-form checks allow 2e-4. The simulation
checks allow Z = 4 standard errors of the simulated statistic plus its reported bias (the
references are not fitted to the simulation).
"""

import math

import numpy as np
import pytest

import crandall
from crandall import analytic
from crandall.analytic.schedule import distance_mean, noise_energy, stop_time_sf, velocity_law

S2 = math.sqrt(2.0)
Z = 4.0


def test_one_intensity_in_pieces_is_the_closed_form():
    law = velocity_law([(1.0, S2), (2.5, S2), (5.0, S2)], 2.0, 5.0)
    for y in (0.0, 0.7, 3.0, 8.0, 15.0):
        assert math.isclose(law.sf(y), float(analytic.velocity_sf(y, 5.0)), rel_tol=2e-4)
    assert math.isclose(law.moment(2), float(analytic.velocity_var(5.0)), rel_tol=2e-4)
    assert abs(law.moment(1)) < 1e-12  # symmetric
    assert math.isclose(stop_time_sf([(5.0, S2)], 2.0, 9.0), float(analytic.stop_time_sf(9.0, 5.0)),
                        rel_tol=2e-4)
    assert math.isclose(distance_mean([(5.0, S2)], 2.0, 3.0), float(analytic.distance_mean(3.0)),
                        rel_tol=2e-4)


def test_a_pause_is_the_switch_off_and_the_noise_returns_from_the_atom():
    law = velocity_law([(3.0, S2), (4.0, 0.0)], 2.0, 4.0)
    assert math.isclose(law.atom, float(analytic.velocity_atom(4.0, 3.0)), rel_tol=2e-4)
    for y in (0.5, 2.0, 6.0):
        assert math.isclose(law.sf(y), float(analytic.velocity_sf(y, 4.0, 3.0)), rel_tol=2e-4)
    # After the pause the noise returns: the mass is whole again, none at 0.
    after = velocity_law([(3.0, S2), (4.0, 0.0), (6.0, S2)], 2.0, 6.0)
    assert after.atom == 0.0
    assert math.isclose(after.sf(-1e9), 1.0, rel_tol=1e-9)
    # The energy identity's input.
    assert noise_energy([(3.0, S2), (4.0, 0.0), (6.0, S2)], 10.0) == pytest.approx(10.0)


def test_no_noise_is_the_deterministic_coast():
    law = velocity_law([(1.0, 0.0)], 2.0, 0.5, v0=3.0)
    assert law.point == 2.0 and law.sf(1.99) == 1.0 and law.sf(2.0) == 0.0
    assert stop_time_sf([(1.0, 0.0)], 2.0, 1.0 + 1e-9, v0=3.0) == 1.0  # 1.0 + 0.5: at rest later
    assert stop_time_sf([(1.0, 0.0)], 2.0, 1.6, v0=3.0) == 0.0


def test_against_simulation_aftershock_and_a_start_in_motion():
    scene = crandall.Scene.from_toml("aftershock")
    sim_scene = crandall.Scene.from_dict({**scene.to_dict(), "distributions": ["stop_time"]})
    r = crandall.simulate(sim_scene, paths=200_000, seed=41)
    pieces = [(e, n) for e, n in scene.pieces]
    # In the pause every body of the run is at rest (the law's last 1e-17 of moving mass is
    # below what 2e5 paths can see): no path carries the velocity's spread there, and its
    # variance has no standard error (Result.carriers; it was 0).
    with pytest.warns(crandall.StatisticsWarning, match=r"t = 6 \(none\), 10 \(none\)"):
        ses = r.var_stderr("velocity")
    for i, t in enumerate(scene.times):
        law = velocity_law(pieces, scene.drift, float(t), scene.v0)
        # The velocity is symmetric: its variance is E V^2 (exact in law: no bias).
        sim, se = float(r.var("velocity")[i]), float(ses[i])
        if math.isnan(se):
            assert r.carriers("velocity")[i] == 0 and sim == 0.0, (t, sim)
            assert law.moment(2) < 1e-12, (t, law.moment(2))
        else:
            assert abs(sim - law.moment(2)) <= Z * se, (t, sim, law.moment(2), se)
        d = distance_mean(pieces, scene.drift, float(t), scene.v0)
        sim, se, bias = (float(r.mean("distance")[i]), float(r.stderr("distance")[i]),
                         float(np.abs(r.bias("distance")[i])))
        assert abs(sim - d) <= Z * se + bias, (t, sim, d, se, bias)
    p = stop_time_sf(pieces, scene.drift, 13.01, scene.v0)
    sim = r.exceedance("stop_time", 13.01)
    assert 0.01 < p < 0.99
    assert abs(sim.value - p) <= Z * math.sqrt(p * (1 - p) / 200_000) + sim.resolution
    # A crate sliding in at 1.5 m/s into shaking of 1 m s^-3/2 for 1 s.
    start = crandall.Scene(mu=0.3, h=1.0, t0=1.0, v0=1.5, times=[0.25, 1.0])
    r = crandall.simulate(start, paths=200_000, seed=42)
    for i, t in enumerate(start.times):
        law = velocity_law([(start.t0, start.noise)], start.drift, float(t), start.v0)
        sim, se = float(r.mean("velocity")[i]), float(r.stderr("velocity")[i])
        assert abs(sim - law.moment(1)) <= Z * se, (t, sim, law.moment(1))
        if i == 0:
            assert law.moment(1) > 0.1  # the start is still felt


def test_bad_input_is_refused():
    with pytest.raises(ValueError, match="pieces"):
        velocity_law([(2.0, S2), (1.0, S2)], 2.0, 1.0)
    with pytest.raises(ValueError, match="pieces"):
        velocity_law([(2.0, -1.0)], 2.0, 1.0)
    with pytest.raises(ValueError, match="drift"):
        velocity_law([(2.0, S2)], 0.0, 1.0)
    with pytest.raises(ValueError, match="time"):
        velocity_law([(2.0, S2)], 2.0, float("nan"))
    with pytest.raises(ValueError, match="v0"):
        velocity_law([(2.0, S2)], 2.0, 1.0, v0=float("inf"))
