"""A piecewise intensity (Scene(h=[...], t0=[...])): pieces, pauses, aftershocks. Each piece is
the same sign-drift diffusion with its own intensity, stepped exactly; no step straddles a
piece's end; the identities that hold for any schedule are used (the exact step; the mean
distance through Ito's formula with the noise's energy int h^2 dt). Statistical checks: fixed
seeds, |z| <= 4 from the reported total errors (a false failure has probability about 6e-5 per
check)."""

from __future__ import annotations

import math

import numpy as np
import pytest

import crandall
from crandall import analytic, model
from crandall.analytic import schedule


def test_one_piece_given_as_a_sequence_is_the_scalar_scene_bit_for_bit():
    kw = dict(mu=0.3, g=9.81, times=[0.5, 1.0, 2.5])
    a = crandall.simulate(crandall.Scene(h=[1.0], t0=[2.0], **kw), paths=3000, seed=4)
    b = crandall.simulate(crandall.Scene(h=1.0, t0=2.0, **kw), paths=3000, seed=4)
    for name in b.names:
        assert np.asarray(a.mean(name)).tobytes() == np.asarray(b.mean(name)).tobytes(), name
        assert np.asarray(a.var(name)).tobytes() == np.asarray(b.var(name)).tobytes(), name


def test_a_pause_before_the_shaking_delays_the_paper_scene():
    # No noise on [0, 1): the body stays at rest (exactly), then the paper's scene from
    # tau = 1: Var U1(1 + tau) is the paper's Var U1(tau) (exact in law: bias 0, stderr only).
    sc = crandall.Scene.scaled(tau0=[1.0, 3.0], h=[0.0, 1.0], times=[0.5, 2.0, 3.0],
                               observe=["velocity", "stop"])
    r = crandall.simulate(sc, paths=40_000, seed=8)
    assert r.mean("velocity")[0] == 0.0 and r.var("velocity")[0] == 0.0
    ref = analytic.velocity_var(np.array([1.0, 2.0]), 2.0)
    got, se = r.var("velocity")[1:], r.var_stderr("velocity")[1:]
    assert np.all(np.abs(got - ref) <= 4 * se), (got, ref, se)
    assert r.exact("velocity", "var") and r.bias("velocity", "var").max() == 0.0
    # The stop: the paper's scene with tau0 = 2, shifted by 1.
    assert abs(r.mean("stop_time") - (1.0 + analytic.stop_time_mean(2.0))) <= 4 * r.error(
        "stop_time")


def test_a_stop_inside_a_final_pause_is_located_there():
    # Pauses after the last shaken piece are the coast after the switch-off: the body that
    # stops in them stops when its speed runs out, not at the pause's end. h = [1, 0] until
    # [5, 10] is the paper's scene with tau0 = 5 (one piece at the unit intensity), bit for
    # bit, so its stop time is the paper's (mean 5.25, eq14) and its closed forms apply.
    kw = dict(times=[1.0, 7.0], observe=["velocity", "distance", "stop"])
    paused = crandall.Scene.scaled(tau0=[5.0, 8.0, 10.0], h=[1.0, 0.0, 0.0], **kw)
    plain = crandall.Scene.scaled(tau0=5.0, **kw)
    assert paused.t0 == 5.0 and paused.pieces is None and paused.effects == frozenset()
    assert paused.to_dict()["tau0"] == [5.0, 8.0, 10.0]  # the schedule as given is kept
    a = crandall.simulate(paused, paths=20_000, seed=3)
    b = crandall.simulate(plain, paths=20_000, seed=3)
    for name in b.names:
        assert np.asarray(a.mean(name)).tobytes() == np.asarray(b.mean(name)).tobytes(), name
    assert abs(a.mean("stop_time") - analytic.stop_time_mean(5.0)) <= 4 * a.error("stop_time")
    # Two shaken pieces, then a pause: the noise ends at 2 s, where the coast starts; the
    # mean stop time is 2 s + E|V(2)| / (mu g), E|V(2)| from the velocity's law across the
    # pieces (crandall.analytic.schedule, quadrature, relative error about 3e-5: 1e-4 of
    # the mean is allowed for it), not from the simulation.
    sc = crandall.Scene(mu=0.3, h=[1.0, 0.5, 0.0], t0=[1.0, 2.0, 30.0], times=[1.0],
                        observe=["velocity", "stop"])
    assert sc.t0 == 2.0 and sc.pieces == ((1.0, 1.0), (2.0, 0.5))
    r = crandall.simulate(sc, paths=40_000, seed=5)
    c = 0.3 * 9.81
    law = schedule.velocity_law([(1.0, 1.0), (2.0, 0.5)], c, 2.0)
    want = 2.0 + float(np.sum(law.weights * np.abs(law.grid))) / c
    assert r.mean("stop_time") < 3.0
    assert abs(r.mean("stop_time") - want) <= 4 * r.error("stop_time") + 1e-4 * want


