"""Runs to an accuracy of a filtered excitation (simulate(scene, error=EPS) on a Kanai-Tajimi
scene: crandall.model.FILTERED_LEVELS, docs/methods/adaptive.md). Their calibration over many
seeds is bench/filtered_error.py's; here a run meets a loose target against references from
outside the code, says which model it used, estimates the stop time (its last rest searched
for touches), and resumes from a checkpoint to the same bits."""

from __future__ import annotations

import math

import numpy as np
import pytest
import scipy.linalg

import crandall
from crandall import KanaiTajimi, Scene, adaptive, envelopes
from crandall.adaptive.levels import FILTER_MAX_PATHS
from crandall.errors import ParameterError

ZETA = 0.6
T0 = 10.0


def _kt(omega=2.0, **kw):
    return KanaiTajimi(omega=omega, zeta=ZETA, h=1.0, **kw)


def _frictionless(times=(1.0, 2.0)):
    return Scene(mu=0.0, g=1.0, excitation=_kt(), t0=T0, times=list(times),
                 observe=["velocity", "distance"])


def _velocity_var(t, omega=2.0):
    """Var V(t) from rest without friction, V = -int a_g: Van Loan's integral of the filter's
    state augmented by G = int a_g (a_g = -omega^2 x - 2 zeta omega x', driven by -dW), by
    SciPy's expm: a reference independent of the core's own construction."""
    a = np.array([[0.0, 1.0, 0.0], [-omega ** 2, -2 * ZETA * omega, 0.0],
                  [-omega ** 2, -2 * ZETA * omega, 0.0]])
    b = np.array([0.0, -1.0, 0.0])
    m = np.zeros((6, 6))
    m[:3, :3], m[:3, 3:], m[3:, 3:] = -a, np.outer(b, b), a.T
    e = scipy.linalg.expm(m * t)
    return float((e[3:, 3:].T @ e[:3, 3:])[2, 2])


def _distance_mean(t):
    """E int_0^t |V| ds = sqrt(2 / pi) int_0^t sd V(s) ds (V is Gaussian without friction)."""
    # Gauss-Legendre with 48 nodes on [0, t] (sd V grows like s^1.5 near 0, smooth beyond):
    # agrees with SciPy's adaptive quad to 1e-9 here, far below the runs' errors.
    x, w = np.polynomial.legendre.leggauss(48)
    s = 0.5 * t * (x + 1.0)
    integral = 0.5 * t * sum(wi * math.sqrt(_velocity_var(si)) for wi, si in zip(w, s))
    return math.sqrt(2.0 / math.pi) * integral


def test_a_frictionless_run_meets_a_loose_target_against_van_loan(tmp_path):
    rel = 0.05
    r = crandall.simulate(_frictionless(), rel_error=rel, seed=11, threads=2,
                          statistics=["velocity:var", "distance:mean"])
    for i, t in enumerate((1.0, 2.0)):
        for stat, ref in (("var", _velocity_var(t)), ("mean", _distance_mean(t))):
            name = "velocity" if stat == "var" else "distance"
            value = (r.var(name) if stat == "var" else r.mean(name))[i]
            err = r.error(name, stat)[i]
            # The run's own rule: error <= rel x |value| (the distance's mean exceeds its
            # standard deviation here, so that is its scale too).
            assert err <= rel * abs(value), (name, stat, t)
            # 4 reported errors: a false failure has probability about 6e-5 per statistic.
            assert abs(value - ref) <= 4 * err, (name, stat, t, value, ref, err)
    # The result names the model it rested on, also read back from a file.
    assert r.model == "filtered_levels"
    assert "model=filtered_levels" in r.summary()
    assert len(r.levels) >= 3  # the measured bias needs the two finest levels' means
    r.save(tmp_path / "r.nc")
    back = crandall.load(tmp_path / "r.nc")
    assert back.model == "filtered_levels"
    assert back.table("distance").tobytes() == r.table("distance").tobytes()
    white = crandall.simulate(Scene.scaled(tau0=1.0, times=[1.0], observe=["velocity"]),
                              error=0.1, seed=3, threads=1)
    assert white.model == "levels" and "model=" not in white.summary()


