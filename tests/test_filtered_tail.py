"""Tail probabilities of a filtered excitation (crandall.tail's splitting on the core's filtered
walk, docs/filtered.md "Continued paths"): the continued paths against the fixed-step walk,
splitting against plain Monte Carlo of the fixed-step core, a small probability by two seeds,
the refusals, and the same bits for any thread count.

Tolerances: two estimates agree within Z = 3.5 times their combined standard error (with the
fixed seeds a check holds or not; a correct estimator fails one with probability about 5e-4).
"""

import importlib
import json
import math

import numpy as np
import pytest

import crandall
from crandall import KanaiTajimi, Scene, _core, engine
from crandall.errors import ParameterError
from crandall.spec import RunSpec
from crandall.tail import tail

Z = 3.5
TAIL = importlib.import_module("crandall.tail")  # the module (crandall.tail is the function)
DT = 0.02
# A run whose pilot underestimated the variance reports its larger relative error with a
# warning; the checks below use the reported standard error, so they hold either way.
pytestmark = pytest.mark.filterwarnings("ignore:tail. relative error:crandall.results.StatisticsWarning")


def _scene(ring_down=False, **kw):
    # omega t0 = 3: the ground motion's correlation time is a third of the shaking.
    return Scene(mu=1.0, g=1.0, excitation=KanaiTajimi(omega=2.0, zeta=0.6, h=1.0,
                                                        ring_down=ring_down),
                 t0=1.5, times=[1.5], observe=["displacement", "distance", "stop"], **kw)


def _plan(scene, paths, seed):
    return _core.Plan(engine.plan_options(RunSpec.create(scene, paths=paths, seed=seed, dt=DT,
                                                         method="exact")))


def test_a_continuation_from_the_start_is_the_fixed_step_walks_path():
    # The walked grid's path p of the fixed-step block (filtered_trajectory walks it point by
    # point, event substeps included) against extend_filtered_paths of path p from point 0 with
    # the plan's seed: bit for bit at every grid point. Then a continuation from a middle point
    # of a stored path gives the same rest of the path again.
    scene = _scene(v0=0.3, u0=0.1)
    plan = _plan(scene, paths=8, seed=11)
    lengths, noises, z0 = _core.filtered_grid(plan)
    assert len(lengths) == 75 and np.all(noises > 0) and np.all(z0 == 0)
    times = np.concatenate([[0.0], np.cumsum(lengths)])
    n = 8
    states = np.zeros((n, len(times), 6))
    states[:, 0, :3] = (0.3, 0.1, 0.0)
    _core.extend_filtered_paths(plan, states, np.arange(n), np.zeros(n), np.arange(n))
    rested = 0
    for p in range(n):
        tr = _core.filtered_trajectory(plan, p)
        t = np.asarray(tr["t"])
        # The last point the walk records at each grid time (a stop inside a step comes before
        # the step's end).
        at = np.array([np.flatnonzero(np.abs(t - x) <= 1e-9)[-1] for x in times])
        for name, col in (("V", 0), ("U", 1), ("S", 2)):
            np.testing.assert_array_equal(states[p, :, col], np.asarray(tr[name])[at], name)
        rested += int(np.any(states[p, 1:, 0] == 0.0))
    assert rested > 0  # some paths stick: the events are part of what is compared
    again = states.copy()
    again[:, 40:] = np.nan
    _core.extend_filtered_paths(plan, again, np.arange(n), np.full(n, 39), np.arange(n))
    np.testing.assert_array_equal(again, states)
    # Another thread count, the same bits.
    two = states.copy()
    two[:, 1:] = 0.0
    _core.extend_filtered_paths(plan, two, np.arange(n), np.zeros(n), np.arange(n), threads=2)
    np.testing.assert_array_equal(two, states)
    # Clough-Penzien (4 filter numbers) with static friction: the walk's V at the last point.
    cp = Scene(mu=1.0, mu_static=1.2, g=1.0, t0=1.5, times=[1.5],
               observe=["velocity", "displacement", "distance"],  # (the walk ends at 1.5)
               excitation=crandall.CloughPenzien(omega=3.0, zeta=0.6, omega_f=0.5, zeta_f=0.6,
                                                 h=1.0))
    plan = _plan(cp, paths=4, seed=2)
    states = np.zeros((4, len(_core.filtered_grid(plan)[0]) + 1, 8))
    _core.extend_filtered_paths(plan, states, np.arange(4), np.zeros(4), np.arange(4))
    for p in range(4):
        tr = _core.filtered_trajectory(plan, p)
        assert states[p, -1, 0] == tr["V"][-1] and states[p, -1, 2] == tr["S"][-1]
    with pytest.raises(ValueError, match="streams"):
        _core.extend_filtered_paths(plan, states, [0], [0], [1 << 40])
    with pytest.raises(ValueError, match="states must be"):
        _core.extend_filtered_paths(plan, states[:, :, :6].copy(), [0], [0], [0])


