"""A filtered excitation's event depth as a run option (RunSpec.event_depth; docs/filtered.md,
"The event depth"): its range is the core's, the default runs as before, and the bias estimate
of a run at a coarse depth covers what the depth moves."""

import math

import numpy as np
import pytest

import crandall
from crandall import KanaiTajimi, Scene, _core, engine
from crandall.spec import MAX_EVENT_DEPTH, MIN_EVENT_DEPTH, RunSpec
from conftest import same_result

# bench/filtered.py's scene at omega t* = 4: zeta = 0.6, h = 1, mu g = 1, t0 = 10 s (t* = 2 s).
SCENE = Scene(mu=1.0, g=1.0, excitation=KanaiTajimi(omega=2.0, zeta=0.6, h=1.0), t0=10.0,
              times=[10.0], observe=["distance", "stop"])


def _plan(spec, **options):
    o = engine.plan_options(spec, histograms=False)
    for name, value in options.items():
        setattr(o, name, value)
    return _core.Plan(o)


def test_the_range_is_the_cores():
    spec = RunSpec.create(SCENE, paths=10, seed=1, event_depth=MAX_EVENT_DEPTH)
    _plan(spec)
    with pytest.raises(ValueError, match="event_depth"):
        _plan(spec, event_depth=MAX_EVENT_DEPTH + 1)
    # The bias estimate's coupled run (three grids) needs MIN_EVENT_DEPTH, not one less.
    low = RunSpec.create(SCENE, paths=10, seed=1, event_depth=MIN_EVENT_DEPTH)
    _plan(low, method="richardson")
    with pytest.raises(ValueError, match="event_depth must be at least"):
        _plan(low, method="richardson", event_depth=MIN_EVENT_DEPTH - 1)
    for bad, match in ((MIN_EVENT_DEPTH - 1, ">= 2"), (MAX_EVENT_DEPTH + 1, "<= 20"),
                       (4.0, "an integer"), (True, "an integer")):
        with pytest.raises(crandall.ParameterError, match="event_depth must be") as info:
            crandall.simulate(SCENE, paths=10, seed=1, event_depth=bad)
        assert match in str(info.value)
    with pytest.raises(crandall.ParameterError, match="event_depth: not with") as info:
        crandall.simulate(SCENE, rel_error=0.1, event_depth=4)
    assert "depth 4" in str(info.value)


def test_a_run_to_an_accuracy_searches_every_level_to_its_own_depth(monkeypatch):
    # Every level of a filtered run to an accuracy bisects to FILTER_EVENT_DEPTH (4), not the
    # fixed-step default (8): the finer levels correct what the shallow search leaves.
    from crandall.adaptive import levels
    assert levels.FILTER_EVENT_DEPTH == 4
    seen = []
    made = levels._Level.__init__

    def spy(self, *args, **kw):
        made(self, *args, **kw)
        seen.append(self.plan.options.event_depth)

    monkeypatch.setattr(levels._Level, "__init__", spy)
    r = crandall.simulate(SCENE, rel_error=0.1, seed=2, threads=1,
                          statistics=["distance_at_stop:mean"])
    assert len(seen) == len(r.levels) >= 3 and set(seen) == {4}


def test_the_default_depth_is_the_cores_and_leaves_the_spec_as_it_was():
    default = crandall.simulate(SCENE, paths=300, seed=3, threads=1)
    assert "event_depth" not in default.spec.to_dict()
    eight = crandall.simulate(SCENE, paths=300, seed=3, threads=1, event_depth=8)
    assert eight.spec.to_dict()["event_depth"] == 8
    assert same_result(default, eight)


