"""Property-based tests of schedules (hypothesis, fixed seed): pauses, stops inside pauses,
intensities of 0 given as a number or as pieces, and starts in motion (issue 30).

(a) Where the motion is deterministic, every path gives the closed form to rounding (1e-12 of
    the magnitudes summed): before any noise the coast from the start (V = sign(v0) max(|v0|
    - c t, 0), S = its integral, U = u0 + sign(v0) S), inside a pause the coast from the
    pause's start, after the last noise the coast from there and the stop |V| / c later;
    with no noise at all the stop is |v0| / c (0 at rest). Per-path values come from the
    core's path loop (``_core.run_samples``, the values a fixed-step run sums), on every grid
    of the exact, Richardson and refine methods; the tail's deterministic answers and its own
    grid integrals (the closed-form coast of its pause steps) must agree with the same closed
    forms. Euler-Maruyama is left out: it is the biased baseline, not exact in a pause.
(b) Every statistic that ``crandall.model.exact`` labels exact (the velocity, the kinetic
    energy, the stop time) is reported with bias 0, so it must agree with an independent
    sampler: Euler-Maruyama written here in NumPy (its own random numbers, its own grid, the
    schedule read from the test's data rather than from the Scene, the stop found as the
    time the body comes to rest for good rather than from ``Scene.t0``), with its step bias
    estimated by halving on coupled paths (measured first order: the halving differences fall
    2.1 to 2.6 times per halving on a start in motion, a pause and a weaker piece, so the bias
    of the finer grid is about one difference; twice it plus two of its standard errors is
    allowed) and the statistical errors of both runs (4 combined standard errors).
(c) The same scene written two ways (a number or one piece; a piece or a pause split in two;
    trailing pauses written or left out; equal neighbours merged) gives the same bits: the
    grid's steps and the random numbers are the same, so every statistic must be.

Each example is a fraction of a second (SI scenes of at most 4 s, few paths, steps of 1/64 s).
"""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest
from hypothesis import HealthCheck, assume, example, given, settings
from hypothesis import strategies as st

import crandall
from crandall import _core, engine, model
from crandall.tail import _extend, _Problem
from crandall.spec import RunSpec

SETTINGS = settings(derandomize=True, deadline=None, max_examples=30, database=None,
                    suppress_health_check=[HealthCheck.too_slow])
G = 9.81
#: Piece ends and output times lie on this grid, and the steps divide it, so that a schedule
#: written two ways has the same steps (c).
TICK = 1.0 / 8.0
DT = 1.0 / 64.0
#: The methods whose every grid integrates a pause exactly.
EXACT_GRID_METHODS = ("exact", "richardson", "richardson2", "refine")
ALL = ["velocity", "displacement", "distance", "kinetic_energy", "dissipated_energy", "stop"]


# -- strategies -----------------------------------------------------------------------------

intensity = st.sampled_from([0.0, 0.0, 0.4, 1.0, 1.5])
#: A schedule as the test's own data: [(length in ticks, h), ...], at least one piece.
pieces = st.lists(st.tuples(st.integers(1, 8), intensity), min_size=1, max_size=4)
start_velocity = st.one_of(st.just(0.0), st.floats(-3.0, 3.0).filter(lambda v: abs(v) > 1e-3))
start_displacement = st.one_of(st.just(0.0), st.floats(-1.0, 1.0))
mu = st.sampled_from([0.05, 0.3, 0.6])


def ends_of(schedule):
    """[(end, h), ...] in seconds from [(ticks, h), ...]."""
    out, t = [], 0
    for n, h in schedule:
        t += n
        out.append((t * TICK, h))
    return out


def last_noise(schedule) -> float:
    """The end of the last shaken piece, 0 if none: where the noise ends."""
    return max((e for e, h in ends_of(schedule) if h > 0), default=0.0)


def first_noise(schedule) -> float:
    """The start of the first shaken piece, inf if none."""
    start = 0.0
    for e, h in ends_of(schedule):
        if h > 0:
            return start
        start = e
    return math.inf


def scene_of(schedule, *, m, v0, u0, times, observe=None, scalar=False):
    """The SI scene of a schedule: as lists, or (``scalar``, one piece) as numbers."""
    e = ends_of(schedule)
    if scalar:
        assert len(e) == 1
        h, t0 = e[0][1], e[0][0]
    else:
        h, t0 = [x for _, x in e], [x for x, _ in e]
    return crandall.Scene(mu=m, h=h, t0=t0, v0=v0, u0=u0, times=times,
                          observe=observe or ALL)


