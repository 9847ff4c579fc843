"""Tail probabilities (crandall.tail): splitting and importance sampling against the closed
forms of the stop time's and the velocity's laws, against each other, against plain Monte
Carlo, with piecewise scenes and an initial state; reproducibility, checkpoints and refusals.

Tolerances: an estimate and its reference agree within Z standard errors (Z = 3.5: with the
fixed seeds each check either holds or not, and a correct estimator fails a single check with
probability about 5e-4); two estimates within Z times their combined standard error. The
references (crandall.analytic's laws, the transition density's integrals, plain Monte Carlo of
the fixed-step core) are independent of the estimators.
"""

import importlib
import json
import math
import warnings

import numpy as np
import pytest
from scipy.integrate import quad
from scipy.optimize import brentq

import crandall
from crandall import analytic
from crandall.errors import ParameterError
from crandall.results import StatisticsWarning
from crandall.tail import TAIL_QUANTITIES, log_transition_density, pareto_shape, tail

Z = 3.5
# A run whose pilot underestimated the variance reports its larger relative error with a
# warning; the checks below use the reported standard error, so they hold either way.
pytestmark = pytest.mark.filterwarnings("ignore:tail. relative error:crandall.results.StatisticsWarning")
PAPER = crandall.Scene.scaled(tau0=5, times=[5])
TAIL = importlib.import_module("crandall.tail")  # the module (crandall.tail is the function)


def level_of(sf, p, lo, hi):
    """The level where the survival function sf equals p (brentq on logs)."""
    return brentq(lambda x: math.log(sf(x)) - math.log(p), lo, hi, xtol=1e-12)


def agree(estimate, stderr, reference):
    assert abs(estimate - reference) <= Z * stderr, (estimate, stderr, reference)


def test_stop_time_tail_against_the_closed_form_down_to_1e_12():
    ps = [1e-6, 1e-9, 1e-12]
    levels = [level_of(lambda t: analytic.stop_time_sf(t, 5.0), p, 5.0, 40.0) for p in ps]
    # Velocity and stop time are exact on any grid: a coarse one (dt = 0.25) costs less.
    r = tail(PAPER, "stop_time", levels, seed=11, dt=0.25, rel_error=0.15, threads=1)
    assert r.reliable.all()
    for i, p in enumerate(ps):
        agree(r.probability[i], r.stderr[i], p)
        lo, hi = r.interval()
        assert lo[i] < hi[i]
    assert r.diagnostics["replicas"] == r.samples >= 10


def test_velocity_tails_against_the_closed_form_before_and_after_the_switch_off():
    # |V(3)| with the noise on, and V(6) one time unit after the switch-off (the coast).
    p_speed = [1e-6, 1e-9]
    speed_levels = [level_of(lambda y: 2 * analytic.velocity_sf(y, 3.0, 5.0), p, 0.1, 60) for p in p_speed]
    r = tail(PAPER, "speed", speed_levels, time=3.0, seed=12, dt=0.25, rel_error=0.15, threads=1)
    for i, p in enumerate(p_speed):
        agree(r.probability[i], r.stderr[i], p)
    y = level_of(lambda y: analytic.velocity_sf(y, 6.0, 5.0), 1e-9, 0.1, 60)
    r = tail(PAPER, "velocity", [y], time=6.0, seed=13, dt=0.25, rel_error=0.15, threads=1)
    agree(r.probability[0], r.stderr[0], 1e-9)


def test_importance_sampling_against_the_closed_form():
    ps = [1e-6, 1e-9, 1e-12]
    for p in ps:
        level = level_of(lambda t: analytic.stop_time_sf(t, 5.0), p, 5.0, 40.0)
        r = tail(PAPER, "stop_time", [level], seed=14, method="importance", rel_error=0.1,
                 threads=1)
        assert r.reliable.all(), r.diagnostics
        agree(r.probability[0], r.stderr[0], p)
        # The velocity quantities run on the coarsest exact grid: one step per part.
        assert r.diagnostics["pareto_shape"][0] < 0.7


def test_splitting_and_importance_agree_on_the_distance_at_the_stop():
    # Both estimate the same grid quantity (dt = 0.05, the trapezoid rule of the exact
    # skeleton). Levels near 1e-6 and 1e-9 (from earlier runs: 30.5 and 44). On this fine grid
    # the weights see the time a path spends near 0, so their tail is near the Pareto
    # diagnostic's bound: at 1e-6 the estimate is reliable; at 1e-9 it may be flagged, and the
    # number must agree all the same.
    levels = [30.5, 44.0]
    s = tail(PAPER, "distance_at_stop", levels, seed=15, dt=0.05, rel_error=0.15, threads=2)
    for i, lv in enumerate(levels):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", StatisticsWarning)
            m = tail(PAPER, "distance_at_stop", [lv], seed=16 + i, dt=0.05, method="importance",
                     rel_error=0.15, threads=2)
        if i == 0:
            assert m.reliable.all(), m.diagnostics
        assert 1e-10 < s.probability[i] < 1e-5
        combined = math.hypot(s.stderr[i], m.stderr[0])
        assert abs(s.probability[i] - m.probability[0]) <= Z * combined, (s.probability[i], m.probability[0], combined)
    # Splitting of the one level near 1e-9, with the score normalised towards it.
    one = tail(PAPER, "distance_at_stop", [44.0], seed=18, dt=0.05, rel_error=0.15, threads=2)
    combined = math.hypot(one.stderr[0], m.stderr[0])
    assert abs(one.probability[0] - m.probability[0]) <= Z * combined, (one.probability[0], m.probability[0], combined)