def _ground_maxima(t, step, paths, seed):
    """max over [0, t] of |G| and |D| (G = int a_g, D = int G: without friction V = -G and
    U = -D) on NumPy paths of the filter's exact discretisation over ``step`` (Van Loan's block
    exponential by SciPy's expm), on the grid ``step`` and on every second point of it."""
    omega = 2.0
    a = np.array([[0.0, 1.0, 0.0, 0.0], [-omega ** 2, -2 * ZETA * omega, 0.0, 0.0],
                  [-omega ** 2, -2 * ZETA * omega, 0.0, 0.0], [0.0, 0.0, 1.0, 0.0]])
    b = np.array([0.0, -1.0, 0.0, 0.0])
    m = np.zeros((8, 8))
    m[:4, :4], m[:4, 4:], m[4:, 4:] = -a, np.outer(b, b), a.T
    e = scipy.linalg.expm(m * step)
    phi = e[4:, 4:].T
    q = phi @ e[:4, 4:]
    w, v = np.linalg.eigh(0.5 * (q + q.T))
    root = v * np.sqrt(np.clip(w, 0.0, None))
    rng = np.random.default_rng(seed)
    y = np.zeros((paths, 4))
    fine, coarse = np.zeros((2, paths)), np.zeros((2, paths))
    for k in range(1, int(round(t / step)) + 1):
        y = y @ phi.T + rng.standard_normal((paths, 4)) @ root.T
        np.maximum(fine, np.abs(y[:, 2:].T), out=fine)
        if k % 2 == 0:
            np.maximum(coarse, np.abs(y[:, 2:].T), out=coarse)
    return fine, coarse


def test_a_frictionless_run_meets_a_loose_target_for_the_peaks_against_numpy():
    # Without friction the peak speed and the peak displacement up to t are the maxima over
    # [0, t] of |G| and |D|, a Gaussian process simulated here outside the core; the run's
    # levels carry the per-path maxima of the filtered core's coupled grids
    # (docs/filtered.md, "Peaks"). Over 200 seeds per target (rel_error=0.02 and 0.01) their
    # 95 % intervals held the reference in 92.0-96.0 % of runs without friction
    # (bench/results/filtered_error_peaks*.json).
    t, rel = 1.0, 0.05
    sc = Scene(mu=0.0, g=1.0, excitation=_kt(), t0=T0, times=[t],
               observe=["velocity", "displacement", "peaks"])
    r = crandall.simulate(sc, rel_error=rel, seed=14, threads=2,
                          statistics=["peak_speed:mean", "peak_speed:var",
                                      "peak_displacement:mean", "peak_displacement:var"])
    assert r.model == "filtered_levels"
    fine, coarse = _ground_maxima(t, 0.01, 40000, 20261127)
    for k, name in enumerate(("peak_speed", "peak_displacement")):
        assert not r.exact(name)
        x = fine[k]
        c = x - x.mean()
        for stat, ref, ref_se, rest in (
                ("mean", x.mean(), x.std(ddof=1) / math.sqrt(len(x)),
                 x.mean() - coarse[k].mean()),
                ("var", x.var(ddof=1), math.sqrt(((c ** 4).mean() - (c ** 2).mean() ** 2)
                                                 / len(x)),
                 x.var(ddof=1) - coarse[k].var(ddof=1))):
            value = float((r.mean(name) if stat == "mean" else r.var(name))[0])
            err = float(r.error(name, stat)[0])
            assert err <= rel * abs(value), (name, stat)
            # What the reference's grid still misses is bounded by its first-order rest, the
            # paired difference to every second point (about 1e-4 for the mean peak speed,
            # a tenth of its standard error): added to the tolerance. 4 combined errors: a
            # false failure has probability about 6e-5 per statistic.
            assert abs(value - ref) <= 4 * math.hypot(err, ref_se) + abs(rest), (
                name, stat, value, ref, err, ref_se, rest)


def test_white_noise_refuses_the_peaks_in_a_run_to_an_accuracy():
    # Its levels record no per-path maxima (docs/methods/adaptive.md).
    sc = Scene.scaled(tau0=1.0, times=[1.0], observe=["velocity", "peaks"])
    with pytest.raises(ParameterError, match="under white noise") as exc:
        crandall.simulate(sc, error=0.1, seed=1)
    assert exc.value.name == "observe"