def coast(x, u, s, c, elapsed):
    """The deterministic coast (no noise, deceleration c) over ``elapsed`` from (x, u, s),
    written here from the equations of motion, not from the core."""
    x, u, s = (np.asarray(a, dtype=float) for a in (x, u, s))
    a, sign = np.abs(x), np.sign(x)
    stops = c * elapsed >= a
    with np.errstate(invalid="ignore"):  # the branch not taken, at elapsed = inf
        travelled = np.where(stops, a * a / (2 * c), elapsed * (a - 0.5 * c * elapsed))
        return (np.where(stops, 0.0, sign * (a - c * elapsed)), u + sign * travelled,
                s + travelled)


def close(got, want, scale, what):
    """Equal to rounding: within 1e-12 of the magnitudes summed (``scale``), on every path."""
    bad = np.abs(np.asarray(got) - want) > 1e-12 * np.maximum(scale, 1e-300)
    assert not np.any(bad), (what, np.asarray(got)[bad][:3], np.asarray(want)[bad][:3])


# -- (a) the stop and the coast where the motion is deterministic ---------------------------

@SETTINGS
@given(schedule=pieces, m=mu, v0=start_velocity, u0=start_displacement,
       extra=st.lists(st.integers(0, 40), max_size=3),
       method=st.sampled_from(EXACT_GRID_METHODS))
# Bodies that come to rest in a pause between two shocks, on Richardson's three grids.
@example(schedule=[(4, 1.0), (8, 0.0), (4, 1.0)], m=0.3, v0=2.5, u0=0.1, extra=[],
         method="richardson2")
def test_deterministic_stretches_are_the_closed_form_on_every_path(schedule, m, v0, u0, extra,
                                                                    method):
    c = m * G
    e = ends_of(schedule)
    end, quiet_from, noisy_to = e[-1][0], first_noise(schedule), last_noise(schedule)
    # Output times: the given ones, every piece's start and a point inside it (so that each
    # pause is observed from its start), and where the noise ends.
    starts = [0.0] + [x for x, _ in e[:-1]]
    times = {k * TICK for k in extra} | {noisy_to}
    for (a, (b, _)) in zip(starts, e):
        times |= {a, 0.5 * (a + b), b}
    times = sorted(times)
    scene = scene_of(schedule, m=m, v0=v0, u0=u0, times=times)
    assert scene.t0 == noisy_to
    paths = 64
    spec = RunSpec.create(scene, paths=paths, seed=7, dt=DT, method=method)
    values = _core.run_samples(engine.make_plan(spec), 0, paths, 1)  # path, slot, grid, var
    k = len(times)
    for grid in range(values.shape[2]):
        x, u, s = (values[:, :k, grid, j] for j in range(3))
        at = {t: i for i, t in enumerate(times)}
        # Before any noise: the coast from the start.
        for t, i in at.items():
            if t <= quiet_from:
                wx, wu, ws = coast(v0, u0, 0.0, c, t)
                close(x[:, i], wx, abs(v0) + c * t, ("velocity", t))
                close(s[:, i], ws, ws, ("distance", t))
                close(u[:, i], wu, abs(u0) + ws, ("displacement", t))
        # Inside a pause, and after the last noise: the coast from where the quiet began.
        quiet = [(a, b) for a, (b, h) in zip(starts, e) if h == 0] + [(noisy_to, math.inf)]
        for a, b in quiet:
            i0 = at[a]
            for t, i in at.items():
                if a < t <= b:
                    wx, wu, ws = coast(x[:, i0], u[:, i0], s[:, i0], c, t - a)
                    close(x[:, i], wx, np.abs(x[:, i0]) + c * (t - a), ("pause velocity", t))
                    close(s[:, i], ws, ws, ("pause distance", t))
                    close(u[:, i], wu, np.abs(u[:, i0]) + ws, ("pause displacement", t))
        # The stop: |V| / c after the noise ends (the slot holds the time since then), with
        # the coast's displacement and distance.
        i0 = at[noisy_to]
        ts, us, ss = (values[:, k, grid, j] for j in range(3))
        wx, wu, ws = coast(x[:, i0], u[:, i0], s[:, i0], c, math.inf)
        close(ts, np.abs(x[:, i0]) / c, np.abs(x[:, i0]) / c, "time to the stop")
        close(ss, ws, ws, "distance at the stop")
        close(us, wu, np.abs(u[:, i0]) + ws, "displacement at the stop")
    if noisy_to == 0.0:
        # No noise at all: the stop itself is deterministic, |v0| / c from 0, on every path.
        assert np.all(values[:, k, :, 0] == abs(v0) / c)