def test_splitting_and_importance_agree_on_the_residual_displacement():
    # Importance sampling re-draws the signs of the velocity's excursions, tilted towards the
    # level (docs/methods/tails.md), on top of a lower friction. Levels near 1e-6 and 1e-9 on
    # the paper's scene (dt = 0.05; from earlier runs: 5.6e-7 and 1.4e-9).
    levels = [30.0, 50.0]
    s = tail(PAPER, "residual_displacement", levels, seed=25, dt=0.05, rel_error=0.15, threads=2)
    for i, lv in enumerate(levels):
        m = tail(PAPER, "residual_displacement", [lv], seed=26 + i, dt=0.05,
                 method="importance", rel_error=0.15, threads=2)
        assert m.reliable.all(), m.diagnostics
        assert 1e-10 < s.probability[i] < 1e-5
        combined = math.hypot(s.stderr[i], m.stderr[0])
        assert abs(s.probability[i] - m.probability[0]) <= Z * combined, (s.probability[i], m.probability[0], combined)


def test_the_excursions_add_up_to_the_displacement_at_the_stop():
    # The decomposition importance sampling re-signs: with the core's own signs, u0 plus the
    # signed stretches between touches of 0 (the coast after the grid in the last one) is the
    # displacement where the body stops, path by path; on a scene with a start in motion, an
    # offset and a pause (coast steps inside the grid).
    import importlib

    T = importlib.import_module("crandall.tail")
    sc = crandall.Scene(mu=0.3, h=[1.0, 0.0, 0.8], t0=[1.0, 1.5, 2.5], v0=0.4, u0=0.05,
                        times=[1.0])
    problem = T._Problem(sc, "displacement_at_stop", None, 0.01)
    n = 300
    states = problem.start_states(n)
    touched = np.zeros((n, problem.steps), dtype=np.uint8)
    T._extend(problem, states, np.arange(n), np.zeros(n), np.arange(n), 12345, 1,
              touched=touched)
    fixed, free = T._excursions(problem, states, touched)
    v = states[:, :, 0]
    seg = np.concatenate([np.zeros((n, 1), int), np.cumsum(touched, axis=1)], axis=1)
    signs = np.zeros_like(free)
    for j in range(free.shape[1]):  # each stretch's sign: the velocity's at its first point
        first = np.argmax(seg == j + 1, axis=1)
        has = (seg == j + 1).any(axis=1)
        signs[has, j] = np.sign(v[has, first[has]])
    want = problem.value(problem.score(states))
    np.testing.assert_allclose(fixed + np.sum(signs * free, axis=1), want, rtol=1e-12,
                               atol=1e-12 * np.abs(want).max())
    assert touched.sum() > n and (free >= 0).all()


@pytest.mark.parametrize("name", ["residual_displacement", "displacement_at_stop"])
def test_importance_sampling_of_the_displacement_against_plain_monte_carlo(name):
    # A start in motion, an offset and a pause: the re-drawn signs (the stretch before the
    # first touch keeps the start's sign), the speed-dependent proposals and the weights of the
    # touches, against plain Monte Carlo of the same grid quantity at about 1e-2 (2e5 paths:
    # 2 % standard error).
    sc = crandall.Scene(mu=0.3, h=[1.0, 0.0, 0.8], t0=[1.0, 1.5, 2.5], v0=0.4, u0=0.05,
                        times=[1.0], observe=["displacement", "stop", "residual"])
    p, se = plain(sc, name, [0.5], 200_000, 3, 0.01)
    m = tail(sc, name, [0.5], seed=4, dt=0.01, method="importance", rel_error=0.08, threads=2)
    assert m.reliable.all(), m.diagnostics
    assert 5e-3 < p[0] < 3e-2
    agree(m.probability[0], math.hypot(m.stderr[0], se[0]), p[0])


def plain(scene, name, levels, paths, seed, dt):
    """Plain Monte Carlo of the fixed-step core (method exact, the same grid), binned at the
    levels themselves: its exceedance there is a count."""
    edges = sorted({0.0, *levels, 10 * max(levels)})
    binned = name
    if name == "residual_displacement":  # binned as the signed displacement, then folded
        binned, edges = "displacement_at_stop", sorted({-e for e in edges} | set(edges))
    s = crandall.Scene.from_dict({**scene.to_dict(), "distributions": [name], "bins": {binned: edges}})
    r = crandall.simulate(s, paths=paths, seed=seed, dt=dt, method="exact")
    p = np.array([r.exceedance(name, lv).value for lv in levels])
    return p, np.sqrt(p * (1 - p) / paths)


@pytest.mark.parametrize("name, levels", [("distance_at_stop", [10.5, 15.0]),
                                          ("residual_displacement", [9.6, 15.5])])
def test_splitting_agrees_with_plain_monte_carlo_at_1e_3_and_1e_4(name, levels):
    scene = crandall.Scene.scaled(tau0=5, times=[5], observe=["displacement", "distance", "stop", "residual"])
    mc, mc_se = plain(scene, name, levels, 400_000, 21, 0.05)
    assert 5e-4 < mc[0] < 3e-3 and 5e-5 < mc[1] < 3e-4
    r = tail(scene, name, levels, seed=22, dt=0.05, rel_error=0.1, threads=2)
    assert r.diagnostics["score"] == "plain"
    for i in range(2):
        assert abs(r.probability[i] - mc[i]) <= Z * math.hypot(r.stderr[i], mc_se[i])
    # One level per run: splitting ranks the paths by the score normalised towards that level
    # (docs/methods/tails.md, "The score"), another score than the curve's above.
    for i, lv in enumerate(levels):
        one = tail(scene, name, [lv], seed=23 + i, dt=0.05, rel_error=0.1, threads=2)
        assert abs(one.probability[0] - mc[i]) <= Z * math.hypot(one.stderr[0], mc_se[i])


