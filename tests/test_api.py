"""The public API: scenes, validation, reproducibility, special scenes (fast unit tests)."""

import importlib
import math
import os

import numpy as np
import pytest

import crandall
from crandall import _core
from conftest import same_result


# -- bad input: a ValueError that names the parameter --------------------------------------

@pytest.mark.parametrize(
    "kwargs, word",
    [
        ({"mu": float("nan")}, "mu"),
        ({"mu": -0.1}, "mu"),
        ({"mu": math.inf}, "mu"),
        ({"h": -1.0}, "h"),
        ({"h": float("nan")}, "h"),
        ({"t0": -1.0}, "t0"),
        ({"t0": float("nan")}, "t0"),
        ({"g": 0.0}, "g"),
        ({"g": -9.81}, "g"),
        ({"mass": 0.0}, "mass"),
        ({"mass": math.inf}, "mass"),
        ({"times": [1.0, 0.5]}, "times"),
        ({"times": [0.5, 0.5]}, "times"),
        ({"times": [-1.0, 1.0]}, "times"),
        ({"times": [1.0, float("nan")]}, "times"),
        ({"times": [1.0, math.inf]}, "times"),
        ({"times": []}, "times"),
        ({"times": [[1.0, 2.0]]}, "times"),
        ({"observe": ["velocity", "speed"]}, "observe"),
        ({"observe": []}, "observe"),
        ({"t0": math.inf, "observe": ["stop"]}, "observe"),
        ({"mu": 0.0, "observe": ["stop"]}, "observe"),
        ({"mu": "0.3"}, "mu"),
    ],
)
def test_bad_scene_raises_naming_parameter(kwargs, word):
    args = dict(mu=0.3, h=1.0, t0=2.0, times=[1.0, 2.0])
    args.update(kwargs)
    with pytest.raises(ValueError, match=word):
        crandall.Scene(**args)


@pytest.mark.parametrize("tau0", [-1.0, float("nan"), -math.inf])
def test_bad_scaled_scene(tau0):
    with pytest.raises(ValueError, match="tau0"):
        crandall.Scene.scaled(tau0=tau0, times=[1.0])


def test_scene_rejects_unknown_keyword():
    with pytest.raises(TypeError):
        crandall.Scene(mu=0.3, h=1.0, t0=1.0, times=[1.0], friction=0.2)
    with pytest.raises(TypeError):
        crandall.Scene(0.3, 1.0, 1.0)  # keyword-only


@pytest.mark.parametrize(
    "kwargs, word",
    [
        ({"paths": 0}, "paths"),
        ({"paths": -5}, "paths"),
        ({"paths": 2.5}, "paths"),
        ({"paths": True}, "paths"),
        ({"dt": 0.0}, "dt"),
        ({"dt": -0.01}, "dt"),
        ({"dt": float("nan")}, "dt"),
        ({"dt": math.inf}, "dt"),
        ({"method": "milstein"}, "method"),
        ({"seed": -1}, "seed"),
        ({"seed": 2**64}, "seed"),
        ({"seed": 1.5}, "seed"),
        ({"threads": 0}, "threads"),
    ],
)
def test_bad_run_raises_naming_parameter(paper_scene, kwargs, word):
    args = dict(paths=10, seed=1)
    args.update(kwargs)
    with pytest.raises(ValueError, match=word):
        crandall.simulate(paper_scene, **args)


def test_simulate_needs_a_scene():
    with pytest.raises(ValueError, match="scene"):
        crandall.simulate("paper", paths=10)


def test_memory_beyond_the_machine_is_refused():
    # 5e7 output times (a 400 MB array) need ~250 GB of accumulators with two threads: refused
    # with a ValueError before anything is allocated or run.
    big = crandall.Scene.scaled(tau0=1.0, times=np.linspace(1.0, 2.0, 50_000_000),
                                observe=["velocity"])
    with pytest.raises(ValueError, match="times"):
        crandall.simulate(big, paths=1, seed=1, threads=2)


def test_unknown_result_name(paper_scene):
    r = crandall.simulate(paper_scene, paths=64, seed=1)
    with pytest.raises(ValueError, match="name"):
        r.mean("speed")
    vel_only = crandall.simulate(
        crandall.Scene.scaled(tau0=1.0, times=[1.0], observe=["velocity"]), paths=64, seed=1)
    with pytest.raises(ValueError, match="distance"):
        vel_only.mean("distance")
    with pytest.raises(ValueError, match="k"):
        vel_only.moment(0, 1, 0)
    with pytest.raises(ValueError, match="j"):
        r.moment(-1, 0, 0)
    with pytest.raises(ValueError, match="4"):
        r.moment(3, 1, 1)