@settings(SETTINGS, max_examples=10)  # a run to an accuracy and three tails each
@given(schedule=pieces.filter(lambda p: all(h == 0 for _, h in p)) | st.just([(16, 0.0)]),
       m=mu, v0=start_velocity, u0=start_displacement, scalar=st.booleans())
def test_without_noise_every_estimator_reports_the_coast(schedule, m, v0, u0, scalar):
    # No noise ever (h = 0 as a number, issue 30, or pauses only): the fixed-step run, the
    # run to an accuracy and the tail report the coast from the start, exactly.
    c = m * G
    if scalar:
        schedule = [(sum(n for n, _ in schedule), 0.0)]
    scene = scene_of(schedule, m=m, v0=v0, u0=u0, times=[0.25, 1.0], scalar=scalar)
    assert scene.t0 == 0.0
    stop = abs(v0) / c
    x1, u1, s1 = coast(v0, u0, 0.0, c, 1.0)
    _, ustop, sstop = coast(v0, u0, 0.0, c, math.inf)
    r = crandall.simulate(scene, paths=16, seed=1, threads=1)
    assert r.mean("stop_time") == pytest.approx(stop, rel=1e-14, abs=1e-300)
    assert r.exact("stop_time") and r.bias("stop_time") == 0.0
    assert r.mean("distance_at_stop") == pytest.approx(sstop, rel=1e-13, abs=1e-300)
    assert r.mean("displacement_at_stop") == pytest.approx(ustop, rel=1e-13,
                                                            abs=1e-13 * (abs(u0) + sstop))
    assert r.mean("distance")[1] == pytest.approx(s1, rel=1e-13, abs=1e-300)
    a = crandall.simulate(scene, error=0.05, seed=1, threads=1)
    assert a.mean("stop_time") == pytest.approx(stop, rel=1e-14, abs=1e-300)
    assert a.mean("displacement")[1] == pytest.approx(u1, rel=1e-13,
                                                       abs=1e-13 * (abs(u0) + s1))
    # The tail: a deterministic answer, on the right side of levels just around the value.
    for quantity, value in (("stop_time", stop), ("distance_at_stop", sstop),
                            ("displacement_at_stop", ustop)):
        if value == 0.0:
            continue
        w = 1e-9 * abs(value)
        t = crandall.tail(scene, quantity, [value - w, value + w], seed=1, threads=1)
        assert t.probability.tolist() == [1.0, 0.0], (quantity, value)


@SETTINGS
@given(schedule=pieces, m=mu, v0=start_velocity)
def test_the_tail_grid_coasts_through_its_pauses(schedule, m, v0):
    # The tail's own paths (crandall.tail: its grid, its streams) cross a pause by the
    # closed-form coast (one exact step per pause): the state at the pause's end is the coast
    # from its start on every path, as on the fixed-step run's grids.
    c = m * G
    assume(last_noise(schedule) > 0.0 and any(h == 0 for _, h in ends_of(schedule)))
    scene = scene_of(schedule, m=m, v0=v0, u0=0.0, times=[1.0])
    problem = _Problem(scene, "distance_at_stop", None, 1.0 / 32.0)
    states = problem.start_states(32)
    _extend(problem, states, np.arange(32), np.zeros(32), np.arange(32), 123, 1)
    points = np.concatenate([[0.0], np.cumsum(problem.lengths)])
    for k in np.flatnonzero(problem.noises == 0):
        x0, u0_, s0 = states[:, k, 0], states[:, k, 1], states[:, k, 2]
        wx, wu, ws = coast(x0, u0_, s0, c, problem.lengths[k])
        close(states[:, k + 1, 0], wx, np.abs(x0) + c * problem.lengths[k], ("tail v", points[k]))
        close(states[:, k + 1, 2], ws, ws, ("tail distance", points[k]))
        close(states[:, k + 1, 1], wu, np.abs(u0_) + ws, ("tail displacement", points[k]))


# -- (b) what is labelled exact against an independent sampler ------------------------------

