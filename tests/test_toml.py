"""Scene files: TOML in physical or scaled units, ranges of times, run settings, errors."""

import math
import pathlib

import numpy as np
import pytest

import crandall
from crandall.paper import default_scene

SCENES = pathlib.Path(__file__).resolve().parent.parent / "python" / "crandall" / "scenes"


def write(tmp_path, text, name="scene.toml"):
    path = tmp_path / name
    path.write_text(text)
    return path


def test_paper_file_is_the_paper_scene():
    scene = crandall.Scene.from_toml(SCENES / "paper.toml")
    assert scene.to_dict() == default_scene().to_dict()
    # No method: the paper's run uses the engine's default, like `crandall run` without a file.
    assert scene.run_settings == {"paths": crandall.paper.DEFAULT_PATHS, "seed": 20261121}


@pytest.mark.parametrize("name", ["crate.toml", "vibrating_table.toml"])
def test_shipped_physical_scenes_load_and_run(name):
    scene = crandall.Scene.from_toml(SCENES / name)
    assert scene.units == "SI"
    assert "stop" in scene.observe
    result = crandall.simulate(scene, paths=2000, seed=1, dt=scene.run_settings.get("dt"))
    assert np.isfinite(result.mean("distance")).all()
    assert result.mean("stop_time") > scene.t0


def test_crate_values(tmp_path):
    scene = crandall.Scene.from_toml(SCENES / "crate.toml")
    assert scene.params == {"mu": 0.3, "h": 1.0, "t0": 2.0, "g": 9.81, "mass": 100.0}
    np.testing.assert_allclose(scene.times, np.arange(1, 13) * 0.25, rtol=0, atol=1e-15)


def test_physical_scene_with_list_of_times(tmp_path):
    path = write(tmp_path, """
        [scene]
        mu = 0.2
        h = 2
        t0 = inf
        times = [1, 2.5]
        observe = "distance"
        [run]
        paths = 10
        seed = 3
        dt = 0.5
        method = "euler"
    """)
    scene = crandall.Scene.from_toml(path)
    assert scene.params == {"mu": 0.2, "h": 2.0, "t0": math.inf, "g": 9.81, "mass": 1.0}
    assert scene.times.tolist() == [1.0, 2.5]
    assert scene.observe == ("distance",)
    assert scene.run_settings == {"paths": 10, "seed": 3, "dt": 0.5, "method": "euler"}


@pytest.mark.parametrize("times, expected", [
    ("{ start = 0.5, stop = 2.0, num = 4 }", [0.5, 1.0, 1.5, 2.0]),
    ("{ start = 0.5, stop = 2.0, step = 0.5 }", [0.5, 1.0, 1.5, 2.0]),
    ("{ start = 0.1, stop = 0.3, step = 0.1 }", [0.1, 0.2, 0.3]),
    ("{ start = 0, stop = 1, step = 0.4 }", [0.0, 0.4, 0.8]),
    ("{ start = 2, stop = 2, num = 1 }", [2.0]),
])
def test_time_ranges(tmp_path, times, expected):
    path = write(tmp_path, f"[scene]\nunits = 'scaled'\ntau0 = 1\ntimes = {times}\n")
    scene = crandall.Scene.from_toml(path)
    np.testing.assert_allclose(scene.times, expected, rtol=0, atol=1e-14)
    assert scene.run_settings == {}


def test_scene_dict_round_trip():
    for scene in (default_scene(), crandall.Scene(mu=0.3, h=1.0, t0=math.inf, mass=2.0,
                                                  times=[1.0], observe=["velocity"])):
        again = crandall.Scene.from_dict(scene.to_dict())
        assert again.to_dict() == scene.to_dict()
        assert repr(again) == repr(scene)