# -- results: shape, units, seed ------------------------------------------------------------

def test_result_shapes_and_names(paper_scene):
    r = crandall.simulate(paper_scene, paths=1000, seed=7)
    assert r.times.tolist() == [0.25, 0.5, 1.0, 1.5, 3.0]
    assert r.seed == 7 and r.paths == 1000
    for name in ("velocity", "displacement", "distance", "kinetic_energy", "dissipated_energy"):
        assert r.mean(name).shape == (5,)
        assert r.var(name).shape == (5,)
        assert np.all(r.var(name) >= 0)
        if name != "kinetic_energy":
            assert np.all(np.isfinite(r.stderr(name)))
    # The kinetic energy's standard error rests on the velocity's fourth moment: after the
    # switch-off (tau 1.5 and 3) fewer than 30 of these 1000 paths carry it, and it is
    # withheld (tests/test_few_paths.py); it was 0 at tau = 3, where every path was at rest.
    with pytest.warns(crandall.StatisticsWarning, match="carried by fewer than 30 paths"):
        se = r.stderr("kinetic_energy")
    assert np.isfinite(se[:3]).all() and np.isnan(se[3:]).all()
    for name in ("stop_time", "displacement_at_stop", "distance_at_stop",
                 "dissipated_energy_at_stop"):
        assert isinstance(r.mean(name), float)
    assert r.mean("stop_time") > 1.0  # t_s = t0 + |U1(t0)| / 2 > t0
    assert r.mean("dissipated_energy") == pytest.approx(2.0 * r.mean("distance"), rel=1e-15)
    assert r.mean("kinetic_energy") == pytest.approx(0.5 * r.moment(2, 0, 0), rel=1e-12)
    text = str(r)
    assert "seed=7" in text and "stop_time" in text and "distance" in text


def test_seed_none_is_drawn_and_recorded(paper_scene):
    r = crandall.simulate(paper_scene, paths=100)
    assert isinstance(r.seed, int) and 0 <= r.seed < 2**64
    again = crandall.simulate(paper_scene, paths=100, seed=r.seed)
    assert same_result(r, again)


def test_different_seeds_differ(paper_scene):
    a = crandall.simulate(paper_scene, paths=100, seed=1)
    b = crandall.simulate(paper_scene, paths=100, seed=2)
    assert a.mean("distance")[-1] != b.mean("distance")[-1]


@pytest.mark.parametrize("method", ["exact", "euler"])
def test_threads_do_not_change_the_result(method):
    # 70000 paths: two chunks, the second partial, with partial blocks and lanes.
    scene = crandall.Scene.scaled(tau0=0.5, times=[0.1, 0.5, 0.7])
    one = crandall.simulate(scene, paths=70_000, seed=11, dt=0.05, threads=1, method=method)
    two = crandall.simulate(scene, paths=70_000, seed=11, dt=0.05, threads=2, method=method)
    assert same_result(one, two)


def test_results_in_si_units(physical_scene):
    r = crandall.simulate(physical_scene, paths=2000, seed=3)
    s = crandall.Scaling(0.3, 1.0, 9.81)
    assert r.dt == pytest.approx(0.01 * s.time_scale)
    # moment() converts to scaled units: the same number as the scaled velocity variance.
    assert r.moment(2, 0, 0) == pytest.approx(
        (r.mean("velocity") ** 2 + r.var("velocity") * (r.paths - 1) / r.paths) / s.velocity_scale**2,
        rel=1e-9)
    assert r.mean("dissipated_energy_at_stop") == pytest.approx(
        0.3 * 9.81 * r.mean("distance_at_stop"), rel=1e-14)
    heavy = crandall.simulate(
        crandall.Scene(mu=0.3, h=1.0, t0=2.0, times=[0.5, 1.0, 2.0, 3.0], mass=100.0),
        paths=2000, seed=3)
    assert heavy.mean("kinetic_energy") == pytest.approx(100 * r.mean("kinetic_energy"), rel=1e-12)
    assert heavy.mean("distance") == pytest.approx(r.mean("distance"), rel=1e-15)