#: A start in motion and a calm first piece: every path shares the first two grid points, so
#: the normalised score's maximum is taken from the first random one on.
CALM_START = crandall.Scene(mu=0.3, h=[0.0, 1.0], t0=[0.3, 1.5], v0=0.5, times=[1.0],
                            observe=["displacement", "distance", "dissipated_energy", "stop",
                                     "residual"])


@pytest.mark.parametrize("name, level", [("dissipated_energy_at_stop", 2.4),
                                         ("displacement_at_stop", 0.65)])
def test_the_normalised_score_after_a_calm_start_against_plain_monte_carlo(name, level):
    # The energy is binned as the distance (m mu g S); levels near 1e-3 (from plain runs).
    mc_name, mc_level = name, level
    if name == "dissipated_energy_at_stop":
        mc_name, mc_level = "distance_at_stop", level / (CALM_START.mass * CALM_START.drift)
    mc, mc_se = plain(CALM_START, mc_name, [mc_level], 200_000, 41, 0.01)
    assert 3e-4 < mc[0] < 3e-3
    r = tail(CALM_START, name, [level], seed=42, dt=0.01, rel_error=0.1, threads=2)
    assert r.diagnostics["score"] == "normalised"
    assert abs(r.probability[0] - mc[0]) <= Z * math.hypot(r.stderr[0], mc_se[0])


def test_the_normalised_score_ends_at_the_quantity_and_starts_where_paths_differ():
    # At the last point the score is (Q - top) / (scale eps): Q above a level is a score above
    # that level's threshold, the condition for splitting to stay unbiased; the points before
    # the first random one are every path's.
    import importlib

    T = importlib.import_module("crandall.tail")
    # (the scores declared normalised are those of the quantities of the same names)
    for name in [k for k, score in T.SCORES.items() if score.normalised]:
        problem = T._Problem(CALM_START, name, None, 0.01)
        n = 400
        states = problem.start_states(n)
        T._extend(problem, states, np.arange(n), np.zeros(n), np.arange(n), 777, 1)
        xi, m = problem.split_score(states, 0.3)
        q = problem.value(m)
        first = problem.first_random_point()
        assert first == 2  # one exact step over the calm piece, then the first noisy one
        assert np.all(xi[:, :first] == xi[:1, :first]) and np.all(np.ptp(xi[:, first:], axis=0) > 0)
        assert np.all(np.isfinite(xi))
        for lv in np.quantile(q, [0.1, 0.5, 0.9]):
            assert np.array_equal(q > lv, xi[:, -1] > problem.split_threshold(lv, 0.3))
        assert problem.split_threshold(0.3, 0.3) == 0.0
    # An intensity whose sigma^6 overflows keeps the plain score, silently (no overflow
    # warning: the suite turns warnings into errors).
    wild = crandall.Scene(mu=0.3, h=1e60, t0=1.0, times=[1.0])
    assert not T._Problem(wild, "distance_at_stop", None, 0.01).normalisable()
    assert T._Problem(CALM_START, "distance_at_stop", None, 0.01).normalisable()
    assert not T._Problem(CALM_START, "stop_time", None, 0.01).normalisable()
    # Only one intensity over one stretch takes the normalised score (docs/methods/tails.md):
    # calm before or after it, or the same intensity in two pieces, do not change that.
    for h, t0, one in (([1.0, 0.0, 0.5], [1.0, 5.0, 6.0], False),
                       ([1.0, 0.0, 1.0], [1.0, 2.0, 3.0], False),
                       ([0.3, 0.6, 1.0], [1.0, 2.0, 3.0], False),
                       ([1.0, 0.5], [1.0, 2.0], False),
                       ([0.0, 1.0, 0.0], [1.0, 2.0, 3.0], True),
                       ([1.0, 1.0], [1.0, 2.0], True)):
        sc = crandall.Scene(mu=0.3, h=h, t0=t0, times=[1.0])
        problem = T._Problem(sc, "distance_at_stop", None, 0.01)
        assert problem.one_intensity() == one == problem.normalisable(), h
        assert problem.normalisable(schedule=False)


def test_a_piecewise_scene_and_an_initial_state():
    # The main shock, pause and aftershock of the shipped scene aftershock: the stop after the
    # aftershock, against plain Monte Carlo of the fixed-step core on the same grid.
    scene = crandall.Scene.from_toml("aftershock")
    dt = 0.02
    mc, mc_se = plain(scene, "distance_at_stop", [1.6], 200_000, 31, dt)
    assert 2e-4 < mc[0] < 5e-3
    r = tail(scene, "distance_at_stop", [1.6], seed=32, dt=dt, rel_error=0.1, threads=2)
    assert r.diagnostics["score"] == "plain"  # three pieces
    assert abs(r.probability[0] - mc[0]) <= Z * math.hypot(r.stderr[0], mc_se[0])
    # A crate sliding in at 2 m/s with no shaking: the stop is deterministic, at
    # v0 / (mu g) = 0.408 s (after t0 = 0.2, so t_s = t0 + |V(t0)| / (mu g) is that time).
    calm = crandall.Scene(mu=0.5, h=0.0, t0=0.2, v0=2.0, times=[1.0])
    stop = 2.0 / (0.5 * 9.81)
    r = tail(calm, "stop_time", [stop - 0.01, stop + 0.01], seed=1)
    assert r.probability.tolist() == [1.0, 0.0] and r.stderr.tolist() == [0.0, 0.0]
    r = tail(calm, "distance_at_stop", [0.40, 0.41], seed=1)
    assert r.probability.tolist() == [1.0, 0.0]  # v0^2 / (2 mu g) = 0.4077 m