MODEL_FIELDS = ("drift", "noise", "switch_off", "piece_ends", "piece_noise", "start_velocity",
                "start_displacement", "excitation", "filter_a", "filter_b", "filter_c",
                "filter_start", "static_drift", "event_depth", "ring_down")


def test_the_tails_plan_has_the_fixed_step_runs_model():
    # The tail builds its plan's model options itself (it does not reach the engine layer):
    # field by field those of engine.scene_options, with pieces, a start in motion and static
    # friction; its grid ends at the horizon.
    from crandall.tail.problem import _Problem
    scene = Scene(mu=1.0, mu_static=1.3, g=1.0, h=[0.5, 1.0], t0=[0.4, 1.5], v0=0.2, u0=-0.1,
                  times=[1.5], excitation=KanaiTajimi(omega=2.0, zeta=0.6))
    ours = _Problem(scene, "velocity", 1.0, DT)._grid.plan.options
    theirs = engine.scene_options(scene)
    for name in MODEL_FIELDS:
        a, b = getattr(ours, name), getattr(theirs, name)
        assert a == b or (a != a and b != b), name
    assert ours.times == [1.0]


def _plain(scene, level, paths, seed):
    """Plain Monte Carlo of the fixed-step core (the same grid), binned at the level: its
    exceedance there is a count."""
    s = Scene.from_dict({**scene.to_dict(), "distributions": ["distance_at_stop"],
                         "bins": {"distance_at_stop": [0.0, level, 100.0]}})
    r = crandall.simulate(s, paths=paths, seed=seed, dt=DT, method="exact")
    p = r.exceedance("distance_at_stop", level).value
    return p, math.sqrt(p * (1 - p) / paths)


def test_splitting_agrees_with_plain_monte_carlo():
    scene = _scene()
    level = 1.6
    mc, mc_se = _plain(scene, level, 10_000, 5)
    assert 0.01 < mc < 0.1, mc
    r = tail(scene, "distance_at_stop", [level], seed=6, dt=DT, rel_error=0.1, threads=2)
    assert r.method == "splitting" and r.diagnostics["score"] == "plain"
    assert abs(r.probability[0] - mc) <= Z * math.hypot(r.stderr[0], mc_se), (r.probability, mc)


def test_a_small_probability_by_two_seeds():
    # The speed at t0 beyond 4 (P about 1.5e-5; 3.7e-6 for the distance at the stop beyond 12,
    # whose score S + V^2 / (2c) ranks the paths worse: twice the replicas at the same error).
    scene = _scene()
    runs = [tail(scene, "speed", [4.0], time=1.5, seed=s, dt=0.03, rel_error=0.4, threads=2)
            for s in (7, 8)]
    p = [r.probability[0] for r in runs]
    assert all(3e-6 < x < 1e-4 for x in p), p
    assert all(r.reliable.all() and r.rel_error[0] < 0.6 for r in runs)
    for r in runs:
        lo, hi = r.interval()
        assert 0 < lo[0] < r.probability[0] < hi[0] < 3 * r.probability[0]
    assert abs(p[0] - p[1]) <= Z * math.hypot(runs[0].stderr[0], runs[1].stderr[0]), p


def test_stop_time_and_the_velocity_after_the_switch_off():
    # At h = 0.5 a filtered body often rests for good before t0 (the fixed-step run's stop time
    # is then its last arrival at rest, before t0): P(t_s > t0) is the probability that it
    # slides at t0 (0.28), against plain Monte Carlo of the fixed-step core.
    scene = Scene.from_dict({**_scene().to_dict(), "h": 0.5})
    s = Scene.from_dict({**scene.to_dict(), "distributions": ["stop_time"],
                         "bins": {"stop_time": [0.0, 1.0, 1.5, 100.0]}})
    paths = 4000
    m = crandall.simulate(s, paths=paths, seed=9, dt=DT, method="exact")
    mc = m.exceedance("stop_time", 1.5).value
    se = math.sqrt(mc * (1 - mc) / paths)
    r = tail(scene, "stop_time", [1.0, 1.5, 1.8], seed=10, dt=DT, rel_error=0.1, threads=2)
    assert 0.1 < mc < 0.5 and abs(r.probability[1] - mc) <= Z * math.hypot(r.stderr[1], se)
    # Below t0 the levels count the bodies still sliding or last at rest after the level.
    mc1 = m.exceedance("stop_time", 1.0).value
    assert mc < mc1 < 1 and abs(r.probability[0] - mc1) <= Z * math.hypot(
        r.stderr[0], math.sqrt(mc1 * (1 - mc1) / paths))
    # The speed after the switch-off coasts down at mu g: P(|V(t0 + 0.1)| > 0.1) is
    # P(|V(t0)| > 0.2).
    a = tail(scene, "speed", [0.1], time=1.6, seed=12, dt=DT, rel_error=0.1, threads=2)
    b = tail(scene, "speed", [0.2], time=1.5, seed=13, dt=DT, rel_error=0.1, threads=2)
    assert abs(a.probability[0] - b.probability[0]) <= Z * math.hypot(a.stderr[0], b.stderr[0])