def test_physical_scene_is_the_scaled_scene_in_other_units():
    # Same law: the physical scene's statistics, converted by eq8, match the scaled scene
    # statistically (not bitwise: the core runs in each scene's own units).
    s = crandall.Scaling(0.2, 0.5, 9.81)
    tau = np.array([0.5, 2.0])
    phys = crandall.simulate(crandall.Scene(mu=0.2, h=0.5, t0=math.inf, times=s.to_t(tau),
                                            observe=["velocity", "distance"]),
                             paths=40_000, seed=5)
    scal = crandall.simulate(crandall.Scene.scaled(tau0=math.inf, times=tau,
                                                   observe=["velocity", "distance"]),
                             paths=40_000, seed=6)
    d_phys = phys.mean("distance") / s.length_scale
    se = np.hypot(phys.stderr("distance") / s.length_scale, scal.stderr("distance"))
    assert np.all(np.abs(d_phys - scal.mean("distance")) < 5 * se)


# -- special scenes -------------------------------------------------------------------------

def test_body_at_rest_when_h_is_zero():
    r = crandall.simulate(crandall.Scene(mu=0.3, h=0.0, t0=2.0, times=[1.0, 2.0, 5.0]),
                          paths=100, seed=1)
    for name in ("velocity", "displacement", "distance", "kinetic_energy", "dissipated_energy"):
        assert np.all(r.mean(name) == 0.0) and np.all(r.var(name) == 0.0)
    # No noise ever: the noise ends at 0 (Scene.t0, as for h = [0.0]) and a body at rest has
    # stopped there (it was reported at the t0 given, 2 s: issue 30).
    assert r.scene.t0 == 0.0 and r.mean("stop_time") == 0.0
    assert r.var("stop_time") == 0.0


def test_free_brownian_body_when_mu_is_zero():
    # V = h W(t) while the noise is on, then constant: Var V = h^2 t, Var U = h^2 t^3 / 3, checked
    # within 5 standard errors (E S = h E int |W| = h * (2/3) sqrt(2/pi) t^(3/2)).
    h, t0 = 0.8, 4.0
    times = np.array([1.0, 4.0, 6.0])
    r = crandall.simulate(crandall.Scene(mu=0.0, h=h, t0=t0, times=times),
                          paths=40_000, seed=2, dt=0.002)
    t_on = np.minimum(times, t0)
    var_v = h**2 * t_on
    assert np.all(np.abs(r.var("velocity") - var_v) < 5 * r.var_stderr("velocity"))
    # Displacement: U(t) = h int_0^min(t,t0) W + h W(t0) (t - t0)^+.
    after = np.maximum(times - t0, 0.0)
    var_u = h**2 * (t_on**3 / 3 + t_on**2 * after + t_on * after**2)
    assert np.all(np.abs(r.var("displacement") - var_u) < 5 * r.var_stderr("displacement"))
    mean_s = h * (2 / 3) * math.sqrt(2 / math.pi) * t_on**1.5 + h * np.sqrt(2 * t_on / math.pi) * after
    # Trapezoid bias of int |W| at dt = 0.002 is far below the standard error here (~1e-3 rel).
    assert np.all(np.abs(r.mean("distance") - mean_s) < 5 * r.stderr("distance") + 1e-3 * mean_s)
    assert np.all(r.mean("dissipated_energy") == 0.0)
    assert np.all(np.isfinite(r.var("kinetic_energy")))


def test_continuous_as_mu_goes_to_zero():
    times = [0.5, 1.0]
    kw = dict(paths=20_000, seed=9, dt=1e-3)
    free = crandall.simulate(crandall.Scene(mu=0.0, h=1.0, t0=math.inf, times=times), **kw)
    for mu in (1e-3, 1e-9, 1e-300):
        r = crandall.simulate(crandall.Scene(mu=mu, h=1.0, t0=math.inf, times=times), **kw)
        # Same random numbers, friction mu g per unit time: the difference is O(mu g t).
        for name in ("velocity", "displacement", "distance"):
            assert np.all(np.isfinite(r.mean(name)))
            assert np.allclose(r.mean(name), free.mean(name), atol=20 * mu * 9.81, rtol=0)
            assert np.allclose(r.var(name), free.var(name), atol=20 * mu * 9.81, rtol=1e-2)


