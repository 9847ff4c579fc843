"""A white-noise tail run's grid comes from the core's plan (``_core.tail_grid``): the same
bits as the NumPy cut tail/problem.py made before (kept here as the reference), on scenes
with pieces, an envelope, a t0 off the step grid, a start in motion, a time horizon, extra
breaks and the coarse grid."""

from __future__ import annotations

import importlib
import math

import numpy as np
import pytest

import crandall
from crandall import envelopes

TAIL = importlib.import_module("crandall.tail")


def numpy_grid(scene, horizon, dt, breaks=(), coarse=False):
    """tail/problem.py's former cut: the intervals between 0, the pieces' ends, the breaks and
    the horizon, each in max(1, ceil(length / dt - 1e-9)) equal parts (one without noise or
    when coarse) at the points a + (b - a) i / n; (lengths, noises, starts)."""
    pieces = list(scene.pieces) if scene.pieces is not None else [(scene.t0, scene.noise)]
    cuts = sorted({0.0, horizon} | {e for e, _ in pieces if 0 < e < horizon}
                  | {x for x in breaks if 0 < x < horizon})
    lengths, noises, starts = [], [], []
    for a, b in zip(cuts[:-1], cuts[1:]):
        sigma = next(n for e, n in pieces if e >= b)
        if b > a:
            n = 1 if (sigma == 0 or coarse) else max(1, math.ceil((b - a) / dt - 1e-9))
            edges = a + (b - a) * np.arange(n + 1) / n
            lengths.extend(np.diff(edges))
            noises.extend([sigma] * n)
            starts.extend(edges[:-1])
    return (np.asarray(lengths, dtype=np.float64), np.asarray(noises, dtype=np.float64),
            np.asarray(starts, dtype=np.float64))


def _envelope_scene():
    env = envelopes.from_function(lambda t: 0.8 * (1.0 + 0.3 * math.sin(3.0 * t)), 3.7,
                                  pieces=7)
    return crandall.Scene(mu=0.3, envelope=env, v0=0.2, times=[1.0, 5.0])


SCENES = {
    "paper": crandall.Scene.scaled(tau0=5, times=[5]),
    "t0 off the grid": crandall.Scene(mu=0.3, h=1.3, t0=2.0 / 3.0, times=[1.0]),
    "pieces": crandall.Scene(mu=0.3, h=[0.0, 1.0, 0.4, 0.0, 2.0], t0=[0.3, 1.5, 1.7, 2.9, 3.1],
                             times=[1.0]),
    "in motion": crandall.Scene(mu=0.25, h=[0.0, 1.0], t0=[0.3, 1.5], v0=0.5, u0=-0.1,
                                times=[1.0]),
    "envelope": _envelope_scene(),
    "no switch-off": crandall.Scene(mu=0.3, h=1.0, t0=math.inf, times=[2.5]),
}


def _cases():
    for name, scene in SCENES.items():
        end = scene.pieces[-1][0] if scene.pieces is not None else scene.t0
        horizons = [h for h in (end, 0.0, 0.7, 1.0 / 3.0, 1.5, 2.9) if h <= end and math.isfinite(h)]
        for horizon in horizons:
            for dt in (0.1, 0.05, 1.0 / 7.0, 0.013, 0.7, 5.0):
                yield name, horizon, dt, (), False
            yield name, horizon, 0.1, (horizon - 0.25, horizon / 3.0, 0.3), False
            yield name, horizon, 0.1, (horizon - 0.25,), True
            yield name, horizon, 0.1, (), True


@pytest.mark.parametrize("name, horizon, dt, breaks, coarse", list(_cases()))
def test_the_cores_grid_is_the_numpy_cut_bit_for_bit(name, horizon, dt, breaks, coarse):
    scene = SCENES[name]
    core = TAIL.problem.white_noise_grid(scene, horizon, dt, breaks, coarse)
    ref = numpy_grid(scene, horizon, dt, breaks, coarse)
    for got, want in zip(core, ref):
        assert got.dtype == np.float64 and got.shape == want.shape
        assert np.array_equal(got.view(np.uint64), want.view(np.uint64))


def test_a_tail_problem_runs_on_the_cores_grid():
    scene = SCENES["pieces"]
    problem = TAIL._Problem(scene, "distance_at_stop", None, 0.05)
    lengths, noises, starts = numpy_grid(scene, problem.horizon, 0.05)
    assert np.array_equal(problem.lengths, lengths) and np.array_equal(problem.noises, noises)
    assert np.array_equal(problem.step_starts, starts)


def test_too_many_steps_are_refused_naming_dt():
    with pytest.raises(crandall.ParameterError, match=r"^dt: 30000000 steps over one piece"):
        TAIL._Problem(crandall.Scene(mu=0.3, h=1.0, t0=3.0, times=[1.0]), "stop_time", None,
                      1e-7)
