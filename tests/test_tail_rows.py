"""The tail reads what it knows of a quantity from its row and its tail score, never from its
name: a stub row (or a stub score in ``crandall.tail.problem.SCORES``) that declares the signs
re-drawn by importance sampling, the large-deviation window or the energy's factor reaches
those code paths with no change in ``crandall/tail/``; and the filter's ring-down is an effect
of the scene (``model.RING_DOWN``), refused through the model by every tail entry point and
accepted by the others.

The stub rows are existing rows times a factor 2 (levels 2 L of the stub are levels L of the
row's score, exactly), or the distance's score times the energy's factor m mu g (the energy's
score, computed the same way): so the stub's probabilities are the row's bit for bit, the same
seed drawing the same paths. A tail that chose its method by the quantity's name would run
the stub as another quantity (other proposals, other weights) and differ.
"""

from __future__ import annotations

import importlib
import re
import warnings

import numpy as np
import pytest

import crandall
from crandall import _core, model, quantities
from crandall.errors import ParameterError
from crandall.quantities import DISPLACEMENT, DISTANCE, RESIDUAL, STOP, VELOCITY, Quantity

PROBLEM = importlib.import_module("crandall.tail.problem")
IMPORTANCE = importlib.import_module("crandall.tail.importance")

#: The paper's scene at tau0 = 2 (scaled units) and one with pieces, a start in motion and a
#: mass (the energy's factor m mu g is 3 * 0.3 * 9.81 there).
PAPER = crandall.Scene.scaled(tau0=2.0, times=[2.0])
PIECES = crandall.Scene(mu=0.3, h=[1.0, 0.5], t0=[1.0, 2.0], v0=0.2, times=[2.0], mass=3.0)
#: A short importance-sampling run (its proposal pilot, then batches of 50 paths).
IMPORTANCE_RUN = dict(method="importance", particles=50, min_samples=100, max_samples=100,
                      seed=5, threads=1, progress=False)


def _two(scene) -> float:
    return 2.0


def _energy(scene) -> float:
    return scene.mass * scene.drift


