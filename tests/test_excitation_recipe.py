"""The recipe "... a kind of excitation" (docs/architecture.md), followed to its step 1 only: a
kind's class in the style of crandall.excitation's kinds (its parameters checked, its plain
data, its effect, its time scale), registered in ``excitation.KINDS`` for the test. The core
does not step it (step 2) and the model does not declare it (step 3), so every entry point
refuses a scene shaken by it, naming ``scene``, before any path is drawn: simulate,
simulate(error=), simulate_many, a scene file, crandall.tail, crandall.paths,
crandall.fragility and the Dask tasks (a scene rebuilt from its plain data), called here and
through a cluster's worker process (tests/recipe_workers.py registers the stub there).
Declared, the same calls run, a cluster gives the local run's bits, and a result's file
gives them back."""

from __future__ import annotations

import importlib
import math
from dataclasses import dataclass
from typing import Any, Dict, FrozenSet

import numpy as np
import pytest

import crandall
import recipe_workers
from conftest import run_bits, same_result
from crandall import _core, adaptive, engine, excitation, model, streams
from crandall.errors import ParameterError
from crandall.excitation import Excitation
from crandall.scene import Scene
from crandall.spec import RunSpec

tail_module = importlib.import_module("crandall.tail")  # crandall.tail is the function

#: The stub kind's effect (step 2 of the recipe would name it in model.py).
STUB_EFFECT = "stub_excitation"


@dataclass(frozen=True)
class StubKind(Excitation):
    """A kind of excitation at step 1 of the recipe: a class, its checked parameter, its plain
    data, its effect and its time scale; no core options and no block yet."""

    period: float = 1.0
    kind = "stub_kind"

    def __post_init__(self) -> None:
        if not (isinstance(self.period, (int, float)) and math.isfinite(self.period)
                and self.period > 0):
            raise ParameterError("period", f"period must be finite and > 0, got "
                                           f"{self.period!r}")

    @property
    def effects(self) -> FrozenSet[str]:
        return frozenset({STUB_EFFECT})

    def to_dict(self) -> Dict[str, Any]:
        return {"kind": self.kind, "period": self.period}

    def time_scale(self) -> float:
        return self.period


#: The core's functions that draw paths: none may run for a refused scene.
DRAWING = ("run_chunk", "run_samples", "extend_paths", "extend_filtered_paths", "split_replica",
           "exact_steps")


@pytest.fixture
def stub_kind(monkeypatch):
    """The stub kind registered (a scene's plain data, a scene file and a Dask task's scene
    take it by name)."""
    monkeypatch.setitem(excitation.KINDS, StubKind.kind, StubKind)


@pytest.fixture
def no_path_drawn(monkeypatch):
    """Every path-drawing function of the core fails the test if called."""
    def refuse(name):
        def call(*args, **kwargs):
            raise AssertionError(f"_core.{name} drew paths of a refused scene")
        return call

    for name in DRAWING:
        monkeypatch.setattr(_core, name, refuse(name))


_PLAIN = dict(mu=0.5, h=1.0, t0=1.0, times=[0.5, 1.0])


def _scene() -> Scene:
    return Scene(**_PLAIN, excitation=StubKind(period=0.5))


def _scene_file(tmp_path) -> Scene:
    path = tmp_path / "stub.toml"
    path.write_text('[scene]\nmu = 0.5\nh = 1.0\nt0 = 1.0\ntimes = [0.5, 1.0]\n'
                    'excitation = { kind = "stub_kind", period = 0.5 }\n')
    return Scene.from_toml(path)


def _spec() -> Dict[str, Any]:
    # A spec's plain data as the client sends it: built from the plain scene, then shaken by
    # the stub kind (a RunSpec of the stub's scene is refused before it could be sent).
    spec = RunSpec(Scene(**_PLAIN), 100, 1, 0.01, "exact").to_dict()
    spec["scene"] = _scene().to_dict()
    return spec


def _accuracy_task() -> Dict[str, Any]:
    return {"scene": _scene().to_dict(), "eps": 0.1, "rel": None, "seed": 1, "threads": 1,
            "statistics": ["velocity:mean"], "centre": [0.0], "beta": None,
            "use_controls": False, "random_stream": streams.RANDOM_STREAM}


def _tail_task() -> Dict[str, Any]:
    return {"scene": _scene().to_dict(), "quantity": "distance_at_stop", "time": None,
            "dt": 0.01, "levels": [0.5], "particles": 10, "key": 1, "proposal": None}