def test_time_zero_and_t0_zero():
    r = crandall.simulate(crandall.Scene.scaled(tau0=0.0, times=[0.0, 1.0]), paths=50, seed=1)
    assert np.all(r.mean("velocity") == 0.0) and np.all(r.var("distance") == 0.0)
    assert r.mean("stop_time") == 0.0


def test_stop_only_scene_needs_no_times():
    r = crandall.simulate(crandall.Scene.scaled(tau0=5.0, times=[], observe=["stop"]),
                          paths=1000, seed=1)
    assert r.names == ("stop_time",)
    assert r.mean("stop_time") > 5.0


def test_velocity_only_scene_has_no_internal_steps():
    scene = crandall.Scene.scaled(tau0=math.inf, times=[1.0, 1e6], observe=["velocity"])
    r = crandall.simulate(scene, paths=10, seed=1, dt=1e-6)
    assert r.steps_per_path == 2
    stop_scene = crandall.Scene.scaled(tau0=1e5, times=[], observe=["stop"])
    assert crandall.simulate(stop_scene, paths=10, seed=1, dt=1e-6).steps_per_path == 1


def test_core_exposes_chunking_constants():
    assert _core.CHUNK_PATHS % _core.BLOCK_PATHS == 0
    assert _core.BLOCK_PATHS % _core.LANES == 0


# -- build ------------------------------------------------------------------------------------

def _cpu_flags() -> set:
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                if line.startswith("flags"):
                    return set(line.split(":", 1)[1].split())
    except OSError:
        pass
    return set()


def test_build_info_says_what_the_build_targets():
    info = _core.build_info()
    assert set(info) == {"isa", "isa_compiled", "isa_available", "philox_paths_per_register",
                         "doubles_per_register", "random_stream", "compiler"}
    assert info["philox_paths_per_register"] in (1, 4, 8)
    assert info["doubles_per_register"] in (2, 4, 8)
    assert info["random_stream"] == _core.RANDOM_STREAM
    assert info["isa"] in info["isa_available"] and "baseline" in info["isa_available"]
    # The best variant the CPU supports runs unless CRANDALL_ISA forces one: a host with AVX2
    # or AVX-512 gets the vector generator, or the speed the README quotes is not what users get.
    if os.environ.get("CRANDALL_ISA"):
        return
    flags = _cpu_flags()
    if {"avx512f", "avx512bw", "avx512dq", "avx512vl", "avx512cd"} <= flags:
        assert info["isa"] == "avx512" and info["philox_paths_per_register"] == 8
    elif {"avx2", "fma", "bmi2"} <= flags:
        assert info["isa"] == "avx2" and info["philox_paths_per_register"] == 4


# -- hardening: no raw exception, no silent wrong number -----------------------------------

@pytest.mark.parametrize("paths", [2**63 + 1, 2**64 - 1, 2**64, 2**100])
def test_too_many_paths_is_a_value_error(paths):
    scene = crandall.Scene.scaled(tau0=1.0, times=[1.0], observe=["velocity"])
    with pytest.raises(ValueError, match="paths"):
        crandall.simulate(scene, paths=paths, seed=1)


@pytest.mark.parametrize("kwargs, words", [
    ({"mu": 1e308, "h": 1.0}, "mu, g"),
    ({"mu": 1e300, "h": 1.0, "g": 1e10}, "mu, g"),
])
def test_friction_that_overflows_is_a_value_error(kwargs, words):
    with pytest.raises(ValueError, match=words):
        crandall.Scene(t0=1.0, times=[1.0], **kwargs)


@pytest.mark.parametrize("mu, h", [(1e-300, 1.0), (1.0, 1e300), (1e300, 1e-300), (1e-200, 1e100)])
def test_scaling_beyond_doubles_is_a_value_error_naming_mu_h_g(mu, h):
    with pytest.raises(ValueError, match="mu, h, g"):
        crandall.Scaling(mu, h)


def test_scales_are_computed_without_overflow():
    # 2 h^4 / (mu g)^3 = 2 (h / mu g)^3 h: the powers of h and mu g alone overflow.
    s = crandall.Scaling(mu=1e-150, h=1e-110, g=1.0)
    assert s.time_scale == pytest.approx(2e80, rel=1e-12)
    assert s.velocity_scale == pytest.approx(1e-70, rel=1e-12)
    assert s.length_scale == pytest.approx(2e10, rel=1e-12)