def euler_pair(schedule, c, v0, times, step, paths, seed):
    """Euler-Maruyama of dV = -c sign(V) dt + h(t) dW from v0 on the schedule [(end, h), ...]
    (no noise after the last end), on two grids of one Brownian path: steps step / 2 (fine)
    and step (coarse, whose increments are the sums of two fine ones). Steps without noise
    are the deterministic deceleration, taken exactly. Returns, per grid, V at ``times``
    (len(times) x paths) and the stop time: the time the body comes to rest for good (0 for
    a body at rest that is never shaken)."""
    rng = np.random.default_rng(seed)
    end = schedule[-1][0]
    points = sorted({0.0, *(x for x, _ in schedule), *(t for t in times if t < end)})
    x = np.full((2, paths), float(v0))
    rest = np.full((2, paths), 0.0 if v0 == 0 else math.nan)  # nan: moving
    at = np.empty((2, len(times), paths))
    index = {t: i for i, t in enumerate(times)}
    if 0.0 in index:
        at[:, index[0.0]] = v0
    for a, b in zip(points[:-1], points[1:]):
        h = next(n for x_, n in schedule if x_ >= b)
        if h == 0.0:
            speed = np.abs(x)
            stops = (speed > 0) & (speed <= c * (b - a))
            rest = np.where(stops, a + speed / c, rest)
            x = np.sign(x) * np.maximum(speed - c * (b - a), 0.0)
        else:
            n = max(1, math.ceil((b - a) / step - 1e-9))
            coarse = (b - a) / n
            fine = coarse / 2
            for _ in range(n):
                z = rng.standard_normal((2, paths))
                f, g = x[0], x[1]
                f = f - c * np.sign(f) * fine + h * math.sqrt(fine) * z[0]
                f = f - c * np.sign(f) * fine + h * math.sqrt(fine) * z[1]
                g = g - c * np.sign(g) * coarse + h * math.sqrt(fine) * (z[0] + z[1])
                x = np.stack([f, g])
            rest[:] = math.nan
        if b in index:
            at[:, index[b]] = x
    speed = np.abs(x)
    for t, i in index.items():
        if t > end:
            at[:, i] = np.sign(x) * np.maximum(speed - c * (t - end), 0.0)
    stop = np.where(np.isnan(rest), end + speed / c, rest)
    return (at[0], stop[0]), (at[1], stop[1])


def agrees_with_euler(label, got, got_se, fine, coarse):
    """``got`` (an exact statistic, with its standard error) against the sampler's value on the
    fine grid, given per path on both grids: within 4 combined standard errors plus the fine
    grid's step bias, taken as twice the halving difference plus two of its standard errors."""
    n = len(fine)
    diff = coarse - fine
    bias = abs(diff.mean()) + 2 * diff.std() / math.sqrt(n)
    se = math.hypot(got_se, fine.std() / math.sqrt(n))
    # Where the statistic is deterministic both are the closed form, to rounding.
    rounding = 1e-12 * (abs(got) + abs(fine.mean()))
    assert abs(got - fine.mean()) <= 4 * se + 2 * bias + rounding, (label, got, fine.mean(),
                                                                     se, bias)


@settings(SETTINGS, max_examples=8)
@given(schedule=pieces.filter(lambda p: sum(n for n, _ in p) <= 20),
       m=st.sampled_from([0.3, 0.6]), v0=start_velocity,
       times=st.lists(st.integers(1, 28), min_size=1, max_size=3, unique=True),
       scalar=st.booleans())
# Issue 30's scene: Scene(mu=0.3, h=0.0, t0=2.0, v0=1.0, times=[1.0]) (its stop was 2.0 s).
@example(schedule=[(16, 0.0)], m=0.3, v0=1.0, times=[8], scalar=True)
# A start in motion that stops in a pause between two shocks.
@example(schedule=[(4, 1.0), (8, 0.0), (4, 1.0)], m=0.3, v0=2.5, times=[4, 10, 20],
         scalar=False)