#: Every entry point that draws paths of a scene, given the test's tmp_path.
ENTRY_POINTS = {
    "simulate": lambda tmp: crandall.simulate(_scene(), paths=100, seed=1, threads=1),
    "simulate(error=)": lambda tmp: crandall.simulate(_scene(), error=0.1, seed=1, threads=1),
    "simulate_many": lambda tmp: crandall.simulate_many([_scene()], paths=100, seed=1,
                                                        threads=1),
    "scene file": lambda tmp: crandall.simulate(_scene_file(tmp), paths=100, seed=1,
                                                threads=1),
    "tail": lambda tmp: crandall.tail(_scene(), "distance_at_stop", [0.5], seed=1, threads=1),
    "paths": lambda tmp: crandall.paths(_scene(), n=2, seed=1, threads=1),
    "fragility": lambda tmp: crandall.fragility(_scene(), "distance_at_stop", [0.5],
                                                intensities=[0.5, 1.0], seed=1, threads=1,
                                                progress=False),
    "RunSpec.from_dict": lambda tmp: RunSpec.from_dict(_spec()),
    "fixed-step Dask task": lambda tmp: engine.run_chunks(_spec(), 0, 1, 1,
                                                          streams.RANDOM_STREAM),
    "accuracy Dask task": lambda tmp: adaptive.batch_task(_accuracy_task(), 0, 0, 10),
    "tail Dask task": lambda tmp: tail_module.sample(_tail_task(), 0, 1, None,
                                                     streams.RANDOM_STREAM),
}


def test_the_stub_kind_is_a_kind_of_the_scene(stub_kind):
    # Step 1 holds: the scene takes the kind, its plain data and a file give it back, and the
    # kind's effect is the scene's.
    sc = _scene()
    assert sc.excitation == StubKind(period=0.5)
    assert STUB_EFFECT in sc.effects
    assert Scene.from_dict(sc.to_dict()).excitation == sc.excitation
    with pytest.raises(ParameterError) as exc:
        Scene(**_PLAIN, excitation={"kind": "stub_kind", "period": -1.0})
    assert exc.value.name == "period"


def test_an_undeclared_kind_is_unknown_to_the_scene():
    with pytest.raises(ParameterError, match="excitation: unknown kind 'stub_kind'") as exc:
        Scene(**_PLAIN, excitation={"kind": "stub_kind"})
    assert exc.value.name == "excitation"


@pytest.mark.parametrize("entry", sorted(ENTRY_POINTS))
def test_every_entry_point_refuses_a_kind_the_core_does_not_step(entry, stub_kind,
                                                                 no_path_drawn, tmp_path):
    with pytest.raises(ParameterError, match=f"scene: holds {STUB_EFFECT}, which this "
                                             "crandall does not simulate") as exc:
        ENTRY_POINTS[entry](tmp_path)
    assert exc.value.name == "scene"


#: The models of the estimators that rest on one (runs to an accuracy, tails, sample paths).
_MODELS = (model.LEVELS, model.TAIL_MODEL, model.TAIL_SPLITTING)


@pytest.fixture
def stub_declared(monkeypatch):
    """Steps 2 and 3 pretended: the core declared to step the kind (its options are none, so
    the paths are white noise's) and the models of runs to an accuracy, tails and sample paths
    to hold under it."""
    monkeypatch.setattr(model, "SIMULATED", model.SIMULATED | {STUB_EFFECT})
    kept = {ident: ident.supports for ident in _MODELS}
    for ident, supports in kept.items():
        object.__setattr__(ident, "supports", supports | {STUB_EFFECT})  # (frozen)
    yield
    for ident, supports in kept.items():
        object.__setattr__(ident, "supports", supports)


@pytest.mark.parametrize("entry", ["simulate", "simulate(error=)", "scene file",
                                   "RunSpec.from_dict", "fixed-step Dask task",
                                   "tail Dask task"])
def test_the_refusal_comes_from_the_declaration_alone(entry, stub_kind, stub_declared,
                                                      tmp_path):
    ENTRY_POINTS[entry](tmp_path)


def test_a_kind_the_tails_splitting_holds_for_but_not_its_paths_is_refused(stub_kind,
                                                                           monkeypatch):
    # Step 3 half done: simulated, and TAIL_SPLITTING declared, but the tail has no paths of
    # its own for the kind (neither the sign-drift diffusion's, TAIL_MODEL, nor the filtered
    # walk): refused naming the scene, instead of the white-noise paths.
    monkeypatch.setattr(model, "SIMULATED", model.SIMULATED | {STUB_EFFECT})
    kept = model.TAIL_SPLITTING.supports
    object.__setattr__(model.TAIL_SPLITTING, "supports", kept | {STUB_EFFECT})
    try:
        with pytest.raises(ParameterError, match="scene: crandall.tail continues the paths "
                                                 f".* not those of a scene with {STUB_EFFECT}"
                           ) as exc:
            crandall.tail(_scene(), "distance_at_stop", [0.5], seed=1, threads=1)
        assert exc.value.name == "scene"
    finally:
        object.__setattr__(model.TAIL_SPLITTING, "supports", kept)


