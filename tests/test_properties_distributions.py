"""Property-based tests of distributions on any scene (hypothesis, fixed seed): whatever the
physical parameters, a scene asking for every distribution either is refused with a
ValueError naming a parameter, or runs and answers every quantile and exceedance with finite
numbers (or a ValueError naming ``name``, for a quantity identically 0), its histograms
counting every path once."""

import math
import warnings

import numpy as np
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import crandall
from crandall.quantities import quantity

SETTINGS = settings(derandomize=True, deadline=None, max_examples=200,
                    suppress_health_check=[HealthCheck.too_slow])
PARAMETERS = ("mu", "h", "t0", "g", "mass", "times", "observe", "paths", "dt", "name",
              "distributions", "bins")
positive = st.sampled_from([5e-324, 1e-300, 1e-12, 1e-3, 0.3, 1.0, 9.81, 1e3, 1e12, 1e300,
                            1.7e308])
nonnegative = st.one_of(st.just(0.0), positive)


def names_a_parameter(exc: ValueError) -> bool:
    first = str(exc).split(":")[0]
    return any(p in first.replace(",", " ").split() or first.startswith(p) for p in PARAMETERS)


@SETTINGS
@given(mu=nonnegative, h=nonnegative, t0=st.one_of(nonnegative, st.just(math.inf)),
       g=positive, mass=positive,
       times=st.lists(st.sampled_from([0.0, 1e-6, 0.01, 0.5, 1.0, 3.0, 1e3]), min_size=1,
                      max_size=3, unique=True).map(sorted),
       peaks=st.booleans(), per_octave=st.sampled_from([None, 1, 8, 64]))
def test_any_scene_with_distributions_answers_or_refuses(mu, h, t0, g, mass, times, peaks,
                                                          per_octave):
    try:
        scene = crandall.Scene(mu=mu, h=h, t0=t0, g=g, mass=mass, times=times,
                               distributions=True, bins=per_octave)
        if peaks:
            scene = crandall.Scene(mu=mu, h=h, t0=t0, g=g, mass=mass, times=times,
                                   observe=list(scene.observe) + ["peaks"],
                                   distributions=True, bins=per_octave)
    except ValueError as exc:
        assert names_a_parameter(exc), str(exc)
        return
    # Few steps: the run's length is not what is tested.
    horizon = max([x for x in (scene.times[-1], scene.t0) if math.isfinite(x)] + [0.0])
    dt = horizon / 20 if horizon > 0 else 1.0
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # statistics of 3 paths may warn; not the point here
        try:
            r = crandall.simulate(scene, paths=3, seed=1, dt=dt, method="exact", threads=1)
        except ValueError as exc:
            assert names_a_parameter(exc), str(exc)
            return
        for name in r.distributions:
            t = None if quantity(name).at_stop else float(r.times[-1])
            try:
                est = r.quantile(name, 0.5, time=t)
                p = r.exceedance(name, 0.0, time=t)
            except ValueError as exc:
                assert str(exc).startswith("name:"), str(exc)
                continue
            assert not math.isnan(est.value) and est.low <= est.high, (name, est)
            assert 0.0 <= p.low <= p.value <= p.high <= 1.0, (name, p)
    for counts in r.accumulators.histograms.counts:
        assert int(counts.sum()) == 3


@SETTINGS
@given(tau0=st.sampled_from([0.0, 1e-300, 1e-12, 0.5, 5.0, 1e3, 1e12, 1e300, math.inf]),
       times=st.lists(st.sampled_from([0.0, 1e-300, 1e-8, 0.5, 5.0, 1e6, 1e300]), min_size=1,
                      max_size=3, unique=True).map(sorted),
       peaks=st.booleans())
def test_any_scaled_scene_with_distributions_answers_or_refuses(tau0, times, peaks):
    try:
        observe = None if not peaks else (
            ["velocity", "displacement", "distance", "peaks"]
            + (["stop"] if math.isfinite(tau0) else []))
        scene = crandall.Scene.scaled(tau0=tau0, times=times, observe=observe,
                                      distributions=True)
    except ValueError as exc:
        assert names_a_parameter(exc), str(exc)
        return
    horizon = max([x for x in (scene.times[-1], scene.t0) if math.isfinite(x)] + [0.0])
    dt = horizon / 20 if horizon > 0 else 1.0
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        try:
            r = crandall.simulate(scene, paths=3, seed=1, dt=dt, method="exact", threads=1)
        except ValueError as exc:
            assert names_a_parameter(exc), str(exc)
            return
        for name in r.distributions:
            t = None if quantity(name).at_stop else float(r.times[-1])
            est = r.quantile(name, 0.5, time=t)
            assert not math.isnan(est.value) and est.low <= est.high, (name, est)
    for counts in r.accumulators.histograms.counts:
        assert int(counts.sum()) == 3


_ATOMS = {}


def _atom_result():
    """A run whose laws have atoms at 0: the velocity after most bodies have stopped, and a
    distance and a stop time; made once (each example only asks it questions)."""
    if not _ATOMS:
        sc = crandall.Scene.scaled(tau0=0.5, times=[0.25, 0.5, 1.0],
                                   observe=["velocity", "distance", "kinetic_energy", "stop"],
                                   distributions=True)
        _ATOMS["r"] = crandall.simulate(sc, paths=5000, seed=4, threads=1)
    return _ATOMS["r"]


@settings(SETTINGS, max_examples=150)
@given(name=st.sampled_from(["velocity", "distance", "kinetic_energy", "stop_time",
                             "distance_at_stop", "bogus"]),
       q=st.one_of(st.floats(min_value=0.0, max_value=1.0), st.sampled_from([math.nan, -1.0,
                                                                              "0.5", True])),
       level=st.one_of(st.sampled_from([0.0, -0.0, 5e-324, -5e-324, 1e-300, -1e-300, math.inf,
                                        -math.inf, math.nan, 0.5, 1e300]),
                       st.floats(min_value=-3.0, max_value=3.0)),
       time=st.one_of(st.sampled_from([None, 0.25, 0.5, 1.0, 0.25 + 1e-17, 0.3, math.inf,
                                       -math.inf, math.nan, "1.0", True]),
                      st.floats(allow_nan=True, allow_infinity=True)),
       confidence=st.sampled_from([0.95, 0.5, 0.999, 0.0, 1.0, math.nan]))
def test_quantiles_and_exceedances_with_atoms_answer_honestly_or_refuse(name, q, level, time,
                                                                        confidence):
    r = _atom_result()
    for call in (lambda: r.quantile(name, q, time=time, confidence=confidence),
                 lambda: r.exceedance(name, level, time=time, confidence=confidence),
                 lambda: r.histogram(name, time=time)):
        try:
            out = call()
        except ValueError as exc:
            head = str(exc).split(":")[0].split()[0] if str(exc) else ""
            assert head in ("name", "q", "level", "time", "confidence"), str(exc)
            continue
        if isinstance(out, tuple):
            assert not math.isnan(out.value) and out.low <= out.high, out
            assert out.resolution >= 0
    # Exceedance is non-increasing in the level, and strict at an atom: P(X > 0) plus the
    # atom is P(X >= 0), from the same counts.
    if name != "bogus":
        t = None if quantity(name).at_stop else 1.0
        a, b = sorted([0.0, level if isinstance(level, float) and not math.isnan(level)
                       else 0.0])
        pa, pb = r.exceedance(name, a, time=t).value, r.exceedance(name, b, time=t).value
        assert pa >= pb