def test_a_schedule_without_noise_is_the_deterministic_coast():
    # No piece shakes: the body coasts from v0 and stops at |v0| / (mu g) after covering
    # v0^2 / (2 mu g), on every path (a body at rest stays at rest and stops at 0).
    c = 0.3 * 9.81
    sc = crandall.Scene(mu=0.3, h=[0.0, 0.0], t0=[1.0, 4.0], v0=-0.9, times=[0.1],
                        observe=["velocity", "distance", "stop"])
    assert sc.t0 == 0.0 and sc.pieces is None
    r = crandall.simulate(sc, paths=300, seed=1)
    assert r.mean("stop_time") == pytest.approx(0.9 / c, rel=1e-14) and r.var("stop_time") == 0
    assert r.mean("distance_at_stop") == pytest.approx(0.81 / (2 * c), rel=1e-14)
    assert r.mean("velocity")[0] == pytest.approx(-0.9 + 0.1 * c, rel=1e-14)
    rest = crandall.Scene(mu=0.3, h=[0.0], t0=[2.0], times=[1.0], observe=["velocity", "stop"])
    r = crandall.simulate(rest, paths=300, seed=1)
    assert r.mean("stop_time") == 0.0 and r.mean("velocity")[0] == 0.0


def test_a_scalar_intensity_of_zero_is_the_deterministic_coast_too():
    # issue 30, finding 1: h = 0 given as a number is the schedule h = [0]: no noise ever, so
    # the noise ends at 0 (Scene.t0), the body coasts from v0 and stops at |v0| / (mu g) after
    # v0^2 / (2 mu g), in every estimator. It was reported at t0 = 2 s with bias 0 (simulate,
    # error= and tail), and its displacement came from the trapezoid rule through the kink.
    c = 0.3 * 9.81
    kw = dict(mu=0.3, v0=1.0, u0=0.05, times=[0.1, 1.0])
    scalar = crandall.Scene(h=0.0, t0=2.0, **kw)
    listed = crandall.Scene(h=[0.0], t0=[2.0], **kw)
    assert scalar.t0 == 0.0 and scalar.to_dict()["t0"] == 2.0  # the schedule as given is kept
    stop, travel = 1.0 / c, 1.0 / (2 * c)
    a = crandall.simulate(scalar, paths=300, seed=1)
    b = crandall.simulate(listed, paths=300, seed=1)
    for name in b.names:
        assert np.asarray(a.mean(name)).tobytes() == np.asarray(b.mean(name)).tobytes(), name
    assert a.mean("stop_time") == pytest.approx(stop, rel=1e-14) and a.bias("stop_time") == 0
    assert a.mean("distance_at_stop") == pytest.approx(travel, rel=1e-14)
    assert a.mean("displacement_at_stop") == pytest.approx(0.05 + travel, rel=1e-14)
    assert a.mean("distance")[1] == pytest.approx(travel, rel=1e-14)
    # Everything after t = 0 is the closed-form coast: the grids agree to rounding.
    assert np.all(np.abs(a.bias("displacement")) <= 1e-14 * travel) and a.var("stop_time") == 0
    e = crandall.simulate(scalar, error=0.01, seed=1, threads=1)
    assert e.mean("stop_time") == pytest.approx(stop, rel=1e-14)
    assert e.mean("displacement")[1] == pytest.approx(0.05 + travel, rel=1e-14)
    assert e.mean("displacement_at_stop") == pytest.approx(0.05 + travel, rel=1e-14)
    t = crandall.tail(scalar, "stop_time", [0.9 * stop, 1.1 * stop, 1.5], seed=1)
    assert t.probability.tolist() == [1.0, 0.0, 0.0]
    assert t.diagnostics.get("deterministic")
    lo, hi = t.interval()  # a deterministic answer: its interval is the point itself
    assert lo.tolist() == hi.tolist() == t.probability.tolist()
    t = crandall.tail(scalar, "distance_at_stop", [0.999 * travel, 1.001 * travel], seed=1)
    assert t.probability.tolist() == [1.0, 0.0]