def test_tiny_friction_scene_runs_with_the_default_step():
    # mu = 1e-300: the scaled units overflow; the scene is simulated in SI units (no scaling),
    # with the frictionless default step, and matches the free body (Var V = h^2 t).
    scene = crandall.Scene(mu=1e-300, h=1.0, t0=math.inf, times=[0.5, 1.0])
    assert scene.scaling is None
    r = crandall.simulate(scene, paths=20_000, seed=3)
    var = r.var("velocity")
    assert np.all(np.abs(var - np.array([0.5, 1.0])) <= 5 * r.var_stderr("velocity"))
    with pytest.raises(ValueError, match="scaled units"):
        r.moment(2, 0, 0)


def test_huge_noise_scene_is_a_value_error_not_nan():
    # h = 1e300: Var V = h^2 t overflows doubles; a ValueError naming the parameters, not NaN.
    scene = crandall.Scene(mu=1.0, h=1e300, t0=1.0, times=[1.0], observe=["velocity"])
    with pytest.raises(ValueError, match="not finite"):
        crandall.simulate(scene, paths=100, seed=1)


@pytest.mark.parametrize("times, word", [
    ("1.0", "string"),
    (b"1.0", "string"),
    (["1", "2"], "strings"),
    ([True], "booleans"),
    ([True, 2.0], "booleans"),
    ([1 + 0j], "complex"),
    (np.array([1.0, 2.0], dtype=complex), "complex"),
    ([1.0, "2"], "strings"),
    ([1.0, None], "times"),
    ([[1.0, 2.0]], "one-dimensional"),
])
def test_times_must_be_real_numbers(times, word):
    with pytest.raises(ValueError, match="times") as info:
        crandall.Scene.scaled(tau0=1.0, times=times)
    assert word in str(info.value)


def test_object_arrays_of_numbers_are_accepted():
    from fractions import Fraction
    scene = crandall.Scene.scaled(tau0=1.0, times=[Fraction(1, 2), np.float32(1.0), 2])
    assert scene.times.tolist() == [0.5, 1.0, 2.0]


def test_callers_times_array_stays_writeable():
    times = np.array([0.5, 1.0])
    scene = crandall.Scene.scaled(tau0=1.0, times=times)
    assert times.flags.writeable
    times[0] = 0.25  # the scene has its own copy
    assert scene.times[0] == 0.5 and not scene.times.flags.writeable


@pytest.mark.parametrize("observe", [b"velocity", bytearray(b"velocity"), [b"velocity"], [1],
                                     {"velocity": 1}])
def test_observe_must_be_names(observe):
    # Before: b"velocity" was read as the names 118, 101, ... ("unknown observable 118").
    with pytest.raises(ValueError, match="observe.* must be"):
        crandall.Scene.scaled(tau0=1.0, times=[1.0], observe=observe)


@pytest.mark.parametrize("client", ["tcp://127.0.0.1:8786", 42, object()])
def test_client_must_be_a_dask_client(client):
    scene = crandall.Scene.scaled(tau0=1.0, times=[1.0], observe=["velocity"])
    with pytest.raises(ValueError, match="client"):
        crandall.simulate(scene, paths=10, seed=1, client=client)
    with pytest.raises(ValueError, match="client"):
        crandall.simulate_many([scene], paths=10, seed=1, client=client)


# -- memory: the check honours rlimits and cgroups -------------------------------------------

def test_cgroup_v2_and_v1_limits_are_read(tmp_path, monkeypatch):
    sim = importlib.import_module("crandall._resources")

    monkeypatch.setattr(sim, "open", open, raising=False)
    (tmp_path / "memory.max").write_text("1000000000\n")
    (tmp_path / "memory.current").write_text("400000000\n")
    assert sim._cgroup_available(str(tmp_path)) == 600_000_000
    (tmp_path / "memory.max").write_text("max\n")
    assert sim._cgroup_available(str(tmp_path)) is None
    v1 = tmp_path / "memory"
    v1.mkdir()
    (v1 / "memory.limit_in_bytes").write_text("300000000\n")
    (v1 / "memory.usage_in_bytes").write_text("100000000\n")
    assert sim._cgroup_available(str(tmp_path)) == 200_000_000
    (v1 / "memory.limit_in_bytes").write_text(str(2**63 - 4096))  # v1's "unlimited"
    assert sim._cgroup_available(str(tmp_path)) is None


