"""Hard schedules and starts: a thousand pieces, pieces far shorter and far longer than the
model's time scale, a start far faster or far slower than the noise's velocity scale. The
references are closed forms independent of the simulation: the energy law, the stationary law
of the sign-drift diffusion, the deterministic drift of a body too fast to turn, the paper's
stop time. Statistical checks: fixed seeds, |z| <= 4 from the reported errors."""

from __future__ import annotations

import math

import numpy as np

import crandall
from crandall import analytic, model

C = 0.3 * 9.81  # mu g


def test_a_thousand_pieces_keep_the_energy_law():
    ends = np.linspace(0.002, 2.0, 1000)
    h = 0.5 + 0.5 * (np.arange(1000) % 3)  # 0.5, 1.0, 1.5, ...
    sc = crandall.Scene(mu=0.3, h=h.tolist(), t0=ends.tolist(), times=[1.0, 2.0],
                        observe=["velocity", "distance", "stop"])
    assert len(sc.pieces) == 1000
    r = crandall.simulate(sc, paths=80_000, seed=1)
    want = model.noise_energy(sc, sc.t0) / (2 * C)
    assert abs(r.mean("distance_at_stop") - want) <= 4 * r.error("distance_at_stop")
    # The variance at the stop through Ito's isometry (its integral runs across all 1000
    # pieces, each with its own h) against the fixed-step run's sample variance: 4 combined
    # reported errors (about 1.3 % and 0.6 % of the variance: a shift of 6 % fails).
    a = crandall.simulate(sc, rel_error=0.01, seed=2, threads=2,
                          statistics=["distance_at_stop:var"])
    err = math.hypot(a.error("distance_at_stop", "var"), r.error("distance_at_stop", "var"))
    assert abs(a.var("distance_at_stop") - r.var("distance_at_stop")) <= 4 * err


def test_a_piece_far_shorter_than_the_time_scale():
    # A strong piece 1e-6 s long (its spread 3e-3 m/s against a velocity scale h^2/(2 mu g)
    # of 0.17 m/s) between two ordinary ones: no step straddles it, nothing degenerates,
    # and the energy law holds (the piece's own share, 1.4e-6 m, is below the run's error).
    sc = crandall.Scene(mu=0.3, h=[1.0, 3.0, 1.0], t0=[0.5, 0.5 + 1e-6, 1.0],
                        times=[0.5, 0.5 + 1e-6, 1.0], observe=["velocity", "distance", "stop"])
    assert len(sc.pieces) == 3
    r = crandall.simulate(sc, paths=20_000, seed=2)
    want = (1.0 * 0.5 + 9.0 * 1e-6 + 1.0 * (0.5 - 1e-6)) / (2 * C)
    assert abs(r.mean("distance_at_stop") - want) <= 4 * r.error("distance_at_stop")


def test_pieces_far_longer_than_the_time_scale_reach_the_stationary_law():
    # After 1000 s (about 5e4 relaxation times h^2/(2 c^2)) the velocity has the stationary
    # law of dV = -c sign(V) dt + h dW, a Laplace law of scale h^2 / (2 c): E V^2 =
    # h^4 / (2 c^2). A velocity-only scene steps once per segment, whatever the length.
    sc = crandall.Scene(mu=0.3, h=[1.0, 0.5], t0=[1000.0, 2000.0], times=[999.0, 1999.0],
                        observe=["velocity", "stop"])
    r = crandall.simulate(sc, paths=40_000, seed=3)
    want = np.array([1.0 ** 4, 0.5 ** 4]) / (2 * C * C)
    got, se = r.var("velocity"), r.var_stderr("velocity")
    assert np.all(np.abs(got - want) <= 4 * se), (got, want, se)
    assert r.exact("velocity", "var")


def test_a_start_far_faster_than_the_noise_drifts_and_coasts():
    # v0 = 1e6 m/s: the body never turns, so V(t) = v0 - c t + h W(t) while shaken and it
    # stops at t0 + V(t0) / c: mean v0 / c, variance h^2 t0 / c^2. The mean distance at the
    # stop is the energy law's (v0^2 + h^2 t0) / (2 c).
    v0, h, t0 = 1e6, 1.0, 2.0
    sc = crandall.Scene(mu=0.3, h=h, t0=t0, v0=v0, times=[1.0],
                        observe=["velocity", "distance", "stop"])
    r = crandall.simulate(sc, paths=20_000, seed=4)
    assert abs(r.mean("stop_time") - v0 / C) <= 4 * r.error("stop_time")
    assert abs(r.var("stop_time") - h * h * t0 / C ** 2) <= 4 * r.var_stderr("stop_time")
    want = (v0 ** 2 + h * h * t0) / (2 * C)
    assert abs(r.mean("distance_at_stop") - want) <= 4 * r.error("distance_at_stop") + \
        1e-12 * want  # the integrals' rounding at 1e11 m
    assert np.isfinite(r.var("distance_at_stop"))


def test_a_start_far_slower_than_the_noise_is_the_paper_scene():
    # v0 = 1e-300 (scaled): the noise takes over at once; the stop time is the paper's.
    sc = crandall.Scene.scaled(tau0=2.0, v0=1e-300, times=[1.0], observe=["velocity", "stop"])
    r = crandall.simulate(sc, paths=40_000, seed=5)
    assert abs(r.mean("stop_time") - analytic.stop_time_mean(2.0)) <= 4 * r.error("stop_time")
    assert math.isfinite(r.var("velocity")[0])