@pytest.mark.parametrize("text, key, what", [
    ("[scene]\nmu = -0.3\nh = 1\nt0 = 1\ntimes = [1]", "scene.mu", ">= 0"),
    ("[scene]\nmu = 0.3\nh = 1\nt0 = 1\ntimes = [2, 1]", "scene.times", "increasing"),
    ("[scene]\nmu = 0.3\nh = 1\ntimes = [1]", "scene.t0", "missing"),
    ("[scene]\nmu = 0.3\nh = 1\nt0 = 1\ntime = [1]", "scene.time", "unknown key"),
    ("[scene]\nmu = '0.3'\nh = 1\nt0 = 1\ntimes = [1]", "scene.mu", "number"),
    ("[scene]\nunits = 'scaled'\ntau0 = 1\nmu = 0.3\ntimes = [1]", "scene.mu", "units = 'SI'"),
    ("[scene]\nunits = 'metric'\ntau0 = 1\ntimes = [1]", "scene.units", "'SI' or 'scaled'"),
    ("[scene]\nunits = 'scaled'\ntau0 = 1\ntimes = [1]\nobserve = ['speed']", "scene.observe",
     "speed"),
    ("[scene]\nunits = 'scaled'\ntau0 = 1\ntimes = {start = 0, stop = 1}", "scene.times",
     "num or step"),
    ("[scene]\nunits = 'scaled'\ntau0 = 1\ntimes = {start = 0, stop = 1, num = 0}",
     "scene.times.num", ">= 1"),
    ("[scene]\nunits = 'scaled'\ntau0 = 1\ntimes = {start = 0, stop = 1, step = -1}",
     "scene.times.step", "> 0"),
    ("[scene]\nunits = 'scaled'\ntau0 = 1\ntimes = {start = 2, stop = 1, num = 3}",
     "scene.times.stop", "start <= stop"),
    ("[scene]\nunits = 'scaled'\ntau0 = 1\ntimes = {stop = 1, num = 3}", "scene.times.start",
     "missing"),
    ("[scene]\nunits = 'scaled'\ntau0 = 1\ntimes = [1]\n[run]\npaths = 0", "run.paths", ">= 1"),
    ("[scene]\nunits = 'scaled'\ntau0 = 1\ntimes = [1]\n[run]\nseed = -1", "run.seed", ">= 0"),
    ("[scene]\nunits = 'scaled'\ntau0 = 1\ntimes = [1]\n[run]\nmethod = 'rk4'", "run.method",
     "exact"),
    ("[scene]\nunits = 'scaled'\ntau0 = 1\ntimes = [1]\n[run]\ndt = 0", "run.dt", "> 0"),
    ("[scene]\nunits = 'scaled'\ntau0 = 1\ntimes = [1]\n[run]\nevent_depth = 1",
     "run.event_depth", "from 2 to 20"),
    ("[scene]\nunits = 'scaled'\ntau0 = 1\ntimes = [1]\n[run]\nevent_depth = 4.0",
     "run.event_depth", "integer"),
    ("[scene]\nunits = 'scaled'\ntau0 = 1\ntimes = [1]\n[run]\nthreads = 2", "run.threads",
     "unknown key"),
    ("[scene]\nunits = 'scaled'\ntau0 = 1\ntimes = [1]\n[sceen]\n", "sceen", "unknown key"),
    ("title = 'no scene'\n", "scene", "missing"),
    ("[scene]\nmu = 0.3\nh = \n", "", "not valid TOML"),
])
def test_errors_name_the_file_and_the_key(tmp_path, text, key, what):
    path = write(tmp_path, text, name="bad-scene.toml")
    with pytest.raises(ValueError) as info:
        crandall.Scene.from_toml(path)
    msg = str(info.value)
    assert msg.startswith(str(path) + ": "), msg
    assert f": {key}: " in msg or not key, msg
    assert what in msg, msg


def test_missing_file_is_a_value_error(tmp_path):
    with pytest.raises(ValueError, match="nowhere.toml: cannot read"):
        crandall.Scene.from_toml(tmp_path / "nowhere.toml")