def test_what_is_labelled_exact_agrees_with_an_independent_sampler(schedule, m, v0, times,
                                                                   scalar):
    c = m * G
    times = sorted(t * TICK for t in times)
    scene = scene_of(schedule, m=m, v0=v0, u0=0.0, times=times,
                     observe=["velocity", "kinetic_energy", "stop"],
                     scalar=scalar and len(schedule) == 1)
    r = crandall.simulate(scene, paths=40_000, seed=3, threads=1)
    labelled = [n for n in r.names if model.exact(n, scene)]
    assert set(labelled) == {"velocity", "kinetic_energy", "stop_time"}
    for name in labelled:
        for stat in ("mean", "var"):
            assert np.all(np.asarray(r.bias(name, stat)) == 0.0), (name, stat)
    (v_f, stop_f), (v_c, stop_c) = euler_pair(ends_of(schedule), c, v0, times, 1.0 / 128,
                                              8000, seed=11)
    # The kinetic energy's standard error rests on the velocity's fourth moment: where fewer
    # than MIN_CARRIERS paths carry the spread (nearly all at rest) it is withheld, and no
    # comparison can be made there (the test makes none; the velocity's mean still has one).
    with warnings.catch_warnings():
        # The warning of the withheld times, which are skipped below.
        warnings.simplefilter("ignore", crandall.StatisticsWarning)
        ke_se = r.stderr("kinetic_energy")
    withheld = np.isnan(ke_se)
    assert (np.asarray(r.carriers("kinetic_energy"))[withheld]
            < crandall.results.MIN_CARRIERS).all()
    for i, t in enumerate(times):
        agrees_with_euler(("E V", t), r.mean("velocity")[i], r.stderr("velocity")[i],
                          v_f[i], v_c[i])
        if not withheld[i]:
            agrees_with_euler(("E V^2 / 2", t), r.mean("kinetic_energy")[i], ke_se[i],
                              v_f[i] ** 2 / 2, v_c[i] ** 2 / 2)
    agrees_with_euler("E t_s", r.mean("stop_time"), r.stderr("stop_time"), stop_f, stop_c)
    # The stop time's second moment: Var t_s + (E t_s)^2, as the mean of t_s^2 per path.
    mean, var = r.mean("stop_time"), r.var("stop_time")
    second_se = math.hypot(r.var_stderr("stop_time"), 2 * mean * r.stderr("stop_time"))
    agrees_with_euler("E t_s^2", var + mean * mean, second_se, stop_f ** 2, stop_c ** 2)


# The collapsing envelope of issue 30, finding 2 (an envelope whose h(t) is 0 after its first
# piece, or given one piece) has its own property suite: tests/test_envelope_collapse.py
# (every envelope scene keeps its effect and labels nothing exact; the piece error it reports
# covers the error against 256 pieces).


# -- (c) one scene written two ways --------------------------------------------------------

def split(schedule, cuts):
    """The schedule with piece i cut in two where cuts[i] (ticks into it) falls inside it."""
    out = []
    for (n, h), cut in zip(schedule, cuts + [0] * len(schedule)):
        if 0 < cut < n:
            out += [(cut, h), (n - cut, h)]
        else:
            out.append((n, h))
    return out


def merged(schedule):
    """Neighbours of one intensity merged, trailing pauses dropped (the coast after the
    noise either way), a schedule of no noise at all one pause."""
    out = []
    for n, h in schedule:
        if out and out[-1][1] == h:
            out[-1] = (out[-1][0] + n, h)
        else:
            out.append((n, h))
    while len(out) > 1 and out[-1][1] == 0:
        out.pop()
    return out


@SETTINGS
@given(schedule=pieces, cuts=st.lists(st.integers(1, 7), max_size=4), m=mu,
       v0=start_velocity, u0=start_displacement,
       times=st.lists(st.integers(0, 40), min_size=1, max_size=3, unique=True),
       method=st.sampled_from(["exact", "richardson", "refine"]))
def test_one_scene_written_two_ways_gives_the_same_bits(schedule, cuts, m, v0, u0, times,
                                                        method):
    times = sorted(t * TICK for t in times)
    short = merged(schedule)
    scenes = [scene_of(split(schedule, cuts), m=m, v0=v0, u0=u0, times=times),
              scene_of(short, m=m, v0=v0, u0=u0, times=times, scalar=len(short) == 1)]
    if len(short) == 1 and short[0][1] > 0:
        scenes.append(scene_of(short, m=m, v0=v0, u0=u0, times=times))  # one piece, a list
    assert len({(s.t0, s.noise) for s in scenes}) == 1
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # NaN statistics of a body that never moves are fine
        runs = [crandall.simulate(s, paths=64, seed=5, dt=DT, method=method, threads=1)
                for s in scenes]
        for other in runs[1:]:
            assert other.names == runs[0].names
            for name in runs[0].names:
                for stat in ("mean", "var"):
                    a = np.asarray(getattr(runs[0], stat)(name))
                    b = np.asarray(getattr(other, stat)(name))
                    assert a.tobytes() == b.tobytes(), (name, stat, a, b)