@pytest.mark.parametrize("method", ["exact", "richardson", "richardson2", "refine"])
def test_a_stop_inside_a_pause_has_the_exact_coast_on_every_path(method):
    # issue 30, finding 1: a body that comes to rest inside a pause (no noise) covers exactly
    # V^2 / (2 mu g) from where the pause starts, on every path and on each of the method's
    # grids. The trapezoid rule is exact on the pause's steps where the speed falls linearly
    # but not in the step where it reaches 0 (the kink): at dt = 0.01 it was off by up to
    # c dt^2 / 8 = 3.7e-5 m per path. Per-path values of the core's path loop (run_samples,
    # what a run to an accuracy reads; the fixed-step run sums the same values).
    from crandall import _core, engine
    from crandall.spec import RunSpec

    c = 0.3 * 9.81
    sc = crandall.Scene(mu=0.3, h=[1.0, 0.0, 1.0], t0=[0.5, 3.0, 3.2], v0=3.0, u0=0.1,
                        times=[0.5, 2.5], observe=["velocity", "displacement", "distance", "stop"])
    spec = RunSpec.create(sc, paths=2000, seed=3, dt=0.01, method=method)
    v = _core.run_samples(engine.make_plan(spec), 0, 2000)  # path, slot, grid, variable
    x, u, s = v[:, 0, :, 0], v[:, 0, :, 1], v[:, 0, :, 2]
    assert np.all(np.abs(x) < 2.5 * c)  # every body comes to rest before 2.5 s
    assert np.all(v[:, 1, :, 0] == 0.0)
    travel = x * x / (2 * c)
    np.testing.assert_allclose(v[:, 1, :, 2], s + travel, rtol=1e-12, atol=0)
    np.testing.assert_allclose(v[:, 1, :, 1], u + np.sign(x) * travel, rtol=1e-12,
                               atol=1e-12 * np.max(np.abs(u)))


def test_the_energy_law_holds_for_any_schedule():
    # E[mu g S(t_s)] = v0^2 / 2 + int h^2 dt / 2: here 1 * 1 + 0 + 0.36 * 1 plus a start at
    # 0.4 m/s.
    sc = crandall.Scene(mu=0.3, h=[1.0, 0.0, 0.6], t0=[1.0, 1.5, 2.5], v0=0.4,
                        times=[0.5, 1.2, 2.0], observe=["velocity", "distance", "stop"])
    assert sc.effects == {model.PIECEWISE_INTENSITY, model.INITIAL_STATE}
    c = 0.3 * 9.81
    want = (0.4 ** 2 + 1.0 + 0.36) / (2 * c)
    r = crandall.simulate(sc, paths=40_000, seed=2)
    assert abs(r.mean("distance_at_stop") - want) <= 4 * r.error("distance_at_stop")
    # A run to an accuracy answers it through the identity: exact, no error.
    a = crandall.simulate(sc, error=0.02, seed=2, threads=2)
    assert a.exact("distance_at_stop") and a.mean("distance_at_stop") == pytest.approx(want,
                                                                                      rel=1e-13)
    assert model.noise_energy(sc, 2.0) == pytest.approx(1.0 + 0.36 * 0.5, rel=1e-15)
    # Its mean distance over time (the identity, with the pieces) agrees with the fixed-step
    # run's.
    gap = np.abs(a.mean("distance") - r.mean("distance"))
    assert np.all(gap <= 4 * np.hypot(a.error("distance"), r.error("distance"))), gap


