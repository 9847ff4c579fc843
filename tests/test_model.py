"""Model features (crandall.model): an identity is used, and a number reported exact, only for
scenes whose effects it supports. The scenes of this version hold no effect beyond the paper's;
a stub effect (no dynamics of its own, declared simulated for the test) stands in for the
initial states and intensity schedules to come, which no identity supports yet.

The recipe's legs: simulate, simulate(error=), simulate_many, crandall.tail, crandall.paths,
crandall.fragility, a scene file, a result's and a tail's file, and Dask, both the tasks
called here and the entry points given a client of a worker process (tests/recipe_workers.py
makes the stub there too)."""

from __future__ import annotations

import importlib

import numpy as np
import pytest

import crandall
import recipe_workers
from conftest import run_bits, same_result
from crandall import adaptive, engine, model, plots, streams
from crandall.errors import ParameterError
from crandall.scene import Scene
from crandall.spec import RunSpec

tail_module = importlib.import_module("crandall.tail")  # crandall.tail is the function


class _StubScene(Scene):
    """The paper's scene that says it holds one more effect."""

    @property
    def effects(self) -> frozenset:
        return frozenset({"stub"})


def _stub(**kw):
    return _StubScene(mu=0.5, h=1.0, t0=1.0, times=[0.5, 1.0], **kw)


@pytest.fixture
def stub_simulated(monkeypatch):
    """The core declared to simulate the stub, and the estimators that rest on a model of
    their own (runs to an accuracy, tails and sample paths) declared to hold under it."""
    monkeypatch.setattr(model, "SIMULATED", frozenset({"stub"}))
    kept = {ident: ident.supports for ident in (model.LEVELS, model.TAIL_MODEL,
                                                model.TAIL_SPLITTING)}
    for ident, supports in kept.items():
        object.__setattr__(ident, "supports", supports | {"stub"})
    yield
    for ident, supports in kept.items():
        object.__setattr__(ident, "supports", supports)


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


_PLAIN = dict(mu=0.5, h=1.0, t0=1.0, times=[0.5, 1.0])
_SPEC = RunSpec(Scene(**_PLAIN), 100, 1, 0.01, "exact").to_dict()
_ACCURACY_TASK = {"scene": Scene(**_PLAIN).to_dict(), "eps": 0.1, "rel": None, "seed": 1,
                  "threads": 1, "statistics": ["velocity:mean"], "centre": [0.0], "beta": None,
                  "use_controls": False, "random_stream": streams.RANDOM_STREAM}
_TAIL_TASK = {"scene": Scene(**_PLAIN).to_dict(), "quantity": "distance_at_stop", "time": None,
              "dt": 0.01, "levels": [0.5], "particles": 10, "key": 1, "proposal": None}

#: Every entry point that draws paths of a scene, given the scene (as an object or, for the
#: Dask tasks and the spec's plain data, rebuilt from its dict).
ENTRY_POINTS = {
    "simulate": lambda sc: crandall.simulate(sc, paths=100, seed=1, threads=1),
    "simulate(error=)": lambda sc: crandall.simulate(sc, error=0.1, seed=1, threads=1),
    "simulate(rel_error=)": lambda sc: crandall.simulate(sc, rel_error=0.1, seed=1, threads=1),
    "simulate_many": lambda sc: crandall.simulate_many([sc], paths=100, seed=1, threads=1),
    "tail": lambda sc: crandall.tail(sc, "distance_at_stop", [0.5], seed=1, threads=1),
    "paths": lambda sc: crandall.paths(sc, n=2, seed=1, threads=1),
    "fragility": lambda sc: crandall.fragility(sc, "distance_at_stop", [0.5],
                                               intensities=[0.5, 1.0], seed=1, threads=1,
                                               progress=False),
    "RunSpec": lambda sc: RunSpec(sc, 100, 1, 0.01, "exact"),
    "RunSpec.create": lambda sc: RunSpec.create(sc, paths=100, seed=1),
    "RunSpec.from_dict": lambda sc: RunSpec.from_dict(_SPEC),
    "fixed-step Dask task": lambda sc: engine.run_chunks(_SPEC, 0, 1, 1,
                                                         streams.RANDOM_STREAM),
    "accuracy Dask task": lambda sc: adaptive.batch_task(_ACCURACY_TASK, 0, 0, 10),
    "tail Dask task": lambda sc: tail_module.sample(_TAIL_TASK, 0, 1, None,
                                                    streams.RANDOM_STREAM),
}