def test_memory_check_uses_the_smallest_limit(monkeypatch):
    sim = importlib.import_module("crandall._resources")

    monkeypatch.setattr(sim, "_cgroup_available", lambda root="/sys/fs/cgroup": 10 << 20)
    assert sim.available_memory() <= 10 << 20
    scene = crandall.Scene.scaled(tau0=1.0, times=np.linspace(0.1, 1.0, 10_000))
    with pytest.raises(ValueError, match="times"):
        crandall.simulate(scene, paths=10, seed=1, threads=1)


_RLIMIT_SCRIPT = r"""
import resource, sys
import numpy as np
import crandall
import importlib
sim = importlib.import_module('crandall._resources')
sizes = sim._process_sizes()
limit = sizes["VmSize"] + (1 << 30)
resource.setrlimit(resource.RLIMIT_AS, (limit, resource.RLIM_INFINITY))
scene = crandall.Scene.scaled(tau0=5.0, times=np.linspace(1e-3, 10.0, 10**6))
try:
    crandall.simulate(scene, paths=1, seed=1, threads=2)
except ValueError as exc:
    print("ValueError:", exc)
    sys.exit(0)
print("no error")
sys.exit(3)
"""


def test_address_space_rlimit_gives_a_value_error_not_an_abort():
    import os
    import subprocess
    import sys

    if not os.path.exists("/proc/self/status"):
        pytest.skip("needs /proc")
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(sys.path))
    proc = subprocess.run([sys.executable, "-c", _RLIMIT_SCRIPT], capture_output=True,
                          text=True, timeout=120, env=env)
    assert proc.returncode == 0, (proc.returncode, proc.stdout, proc.stderr[-2000:])
    assert "ValueError: times" in proc.stdout


def test_times_from_a_generator_and_object_arrays():
    scene = crandall.Scene.scaled(tau0=1.0, times=(t for t in (0.5, 1.0)))
    assert scene.times.tolist() == [0.5, 1.0]
    with pytest.raises(ValueError, match="strings"):
        crandall.Scene.scaled(tau0=1.0, times=np.array(["1", "2"], dtype=object))


# -- few paths, and standard errors that cannot be estimated ---------------------------------

@pytest.mark.parametrize("method", ["richardson", "richardson2", "exact"])
def test_variances_are_never_negative_and_the_summary_never_fails(method):
    # Before: richardson's extrapolated second moment went negative for 1 or 2 paths, and
    # the summary raised "math domain error".
    scene = crandall.Scene.scaled(tau0=5, times=[0.5, 1.0, 6.0])
    for paths in (2, 3, 5):
        for seed in range(1, 16):
            r = crandall.simulate(scene, paths=paths, seed=seed, method=method)
            for name in r.names:
                var = np.atleast_1d(r.var(name))
                assert np.all(var >= 0), (paths, seed, name, var)
                assert np.all(np.isfinite(r.std(name)))
            str(r)


def test_one_path_has_no_variance():
    r = crandall.simulate(crandall.Scene.scaled(tau0=5, times=[1.0]), paths=1, seed=1)
    with pytest.warns(crandall.StatisticsWarning, match="at least 2 paths"):
        var = r.var("distance")
    assert np.isnan(var).all()
    assert math.isnan(r.var("stop_time"))  # said once per result (warnings are errors here)
    with pytest.warns(crandall.StatisticsWarning):
        assert np.isnan(r.var_stderr("distance")).all()
    text = str(r)  # no warning, no error: "n/a"
    assert "n/a" in text
    assert np.isfinite(r.mean("distance")).all()


def test_var_stderr_is_nan_with_a_warning_when_it_cannot_be_estimated():
    # richardson at dt = 5 (tau0 = 10): the combined fourth-moment term m4 - m2^2 is negative.
    # Before: var_stderr reported 0.0.
    r = crandall.simulate(crandall.Scene.scaled(tau0=10, times=[10]), paths=400_000, seed=10,
                          dt=5.0)
    with pytest.warns(crandall.StatisticsWarning, match="negative"):
        se = r.var_stderr("distance")
    assert np.isnan(se).all()


def test_var_stderr_of_a_constant_is_zero_without_warning():
    r = crandall.simulate(crandall.Scene.scaled(tau0=0.0, times=[0.0, 1.0]), paths=50, seed=1)
    assert np.all(r.var_stderr("distance") == 0.0)
    r = crandall.simulate(crandall.Scene.scaled(tau0=1.0, times=[1.0]), paths=5000, seed=1)
    assert np.all(r.var_stderr("distance") > 0)