def test_a_level_below_every_path_is_flagged_not_reported_as_certain():
    # The distance at the stop on the paper's scene is below 0.5 for a small share of paths:
    # every particle of every replica starts above it, each replica gives 1, and their spread
    # (0) is no standard error. Flagged, with a warning naming the case; a level of the same
    # run that paths do cross is not.
    with pytest.warns(StatisticsWarning, match="every path exceeded it"):
        r = tail(PAPER, "distance_at_stop", [0.5, 6.0], seed=3, dt=0.1, threads=1)
    assert r.probability[0] == 1.0 and r.stderr[0] == 0.0
    assert r.reliable.tolist() == [False, True]
    assert r.diagnostics["all_replicas_one"] == [True, False]


def test_the_result_does_not_depend_on_threads_and_a_checkpoint_resumes_bitwise(tmp_path):
    args = dict(seed=5, dt=0.25, rel_error=0.3)
    one = tail(PAPER, "stop_time", [12.0], threads=1, **args)
    two = tail(PAPER, "stop_time", [12.0], threads=2, **args)
    assert one.probability.tobytes() == two.probability.tobytes()
    assert one.stderr.tobytes() == two.stderr.tobytes()
    # Replicas run three at a time here: batches that do not divide the pilot's.
    three = tail(PAPER, "stop_time", [12.0], threads=3, **args)
    assert three.probability.tobytes() == one.probability.tobytes()
    assert three.samples == one.samples
    path = tmp_path / "tail.ckpt"
    full = tail(PAPER, "stop_time", [12.0], threads=2, checkpoint=str(path), **args)
    assert full.probability.tobytes() == one.probability.tobytes()
    # An interrupted run: only its first samples were saved (with their checksum). Resuming
    # gives the same bits.
    with np.load(path) as stored:
        arrays = {k: stored[k] for k in stored.files}
    data = json.loads(str(arrays["state"]))
    data["samples"] = data["samples"][:7]
    data["checksum"] = TAIL._digest(full.spec, data["samples"]).hexdigest()
    with open(path, "wb") as f:
        np.savez(f, identity=arrays["identity"], state=np.array(json.dumps(data)))
    resumed = tail(PAPER, "stop_time", [12.0], threads=2, checkpoint=str(path), **args)
    assert resumed.probability.tobytes() == one.probability.tobytes()
    with pytest.raises(ValueError, match="levels"):
        tail(PAPER, "stop_time", [13.0], threads=2, checkpoint=str(path), **args)
    # A damaged state is refused naming the file and the field; so is another run's estimator.
    for state in ("[1, 2]", '{"samples": 3}', "{not json"):
        with open(path, "wb") as f:
            np.savez(f, identity=arrays["identity"], state=np.array(state))
        with pytest.raises(ValueError, match=r"tail.ckpt is not a checkpoint of a tail run "
                                             r"\(field state"):
            tail(PAPER, "stop_time", [12.0], threads=2, checkpoint=str(path), **args)
    with pytest.raises(ValueError, match="is a checkpoint of a tail run"):
        crandall.simulate(PAPER, paths=10, seed=5, checkpoint=path)


# -- checkpoints: what a damaged or edited one is refused for ------------------------------

#: The finished runs whose checkpoints the tests below edit: small ones (a splitting run of 40
#: replicas, an importance-sampling run of 6 batches), at two levels so that the fields'
#: consistency across levels is checked too.
EDITED_RUNS = {"splitting": dict(seed=5, dt=0.25, rel_error=0.3, threads=1, max_samples=60),
               "importance": dict(seed=5, dt=0.25, rel_error=0.3, threads=1,
                                  method="importance")}
EDITED_LEVELS = [8.0, 9.0]


@pytest.fixture(scope="module")
def finished(tmp_path_factory):
    """Per method: (the run's result, its checkpoint's identity and state as plain data)."""
    out = {}
    for method, args in EDITED_RUNS.items():
        path = tmp_path_factory.mktemp(method) / "t.ckpt"
        # The files are what these tests are about, not the estimates: a level that a run
        # flags (a StatisticsWarning) serves as well.
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", StatisticsWarning)
            result = tail(PAPER, "stop_time", EDITED_LEVELS, checkpoint=str(path), **args)
        with np.load(path) as stored:
            out[method] = (result, json.loads(str(stored["identity"])),
                           json.loads(str(stored["state"])))
    return out


def _write_checkpoint(path, identity, state):
    with open(path, "wb") as f:
        np.savez(f, identity=np.array(json.dumps(identity)), state=np.array(json.dumps(state)))


def _resume(path, method, levels=EDITED_LEVELS, **changed):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", StatisticsWarning)
        return tail(PAPER, "stop_time", levels, checkpoint=str(path),
                    **{**EDITED_RUNS[method], **changed})


def _set(sample, key, value):
    def edit(samples):
        samples[sample][key] = value(samples[sample][key]) if callable(value) else value
    return edit


def _above_the_weight(sample):
    """The last level's estimate of a sample set to twice the weight its iterations leave
    (0.9^iterations with 200 particles), or to 1."""
    def edit(samples):
        s = samples[sample]
        assert s["iterations"] > 0
        s["estimates"][-1] = min(1.0, 2 * 0.9 ** s["iterations"])
    return edit


def _drop(sample, key):
    def edit(samples):
        del samples[sample][key]
    return edit


def _top_sum(samples):
    # A sum of weights larger than its hits times the largest weight.
    s = samples[0]
    assert s["hits"][0] >= 1
    s["sum"][0] = s["top"][0][-1] * (s["hits"][0] + 1)