def _run(*args, **kw):
    """crandall.tail's result and the texts of its warnings (a short run's StatisticsWarning,
    its target missed or its weights degenerate, is part of what two runs must share)."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        r = crandall.tail(*args, **kw)
    return r, [str(w.message) for w in caught]


def _same_run(a, b) -> None:
    (a, warned_a), (b, warned_b) = a, b
    assert [x.hex() for x in a.probability] == [x.hex() for x in b.probability]
    assert [x.hex() for x in a.stderr] == [x.hex() for x in b.stderr]
    assert a.samples == b.samples and a.steps == b.steps
    assert [re.sub(r"levels \S+ are", "levels are", w) for w in warned_a] == [
        re.sub(r"levels \S+ are", "levels are", w) for w in warned_b]
    assert a.diagnostics == b.diagnostics


def _with_rows(monkeypatch, *rows) -> None:
    monkeypatch.setattr(quantities, "QUANTITIES", quantities.QUANTITIES + rows)


def test_a_score_that_declares_its_signs_gets_the_sign_redraw(monkeypatch):
    # A new score, the residual displacement's function declared as the magnitude of a sum
    # of re-drawn signs, and a row "twice_residual" on it: importance sampling re-draws its
    # signs (its own drifts, speed thresholds, pilot and two-sided tilts), P(2 |U| > 2 L)
    # is P(|U| > L) bit for bit, and its proposals are the residual displacement's.
    declared = PROBLEM.SCORES["residual_displacement"]
    monkeypatch.setitem(PROBLEM.SCORES, "stub_magnitude",
                        PROBLEM.TailScore(declared.function, signs="magnitude"))
    _with_rows(monkeypatch, Quantity("twice_residual", DISPLACEMENT, "m", "twice |U(t_s)|",
                                     (STOP, "displacement", RESIDUAL), factor=_two,
                                     at_stop=True, tail="stub_magnitude", held=False))
    own = _run(PAPER, "residual_displacement", [2.0], dt=0.2, **IMPORTANCE_RUN)
    stub = _run(PAPER, "twice_residual", [4.0], dt=0.2, **IMPORTANCE_RUN)
    _same_run(own, stub)  # (the proposals tried and the pilot's size among the diagnostics)
    tried = [(t["drift"] / PAPER.drift, t["slow"]) for t in stub[0].diagnostics["proposals_tried"]]
    assert {d for d, _ in tried} == set(IMPORTANCE.SIGN_DRIFTS)
    assert {s for _, s in tried} == set(IMPORTANCE.SLOW_FACTORS)


def test_a_row_on_a_velocity_score_gets_the_large_deviation_window(monkeypatch):
    # "twice_speed" = 2 |V(t)| on the speed's score: its level 2 L is the speed L, whose
    # large-deviation window (the speed |L| + c (t - t0) reached over its last (..) / c) joins
    # the pilot's windows; the run is the speed's bit for bit.
    _with_rows(monkeypatch, Quantity("twice_speed", VELOCITY, "m/s", "twice the speed",
                                     ("velocity",), factor=_two, tail="speed", held=False))
    top = 2.0
    speed = PROBLEM._Problem(PAPER, "speed", 2.5, None)
    stub = PROBLEM._Problem(PAPER, "twice_speed", 2.5, None)
    windows = IMPORTANCE._ld_windows(stub, 2 * top)
    assert windows == IMPORTANCE._ld_windows(speed, top) == [
        min(speed.horizon, (top + PAPER.drift * 0.5) / PAPER.drift)]
    assert windows[0] not in {speed.horizon * f for f in (1 / 16, 1 / 8, 1 / 4, 1 / 2, 1.0)}
    own = _run(PAPER, "speed", [top], time=2.5, **IMPORTANCE_RUN)
    twice = _run(PAPER, "twice_speed", [2 * top], time=2.5, **IMPORTANCE_RUN)
    _same_run(own, twice)
    assert windows[0] in {t["window"] for t in twice[0].diagnostics["proposals_tried"]}


def test_a_row_with_the_energys_factor_is_the_energy(monkeypatch):
    # "work" = m mu g S(t_s) on the distance's score: splitting's Python loop (the core has no
    # score named "work") gives the bits of the dissipated energy, which the core's loop scores
    # with the scene's mass (split_core passes it for every quantity; only the energy reads it).
    _with_rows(monkeypatch, Quantity("work", DISTANCE, "J", "work of friction", (STOP,),
                                     factor=_energy, at_stop=True, tail="distance_at_stop",
                                     held=False))
    assert "work" not in _core.SPLIT_QUANTITIES
    assert PROBLEM._Problem(PIECES, "dissipated_energy_at_stop", None, 0.02).in_core
    assert not PROBLEM._Problem(PIECES, "work", None, 0.02).in_core
    kw = dict(seed=7, min_samples=3, max_samples=3, particles=40, dt=0.02, threads=1,
              progress=False)
    for levels in ([1.5], [0.5, 1.5]):  # the normalised score, then the plain one
        energy = _run(PIECES, "dissipated_energy_at_stop", levels, **kw)
        work = _run(PIECES, "work", levels, **kw)
        _same_run(energy, work)


# -- the ring-down: an effect of the scene ------------------------------------------------

def _ring_scene(ring_down: bool = True) -> crandall.Scene:
    return crandall.Scene(mu=1.0, g=1.0, t0=2.0, times=[2.0],
                          observe=["velocity", "distance", "stop"],
                          excitation=crandall.KanaiTajimi(omega=2.0, zeta=0.6, h=1.0,
                                                          ring_down=ring_down))


@pytest.fixture
def no_path_drawn(monkeypatch):
    """The core's path-drawing functions fail the test if called."""
    def refuse(*args, **kwargs):
        raise AssertionError("the core drew paths of a refused scene")

    for name in ("run_chunk", "run_samples", "extend_paths", "extend_filtered_paths",
                 "split_replica", "exact_steps"):
        monkeypatch.setattr(_core, name, refuse)


