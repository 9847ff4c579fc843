"""max_seconds bounds every run to an accuracy and every tail run, pilots included, and the
refusals say what would help (issue 30, finding 5; the pilots' memory check, the default step
of short excitations and the speed long after the switch-off, finding 8).

The timing checks allow a generous margin (MARGIN) for a loaded machine: a run with
max_seconds = B must return or be refused within B + MARGIN, where before it ran for minutes
(dt = 1e-5: more than 60 s at max_seconds = 3; the pause below: more than 100 s at 5). Each
runs under a watchdog (SIGALRM, whose exception the core's Ctrl-C poll carries out of a long
call), so that a run that does not stop fails the test instead of hanging it.
"""

import contextlib
import math
import signal
import time

import numpy as np
import pytest

import crandall
from crandall import analytic
from crandall.errors import ParameterError
from crandall.results import StatisticsWarning
from crandall.tail import StatisticsFailure, tail

PAPER = crandall.Scene.scaled(tau0=5, times=[5])
MARGIN = 20.0
Z = 3.5  # as tests/test_tail.py: an estimate within Z standard errors of its reference


class Hung(Exception):
    pass


@contextlib.contextmanager
def bounded(max_seconds):
    """Fail (Hung) if the block outlasts max_seconds + MARGIN; yield the elapsed time's clock."""
    def alarm(signum, frame):
        raise Hung(f"still running after max_seconds + {MARGIN} s")

    old = signal.signal(signal.SIGALRM, alarm)
    signal.setitimer(signal.ITIMER_REAL, max_seconds + MARGIN + 5.0)
    start = time.perf_counter()
    try:
        yield lambda: time.perf_counter() - start
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, old)


def test_a_tail_pilot_that_cannot_finish_is_refused_before_it_starts():
    # 5e5 steps per path: the pilot's 20 replicas of 200 paths are 2e9 path-steps, minutes
    # on any machine. Refused at once, saying what would help for this quantity.
    for method, what in (("splitting", "the pilot's 20 replicas would take at least"),
                         ("importance", "importance sampling's proposal pilot")):
        with bounded(3) as elapsed:
            with pytest.raises(ParameterError, match=f"^max_seconds: {what}") as info:
                tail(PAPER, "distance_at_stop", 30.0, dt=1e-5, max_seconds=3, seed=1,
                     threads=1, method=method)
            assert elapsed() < 3 + MARGIN
        assert info.value.name == "max_seconds"
        assert "a larger dt (a coarser trapezoid rule" in str(info.value)
        assert "a larger max_seconds" in str(info.value)


def test_a_replica_that_does_not_reach_the_level_stops_at_max_seconds():
    # P(t_s > 100 s) for mu = 0.3, h = 1, t0 = 20 s is far below anything splitting resolves
    # in seconds: the pilot's first replicas (a group of tail.run.GROUP = 4, run in step)
    # iterate on until their particles tie (2.3 s a replica on an idle 2-core machine, so
    # about 9 s for the group; at t0 = 5 s the whole pilot of 20 took 3.9 s, which a faster
    # machine finishes within max_seconds). They stop at max_seconds, saying how far the first
    # got, or, on a machine fast enough to finish them, the rest of the pilot (16 replicas) is
    # refused saying that the replicas' particles died tied below the level. Either way the
    # level is called out of reach, and more particles (which would not help) are not advised.
    scene = crandall.Scene(mu=0.3, h=1.0, t0=20.0, times=[20.0])
    with bounded(3) as elapsed:
        with pytest.raises(ParameterError, match=r"^max_seconds: the pilot's (replica 0 had not "
                           r"reached level 100 when max_seconds=3 ran out|16 remaining "
                           r"replicas would take about)") as info:
            tail(scene, "stop_time", 100.0, max_seconds=3, seed=1, threads=1)
        assert elapsed() < 3 + MARGIN
    text = str(info.value)
    assert "beyond what the paths reach" in text and "more particles" not in text
    assert "probabilities do not depend on it" in text  # dt: exact for the stop time


def test_a_level_every_replica_dies_below_is_called_out_of_reach():
    # At level 1000 every pilot replica ends in an extinction (its particles tied at one score
    # below the level): the level is out of reach, which more particles cannot change.
    with pytest.raises(StatisticsFailure, match="beyond what the paths reach") as info:
        tail(PAPER, "stop_time", 1000.0, dt=0.25, seed=1, threads=1)
    assert "more particles" not in str(info.value)
    assert "got as far as a probability of about" in str(info.value)


def test_the_second_stage_stops_at_max_seconds_with_a_warning():
    # A target far beyond what 4 s give: the run keeps what it has and says so.
    level = 5.0 + 4.0  # P(t_s > 9) ~ 1e-4 on the paper's scene
    with bounded(4) as elapsed:
        with pytest.warns(StatisticsWarning, match=r"limited by max_seconds \(4 s\)"):
            r = tail(PAPER, "stop_time", level, dt=0.1, rel_error=0.002, max_seconds=4,
                     seed=2, threads=1)
        assert elapsed() < 4 + MARGIN
    assert r.samples >= 2 and r.seconds < 4 + MARGIN