def _top_reversed(samples):
    s = samples[0]
    assert len(s["top"][0]) >= 2 and s["top"][0][0] < s["top"][0][-1]
    s["top"][0] = s["top"][0][::-1]


@pytest.mark.parametrize("reseal", [False, True])
@pytest.mark.parametrize("method, edit, field", [
    # Each was accepted as read, or raised a raw KeyError or TypeError: the estimate moved,
    # or came out negative.
    ("splitting", _set(0, "estimates", lambda e: [-x for x in e]), r"samples\[0\]\.estimates"),
    ("splitting", _set(3, "estimates", lambda e: [min(1.0, 2 * x) for x in e[:1]]),
     r"samples\[3\]\.estimates"),  # one level's estimate only
    ("splitting", _set(0, "estimates", [0.5, 1.5]), r"samples\[0\]\.estimates"),
    ("splitting", _set(0, "estimates", [0.5, float("nan")]), r"samples\[0\]\.estimates"),
    ("splitting", _set(0, "estimates", "a"), r"samples\[0\]\.estimates"),
    ("splitting", _drop(1, "estimates"), r"samples\[1\]\.estimates"),
    # Above the weight its iterations leave (0.9^iterations): the last level's estimate.
    ("splitting", _set(0, "iterations", 3), r"samples\[0\]\.(estimates|steps)"),
    ("splitting", _above_the_weight(2), r"samples\[2\]\.estimates|checksum"),
    ("splitting", _set(0, "iterations", -1), r"samples\[0\]\.iterations"),
    ("splitting", _set(0, "iterations", True), r"samples\[0\]\.iterations"),
    ("splitting", _set(0, "steps", 0), r"samples\[0\]\.steps"),
    ("splitting", _drop(0, "steps"), r"samples\[0\]\.steps"),
    ("splitting", lambda samples: samples.extend(samples * 2), r"samples: 120 of them, more than "
                                                               r"the 80"),
    ("importance", _set(0, "sum", lambda s: [-x for x in s]), r"samples\[0\]\.sum"),
    ("importance", _top_sum, r"samples\[0\]\.sum"),
    ("importance", _set(0, "hits", lambda h: [h[0], 10 ** 6]), r"samples\[0\]\.hits"),
    ("importance", _set(0, "hits", lambda h: [h[0], h[0] + 1]), r"samples\[0\]\.(hits|top)"),
    ("importance", _top_reversed, r"samples\[0\]\.top\[0\]"),
    ("importance", _set(0, "paths", 199), r"samples\[0\]\.paths"),
    ("importance", _set(0, "top", None), r"samples\[0\]\.top"),
    ("importance", _set(0, "sum2", "x"), r"samples\[0\]\.sum2"),
])
def test_edited_tail_checkpoints_are_refused_naming_the_file_and_the_field(
        tmp_path, finished, method, edit, field, reseal):
    result, identity, state = finished[method]
    samples = json.loads(json.dumps(state["samples"]))
    edit(samples)
    # Resealed: the checksum computed anew over the edit, so that the fields' own checks are
    # what must refuse it.
    checksum = (TAIL._digest(result.spec, samples).hexdigest() if reseal
                else state["checksum"])
    path = tmp_path / "edited.ckpt"
    _write_checkpoint(path, identity, {"samples": samples, "checksum": checksum})
    with pytest.raises(ValueError, match=rf"^checkpoint: .*edited.ckpt is damaged \(field "
                                         rf"({field})"):
        _resume(path, method)


@pytest.mark.parametrize("method", ["splitting", "importance"])
def test_a_tail_checkpoint_edited_within_the_ranges_is_refused_by_its_checksum(
        tmp_path, finished, method):
    result, identity, state = finished[method]
    path = tmp_path / "edited.ckpt"
    # The checkpoint as written resumes (its checks pass what the run wrote) to the same bits.
    _write_checkpoint(path, identity, state)
    assert _resume(path, method).probability.tobytes() == result.probability.tobytes()
    # One number a little larger: every range still holds.
    samples = json.loads(json.dumps(state["samples"]))
    key = "estimates" if method == "splitting" else "sum"
    samples[1][key][0] *= 1.001
    _write_checkpoint(path, identity, {"samples": samples, "checksum": state["checksum"]})
    with pytest.raises(ValueError, match=r"edited.ckpt is damaged \(field checksum: it does not "
                                         r"match"):
        _resume(path, method)
    # No checksum at all.
    _write_checkpoint(path, identity, {"samples": state["samples"]})
    with pytest.raises(ValueError, match=r"edited.ckpt is damaged \(field checksum: missing"):
        _resume(path, method)
    # The identity edited to another run's (its lower level; resumed with those levels, and
    # the same importance-sampling proposal, chosen for the top one): the samples are another
    # run's, estimates at another level. The checksum covers the run's spec.
    other = {**identity, "levels": [7.5, 9.0]}
    _write_checkpoint(path, other, state)
    with pytest.raises(ValueError, match=r"edited.ckpt is damaged \(field checksum: it does "
                                         r"not match"):
        _resume(path, method, levels=[7.5, 9.0])


def test_a_tail_checkpoint_of_another_target_or_pilot_is_refused(tmp_path, finished):
    # rel_error, min_samples and max_samples set how many samples the run takes: resuming
    # with other ones would continue another run's count silently.
    result, identity, state = finished["splitting"]
    path = tmp_path / "t.ckpt"
    _write_checkpoint(path, identity, state)
    for changed, text in ((dict(rel_error=0.2), "rel_error: checkpoint has 0.3, this run 0.2"),
                          (dict(min_samples=30), "min_samples: checkpoint has 20, this run 30"),
                          (dict(max_samples=70), "max_samples: checkpoint has 60, this run 70")):
        with pytest.raises(ValueError, match=rf"belongs to a different run \({text}\)"):
            _resume(path, "splitting", **changed)