def test_the_mean_distance_at_the_stop_meets_the_target_against_the_euler_anchor():
    # omega t* = 4 (t* = 2 h^2 / (mu g)^2 = 2 s): fine-step Euler outside the project gave
    # 0.776 +- 0.003 of the white-noise value h^2 t0 / (2 mu g) = 5 (tests/test_filtered.py).
    sc = Scene(mu=1.0, g=1.0, excitation=_kt(), t0=T0, times=[T0], observe=["distance", "stop"])
    eps = 0.06
    r = crandall.simulate(sc, error=eps, seed=12, threads=2, statistics=["distance_at_stop:mean"])
    value, err = r.mean("distance_at_stop"), r.error("distance_at_stop")
    assert err <= eps and r.bias("distance_at_stop") > 0.0 and not r.exact("distance_at_stop")
    # 4 standard deviations of the difference (the run's error and the anchor's 0.015).
    assert abs(value - 0.776 * 5.0) <= 4 * math.hypot(err, 0.003 * 5.0)


def _ramp(t):
    """A smooth envelope: sin(pi t / 4)^2 on [0, 4] s (zero slope at both ends)."""
    return math.sin(math.pi * t / 4.0) ** 2


def _enveloped_velocity_var(t):
    """Var V(t) without friction under the smooth envelope h(t) = _ramp(t) (the driving noise
    multiplied by it): the covariance ODE dP/dt = A P + P A^T + h(t)^2 b b^T of the filter's
    state augmented by the ground velocity, by SciPy's solve_ivp at tolerance 1e-11 (outside
    the core's pieces and its transition matrices)."""
    from scipy.integrate import solve_ivp
    omega = 2.0
    a = np.array([[0.0, 1.0, 0.0], [-omega ** 2, -2 * ZETA * omega, 0.0],
                  [-omega ** 2, -2 * ZETA * omega, 0.0]])
    bb = np.outer([0.0, -1.0, 0.0], [0.0, -1.0, 0.0])

    def rhs(s, y):
        p = y.reshape(3, 3)
        return (a @ p + p @ a.T + _ramp(s) ** 2 * bb).ravel()

    sol = solve_ivp(rhs, (0.0, t), np.zeros(9), rtol=1e-11, atol=1e-13, method="DOP853")
    return float(sol.y[8, -1])


def test_an_envelope_has_its_pieces_chosen_and_their_error_in_the_bias():
    # A smooth envelope given as 4 pieces, far too few: the run refines them (crandall.pieces,
    # the pilot on the filtered core's coupled grids) and adds the pieces' remaining error to
    # the bias; the variance of the velocity then meets its target against the covariance ODE
    # of the smooth envelope, which knows nothing of pieces.
    env = envelopes.from_function(_ramp, 4.0, pieces=4)
    sc = Scene(mu=0.0, g=1.0, excitation=KanaiTajimi(omega=2.0, zeta=ZETA), envelope=env,
               times=[2.0], observe=["velocity"])
    rel = 0.05
    r = crandall.simulate(sc, rel_error=rel, seed=13, threads=2, statistics=["velocity:var"])
    assert r.scene.envelope.pieces > 4 and r.model == "filtered_levels"
    value, err = float(r.var("velocity")[0]), float(r.error("velocity", "var")[0])
    assert err <= rel * value and not r.exact("velocity", "var")
    assert float(r.bias("velocity", "var")[0]) != 0.0
    # 4 reported errors: a false failure has probability about 6e-5.
    ref = _enveloped_velocity_var(2.0)
    assert abs(value - ref) <= 4 * err, (value, ref, err)


def _stop_times(sc, paths, seed, depth):
    """Per path, the walked grid's stop time at event depth `depth` (the same skeleton and
    bridges at every depth: docs/filtered.md)."""
    from crandall import _core, engine
    from crandall.spec import RunSpec
    spec = RunSpec.create(sc, paths=paths, seed=seed, event_depth=depth)
    plan = _core.Plan(engine.plan_options(spec, histograms=False))
    return np.asarray(_core.run_samples(plan, 0, paths, 1))[:, len(sc.times), 0, 0]