def test_the_proposal_pilot_is_checked_for_memory_before_it_runs(monkeypatch):
    import importlib

    # Each name is replaced in the module that looks it up: the memory check is the run's,
    # the pilot's batches importance sampling's.
    run = importlib.import_module("crandall.tail.run")
    monkeypatch.setattr(run, "available_memory", lambda: 20 << 20)
    calls = []
    importance = importlib.import_module("crandall.tail.importance")
    monkeypatch.setattr(importance, "_importance_batch", lambda *a: calls.append(a))
    # 256 pilot paths of 2001 grid points: about 40 MiB, refused before any path is drawn.
    with pytest.raises(ParameterError, match="^dt: importance sampling's proposal pilot, 256 "
                       "paths of 2001 grid points need about") as info:
        tail(PAPER, "distance_at_stop", [30.0], seed=1, dt=0.0025, threads=1,
             method="importance")
    assert calls == [] and info.value.name == "dt"


def test_a_short_excitation_gets_a_default_step_that_splitting_can_use():
    # tau0 = 0.1: the default step gives fewer than 50 steps while the noise acts. Without a
    # dt from the user the grid is refined to 50 steps (not refused naming a dt never given);
    # a dt the user gave that is too coarse is still refused, naming it.
    short = crandall.Scene.scaled(tau0=0.1, times=[0.1])
    r = tail(short, "distance_at_stop", 0.12, seed=3, rel_error=0.1, threads=1)
    assert r.spec["dt"] == pytest.approx(0.1 / 50)
    s = crandall.Scene.from_dict({**short.to_dict(), "observe": ["distance", "stop"],
                                  "distributions": ["distance_at_stop"],
                                  "bins": {"distance_at_stop": [0.0, 0.12, 1.0]}})
    paths = 400_000
    mc = crandall.simulate(s, paths=paths, seed=4, dt=0.1 / 50, method="exact")
    p = mc.exceedance("distance_at_stop", 0.12).value
    assert 1e-3 < p < 1e-1
    assert abs(r.probability[0] - p) <= Z * math.hypot(r.stderr[0], math.sqrt(p * (1 - p) / paths))
    with pytest.raises(ParameterError, match="^dt: splitting needs at least 50 steps"):
        tail(short, "distance_at_stop", 0.12, dt=0.01, seed=1)


def test_splitting_the_speed_long_after_the_switch_off_against_the_closed_form():
    # |V(9)| four time units after the switch-off: max(|V(5)| - 4 c, 0), 0 for all but 9e-8
    # of the paths. The clipped value tied every particle at 0 (extinction, "use more
    # particles"); the paths are now ranked by |V| - c (t - t0), which is the quantity above 0.
    ps = [5e-8, 1e-9]
    levels = [brent(lambda y: 2 * analytic.velocity_sf(y, 9.0, 5.0), p) for p in ps]
    r = tail(PAPER, "speed", levels, time=9.0, seed=5, dt=0.1, rel_error=0.15, threads=1)
    assert r.reliable.all()
    for i, p in enumerate(ps):
        assert abs(r.probability[i] - p) <= Z * r.stderr[i], (r.probability[i], r.stderr[i], p)
    y = brent(lambda y: analytic.velocity_sf(y, 9.0, 5.0), 1e-9)
    r = tail(PAPER, "velocity", y, time=9.0, seed=6, dt=0.1, rel_error=0.15, threads=1)
    assert abs(r.probability[0] - 1e-9) <= Z * r.stderr[0], (r.probability[0], r.stderr[0])


def brent(sf, p):
    from scipy.optimize import brentq

    return brentq(lambda y: math.log(sf(y)) - math.log(p), 1e-3, 60.0, xtol=1e-12)


def test_an_accuracy_run_through_a_long_pause_is_refused_within_max_seconds():
    # A main shock, a pause of 1e5 s and an aftershock: the base grid steps through the pause
    # (1.7e6 steps per path), so the pilot is about 6e10 path-steps. Refused before it starts,
    # at the rate measured on a few paths, naming the pause's share.
    scene = crandall.Scene(mu=0.3, h=[1.0, 0.0, 1.0], t0=[1.0, 1.0 + 1e5, 2.0 + 1e5],
                           times=[2.0 + 1e5], observe=["velocity", "distance", "stop"])
    with bounded(5) as elapsed:
        with pytest.raises(ValueError, match=r"^max_seconds: reaching error=0.01 would take "
                           r"about .* s more \(the pilot alone") as info:
            crandall.simulate(scene, error=0.01, max_seconds=5, seed=1, threads=1)
        assert elapsed() < 5 + MARGIN
    assert "1e+05 s of the 1e+05 s its paths are stepped through have no noise" in str(info.value)


def test_every_batch_of_an_accuracy_run_is_checked_against_max_seconds(monkeypatch):
    # The measurement before the run says a path takes no time; the batches themselves show
    # their true time, and the run stops before the batch that would end past the bound (it
    # was only checked at a round's end, after all of the round's batches: here the pilot's
    # 4096 paths of 2e4, 4e4 and 8e4 steps on levels 0, 1 and 2, and 4096 more on level 0 for
    # its controls: 6.5e8 path-steps, more than a second on one thread anywhere).
    import importlib

    adaptive = importlib.import_module("crandall.adaptive")
    monkeypatch.setattr(adaptive._Engine, "measure", lambda self, lev: (0.0, 1))
    scene = crandall.Scene.scaled(tau0=5000, times=[5000], observe=["velocity", "distance"])
    with bounded(0.5) as elapsed:
        with pytest.raises(ValueError, match=r"^max_seconds: .* \(the next \d+ paths of level "):
            crandall.simulate(scene, error=1e-3, max_seconds=0.5, seed=1, threads=1)
        assert elapsed() < 0.5 + MARGIN