def test_bad_input_is_refused_naming_the_parameter():
    with pytest.raises(ValueError, match="quantity"):
        tail(PAPER, "height", [1.0])
    with pytest.raises(ValueError, match="time"):
        tail(PAPER, "velocity", [1.0])
    with pytest.raises(ValueError, match="time"):
        tail(PAPER, "stop_time", [9.0], time=3.0)
    with pytest.raises(ValueError, match="levels"):
        tail(PAPER, "stop_time", [9.0, 8.0])
    with pytest.raises(ValueError, match="levels"):
        tail(PAPER, "stop_time", [float("nan")])
    with pytest.raises(ValueError, match="rel_error"):
        tail(PAPER, "stop_time", [9.0], rel_error=0)
    with pytest.raises(ValueError, match="method"):
        tail(PAPER, "stop_time", [9.0], method="euler")
    with pytest.raises(ValueError, match="dt"):
        tail(PAPER, "stop_time", [9.0], dt=-1)
    with pytest.raises(ValueError, match="quantity"):
        tail(crandall.Scene(mu=0.0, h=1.0, t0=2.0, times=[1.0]), "stop_time", [3.0])
    # Sample i's streams start at i * 2^40: at most 2^23 - 1 samples in a run (refused before
    # any path runs; the largest allowed passes the check).
    with pytest.raises(ValueError, match="max_samples: min_samples . max_samples come to more than 8388607 replicas"):
        tail(PAPER, "stop_time", [9.0], max_samples=2 ** 23 - 20)
    with pytest.raises(ValueError, match="max_samples: .* batches of particles = 10 paths.*or more particles"):
        tail(PAPER, "stop_time", [9.0], method="importance", particles=10, max_samples=10 ** 8)
    assert set(TAIL_QUANTITIES) >= {"stop_time", "velocity", "speed", "distance_at_stop",
                                    "residual_displacement", "dissipated_energy_at_stop"}


@pytest.mark.parametrize("kwargs, name", [
    # Each was taken as a number (True as 1, "9" as 9.0) or raised a raw OverflowError or
    # TypeError.
    (dict(levels="9"), "levels"),
    (dict(levels=True), "levels"),
    (dict(levels=[True, 9.0]), "levels"),
    (dict(levels=np.array([False, True])), "levels"),
    (dict(levels=[9.0, "10"]), "levels"),
    (dict(quantity="speed", time="1"), "time"),
    (dict(quantity="speed", time=True), "time"),
    (dict(dt="0.25"), "dt"),
    (dict(quantity=["stop_time"]), "quantity"),
    (dict(checkpoint=5), "checkpoint"),
    # The pilot's variance bound is infinite below 3 replicas (variance_upper_factor(2)).
    (dict(min_samples=2), "min_samples"),
    (dict(min_samples=2.5), "min_samples"),
    # A target the sample counts cannot reach (1 / rel_error^2 above max_samples' 10^12).
    (dict(rel_error=1e-300), "rel_error"),
    (dict(rel_error=1e-7), "rel_error"),
    (dict(rel_error=True), "rel_error"),
])
def test_bad_types_and_ranges_are_parameter_errors(kwargs, name):
    args = {"quantity": "stop_time", "levels": [9.0], "seed": 1, "dt": 0.25, "threads": 1,
            **kwargs}
    with pytest.raises(ParameterError, match=f"^{name}") as err:
        tail(PAPER, args.pop("quantity"), args.pop("levels"), **args)
    assert err.value.name == name


def test_levels_are_taken_from_any_sequence_of_numbers():
    for given in (range(8, 10), (x for x in (8.0, 9.0)), np.array([8, 9]), [np.float32(8), 9]):
        assert TAIL._levels(given).tolist() == [8.0, 9.0]
    assert TAIL._levels(np.float64(9.0)).tolist() == [9.0]
    with pytest.raises(ParameterError, match="^levels must be a number or a non-empty sequence"):
        TAIL._levels([[8.0, 9.0]])  # nested: not one-dimensional


def test_the_smallest_allowed_pilot_and_target_run():
    # min_samples = 3 replicas (a finite variance bound); rel_error = 1e-6 (the run then stops
    # at max_samples and says so).
    r = tail(PAPER, "stop_time", [9.0], seed=1, dt=0.25, threads=1, min_samples=3,
             max_samples=3, rel_error=0.5)
    assert r.samples == 3  # never fewer than the pilot
    with pytest.warns(StatisticsWarning, match="limited by max_samples"):
        tail(PAPER, "stop_time", [9.0], seed=1, dt=0.25, threads=1, max_samples=20,
             rel_error=1e-6)


def test_simulate_refuses_a_checkpoint_that_is_not_a_path_naming_it():
    for kw in (dict(paths=10), dict(rel_error=0.1)):
        with pytest.raises(ParameterError, match="^checkpoint must be a path") as err:
            crandall.simulate(PAPER, seed=1, checkpoint=5, **kw)
        assert err.value.name == "checkpoint"


def test_coverage_of_the_interval():
    # 100 seeds at about 1e-6 (stop time, the coarsest grid splitting takes, 50 steps): the
    # 95 % interval's coverage lies within 3 binomial standard deviations of 95 %
    # (sqrt(0.95 * 0.05 / 100) = 2.2 %). bench/tails_coverage.py measures it over 1000 seeds.
    level = level_of(lambda t: analytic.stop_time_sf(t, 5.0), 1e-6, 5.0, 40.0)
    hits = 0
    for seed in range(100):
        r = tail(PAPER, "stop_time", [level], seed=1000 + seed, dt=0.1, rel_error=0.3,
                 particles=50, threads=1)
        lo, hi = r.interval()
        hits += lo[0] <= 1e-6 <= hi[0]
    assert abs(hits / 100 - 0.95) <= 3 * math.sqrt(0.95 * 0.05 / 100), hits