def test_the_last_rests_touches_make_the_stop_time_all_but_independent_of_the_depth():
    # omega t* = 1: the body rests for good about 2 s before t0 on average. Before the last
    # rest's touches were searched (to depth 20 whatever the event depth), depth 8 against
    # 10 moved the mean stop time by 9.1e-3 +- 1.5e-3 s (docs/filtered.md); now depth 8
    # against 20 moves it by about -6e-6 +- 4e-7 s, the sliding events' own depth error.
    # The bound 1e-4 s is 1 % of the old shift and over 100 standard errors of the new one.
    sc = Scene(mu=1.0, g=1.0, excitation=_kt(omega=0.5), t0=T0, times=[T0], observe=["stop"])
    shallow, deep = (_stop_times(sc, 4000, 5, d) for d in (8, 20))
    d = shallow - deep
    assert abs(d.mean()) < 1e-4, (d.mean(), d.std() / math.sqrt(d.size))


def test_the_stop_time_meets_a_target_against_the_touch_counting_euler_reference():
    # bench/stop_time_reference.py (bench/results/stop_time_reference.json): an Euler peer
    # that counts a resting body's touches of mu_s g by the Brownian bridge's probability,
    # extrapolated to dt -> 0 at first order (three steps agree): at omega t* = 4 the mean
    # stop time is 10.3877 +- 0.0013 s and its variance 0.3624 +- 0.0021 s^2.
    sc = Scene(mu=1.0, g=1.0, excitation=_kt(), t0=T0, times=[T0], observe=["distance", "stop"])
    r = crandall.simulate(sc, error=0.01, seed=3, threads=2,
                          statistics=["stop_time:mean", "stop_time:var"])
    assert r.model == "filtered_levels"
    for stat, ref, ref_se in (("mean", 10.3877, 0.0013), ("var", 0.3624, 0.0021)):
        value = float(r.mean("stop_time") if stat == "mean" else r.var("stop_time"))
        err = float(r.error("stop_time", stat))
        assert err <= 0.01 and float(r.bias("stop_time", stat)) != 0.0
        # 4 of the combined errors: a false failure has probability about 6e-5 each.
        assert abs(value - ref) <= 4 * math.hypot(err, ref_se), (stat, value, ref, err)


def test_a_filtered_fixed_step_checkpoint_names_its_touch_search(tmp_path):
    # The stop time counts the touches found down to _core.TOUCH_DEPTH: a checkpoint whose
    # stop times were summed without that search belongs to another run.
    import json
    sc = Scene(mu=1.0, g=1.0, excitation=_kt(), t0=2.0, times=[2.0], observe=["stop"])
    path = tmp_path / "f.ckpt"
    kw = dict(paths=64, seed=1, threads=1)
    crandall.simulate(sc, checkpoint=path, **kw)
    with np.load(path) as data:
        arrays = {k: data[k] for k in data.files}
    ident = json.loads(str(arrays["identity"]))
    assert ident["touch_depth"] == crandall._core.TOUCH_DEPTH == 20
    edited = {k: v for k, v in ident.items() if k != "touch_depth"}
    with open(path, "wb") as f:
        np.savez(f, **{**arrays, "identity": np.array(json.dumps(edited))})
    with pytest.raises(ValueError, match=r"belongs to a different run \(.*touch_depth"):
        crandall.simulate(sc, checkpoint=path, **kw)
    # Without the stop observed (or under white noise) the identity has no such field.
    white = Scene.scaled(tau0=1.0, times=[1.0], observe=["stop"])
    no_stop = Scene(mu=1.0, g=1.0, excitation=_kt(), t0=2.0, times=[2.0], observe=["distance"])
    for other in (white, no_stop):
        p = tmp_path / "o.ckpt"
        crandall.simulate(other, checkpoint=p, **kw)
        with np.load(p) as data:
            assert "touch_depth" not in json.loads(str(data["identity"]))
        p.unlink()