def test_refusals_name_the_parameter():
    scene = _scene()
    with pytest.raises(ParameterError, match="method: importance sampling is not available "
                                             "for a scene with filtered_excitation") as e:
        tail(scene, "distance_at_stop", [1.0], method="importance", seed=1, dt=DT)
    assert e.value.name == "method"
    # A Dask task of importance sampling (its job built by hand: crandall.tail refuses the
    # method first) refuses the scene too, before any path is drawn.
    from crandall.tail.run import sample
    job = {"scene": scene.to_dict(), "quantity": "distance_at_stop", "time": None, "dt": DT,
           "levels": [1.0], "particles": 10, "key": 1, "proposal": (1.0, 0.0, 0.0, None)}
    with pytest.raises(ParameterError, match="scene: importance sampling .crandall.tail. is "
                                             "not available for a scene with "
                                             "filtered_excitation") as e:
        sample(job, 0, 1)
    assert e.value.name == "scene"
    with pytest.raises(ParameterError, match="ring_down") as e:
        tail(_scene(ring_down=True), "distance_at_stop", [1.0], seed=1, dt=DT)
    assert e.value.name == "scene"
    for name in ("peak_speed_at_stop", "peak_displacement_at_stop"):
        with pytest.raises(ParameterError, match=f"quantity: {name} is not available") as e:
            tail(scene, name, [1.0], seed=1, dt=DT)
        assert e.value.name == "quantity"
    # The normalised score (the sign-drift velocity's spread to come) is never used.
    from crandall.tail.problem import _Problem
    assert not _Problem(scene, "distance_at_stop", None, DT).normalisable()
    # Sample paths are the white-noise core's: still refused.
    with pytest.raises(ParameterError, match="scene: crandall.paths is not available"):
        crandall.paths(scene, n=2, seed=1)


def test_the_same_bits_for_any_thread_count_and_a_checkpoint_resumes_bitwise(tmp_path):
    scene = _scene()
    kw = dict(seed=14, dt=DT, rel_error=0.3, min_samples=6, max_samples=6)
    one = tail(scene, "residual_displacement", [1.0], threads=1, **kw)
    two = tail(scene, "residual_displacement", [1.0], threads=2, **kw)
    assert one.probability.tobytes() == two.probability.tobytes()
    assert one.stderr.tobytes() == two.stderr.tobytes()
    assert one.steps == two.steps and one.samples == 6
    # Its samples are the Dask task's (run.sample from the job's plain data, the scene by
    # Scene.from_dict): a checkpoint of the first 3 resumes to the same bits.
    path = tmp_path / "tail.ckpt"
    full = tail(scene, "residual_displacement", [1.0], threads=2, checkpoint=str(path), **kw)
    assert full.probability.tobytes() == one.probability.tobytes()
    with np.load(path) as stored:
        arrays = {k: stored[k] for k in stored.files}
    data = json.loads(str(arrays["state"]))
    data["samples"] = data["samples"][:3]
    data["checksum"] = TAIL._digest(full.spec, data["samples"]).hexdigest()
    with open(path, "wb") as f:
        np.savez(f, identity=arrays["identity"], state=np.array(json.dumps(data)))
    resumed = tail(scene, "residual_displacement", [1.0], threads=1, checkpoint=str(path), **kw)
    assert resumed.probability.tobytes() == one.probability.tobytes()


def test_fragility_of_a_filtered_scene_runs_each_point_as_its_own_tail():
    # The scaling of eq8 (model.SCALING) does not hold under a filtered excitation: no run is
    # shared, and each grid point is the tail run of its own scene with its own seed, bit for
    # bit. P(S > d) grows with the intensity.
    from crandall.fragility.grid import _run_seed, point_scene
    sc = Scene(mu=1.0, g=1.0, excitation=KanaiTajimi(omega=2.0, zeta=0.6, h=1.0), t0=1.5,
               times=[1.5])
    f = crandall.fragility(sc, "distance_at_stop", [0.5, 1.0], intensities=[0.8, 1.2],
                           rel_error=0.3, seed=7, threads=1, progress=False)
    assert not f.shared and list(f.run) == [0, 1]
    r = tail(point_scene(sc, "intensity", 1.2), "distance_at_stop", [0.5, 1.0], rel_error=0.3,
             seed=_run_seed(7, 1), threads=1, progress=False)
    assert np.array_equal(f.probability[1], r.probability)
    assert np.array_equal(f.stderr[1], r.stderr)
    assert (f.probability[1] > f.probability[0]).all()