def test_coverage_of_the_interval_with_the_normalised_score():
    # 100 seeds of the distance at the stop near 1e-3 (one level under one intensity: the
    # normalised score), against plain Monte Carlo of the same grid quantity (10^6 paths: a
    # relative standard error of 3.3 %). Coverage within 3 binomial standard deviations of
    # 95 %, widened by what a reference off by one of its own standard errors takes from it:
    # with the runs' mean relative error r, an offset of d = (se_mc / mc) / r standard errors
    # covers in Phi(1.96 - d) - Phi(-1.96 - d) (1.3 % less at r = 0.10). Measured: 94 of 100.
    from scipy.stats import norm

    scene = crandall.Scene.scaled(tau0=5, times=[5], observe=["distance", "stop"])
    mc, mc_se = plain(scene, "distance_at_stop", [10.5], 1_000_000, 51, 0.1)
    assert 5e-4 < mc[0] < 3e-3
    hits, rels = 0, []
    for seed in range(100):
        r = tail(PAPER, "distance_at_stop", [10.5], seed=2000 + seed, dt=0.1, rel_error=0.3,
                 particles=50, threads=1)
        assert r.diagnostics["score"] == "normalised"
        lo, hi = r.interval()
        hits += lo[0] <= mc[0] <= hi[0]
        rels.append(r.rel_error[0])
    d = (mc_se[0] / mc[0]) / np.mean(rels)
    offset = 0.95 - (norm.cdf(1.96 - d) - norm.cdf(-1.96 - d))
    assert 0 < offset < 0.05, offset
    assert abs(hits / 100 - 0.95) <= 3 * math.sqrt(0.95 * 0.05 / 100) + offset, (hits, offset)


def test_the_transition_density_integrates_to_one_and_chains():
    s = math.sqrt(2.0)
    # From rest with the paper's friction: the closed form of the paper's velocity law.
    for x in (-3.0, -0.2, 0.0, 1.5, 6.0):
        assert math.isclose(math.exp(log_transition_density(x, 0.0, 1.3, 2.0, s)),
                            float(analytic.noise_on.velocity_pdf(x, 1.3)), rel_tol=1e-12)
    for c in (2.0, 0.5, -1.0, -2.0):
        for x0, t in ((0.0, 0.7), (1.2, 0.3), (-2.0, 2.0)):
            total = quad(lambda x: math.exp(log_transition_density(x, x0, t, c, s)), -np.inf, np.inf,
                         points=None, limit=200)[0]
            assert math.isclose(total, 1.0, rel_tol=1e-8), (c, x0, t, total)
            # Chapman-Kolmogorov: two steps of t/2 make one of t.
            x = 0.9
            two = quad(lambda y: math.exp(log_transition_density(x, y, t / 2, c, s)
                                          + log_transition_density(y, x0, t / 2, c, s)),
                       -np.inf, np.inf, limit=200)[0]
            assert math.isclose(two, math.exp(log_transition_density(x, x0, t, c, s)), rel_tol=1e-7)


def test_pareto_shape_recovers_known_tails():
    rng = np.random.default_rng(0)
    n = 100_000
    m = int(3 * math.sqrt(n))
    for xi in (0.0, 0.5, 1.0):
        u = rng.random(n)
        w = -np.log(u) if xi == 0 else (u ** -xi - 1) / xi
        k = pareto_shape(np.sort(w)[-(m + 1):])
        # The estimate's standard deviation is about (1 + xi) / sqrt(m) = 0.03 (1 + xi).
        assert abs(k - xi) <= 4 * (1 + xi) / math.sqrt(m), (xi, k)


def test_a_dask_cluster_gives_the_local_bits():
    distributed = pytest.importorskip("distributed")
    args = dict(seed=8, dt=0.25, rel_error=0.3, threads=1)
    local = tail(PAPER, "stop_time", [12.0], **args)
    local_is = tail(PAPER, "stop_time", [12.0], method="importance", **args)
    with distributed.LocalCluster(n_workers=1, threads_per_worker=2, processes=False,
                                  dashboard_address=":0") as cluster, distributed.Client(cluster) as client:
        remote = tail(PAPER, "stop_time", [12.0], client=client, **args)
        remote_is = tail(PAPER, "stop_time", [12.0], method="importance", client=client, **args)
    assert remote.probability.tobytes() == local.probability.tobytes()
    assert remote.stderr.tobytes() == local.stderr.tobytes()
    assert remote_is.probability.tobytes() == local_is.probability.tobytes()
    with pytest.raises(ValueError, match="client"):
        tail(PAPER, "stop_time", [12.0], client=object(), **args)


def test_a_run_whose_paths_would_not_fit_in_memory_is_refused_before_it_starts(monkeypatch):
    import importlib

    tail_module = importlib.import_module("crandall.tail.run")  # where the run looks them up
    # 200 particles of 2001 grid points (dt = 0.0025 over tau0 = 5): 4 x 9.6 MB plus a stack
    # per thread; the process "may allocate" 20 MiB.
    monkeypatch.setattr(tail_module, "available_memory", lambda: 20 << 20)
    calls = []
    monkeypatch.setattr(tail_module, "sample", lambda *a: calls.append(a))
    with pytest.raises(ValueError, match="particles: 200 paths of 2001 grid points need about"):
        tail(PAPER, "distance_at_stop", [30.0], seed=1, dt=0.0025, threads=1)
    assert calls == []