def test_scenes_compare_by_value_and_hash_alike():
    a = crandall.Scene(mu=0.3, h=1.0, t0=2.0, times=[1.0, 2.0])
    b = crandall.Scene(mu=0.3, h=1.0, t0=2.0, times=[1.0, 2.0])
    c = crandall.Scene(mu=0.3, h=1.0, t0=2.0, times=[1.0, 2.5])
    assert a == b and hash(a) == hash(b) and a != c and len({a, b, c}) == 2
    assert a == crandall.Scene.from_dict(a.to_dict()) and a != "scene"


def test_numpy_seeds_map_to_documented_ints():
    sc = crandall.Scene.scaled(tau0=1.0, times=[1.0], observe=["velocity"])
    ss = np.random.SeedSequence(12345)
    want = int(np.random.SeedSequence(12345).generate_state(1, np.uint64)[0])
    r = crandall.simulate(sc, paths=100, seed=ss)
    assert r.seed == want
    np.testing.assert_array_equal(r.var("velocity"),
                                  crandall.simulate(sc, paths=100, seed=want).var("velocity"))
    g = np.random.default_rng(7)
    first = int(np.random.default_rng(7).integers(0, 2 ** 64, dtype=np.uint64))
    assert crandall.simulate(sc, paths=10, seed=g).seed == first
    assert crandall.simulate_many([sc, sc], paths=10, seed=np.random.SeedSequence(1))[1].seed == \
        int(np.random.SeedSequence(1).generate_state(1, np.uint64)[0])


def test_printing_a_result_never_runs_paths(monkeypatch):
    # The bias of a fixed-step run's distance takes a run of its own: printing shows it as not
    # estimated yet, naming the call that makes it, and runs nothing.
    r = crandall.simulate(crandall.Scene.scaled(tau0=1.0, times=[0.5, 2.0]), paths=2000, seed=1)
    assert r.bias_pending

    def no_run(result, threads=1):
        raise AssertionError("the bias estimate ran")

    # The hook is looked up where the result asks it (crandall.results.result).
    monkeypatch.setattr(importlib.import_module("crandall.results.result"), "_bias_estimator",
                        no_run)
    text = str(r)
    assert "not estimated yet" in text and "result.estimate_bias()" in text
    assert "estimate_bias()" in r._repr_html_()
    monkeypatch.undo()
    assert r.estimate_bias() is r and not r.bias_pending
    text = str(r)
    assert "not estimated yet" not in text and " ? " not in text
    assert f"{r.bias('distance')[1]:.2g}" in text
    # A result whose statistics are all exact in law needs no run: nothing is pending.
    v = crandall.simulate(crandall.Scene.scaled(tau0=1.0, times=[0.5], observe=["velocity"]),
                          paths=2000, seed=1)
    assert not v.bias_pending and "not estimated yet" not in str(v)


def test_statistics_failure_is_reachable_from_the_package():
    import sys
    # crandall.tail is the function, so the tail module's exception is exported beside it.
    assert crandall.StatisticsFailure is sys.modules["crandall.tail"].StatisticsFailure
    assert issubclass(crandall.StatisticsFailure, RuntimeError)


def test_the_user_facing_types_are_exported():
    import sys
    # What the entry points return and raise is reachable as crandall.NAME and listed in
    # __all__ (crandall.tail is the function, so the tail module's types sit beside it).
    for name in ("Result", "AccuracyResult", "TailResult", "ParameterError",
                 "StatisticsWarning", "StatisticsFailure"):
        assert name in crandall.__all__, name
    assert all(hasattr(crandall, name) for name in crandall.__all__)
    scene = crandall.Scene.scaled(tau0=1.0, times=[0.5], observe=["velocity"])
    assert type(crandall.simulate(scene, error=0.1, seed=1, threads=1)) is crandall.AccuracyResult
    assert issubclass(crandall.AccuracyResult, crandall.Result)
    calm = crandall.Scene(mu=0.5, h=0.0, t0=1.0, times=[0.5])  # no noise: P is 0 or 1 at once
    assert type(crandall.tail(calm, "stop_time", [0.1], seed=1)) is crandall.TailResult
    assert crandall.TailResult is sys.modules["crandall.tail"].TailResult
    with pytest.raises(crandall.ParameterError) as exc:
        crandall.simulate(scene, paths=0, seed=1)
    assert exc.value.name == "paths" and isinstance(exc.value, ValueError)