def test_ring_down_is_an_effect_the_identities_it_holds_under_list():
    ring, plain = _ring_scene(), _ring_scene(False)
    assert ring.effects == plain.effects | {model.RING_DOWN}
    assert model.RING_DOWN in model.SIMULATED
    for identity in (model.ZERO_FRICTION, model.SCHEDULE, model.FILTERED_LEVELS):
        assert model.holds(ring, identity), identity.name
    for identity in (model.TAIL_SPLITTING, model.TAIL_MODEL):
        assert not model.holds(ring, identity) and model.RING_DOWN not in identity.supports


#: Every entry point that refused a ring-down before it was an effect: the tail (either
#: method), its Dask task and fragility's curves (tails); the command line's tail below.
def _tail(scene, tmp_path):
    crandall.tail(scene, "distance_at_stop", [1.0], seed=1, dt=0.05, threads=1)


def _importance(scene, tmp_path):
    crandall.tail(scene, "distance_at_stop", [1.0], method="importance", seed=1, dt=0.05,
                  threads=1)


def _dask_task(scene, tmp_path):
    from crandall.tail.run import sample
    sample({"scene": scene.to_dict(), "quantity": "distance_at_stop", "time": None,
            "dt": 0.05, "levels": [1.0], "particles": 10, "key": 1, "proposal": None}, 0, 1)


def _fragility(scene, tmp_path):
    crandall.fragility(scene, "distance_at_stop", [1.0], intensities=[1.0], seed=1,
                       threads=1, progress=False, dt=0.05)


TAIL_ENTRY_POINTS = {"tail": _tail, "importance": _importance, "tail Dask task": _dask_task,
                     "fragility": _fragility}


def _says_why(text: str) -> None:
    assert "scene: crandall.tail is not available for a scene with ring_down" in text, text
    assert "the shaking ends at t0" in text and "deceleration mu g" in text, text


@pytest.mark.parametrize("entry", sorted(TAIL_ENTRY_POINTS))
def test_every_tail_entry_point_refuses_a_ring_down_saying_why(entry, no_path_drawn, tmp_path):
    with pytest.raises(ParameterError) as exc:
        TAIL_ENTRY_POINTS[entry](_ring_scene(), tmp_path)
    assert exc.value.name == "scene"
    _says_why(str(exc.value))


def test_the_command_lines_tail_refuses_a_ring_down_saying_why(no_path_drawn, tmp_path, capsys):
    from crandall import cli
    path = tmp_path / "ring.toml"
    path.write_text('[scene]\nmu = 1.0\ng = 1.0\nt0 = 2.0\ntimes = [2.0]\n'
                    'excitation = { kind = "kanai_tajimi", omega = 2.0, zeta = 0.6, h = 1.0, '
                    'ring_down = true }\n')
    assert model.RING_DOWN in crandall.Scene.from_toml(path).effects
    assert cli.main(["tail", str(path), "--quantity", "distance_at_stop", "--levels", "1",
                     "--seed", "1", "--threads", "1", "--no-files", "--no-progress"]) == 2
    _says_why(capsys.readouterr().err)


def test_a_ring_down_runs_where_it_ran():
    # The fixed-step run and its bias estimate (tests/test_filtered_snapshot.py keeps their
    # bits) and a run to an accuracy, on the filtered levels (model.FILTERED_LEVELS).
    r = crandall.simulate(_ring_scene(), rel_error=0.1, seed=3, threads=1, progress=False,
                          statistics=["distance_at_stop:mean"])
    assert r.model == model.FILTERED_LEVELS.name
    assert r.stderr("distance_at_stop") <= 0.1 * r.mean("distance_at_stop")
    assert np.isfinite(r.mean("distance_at_stop"))
