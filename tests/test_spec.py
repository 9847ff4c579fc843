"""The run specification: checked once, the identity of checkpoints and the Dask task."""

import dataclasses
import json

import pytest

import crandall
from crandall import _core, checkpoint, engine
from crandall.methods import DEFAULT_MIN_STEPS
from crandall.spec import RunSpec
from conftest import same_result

SCENE = crandall.Scene.scaled(tau0=1.0, times=[0.5, 1.0], observe=["velocity", "distance",
                                                                 "stop"])


def test_create_fills_the_defaults_of_simulate():
    spec = RunSpec.create(SCENE, paths=10)
    assert spec.dt == crandall.default_dt(SCENE) and spec.min_steps == DEFAULT_MIN_STEPS
    assert 0 <= spec.seed < 2**64 and spec.method == "richardson"
    explicit = RunSpec.create(SCENE, paths=10, seed=3, dt=0.1, method="exact")
    assert (explicit.seed, explicit.dt, explicit.min_steps) == (3, 0.1, 0)


@pytest.mark.parametrize("field, value, match", [
    ("paths", 0, "paths must be >= 1"), ("seed", -1, "seed must be >= 0"),
    ("dt", float("nan"), "dt must be finite"), ("method", "rk4", "method must be one of"),
    ("min_steps", -1, "min_steps must be >= 0"), ("scene", "x", "scene must be a"),
])
def test_every_field_is_checked(field, value, match):
    good = RunSpec(SCENE, 10, 1, 0.1, "exact")
    with pytest.raises(ValueError, match=match):
        dataclasses.replace(good, **{field: value})


def test_frozen_and_round_trip():
    spec = RunSpec(SCENE, 10, 1, 0.1, "exact", 4)
    with pytest.raises(dataclasses.FrozenInstanceError):
        spec.paths = 11
    again = RunSpec.from_dict(json.loads(json.dumps(spec.to_dict())))
    assert again.to_dict() == spec.to_dict()


def test_checkpoint_identity_is_what_it_was():
    # The keys and values checkpoints have always stored, so that existing ones still resume.
    spec = RunSpec(SCENE, 10, 7, 0.1, "exact", 4)
    ident = checkpoint.identity(spec)
    assert ident == {"format": "crandall-checkpoint", "format_version": 3,
                     "crandall": crandall.__version__, "random_stream": _core.RANDOM_STREAM,
                     "scene": SCENE.to_dict(), "paths": 10, "seed": 7, "dt": 0.1,
                     "method": "exact", "min_steps": 4}
    assert ident == checkpoint.identity(SCENE, paths=10, seed=7, dt=0.1, method="exact",
                                        min_steps=4)


def test_engine_task_takes_a_spec_or_its_dict():
    spec = RunSpec(SCENE, 300, 5, 0.1, "exact")
    a = engine.run_chunks(spec, 0, 1, 1)
    b = engine.run_chunks(spec.to_dict(), 0, 1, 2, engine.RANDOM_STREAM)
    assert (a[0][0].central == b[0][0].central).all() and (a[0][1].means == b[0][1].means).all()
    r = crandall.simulate(SCENE, paths=300, seed=5, dt=0.1, method="exact")
    assert (r.accumulators.times.central == a[0][0].central).all()
    assert same_result(r, crandall.simulate(SCENE, paths=300, seed=5, dt=0.1, method="exact",
                                            threads=1))


def test_method_grid_counts_are_the_cores():
    # One step of dt to the only output time: the core rounds the step count up to a multiple
    # of its grid group, 2^(grids - 1), which is what methods.GRIDS must say.
    from crandall.methods import GRIDS, METHODS

    scene = crandall.Scene.scaled(tau0=1.0, times=[0.1], observe=["distance"])
    for method in METHODS:
        plan = engine.make_plan(RunSpec(scene, 10, 1, 0.1, method))
        assert plan.steps_per_path == 2 ** (GRIDS[method] - 1), method


def test_result_gives_its_spec():
    r = crandall.simulate(SCENE, paths=300, seed=8)
    spec = r.spec
    assert spec == RunSpec.create(SCENE, paths=300, seed=8)
    again = crandall.simulate(spec.scene, paths=spec.paths, seed=spec.seed, dt=spec.dt,
                              method=spec.method)
    # An explicit dt gives a uniform grid; the default one was graded: repeating needs both.
    assert spec.min_steps == DEFAULT_MIN_STEPS and again.min_steps == 0
    assert same_result(r, crandall.simulate(SCENE, paths=300, seed=8, dt=None))