# Through a cluster: the entry points given a client of one worker process (conftest's
# worker_client), whose crandall knows the stub only as the test tells it (recipe_workers).

#: The stub kind registered in a worker's process (step 1, as the client's stub_kind).
REGISTERED = [("crandall.excitation:KINDS", f"[{StubKind.kind}]", StubKind)]


def _declared_on_workers():
    """Steps 2 and 3 pretended in a worker's process, as the client's stub_declared."""
    return ([("crandall.model", "SIMULATED", model.SIMULATED | {STUB_EFFECT})]
            + [(f"crandall.model:{name}", "supports", getattr(model, name).supports
                | {STUB_EFFECT}) for name in ("LEVELS", "TAIL_MODEL", "TAIL_SPLITTING")])


_TAIL = dict(rel_error=0.5, min_samples=4, max_samples=4, particles=50, dt=0.02)

#: The entry points that take a client, given it and (None: run here, one thread).
CLUSTER_ENTRY_POINTS = {
    "simulate": lambda c: crandall.simulate(_scene(), paths=3000, seed=1, client=c,
                                            threads=None if c else 1),
    "simulate(error=)": lambda c: crandall.simulate(_scene(), error=0.1, seed=1, client=c,
                                                    threads=None if c else 1),
    "simulate_many": lambda c: crandall.simulate_many([_scene(), _scene()], paths=3000, seed=1,
                                                      client=c, threads=None if c else 1),
    "tail": lambda c: crandall.tail(_scene(), "distance_at_stop", [0.5], seed=1, client=c,
                                    threads=None if c else 1, **_TAIL),
}


@pytest.mark.parametrize("entry", sorted(CLUSTER_ENTRY_POINTS))
def test_on_a_cluster_every_entry_point_refuses_the_kind_before_any_path(
        entry, worker_client, stub_kind, no_path_drawn):
    # Neither this process nor the worker's may draw a path.
    _refused_with_no_path_drawn_on_the_worker(entry, worker_client)


def _refused_with_no_path_drawn_on_the_worker(entry, worker_client):
    with recipe_workers.on_workers(worker_client, REGISTERED + recipe_workers.no_path_drawn()):
        with pytest.raises(ParameterError, match=f"scene: holds {STUB_EFFECT}, which this "
                                                 "crandall does not simulate") as exc:
            CLUSTER_ENTRY_POINTS[entry](worker_client)
    assert exc.value.name == "scene"


@pytest.mark.parametrize("entry", sorted(CLUSTER_ENTRY_POINTS))
def test_a_worker_that_does_not_declare_the_kind_refuses_its_tasks(entry, worker_client,
                                                                   stub_kind, stub_declared):
    # The client declares the kind, the worker's crandall only knows its class (a cluster
    # running a crandall of step 1): each Dask task refuses the scene it rebuilds, naming it,
    # before its worker draws a path, and the client raises that error.
    _refused_with_no_path_drawn_on_the_worker(entry, worker_client)


@pytest.mark.parametrize("entry", sorted(CLUSTER_ENTRY_POINTS))
def test_declared_a_cluster_run_is_bitwise_the_local_run(entry, worker_client, stub_kind,
                                                         stub_declared, request):
    local = CLUSTER_ENTRY_POINTS[entry](None)
    if entry in ("simulate", "simulate_many"):
        # Every path of a fixed-step run is the worker's (a run to an accuracy and a tail
        # draw part of theirs in this process).
        request.getfixturevalue("no_path_drawn")
    with recipe_workers.on_workers(worker_client, REGISTERED + _declared_on_workers()):
        remote = CLUSTER_ENTRY_POINTS[entry](worker_client)
    assert run_bits(remote) == run_bits(local)


def test_declared_its_results_files_give_the_run_back(stub_kind, stub_declared, tmp_path):
    # A result's file keeps the scene's plain data, the kind's among them: loaded, the scene
    # is shaken by the stub again, and the numbers are the saved ones.
    pytest.importorskip("xarray")
    r = CLUSTER_ENTRY_POINTS["simulate"](None)
    r.save(tmp_path / "r.nc")
    loaded = crandall.load(tmp_path / "r.nc")
    assert loaded.scene.excitation == StubKind(period=0.5)
    assert STUB_EFFECT in loaded.scene.effects and not loaded.exact("velocity")
    assert same_result(loaded, r)
    t = CLUSTER_ENTRY_POINTS["tail"](None)
    t.save(tmp_path / "t.nc")
    loaded_tail = crandall.load(tmp_path / "t.nc")
    assert run_bits(loaded_tail) == run_bits(t)