def test_checkpoint_resume_is_bitwise(tmp_path, monkeypatch):
    # With friction: without it the velocity and the distance are functions of the ground
    # motion that the control variates nearly reproduce, and one round is enough.
    sc = Scene(mu=1.0, g=1.0, excitation=_kt(), t0=T0, times=[2.0],
               observe=["velocity", "distance"])
    args = dict(rel_error=0.01, seed=21, statistics=["velocity:var", "distance:mean"])
    monkeypatch.setattr(adaptive.entry, "CHECKPOINT_SECONDS", 0.0)
    real = adaptive._core.run_samples

    def batch(first):
        # A level's time per path is measured on its last paths (discarded): no batch.
        return first < FILTER_MAX_PATHS - 64

    total = {"n": 0}

    def counting(*a, **kw):
        total["n"] += batch(a[1])
        return real(*a, **kw)

    monkeypatch.setattr(adaptive._core, "run_samples", counting)
    whole = crandall.simulate(sc, threads=1, **args)
    assert total["n"] >= 4 and whole.cost["rounds"] >= 2
    _resumes_to_its_bits(sc, args, whole, (2, total["n"] - 1), tmp_path, monkeypatch)


def _resumes_to_its_bits(sc, args, whole, stops, tmp_path, monkeypatch):
    """A run interrupted after each count of batches in ``stops`` (Ctrl-C in the core, a
    checkpoint after every batch) and resumed on two threads gives ``whole``'s bits."""
    real = adaptive._core.run_samples
    for stop_after in stops:
        ckpt = tmp_path / f"run{stop_after}.json"
        calls = {"n": 0}

        def interrupted(*a, **kw):
            # A level's time per path is measured on its last paths (discarded): no batch.
            calls["n"] += a[1] < FILTER_MAX_PATHS - 64
            if calls["n"] > stop_after:
                raise KeyboardInterrupt
            return real(*a, **kw)

        monkeypatch.setattr(adaptive._core, "run_samples", interrupted)
        with pytest.raises(KeyboardInterrupt):
            crandall.simulate(sc, threads=2, checkpoint=ckpt, **args)
        monkeypatch.setattr(adaptive._core, "run_samples", real)
        resumed = crandall.simulate(sc, threads=2, checkpoint=ckpt, **args)
        for name in ("velocity", "distance"):
            assert resumed.table(name).tobytes() == whole.table(name).tobytes(), (stop_after,
                                                                                  name)
        assert resumed.cost["paths"] == whole.cost["paths"]
        assert resumed.cost["path_steps"] == whole.cost["path_steps"]


def test_a_long_run_refits_its_controls_and_resumes_to_its_bits(tmp_path, monkeypatch):
    # A refit (levels.REFIT_PILOT) forced on a short run: a pilot of 16384 paths (4 first
    # pilots, the least a refit takes) whenever the base level is asked for 4096 (its first
    # round asks for 5784 here).
    sc = Scene(mu=1.0, g=1.0, excitation=_kt(), t0=T0, times=[2.0],
               observe=["velocity", "distance"])
    args = dict(rel_error=0.01, seed=21, statistics=["velocity:var", "distance:mean"])
    monkeypatch.setattr(adaptive.levels, "REFIT_PILOT", 4 * adaptive.PILOT_PATHS)
    monkeypatch.setattr(adaptive.levels, "REFIT_RATIO", 0.25)
    monkeypatch.setattr(adaptive.entry, "CHECKPOINT_SECONDS", 0.0)
    fits = []
    real_fit = adaptive.features._Features._fit_controls

    def fit(self, block, controls):
        fits.append(len(block))
        return real_fit(self, block, controls)

    monkeypatch.setattr(adaptive.features._Features, "_fit_controls", fit)
    whole = crandall.simulate(sc, threads=1, **args)
    # Fitted twice: on the first pilot, then on the refit's.
    assert fits == [adaptive.PILOT_PATHS, 4 * adaptive.PILOT_PATHS]
    base = whole.levels[0]
    # What the base level drew: its two pilots, the paths set aside (a whole batch of the
    # first round at least) and its estimate.
    assert whole.cost["path_steps"] > (5 * adaptive.PILOT_PATHS + base["paths"]) \
        * base["steps_per_path"] + sum(lv["paths"] * lv["steps_per_path"] * 1.5
                                        for lv in whole.levels[1:])
    # It meets its target by the run's own rule, error <= rel x |value|.
    assert whole.error("velocity", "var")[0] <= 0.01 * whole.var("velocity")[0]
    assert whole.error("distance", "mean")[0] <= 0.01 * whole.mean("distance")[0]
    # Stopped in the first round, at its end (before the refit) and after the refit's pilot.
    _resumes_to_its_bits(sc, args, whole, (3, 4, 5), tmp_path, monkeypatch)
