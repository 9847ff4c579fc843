"""Model features (crandall.model): an identity is used, and a number reported exact, only for
scenes whose effects it supports. The scenes of this version hold no effect beyond the paper's;
a stub effect (no dynamics of its own, declared simulated for the test) stands in for the
initial states and intensity schedules to come, which no identity supports yet."""

from __future__ import annotations

import numpy as np
import pytest

import crandall
from crandall import model, plots
from crandall.scene import Scene


class _StubScene(Scene):
    """The paper's scene that says it holds one more effect."""

    @property
    def effects(self) -> frozenset:
        return frozenset({"stub"})


def _stub(**kw):
    return _StubScene(mu=0.5, h=1.0, t0=1.0, times=[0.5, 1.0], **kw)


@pytest.fixture
def stub_simulated(monkeypatch):
    monkeypatch.setattr(model, "SIMULATED", frozenset({"stub"}))


def test_the_paper_scene_holds_every_identity():
    sc = Scene(mu=0.5, h=1.0, t0=1.0, times=[0.5, 1.0])
    assert sc.effects == frozenset()
    for identity in (model.EXACT_STEP, model.ITO_DISTANCE, model.ISOMETRY, model.ZERO_FRICTION,
                     model.ANALYTIC):
        assert model.holds(sc, identity)


def test_an_effect_the_core_does_not_simulate_is_refused():
    with pytest.raises(ValueError, match="scene: holds stub, which this crandall does not simulate"):
        crandall.simulate(_stub(), paths=100, seed=1)
    with pytest.raises(ValueError, match="scene: holds stub"):
        crandall.simulate(_stub(), error=0.1, seed=1)


def test_nothing_is_reported_exact_for_an_effect_no_identity_supports(stub_simulated):
    sc = _stub()
    paper = Scene(mu=0.5, h=1.0, t0=1.0, times=[0.5, 1.0])
    r = crandall.simulate(sc, paths=4000, seed=3, threads=1, method="exact")
    r_paper = crandall.simulate(paper, paths=4000, seed=3, threads=1, method="exact")
    # The same paths (the stub has no dynamics): only the claims differ.
    np.testing.assert_array_equal(r.mean("velocity"), r_paper.mean("velocity"))
    for name in r.names:
        for stat in ("mean", "var"):
            assert not r.exact(name, stat), (name, stat)
    assert r_paper.exact("velocity") and r_paper.exact("stop_time")
    # The velocity's bias is estimated from the coupled grids instead of set to 0.
    assert np.all(np.isfinite(r.bias("velocity")))

    a = crandall.simulate(sc, error=0.05, seed=3, threads=1)
    a_paper = crandall.simulate(paper, error=0.05, seed=3, threads=1)
    for name in a.names:
        for stat in ("mean", "var"):
            assert not a.exact(name, stat), (name, stat)
    # On the paper's scene the mean distance comes from the velocity through the Ito identity
    # (exact, no bias) and the mean distance at the stop is the constant sigma^2 t0 / (2 c).
    assert a_paper.exact("distance") and a_paper.exact("distance_at_stop")
    assert a_paper.error("distance_at_stop") == 0.0
    assert a.error("distance_at_stop") > 0.0
    # Both are still honest estimates of the same numbers (4 reported errors: a false
    # failure has probability below 1e-4 per statistic).
    for name in ("distance", "velocity", "distance_at_stop"):
        for stat in ("mean", "var"):
            d = np.abs(np.asarray(getattr(a, stat)(name)) - np.asarray(getattr(a_paper, stat)(name)))
            tol = 4 * np.hypot(a.error(name, stat), a_paper.error(name, stat)) + 1e-12
            assert np.all(d <= tol), (name, stat)
    # The variance at the stop comes from Ito's isometry on the paper's scene only; the stub's
    # run sums the squares of the distance (its per-path values hold no isometry slot).
    from crandall import adaptive
    iso = {(t.name, t.stat) for t in adaptive._targets(paper) if t.isometry}
    assert iso == {("distance_at_stop", "var"), ("dissipated_energy_at_stop", "var")}
    assert not any(t.isometry for t in adaptive._targets(sc))


def test_the_closed_forms_are_not_offered_for_an_effect_they_do_not_hold_under(stub_simulated):
    r = crandall.simulate(_stub(distributions=["velocity"]), paths=2000, seed=3, threads=1)
    with pytest.raises(ValueError, match="closed forms do not hold for a scene with stub"):
        crandall.paper.scaled_factors(r)
    assert plots._analytic_law(r, "velocity", 0.5) is None
    from crandall import cli
    with pytest.raises(ValueError, match="closed forms do not hold"):
        cli._analytic_table(_stub())
