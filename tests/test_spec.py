"""The run specification: checked once, the identity of checkpoints and the Dask task."""

import dataclasses
import json
import pathlib
import subprocess
import sys

import pytest

import crandall
from crandall import _core, checkpoint, driver, engine
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
    ("event_depth", 5, "only a filtered excitation"),
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
    assert ident == {"format": "crandall-checkpoint", "format_version": 4,
                     "crandall": crandall.__version__, "random_stream": _core.RANDOM_STREAM,
                     "estimator": "paths",
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


#: A value other than the default for every field of RunSpec but the scene. A new run option
#: (docs/architecture.md, "... a run option") adds its own here, and the test below then
#: checks that it reaches every place a run's options must reach.
OTHER = {"paths": 600, "seed": 2**64 - 3, "dt": 0.05, "method": "exact", "min_steps": 3,
         "event_depth": 5}
#: A scene every field of OTHER applies to (event_depth needs a filtered excitation).
FILTERED_SCENE = crandall.Scene(mu=1.0, g=1.0, t0=1.0, times=[0.5, 1.0],
                                excitation=crandall.KanaiTajimi(omega=2.0, zeta=0.6, h=1.0),
                                observe=["velocity", "distance", "stop"])


def test_every_field_of_the_spec_travels(tmp_path, monkeypatch):
    import importlib
    simulate = importlib.import_module("crandall.simulate")  # the module, not the function
    fields = [f.name for f in dataclasses.fields(RunSpec) if f.name != "scene"]
    assert sorted(fields) == sorted(OTHER), "give the new field a value in OTHER"
    spec = RunSpec(FILTERED_SCENE, **OTHER)
    want = spec.to_dict()
    # The plan and the checkpoint's identity.
    ckpt = tmp_path / "run.ckpt"
    run = simulate.FixedStep(spec, threads=1)
    assert run.identity() == want
    r = driver.drive(run, checkpoints=ckpt, progress=False)[0]
    assert ckpt.exists()
    import numpy as np
    with np.load(ckpt) as data:
        stored = json.loads(str(data["identity"]))
    assert {k: stored[k] for k in want} == want
    # The bias estimate's coupled run starts from the run's own options (asked here first:
    # saving the result estimates it too).
    seen = []
    real = engine.plan_options

    def spy(s, *args, **kw):
        seen.append(s.to_dict())
        return real(s, *args, **kw)

    monkeypatch.setattr(engine, "plan_options", spy)
    r.bias("distance")
    assert seen == [want]
    # The result, and its saved file.
    assert r.spec.to_dict() == want
    r.save(tmp_path / "r.nc")
    assert crandall.load(tmp_path / "r.nc").spec.to_dict() == want
    # A Dask task's argument.
    assert RunSpec.from_dict(json.loads(json.dumps(want))).to_dict() == want


#: The fields of RunSpec that a run to an accuracy also takes: its levels build their own
#: options (docs/architecture.md, "... a run option"), so simulate(error=) refuses every
#: other field users set, naming it.
WITH_ERROR = {"seed"}
#: The fields of RunSpec that crandall.tail also takes, each as an argument of its own (a
#: tail takes no RunSpec): its seed, its grid step and its method, which is the tail's own
#: (splitting or importance), so a fixed-step method is refused naming it. It takes no other.
TAIL_TAKES = {"seed", "dt", "method"}


def test_every_field_users_set_reaches_every_entry_point(tmp_path, monkeypatch, worker_client):
    # The recipe's other legs, for the fields users set (those in simulate's signature):
    # simulate, simulate_many, a scene file's [run] table, `crandall run`'s options and a
    # cluster take each of them; simulate(error=) refuses each but the seed, naming it; and
    # crandall.tail takes only its own seed, step and method.
    import inspect
    from crandall import cli, scene_file
    from crandall.errors import ParameterError
    user = {k: v for k, v in OTHER.items() if k in inspect.signature(crandall.simulate).parameters}
    assert set(user) == set(scene_file.RUN_SETTINGS), \
        "a field users set is a key of a scene file's [run] table (scene_file.RUN_SETTINGS)"
    r = crandall.simulate(FILTERED_SCENE, threads=1, **user)
    want = {k: r.spec.to_dict()[k] for k in user}
    assert want == user
    assert crandall.simulate_many([FILTERED_SCENE], threads=1, **user)[0].spec == r.spec
    remote = crandall.simulate(FILTERED_SCENE, client=worker_client, **user)
    assert remote.spec == r.spec and same_result(remote, r)
    # A scene file's [run] table.
    path = tmp_path / "s.toml"
    path.write_text("[scene]\nunits = 'SI'\nmu = 1.0\ng = 1.0\nt0 = 1.0\ntimes = [0.5, 1.0]\n"
                    "observe = ['velocity', 'distance', 'stop']\n"
                    "excitation = { kind = 'kanai_tajimi', omega = 2.0, zeta = 0.6, h = 1.0 }\n"
                    "[run]\n"
                    + "".join(f"{k} = {json.dumps(v)}\n" for k, v in user.items()))
    from_file = crandall.Scene.from_toml(path)
    assert dict(from_file.run_settings) == user
    # `crandall run`: its options, and the file's [run] table, reach simulate.
    seen = []
    real = cli.simulation.simulate

    def spy(scene, **kw):
        seen.append(kw)
        return real(scene, **kw)

    monkeypatch.setattr(cli.simulation, "simulate", spy)
    flags = [x for k, v in user.items() for x in (f"--{k.replace('_', '-')}", str(v))]
    for argv in (["run", str(path)], ["run", str(path), *flags]):
        assert cli.main([*argv, "--no-files", "--threads", "1"]) == 0
        assert {k: seen[-1][k] for k in user} == user, argv
    # A run to an accuracy: the seed only.
    for k in sorted(set(user) - WITH_ERROR):
        with pytest.raises(ParameterError, match=f"{k}: not with error=") as exc:
            crandall.simulate(FILTERED_SCENE, error=0.1, **{k: user[k]})
        assert exc.value.name == k
    # `crandall run FILE --error`: each of the file's [run] fields but the seed is refused
    # naming it or said unused on stderr (tests/test_cli.py), none dropped without a word.
    assert (set(user) - WITH_ERROR == set(cli.simulation.REFUSED_WITH_ERROR)
            | set(cli.simulation.UNUSED_WITH_ERROR))
    # A tail: no RunSpec.
    tail_takes = set(inspect.signature(crandall.tail).parameters)
    assert set(user) & tail_takes == TAIL_TAKES
    with pytest.raises(ParameterError, match="method") as exc:
        crandall.tail(SCENE, "stop_time", [1.0], method=user["method"], seed=1)
    assert exc.value.name == "method"
    for k in sorted(set(user) - TAIL_TAKES):
        with pytest.raises(TypeError, match=k):
            crandall.tail(SCENE, "stop_time", [1.0], **{k: user[k]})


def test_a_file_whose_spec_disagrees_with_its_attributes_is_refused(tmp_path):
    xr = pytest.importorskip("xarray")
    r = crandall.simulate(SCENE, paths=300, seed=4, method="exact", dt=0.1)
    r.save(tmp_path / "r.nc")
    with xr.open_dataset(tmp_path / "r.nc", engine="scipy") as opened:
        ds = opened.load()
    stored = json.loads(ds.attrs["run_spec"])
    ds.attrs["run_spec"] = json.dumps(dict(stored, seed=5))
    ds.to_netcdf(tmp_path / "bad.nc", engine="scipy", format="NETCDF3_64BIT")
    with pytest.raises(ValueError, match="run_spec has seed=5, the attribute seed 4"):
        crandall.load(tmp_path / "bad.nc")


def test_a_new_core_method_reaches_python_with_no_python_change(tmp_path):
    # docs/architecture.md, "... a method": the core's table (_core.METHOD_TABLE: name, grids,
    # skeleton, order) is the only one; simulate, simulate_many, the scene file, the CLI's
    # --method, a Dask task's spec and the memory estimate follow it, and so do the choices
    # made from its rows: the bias estimate's coupled refinement (skeleton methods only) and
    # the bias exponent a run to an accuracy assumes (the exact method's order). Followed here
    # by giving the core two methods it does not step ("midpoint" on the skeleton, "leapfrog"
    # off it) and the exact method another order, before crandall is imported, in a fresh
    # interpreter: every Python layer takes them from the rows, and the core's plan, which has
    # no such step, refuses them naming the method. A run to an accuracy chooses its grids
    # itself and refuses any method= (naming it).
    core = next(pathlib.Path(crandall.__file__).parent.glob("_core*.so"))
    script = f"""
import importlib.util, json, sys, types
spec = importlib.util.spec_from_file_location("crandall._core", {str(core)!r})
core = importlib.util.module_from_spec(spec)
spec.loader.exec_module(core)
rows = tuple((n, g, s, 1.25 if n == "exact" else o) for n, g, s, o in core.METHOD_TABLE)
core.METHOD_TABLE = rows + (("midpoint", 1, True, 2.0), ("leapfrog", 1, False, 1.0))
core.METHOD_GRIDS = dict(core.METHOD_GRIDS, midpoint=1, leapfrog=1)
sys.modules["crandall._core"] = core
import crandall
from crandall import bias, cli, engine, methods, spec
from crandall.adaptive import schedule
run_module = sys.modules["crandall.simulate"]  # crandall.simulate is the function
scene = crandall.Scene.scaled(tau0=1.0, times=[1.0], observe=["velocity", "distance"])
assert crandall.METHODS[-2:] == ("midpoint", "leapfrog") and methods.GRIDS["midpoint"] == 1
assert methods.ORDERS["midpoint"] == 2.0 and methods.SKELETON["midpoint"]
assert not methods.SKELETON["leapfrog"] and methods.ORDERS["exact"] == 1.25
# The bias estimate: coupled grids 2^(3 - 1) times the run's for the skeleton's method, none
# for the other (its bias NaN, no run); the envelope's pieces follow the same rows.
assert bias.REFINEMENT == dict(exact=2, richardson=0, richardson2=1, midpoint=2), bias.REFINEMENT
for name, coupled in (("midpoint", True), ("leapfrog", False)):
    result = types.SimpleNamespace(paths=10, method=name, scene=scene, names=("distance",))
    assert bias.needs_run_for(result) is coupled, name
    assert bias.piece_method(scene, name) == (name if coupled else "richardson")
# A run to an accuracy: the bias exponent where the levels do not resolve one.
assert schedule.ALPHA == 1.25
got = schedule._Schedule._bias([1.0, 0.4, 0.1], [1.0, 1.0, 1.0])
assert got == max(0.1, 0.4 * 2.0 ** -1.25) / (2.0 ** 1.25 - 1.0), got
try:
    crandall.simulate(scene, error=0.1, seed=1, method="midpoint")
except crandall.ParameterError as exc:
    assert exc.name == "method", exc
else:
    raise AssertionError("a run to an accuracy took a method")
assert spec.check_method("midpoint") == "midpoint"
assert run_module._memory_need(scene, 1, "midpoint") > 0
path = {str(tmp_path / "s.toml")!r}
open(path, "w").write('[scene]\\nunits = "scaled"\\ntau0 = 1.0\\ntimes = [1.0]\\n'
                      '[run]\\nmethod = "midpoint"\\n')
assert crandall.Scene.from_toml(path).run_settings["method"] == "midpoint"
args = cli._parser().parse_args(["run", path, "--method", "midpoint"])
assert args.method == "midpoint"
# A Dask task's argument: the spec as plain data, and the task refusing it where it runs.
run = spec.RunSpec.create(scene, paths=10, seed=1, method="midpoint")
plain = json.loads(json.dumps(run.to_dict()))
assert spec.RunSpec.from_dict(plain) == run
calls = (lambda: crandall.simulate(scene, paths=10, seed=1, method="midpoint"),
         lambda: crandall.simulate_many([scene], paths=10, seed=1, method="leapfrog"),
         lambda: engine.run_chunks(plain, 0, 1, 1))
for call in calls:
    try:
        call()
    except ValueError as exc:
        assert "method" in str(exc), exc
        print("refused:", exc)
    else:
        raise AssertionError("the core stepped a method it does not have")
"""
    out = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True,
                         timeout=120)
    assert out.returncode == 0, out.stderr
    assert out.stdout.count("refused:") == 3, out.stdout
