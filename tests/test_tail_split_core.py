"""Splitting's loop in the core (_core.split_replica, cpp/src/split.cpp) against the Python loop
of splitting.py (the reference, core=False): the same bits, info and errors, for every kind of
score (plain, uncoasted, normalised), quantity family and way a replica ends."""

from __future__ import annotations

import time

import numpy as np
import pytest

import crandall
from crandall import _core
from crandall.tail.problem import _Problem
from crandall.tail.splitting import _splitting_replica, _splitting_replicas

PAPER = crandall.Scene.scaled(tau0=2.0, times=[2.0])
PIECES = crandall.Scene(mu=0.3, h=[1.0, 0.5], t0=[1.0, 2.0], v0=0.2, times=[2.0])
CALM = crandall.Scene(mu=0.3, h=[0.0, 1.0], t0=[0.3, 1.5], v0=0.1, u0=0.05, mass=2.0,
                      times=[1.0])

CASES = [
    # (scene, quantity, time, dt, levels): plain scores, several levels
    (PAPER, "stop_time", None, 0.05, [3.0, 4.0]),
    (PIECES, "residual_displacement", None, 0.02, [0.05, 0.2]),
    (PIECES, "peak_displacement_at_stop", None, 0.02, [0.1, 0.3]),
    (PAPER, "peak_speed_at_stop", None, 0.05, [2.5]),
    (PAPER, "velocity", 1.0, 0.05, [1.0, -0.5]),
    # the velocity and speed after the switch-off: the uncoasted rank
    (PAPER, "speed", 2.5, 0.05, [0.8]),
    # one level of a normalised quantity: the normalised score, after a calm start
    (PAPER, "distance_at_stop", None, 0.05, [6.0]),
    (CALM, "dissipated_energy_at_stop", None, 0.02, [2.0]),
    (CALM, "displacement_at_stop", None, 0.02, [0.4]),
    # every particle tied at 0 (the speed coasted to rest, a level below 0): an extinction
    (PAPER, "speed", 4.0, 0.1, [-0.5, 1.0]),
]


def _same(a, b):
    (ea, ia), (eb, ib) = a, b
    assert np.array_equal(ea, eb, equal_nan=True) and [x.hex() for x in ea] == [x.hex() for x in eb]
    assert ia == ib and all(type(ia[k]) is type(ib[k]) for k in ia)


@pytest.mark.parametrize("scene, quantity, time_, dt, levels", CASES,
                         ids=[f"{c[1]}-{len(c[4])}" for c in CASES])
def test_the_core_loop_gives_the_python_loops_bits(scene, quantity, time_, dt, levels):
    problem = _Problem(scene, quantity, time_, dt)
    lv = np.asarray(levels, dtype=float)
    for replica in (0, 3):
        runs = [_splitting_replica(problem, lv, 30, 3, 77, replica, 1, 5000, core=core)
                for core in (True, False)]
        _same(*runs)
    assert runs[0][1]["iterations"] > 0 or runs[0][1]["extinct"] is not None


@pytest.mark.parametrize("case", [0, 2, 6, 9], ids=lambda i: CASES[i][1])
def test_replicas_in_step_give_each_replicas_bits_alone(case):
    # split_replicas continues the clones of several replicas together in the vector lanes
    # (each row's draws are its own stream's): every replica's outcome is the Python loop's
    # for it alone, whatever the group and its threads; replicas that end at different
    # iterations (an extinction, a level reached early) leave the others running.
    scene, quantity, time_, dt, levels = CASES[case]
    problem = _Problem(scene, quantity, time_, dt)
    lv = np.asarray(levels, dtype=float)
    alone = [_splitting_replica(problem, lv, 30, 3, 77, r, 1, 5000, core=False)
             for r in (0, 3, 4, 11)]
    for threads in (1, 2):
        together = _splitting_replicas(problem, lv, 30, 3, 77, [0, 3, 4, 11], threads, 5000)
        for a, b in zip(together, alone):
            _same(a, b)


def test_a_tail_run_gives_the_same_bits_with_its_replicas_grouped():
    # _LocalReplicas runs a batch's replicas in groups (GROUP per thread): the estimates and
    # counts of a run with one thread (groups of 4), two (two groups) and one replica per
    # call (GROUP 1) are the same bits.
    from crandall.tail import run as tail_run

    def go(threads):
        r = crandall.tail(PAPER, "stop_time", [3.5, 4.5], dt=0.05, rel_error=0.3, seed=11,
                          threads=threads, particles=30)
        return r.probability.tolist(), r.stderr.tolist(), r.samples, r.steps

    one, two = go(1), go(2)
    group = tail_run.GROUP
    try:
        tail_run.GROUP = 1
        single = go(1)
    finally:
        tail_run.GROUP = group
    assert one == two == single


def test_an_extinction_and_the_plain_score_forced_behave_alike():
    problem = _Problem(PAPER, "speed", 4.0, 0.1)
    est, info = _splitting_replica(problem, np.array([-0.5, 1.0]), 30, 3, 5, 0, 1, 100)
    assert info["extinct"] == 0.0 and est[1] == 0.0 and est[0] == 1.0
    problem = _Problem(PAPER, "distance_at_stop", None, 0.05)
    _same(*[_splitting_replica(problem, np.array([6.0]), 30, 3, 9, 1, 1, 5000,
                               normalise=False, core=core) for core in (True, False)])


def test_the_deadline_and_max_iterations_behave_as_the_python_loops():
    problem = _Problem(PAPER, "stop_time", None, 0.05)
    lv = np.array([6.0])
    for core in (True, False):
        est, info = _splitting_replica(problem, lv, 30, 3, 1, 0, 1, 5000,
                                       deadline=time.time() - 1, core=core)
        assert info == {"iterations": 0, "steps": 30 * problem.steps, "log_weight": 0.0,
                        "timed_out": True} and np.isnan(est).all()
        with pytest.raises(RuntimeError, match="splitting did not reach the level after 4 "
                                               "iterations"):
            _splitting_replica(problem, lv, 30, 3, 1, 0, 1, 4, core=core)


def test_the_parents_are_uniform_and_a_pure_function_of_their_key():
    a = _core.split_parents(3, 1, 7, 5, 100_000)
    assert a.min() == 0 and a.max() == 4
    counts = np.bincount(a, minlength=5)
    # binomial sd sqrt(1e5 * 0.2 * 0.8) = 126: 6 sd
    assert np.all(np.abs(counts - 20_000) < 760), counts
    assert np.array_equal(_core.split_parents(3, 1, 7, 5, 10), a[:10])
    for other in ((4, 1, 7), (3, 2, 7), (3, 1, 8)):
        assert not np.array_equal(_core.split_parents(*other, 5, 10), a[:10])
    with pytest.raises(ValueError, match="survivors"):
        _core.split_parents(3, 1, 7, 0, 10)
    with pytest.raises(ValueError, match="replica"):
        _core.split_parents(3, 1 << 32, 7, 5, 10)
