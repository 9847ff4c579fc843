"""Property-based tests of the newer entry points (hypothesis, fixed seed): runs to an
accuracy (``simulate(error=, rel_error=, statistics=, max_seconds=)``), the accuracy fields of
fixed-step results (``Result.bias/error/exact``), and checkpoints of both kinds under random
byte damage.

Whatever the input: either a ValueError whose message starts with the parameter or the file
at fault, or finite, honest numbers (an error within its target, a bias that is 0 only where
the statistic is exact in law, NaN only with a StatisticsWarning saying why); never another
exception, a crash or a hang. Each example is a fraction of a second: scaled scenes of at
most 3 time units, loose targets, few paths.
"""

import math
import warnings

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import crandall
from crandall import StatisticsWarning

SETTINGS = settings(derandomize=True, deadline=None, max_examples=25,
                    suppress_health_check=[HealthCheck.too_slow,
                                           HealthCheck.function_scoped_fixture])

NAMES = ("error", "rel_error", "statistics", "observe", "max_seconds", "times", "progress",
         "seed", "threads")

observe = st.lists(st.sampled_from(["velocity", "displacement", "distance", "kinetic_energy",
                                    "stop"]), min_size=1, max_size=4, unique=True)
scene = st.builds(
    lambda tau0, times, obs: crandall.Scene.scaled(tau0=tau0, times=times, observe=obs),
    st.floats(min_value=0.2, max_value=3.0),
    st.lists(st.floats(min_value=0.05, max_value=3.0), min_size=1, max_size=3, unique=True)
    .map(sorted),
    observe)
target = st.one_of(
    st.floats(min_value=0.08, max_value=1.0),                       # reachable in a moment
    st.sampled_from([0.0, -1.0, math.nan, math.inf, 5e-324, 1e-200, 1e-160, 1e-12, True,
                     "0.1", None]))
statistics = st.one_of(
    st.none(),
    st.lists(st.sampled_from(["velocity:mean", "velocity:var", "distance:var",
                              "displacement:var", "distance_at_stop:mean", "stop_time:var",
                              "distance:median", "bogus:mean"]), min_size=1, max_size=3),
    st.sampled_from([{"distance": "var"}, 5, [], ["velocity", 7], "distance:var"]))


def _first_word_names_a_parameter(exc: Exception) -> bool:
    head = str(exc).split(":")[0].split()[0] if str(exc) else ""
    return any(head.startswith(n) for n in NAMES)


@SETTINGS
@given(sc=scene, value=target, relative=st.booleans(), stats=statistics)
def test_runs_to_an_accuracy_are_honest_or_refused(sc, value, relative, stats):
    kwargs = {"rel_error" if relative else "error": value, "statistics": stats}
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", StatisticsWarning)
            r = crandall.simulate(sc, seed=1, threads=1, max_seconds=20.0, **kwargs)
    except ValueError as exc:
        assert _first_word_names_a_parameter(exc), str(exc)
        return
    assert isinstance(value, float) and math.isfinite(value) and value > 0
    for name in r.names:
        for stat in ("mean", "var"):
            try:
                est = np.atleast_1d(r.mean(name) if stat == "mean" else r.var(name))
            except ValueError:
                continue  # not asked for
            err = np.atleast_1d(r.error(name, stat))
            bias = np.atleast_1d(r.bias(name, stat))
            assert np.all(np.isfinite(est)) and np.all(np.isfinite(err)), (name, stat)
            assert np.all(bias >= 0) and np.all(err >= bias)
            if r.exact(name, stat):
                assert np.all(bias == 0)
            if not relative:
                # The run stops when every estimated error is within the target.
                assert np.all(err <= value * (1 + 1e-12)), (name, stat, err, value)
            lo, hi = r.interval(name, stat)
            assert np.all(np.atleast_1d(lo) <= est) and np.all(est <= np.atleast_1d(hi))


@SETTINGS
@given(sc=scene, method=st.sampled_from(crandall.METHODS),
       dt=st.sampled_from([None, 0.05, 0.25, 0.5, 1.0]), paths=st.sampled_from([1, 2, 50, 400]))
def test_fixed_step_accuracy_fields_are_finite_or_nan_with_a_reason(sc, method, dt, paths):
    r = crandall.simulate(sc, paths=paths, seed=2, dt=dt, method=method, threads=1)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        for name in r.names:
            for stat in ("mean", "var"):
                bias = np.atleast_1d(r.bias(name, stat))
                err = np.atleast_1d(r.error(name, stat))
                exact = r.exact(name, stat)
                if exact:
                    assert np.all(bias == 0), (name, stat)
                if np.isnan(bias).any() or np.isnan(err).any():
                    # NaN only with a reason: a warning naming this statistic, or one that
                    # holds for the whole result (said once per result: fewer than 2 paths).
                    said = [str(w.message) for w in caught
                            if issubclass(w.category, StatisticsWarning)]
                    assert any(name in m or "2 paths" in m for m in said), \
                        (name, stat, method, paths, said)
                else:
                    assert np.all(bias >= 0) and np.all(np.isfinite(err))
                    assert np.all(err >= bias)
                if method in ("euler", "refine") and not exact:
                    assert np.isnan(bias).all()


@pytest.fixture(scope="module")
def checkpoints(tmp_path_factory):
    """A finished checkpoint of each kind, as bytes, with the run that made it."""
    folder = tmp_path_factory.mktemp("ckpt")
    sc = crandall.Scene.scaled(tau0=1.0, times=[0.5, 1.0], observe=["velocity", "distance",
                                                                      "stop"])
    acc, fixed = folder / "acc.json", folder / "fixed.ckpt"
    a = crandall.simulate(sc, error=0.1, seed=3, threads=1, checkpoint=acc)
    f = crandall.simulate(sc, paths=3 * crandall._core.CHUNK_PATHS, seed=3, dt=0.1, threads=1,
                          checkpoint=fixed)
    return sc, {"acc": (acc.read_bytes(), a), "fixed": (fixed.read_bytes(), f)}


@SETTINGS
@given(kind=st.sampled_from(["acc", "fixed"]),
       damage=st.lists(st.tuples(st.integers(min_value=0), st.integers(min_value=0,
                                                                       max_value=255)),
                       min_size=1, max_size=4),
       cut=st.one_of(st.none(), st.integers(min_value=0)))
def test_damaged_checkpoints_are_refused_or_give_the_same_result(checkpoints, tmp_path, kind,
                                                                 damage, cut):
    sc, made = checkpoints
    data, whole = made[kind]
    raw = bytearray(data)
    for at, byte in damage:
        raw[at % len(raw)] = byte
    if cut is not None:
        raw = raw[:cut % len(raw)]
    path = tmp_path / f"damaged-{kind}"
    path.write_bytes(bytes(raw))
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", StatisticsWarning)
            if kind == "acc":
                r = crandall.simulate(sc, error=0.1, seed=3, threads=1, checkpoint=path)
            else:
                r = crandall.simulate(sc, paths=3 * crandall._core.CHUNK_PATHS, seed=3, dt=0.1,
                                      threads=1, checkpoint=path)
    except ValueError as exc:
        assert str(exc).startswith("checkpoint: ") and str(path) in str(exc), str(exc)
        return
    # Accepted: the damage changed nothing the run reads (or the file was re-run from a
    # point the run itself could have saved): the numbers are the run's own.
    for name in ("velocity", "distance"):
        np.testing.assert_array_equal(r.mean(name), whole.mean(name))
        np.testing.assert_array_equal(r.var(name), whole.var(name))