@pytest.mark.parametrize("times, key", [
    ("{ start = 0, stop = 1, num = 100000000 }", "scene.times.num"),
    ("{ start = 0, stop = 1, num = 10000001 }", "scene.times.num"),
    ("{ start = 0, stop = 1, step = 1e-8 }", "scene.times.step"),
    ("{ start = 0, stop = 1, step = 5e-324 }", "scene.times.step"),
    ("{ start = 0, stop = 1e300, step = 1e-300 }", "scene.times.step"),
])
def test_huge_ranges_are_refused_before_they_are_built(tmp_path, times, key):
    # Before: num was not capped (27 s to build 1e8 times before the scene refused them);
    # a subnormal step raised OverflowError. One cap, scene.MAX_RANGE_TIMES, for both forms.
    import time

    from crandall.scene import MAX_RANGE_TIMES

    path = write(tmp_path, f"[scene]\nunits = 'scaled'\ntau0 = 1\ntimes = {times}\n")
    start = time.perf_counter()
    with pytest.raises(ValueError, match=key) as info:
        crandall.Scene.from_toml(path)
    assert time.perf_counter() - start < 0.5
    assert str(MAX_RANGE_TIMES) in str(info.value)


@pytest.mark.parametrize("kwargs, name", [
    (dict(mu=-1.0, h=1.0, t0=1.0, times=[1.0]), "mu"),
    (dict(mu=0.3, h=1.0, t0=1.0, times=[2.0, 1.0]), "times"),
    (dict(mu=0.3, h=1.0, t0=1.0, times=[1.0], observe=["heat"]), "observe"),
    (dict(mu=1e300, g=1e300, h=1.0, t0=1.0, times=[1.0]), "mu, g"),
])
def test_scene_errors_carry_the_parameter_name(kwargs, name):
    from crandall.scene import ParameterError

    with pytest.raises(ValueError) as info:
        crandall.Scene(**kwargs)
    assert isinstance(info.value, ParameterError) and info.value.name == name
    assert str(info.value).startswith(name)


def test_file_key_comes_from_the_error_not_its_wording(tmp_path):
    # Two parameters at fault: no single key of the file, so the table is named.
    path = tmp_path / "s.toml"
    path.write_text("[scene]\nmu = 1e300\ng = 1e300\nh = 1.0\nt0 = 1.0\ntimes = [1.0]\n")
    with pytest.raises(ValueError, match=r"s\.toml: scene: mu, g: the friction deceleration"):
        crandall.Scene.from_toml(path)
    path.write_text("[scene]\nmu = 0.3\nh = 1.0\nt0 = 1.0\ntimes = [1.0]\n"
                    "observe = ['stop', 'heat']\n")
    with pytest.raises(ValueError, match=r"s\.toml: scene\.observe: observe: unknown"):
        crandall.Scene.from_toml(path)


def test_shipped_scenes_are_listed_by_name_with_their_titles():
    listed = crandall.Scene.shipped()
    # Every file of the repository's folder of shipped scenes, by its stem.
    assert sorted(listed) == sorted(p.stem for p in SCENES.glob("*.toml"))
    assert listed["crate"] == "A 100 kg crate on a truck bed, mu = 0.3"


def test_a_shipped_scene_is_read_by_name_from_any_folder(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert crandall.Scene.from_toml("crate") == crandall.Scene.from_toml(SCENES / "crate.toml")
    assert crandall.Scene.from_toml("crate.toml").run_settings == {"paths": 200000, "seed": 7}


def test_a_file_here_comes_before_a_shipped_scene_of_the_same_name(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    write(tmp_path, '[scene]\nunits = "scaled"\ntau0 = 2.0\ntimes = [1.0]\n', name="crate")
    assert crandall.Scene.from_toml("crate").units == "scaled"


def test_an_unknown_name_lists_the_shipped_scenes(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    with pytest.raises(ValueError, match="cratee: cannot read the scene file.*not the name of a "
                                         "shipped scene.*crate, crate_sliding_in"):
        crandall.Scene.from_toml("cratee")
    # A path with a folder is never taken for a name.
    with pytest.raises(ValueError, match="cannot read the scene file: No such file") as info:
        crandall.Scene.from_toml(tmp_path / "crate.toml")
    assert "shipped" not in str(info.value)