def test_the_variance_bound_is_the_chi_square_one():
    # (n - 1) / chi2_0.01(n - 1), against SciPy's chi-square quantile (the code uses
    # Wilson-Hilferty's cube, within 0.5 % of it from 19 degrees of freedom on; above it below).
    import importlib

    from scipy.stats import chi2

    T = importlib.import_module("crandall.tail")
    for n in (20, 50, 1000, 10**6):
        exact = (n - 1) / chi2.ppf(0.01, n - 1)
        assert abs(T.variance_upper_factor(n) / exact - 1) < 5e-3, n
    for n, above in ((4, 0.6), (6, 0.11), (10, 0.03)):  # few degrees of freedom: a larger bound
        ratio = T.variance_upper_factor(n) / ((n - 1) / chi2.ppf(0.01, n - 1))
        assert 1.0 < ratio < 1.0 + above, n
    assert T.variance_upper_factor(1) == math.inf
    assert T.variance_upper_factor(2) == math.inf
    assert 2.45 < T.variance_upper_factor(20) < 2.55  # what a pilot of 20 replicas gets


def test_the_displacements_weights_are_bounded_by_the_defensive_mixture():
    # The signs come from a mixture holding the fair coin, the speeds from one holding the
    # scene's law, each with the share DEFENSIVE (so at most 1 / DEFENSIVE each): every
    # path's weight is at most their product, whatever the proposal.
    import importlib

    T = importlib.import_module("crandall.tail")
    problem = T._Problem(PAPER, "residual_displacement", None, 0.05)
    # Low levels that most paths pass: the paths of the scene's own law, under a reversed
    # friction's density, would weigh astronomically much without the mixture.
    levels = np.array([0.5, 1.0])
    law = T._proposal(problem, 5.0, -2.0 * PAPER.drift)
    w = T._importance_batch(problem, law, levels, 4000, 777, 0, 1)
    assert np.count_nonzero(w[:, 0]) > 1000
    assert w.max() <= 1 / T.DEFENSIVE ** 2 * (1 + 1e-12)
    assert w.max() > 2.0  # the bound is reached for: some weights far above 1


def test_importance_sampling_runs_flagged_reliable_cover_the_stop_time():
    # The stop time at tau0 = 20 past 25 (P = 2.06e-9): a proposal over a final window leaves
    # the velocity at the window's start under the scene's law, and the weight grows with it
    # as fast as its density falls, a tail that pilots never see (window 5, drift -c: a relative
    # variance per path of order 1e8 by quadrature). Runs flagged reliable then covered in 67 %
    # of 150 seeds and averaged 0.92 +- 0.013 of the exact value. Over 60 seeds: the reliable runs'
    # 95 % intervals must cover at a rate within 3 binomial standard errors of 0.95
    # (sqrt(0.95 * 0.05 / n) with n the reliable runs: >= 0.866 for n = 60), and their mean
    # ratio to the exact value must be within 3.5 of its standard errors (the ratios'
    # sample spread / sqrt(n)) of 1.
    scene = crandall.Scene.scaled(tau0=20, times=[20])
    exact = float(analytic.stop_time_sf(25.0, 20.0))
    ratios, covered = [], []
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", StatisticsWarning)
        for seed in range(60):
            r = tail(scene, "stop_time", 25.0, method="importance", seed=900 + seed, threads=1)
            if r.reliable[0]:
                lo, hi = r.interval()
                ratios.append(r.probability[0] / exact)
                covered.append(lo[0] <= exact <= hi[0])
    n = len(ratios)
    assert n >= 45, n  # most runs are reliable
    assert np.mean(covered) >= 0.95 - 3 * math.sqrt(0.95 * 0.05 / n), (np.mean(covered), n)
    agree(np.mean(ratios), np.std(ratios, ddof=1) / math.sqrt(n), 1.0)


def test_the_velocity_proposals_tilt_each_piece_so_the_weights_stay_bounded():
    # A start in motion and two pieces, the loud one first (scaled intensities 1.5 then 0.7,
    # v0 = 6): P(t_s > level) = 1e-8 by quadrature of the transition density. With one
    # reversed friction over both pieces, a path fast at the end of the loud one weighs more
    # the faster it was: 20000 paths gave Pareto shapes of 2.0 and 4.5 and estimates of 0.05
    # and 2e-13 times P. Each piece's friction lowered by theta sigma^2 (the tilt of |V|)
    # telescopes: the weights of the paths past the level are bounded (shape < 0.5, the
    # weights' variance finite), and the estimate agrees with P within Z standard errors.
    import importlib

    T = importlib.import_module("crandall.tail")
    from crandall.analytic import schedule

    scene = crandall.Scene.scaled(tau0=[4.0, 8.0], h=[1.5, 0.7], v0=6.0, times=[8.0])
    pieces = [(float(e), float(n)) for e, n in scene.pieces]
    level = level_of(lambda t: schedule.stop_time_sf(pieces, scene.drift, t, scene.v0), 1e-8,
                     8.5, 30.0)
    p = schedule.stop_time_sf(pieces, scene.drift, level, scene.v0)
    grid = T._grid_for(T._Problem(scene, "stop_time", None, None), 8.0)
    for drift in (-scene.drift, -2 * scene.drift):
        w = T._importance_batch(grid, T._proposal(grid, 8.0, drift), np.array([level]), 20000,
                                99, 0, 1)[:, 0]
        hits = np.sort(w[w > 0])
        assert len(hits) > 1000
        assert pareto_shape(hits[-int(3 * math.sqrt(len(hits))) - 1:]) < 0.5
        agree(w.mean(), w.std() / math.sqrt(len(w)), p)