@pytest.fixture
def every_scene_holds_a_stub(monkeypatch):
    """Every scene, also one rebuilt from plain data by a Dask task, holds the effect "stub"
    (no dynamics of its own), which the core is not declared to simulate."""
    monkeypatch.setattr(Scene, "effects", property(lambda self: frozenset({"stub"})))


@pytest.mark.parametrize("entry", sorted(ENTRY_POINTS))
def test_every_entry_point_refuses_an_effect_the_core_does_not_simulate(
        entry, every_scene_holds_a_stub):
    with pytest.raises(ParameterError,
                       match="scene: holds stub, which this crandall does not simulate") as exc:
        ENTRY_POINTS[entry](Scene(**_PLAIN))
    assert exc.value.name == "scene"


@pytest.mark.parametrize("entry", ["RunSpec", "RunSpec.from_dict", "fixed-step Dask task",
                                   "tail Dask task", "paths"])
def test_every_entry_point_runs_the_stub_once_it_is_declared_simulated(
        entry, every_scene_holds_a_stub, stub_simulated):
    # The refusal above comes from the declaration alone: declared, the same calls run.
    ENTRY_POINTS[entry](Scene(**_PLAIN))


#: The entry points of the estimators with a model of their own, and the identity each rests on.
_ESTIMATOR_MODELS = {"simulate(error=)": model.LEVELS, "simulate(rel_error=)": model.LEVELS,
                     "accuracy Dask task": model.LEVELS, "tail": model.TAIL_SPLITTING,
                     "fragility": model.TAIL_SPLITTING,
                     "tail Dask task": model.TAIL_SPLITTING, "paths": model.TAIL_MODEL}


@pytest.mark.parametrize("entry", sorted(_ESTIMATOR_MODELS))
def test_an_estimator_refuses_a_simulated_effect_its_own_model_does_not_hold_under(
        entry, every_scene_holds_a_stub, monkeypatch):
    # The core simulates the stub, but runs to an accuracy, tails and sample paths rest on
    # models of their own (model.LEVELS, model.TAIL_SPLITTING, model.TAIL_MODEL): each refuses, naming the scene,
    # until its identity lists the effect.
    monkeypatch.setattr(model, "SIMULATED", frozenset({"stub"}))
    identity = _ESTIMATOR_MODELS[entry]
    with pytest.raises(ParameterError, match=f"scene: .* not available for a scene with stub "
                                             rf"\({identity.what[:20]}") as exc:
        ENTRY_POINTS[entry](Scene(**_PLAIN))
    assert exc.value.name == "scene"


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


def test_a_scene_file_of_the_stub_is_refused_until_declared(every_scene_holds_a_stub,
                                                            tmp_path, monkeypatch):
    path = tmp_path / "s.toml"
    path.write_text("[scene]\nmu = 0.5\nh = 1.0\nt0 = 1.0\ntimes = [0.5, 1.0]\n")
    sc = Scene.from_toml(path)
    with pytest.raises(ParameterError, match="scene: holds stub") as exc:
        crandall.simulate(sc, paths=100, seed=1, threads=1)
    assert exc.value.name == "scene"
    monkeypatch.setattr(model, "SIMULATED", frozenset({"stub"}))
    r = crandall.simulate(sc, paths=100, seed=1, threads=1)
    assert not r.exact("velocity")


def test_declared_the_stubs_files_give_the_run_back(every_scene_holds_a_stub, stub_simulated,
                                                    tmp_path):
    # A result's file rebuilds its scene from plain data: loaded, it holds the stub again, so
    # nothing becomes exact, and the numbers are the saved ones; so is a tail's file.
    pytest.importorskip("xarray")
    r = CLUSTER_ENTRY_POINTS["simulate"](None)
    r.save(tmp_path / "r.nc")
    loaded = crandall.load(tmp_path / "r.nc")
    assert not loaded.exact("velocity")
    assert same_result(loaded, r)
    assert np.asarray(loaded.bias("velocity")).tobytes() == np.asarray(r.bias("velocity")).tobytes()
    t = CLUSTER_ENTRY_POINTS["tail"](None)
    t.save(tmp_path / "t.nc")
    assert run_bits(crandall.load(tmp_path / "t.nc")) == run_bits(t)