def test_the_bias_estimate_covers_what_a_coarse_depth_moves():
    # Paired: the same seed at depths 4 and 8 walks the same skeleton and the same bridges
    # (a node's random numbers depend on its place in the bisection tree only, and every
    # depth builds the same roots: test_every_depth_walks_the_same_path), so the per-path
    # difference of the distance at the stop resolves the depth's shift.
    n = 2000
    spec8 = RunSpec.create(SCENE, paths=n, seed=1)
    spec4 = RunSpec.create(SCENE, paths=n, seed=1, event_depth=4)
    s8, s4 = (np.asarray(_core.run_samples(_plan(s), 0, n, 1))[:, 1, 0, 2]
              for s in (spec8, spec4))
    diff = s4 - s8
    shift, se = float(diff.mean()), float(diff.std(ddof=1)) / math.sqrt(n)
    # Measured: shift -4.7e-4 (of a mean 3.85), se 6.3e-5.
    assert abs(shift) > 4 * se, "the depth moves the mean"
    r4 = crandall.simulate(SCENE, paths=n, seed=1, threads=1, event_depth=4)
    bias = float(r4.bias("distance_at_stop", "mean"))  # measured 5.1e-4
    # Depth 8's own error is far below depth 4's (its estimate here: 9e-6), so the shift is
    # depth 4's error, which the bias estimate (other paths, each grid bisected 4 times below
    # its own step) must cover within the shift's 3 standard errors...
    assert abs(shift) <= bias + 3 * se
    # ... and not only as a loose bound: an estimate (a resolved difference of the coupled
    # grids times the measured order's factor r / (r - 1), at most 2 where the error falls at
    # least twofold per halving) within twice the shift's upper end.
    assert not r4.bias_is_bound("distance_at_stop", "mean")
    assert bias <= 2 * (abs(shift) + 3 * se)
    # At the default depth the estimate is far smaller than the shift.
    r8 = crandall.simulate(SCENE, paths=n, seed=1, threads=1)
    assert float(r8.bias("distance_at_stop", "mean")) < (abs(shift) - 3 * se) / 10


def test_every_depth_walks_the_same_path():
    # The noise tree's roots are unique up to their columns' signs; the plan fixes the sign
    # (filter.cpp, canonical_signs), so a depth of either parity builds the default depth's
    # roots up to rounding and the same seed walks the same path: the velocity and the
    # displacement at t = 5 s pair with depth 8's path by path, moved only where an event
    # falls between the depths' finest substeps. Before the sign was fixed, the odd depths
    # walked the mirror image (-V, -U: a correlation of -1).
    scene = Scene(mu=1.0, g=1.0, excitation=KanaiTajimi(omega=2.0, zeta=0.6, h=1.0), t0=10.0,
                  times=[5.0], observe=["velocity", "displacement"])
    n = 200

    def first_slot(depth):
        spec = RunSpec.create(scene, paths=n, seed=1, event_depth=depth)
        return np.asarray(_core.run_samples(_plan(spec), 0, n, 1))[:, 0, 0, :2]

    deep = first_slot(8)
    for depth in (7, 5):
        other = first_slot(depth)
        for k in range(2):
            # Measured: correlations above 1 - 1e-8, the largest |dV| 3.4e-5 (depth 7) and
            # 2.5e-4 (depth 5), against a velocity's spread near 1.
            assert np.corrcoef(deep[:, k], other[:, k])[0, 1] > 0.999
        assert np.max(np.abs(other[:, 0] - deep[:, 0])) < 0.01


def test_an_envelopes_pilot_searches_as_deep_as_the_run(monkeypatch):
    # The pieces of an envelope are chosen by a pilot on the run's coupled grids
    # (crandall.pieces); it searches a filtered excitation's events to the run's depth, as
    # the run's own bias estimate of the pieces does (it used to keep the default 8).
    from crandall import bias, envelopes
    seen = []
    kept = bias.piece_table_kept

    def spy(spec, *args, **kw):
        seen.append(spec.event_depth)
        return kept(spec, *args, **kw)

    monkeypatch.setattr(bias, "piece_table_kept", spy)
    env = envelopes.from_function(lambda t: min(t, 1.0), 2.0, pieces=2)
    scene = Scene(mu=1.0, g=1.0, excitation=KanaiTajimi(omega=2.0, zeta=0.6), envelope=env,
                  times=[2.0], observe=["distance"])
    crandall.simulate(scene, paths=64, seed=3, threads=1, event_depth=4)
    assert seen and set(seen) == {4}