def test_splitting_a_piece_does_not_change_the_law():
    # h = [1, 1] on [0, 1), [1, 2) is the scalar scene (another grid point, other draws, the
    # same law).
    kw = dict(times=[0.5, 1.5, 2.0], observe=["velocity", "distance"])
    a = crandall.simulate(crandall.Scene.scaled(tau0=[1.0, 2.0], h=[1.0, 1.0], **kw),
                          paths=40_000, seed=1, method="exact", dt=0.02)
    b = crandall.simulate(crandall.Scene.scaled(tau0=2.0, **kw), paths=40_000, seed=2,
                          method="exact", dt=0.02)
    for name, stat in (("velocity", "var"), ("distance", "mean"), ("distance", "var")):
        va, vb = getattr(a, stat)(name), getattr(b, stat)(name)
        err = np.hypot(a.error(name, stat), b.error(name, stat))
        assert np.all(np.abs(va - vb) <= 4 * err), (name, stat, va, vb, err)


def test_the_variance_at_the_stop_through_the_isometry_holds_for_any_schedule():
    # A run to an accuracy takes Var S(t_s) as the mean of int h^2 V^2 dt / (mu g)^2 (Ito's
    # isometry, crandall.model.ISOMETRY): on a schedule with a start at 0.4 m/s, a pause and a
    # weaker piece it must agree with the fixed-step run's plain sample variance of S(t_s)
    # (other seed, other estimator), within 4 combined reported errors (stderr and bias):
    # about 0.9 % of the variance each here, so a shift of 6 % or more fails (a piece's h
    # or the start left out of the integral moves it by far more).
    sc = crandall.Scene(mu=0.3, h=[1.0, 0.0, 0.6], t0=[1.0, 1.5, 2.5], v0=0.4,
                        times=[2.0], observe=["distance", "stop"])
    assert model.holds(sc, model.ISOMETRY)
    a = crandall.simulate(sc, rel_error=0.01, seed=4, threads=2,
                          statistics=["distance_at_stop:var"])
    b = crandall.simulate(sc, paths=200_000, seed=5, threads=2)
    va, vb = a.var("distance_at_stop"), b.var("distance_at_stop")
    err = math.hypot(a.error("distance_at_stop", "var"), b.error("distance_at_stop", "var"))
    assert err < 0.015 * vb
    assert abs(va - vb) <= 4 * err, (va, vb, err)
    # The isometry's per-path value spreads far less than (S - E S)^2: the run needed fewer
    # base-level paths than the fixed-step run's 200 000 for about the same error.
    assert a.cost["paths"][0] < 50_000


@pytest.mark.parametrize("kw, match", [
    (dict(h=[1.0, 0.5], t0=[1.0]), "h, t0: a piecewise intensity needs as many"),
    (dict(h=[1.0, 0.5], t0=2.0), "h, t0: give both as numbers, or both as sequences"),
    (dict(h=[1.0, 0.5], t0=[2.0, 1.0]), "t0: the pieces' ends must be > 0 and strictly"),
    (dict(h=[1.0, math.nan], t0=[1.0, 2.0]), r"h\[1\] must not be NaN"),
    (dict(h=[1.0, -1.0], t0=[1.0, 2.0]), r"h\[1\] must be >= 0"),
    (dict(h=[1.0, 1.0], t0=[1.0, math.inf]), r"t0\[1\] must be finite"),
    (dict(h=[], t0=[]), "at least one"),
])
def test_a_bad_schedule_is_refused_naming_the_parameter(kw, match):
    with pytest.raises(ValueError, match=match):
        crandall.Scene(mu=0.3, times=[1.0], **kw)