# Through a cluster: the entry points given a client of one worker process (conftest's
# worker_client), patched as this process is (recipe_workers.on_workers).

def _holds_stub(self) -> frozenset:
    return frozenset({"stub"})


#: Every scene of a worker's process holds the stub (as every_scene_holds_a_stub here).
HOLDS_STUB = [("crandall.scene:Scene", "effects", property(_holds_stub))]


def _simulated_on_workers():
    """stub_simulated in a worker's process."""
    return ([("crandall.model", "SIMULATED", frozenset({"stub"}))]
            + [(f"crandall.model:{name}", "supports", getattr(model, name).supports | {"stub"})
               for name in ("LEVELS", "TAIL_MODEL", "TAIL_SPLITTING")])


_TAIL = dict(rel_error=0.5, min_samples=4, max_samples=4, particles=50, dt=0.02)

#: The entry points that take a client, given it and (None: run here, one thread).
CLUSTER_ENTRY_POINTS = {
    "simulate": lambda c: crandall.simulate(Scene(**_PLAIN), paths=3000, seed=1, client=c,
                                            threads=None if c else 1),
    "simulate(error=)": lambda c: crandall.simulate(Scene(**_PLAIN), error=0.1, seed=1,
                                                    client=c, threads=None if c else 1),
    "simulate_many": lambda c: crandall.simulate_many([Scene(**_PLAIN)] * 2, paths=3000, seed=1,
                                                      client=c, threads=None if c else 1),
    "tail": lambda c: crandall.tail(Scene(**_PLAIN), "distance_at_stop", [0.5], seed=1,
                                    client=c, threads=None if c else 1, **_TAIL),
}


@pytest.fixture
def no_path_drawn_here(monkeypatch):
    """Every path-drawing function of this process's core fails the test if called."""
    for name, refuse in zip(recipe_workers.DRAWING, (c[2] for c in
                                                     recipe_workers.no_path_drawn())):
        monkeypatch.setattr(crandall._core, name, refuse)


@pytest.mark.parametrize("entry", sorted(CLUSTER_ENTRY_POINTS))
def test_on_a_cluster_every_entry_point_refuses_the_stub_before_any_path(
        entry, worker_client, every_scene_holds_a_stub, no_path_drawn_here):
    _refused_with_no_path_drawn_on_the_worker(entry, worker_client)


def _refused_with_no_path_drawn_on_the_worker(entry, worker_client):
    with recipe_workers.on_workers(worker_client, HOLDS_STUB + recipe_workers.no_path_drawn()):
        with pytest.raises(ParameterError, match="scene: holds stub, which this crandall does "
                                                 "not simulate") as exc:
            CLUSTER_ENTRY_POINTS[entry](worker_client)
    assert exc.value.name == "scene"


@pytest.mark.parametrize("entry", sorted(CLUSTER_ENTRY_POINTS))
def test_a_worker_that_does_not_simulate_the_stub_refuses_its_tasks(
        entry, worker_client, every_scene_holds_a_stub, stub_simulated):
    # Declared here, not in the worker's process (a cluster running a crandall that does not
    # simulate the effect): each Dask task refuses the scene it rebuilds, naming it, before
    # its worker draws a path.
    _refused_with_no_path_drawn_on_the_worker(entry, worker_client)


@pytest.mark.parametrize("entry", sorted(CLUSTER_ENTRY_POINTS))
def test_declared_a_cluster_run_of_the_stub_is_bitwise_the_local_run(
        entry, worker_client, every_scene_holds_a_stub, stub_simulated, request):
    local = CLUSTER_ENTRY_POINTS[entry](None)
    if entry in ("simulate", "simulate_many"):
        # Every path of a fixed-step run is the worker's (a run to an accuracy and a tail
        # draw part of theirs in this process).
        request.getfixturevalue("no_path_drawn_here")
    with recipe_workers.on_workers(worker_client, HOLDS_STUB + _simulated_on_workers()):
        remote = CLUSTER_ENTRY_POINTS[entry](worker_client)
    assert run_bits(remote) == run_bits(local)