def test_scaled_pieces_and_scene_files(tmp_path):
    with pytest.raises(ValueError, match="h: in scaled units one intensity is the unit"):
        crandall.Scene.scaled(tau0=1.0, h=0.5, times=[1.0])
    sc = crandall.Scene.scaled(tau0=[1.0, 2.0], h=[1.0, 0.5], times=[1.0, 2.0])
    assert sc.pieces == ((1.0, math.sqrt(2.0)), (2.0, math.sqrt(2.0) * 0.5))
    back = crandall.Scene.from_dict(sc.to_dict())
    assert back.pieces == sc.pieces and back.t0 == 2.0
    path = tmp_path / "s.toml"
    path.write_text('[scene]\nunits = "SI"\nmu = 0.3\nh = [1.0, 0.0, 0.6]\n'
                    't0 = [1.0, 1.5, 2.5]\ntimes = [1.0, 3.0]\n')
    f = crandall.Scene.from_toml(path)
    assert f.pieces == ((1.0, 1.0), (1.5, 0.0), (2.5, 0.6)) and f.t0 == 2.5


@pytest.mark.parametrize("name", ["cabinet_amin_ang.toml", "aftershock.toml"])
def test_the_shipped_piecewise_scenes_keep_the_energy_law(name):
    import pathlib
    path = pathlib.Path(__file__).resolve().parent.parent / "python" / "crandall" / "scenes" / name
    sc = crandall.Scene.from_toml(path)
    assert model.PIECEWISE_INTENSITY in sc.effects
    r = crandall.simulate(sc, paths=4000, seed=6)
    want = sc.mass * model.noise_energy(sc, sc.t0) / 2  # J: m/2 int h^2 dt
    got = r.mean("dissipated_energy_at_stop")
    assert abs(got - want) <= 4 * r.error("dissipated_energy_at_stop"), (got, want)


def test_a_piecewise_scene_with_a_start_saves_and_loads_bitwise(tmp_path):
    sc = crandall.Scene(mu=0.3, h=[1.0, 0.0, 0.6], t0=[1.0, 1.5, 2.5], v0=0.3, u0=-0.1,
                        times=[0.5, 2.0, 3.0], distributions=["distance_at_stop"])
    r = crandall.simulate(sc, paths=1000, seed=3)
    r.save(tmp_path / "r.nc")
    back = crandall.load(tmp_path / "r.nc")
    assert back.scene == sc and back.scene.pieces == sc.pieces and back.scene.v0 == 0.3
    for name in r.names:
        assert np.asarray(back.var(name)).tobytes() == np.asarray(r.var(name)).tobytes()
    a = crandall.simulate(sc.__class__(mu=0.3, h=[1.0, 0.5], t0=[1.0, 2.0], times=[1.0, 2.0]),
                          error=0.05, seed=3)
    a.save(tmp_path / "a.nc")
    assert crandall.load(tmp_path / "a.nc").to_pandas().equals(a.to_pandas())


def test_the_default_step_follows_the_strongest_piece():
    # In scaled units the time scale of a piece r times the unit intensity is 1 / r^2 of the
    # unit's: a piece of 3 gets a step 9 times finer; weaker pieces keep the unit's step, as
    # does a physical scene (its scales are those of its largest h).
    kw = dict(times=[1.0])
    assert crandall.default_dt(crandall.Scene.scaled(tau0=[1.0, 2.0], h=[1.0, 3.0], **kw)) \
        == pytest.approx(0.01 / 9, rel=1e-15)
    assert crandall.default_dt(crandall.Scene.scaled(tau0=[1.0, 2.0], h=[0.5, 0.0], **kw)) \
        == crandall.default_dt(crandall.Scene.scaled(tau0=2.0, **kw))
    si = crandall.Scene(mu=0.3, h=[0.5, 2.0], t0=[1.0, 2.0], **kw)
    assert crandall.default_dt(si) == crandall.default_dt(crandall.Scene(mu=0.3, h=2.0, t0=2.0,
                                                                          **kw))
