"""A body that starts moving (Scene(v0=, u0=)): the core starts every path at the scene's
state, the identities that hold from any start are used (the exact step, the mean distance
through Ito's formula with v0^2 added), the paper's closed forms are not offered, and the
numbers agree with the closed forms of a start (crandall.analytic.start) and with each other.
Statistical checks: fixed seeds, |z| <= 4 with z from the reported total error (stderr and
bias), a false failure has probability about 6e-5 per check."""

from __future__ import annotations

import math

import numpy as np
import pytest

import crandall
from crandall import analytic, model, paper


def test_a_start_is_part_of_the_scene_and_its_data():
    sc = crandall.Scene(mu=0.3, h=1.0, t0=1.0, times=[0.5, 1.0], v0=-0.5, u0=0.1)
    assert (sc.v0, sc.u0) == (-0.5, 0.1) and sc.effects == {model.INITIAL_STATE}
    again = crandall.Scene.from_dict(sc.to_dict())
    assert (again.v0, again.u0) == (-0.5, 0.1)
    # A start at rest keeps the plain data (so checkpoints and files) of before.
    rest = crandall.Scene(mu=0.3, h=1.0, t0=1.0, times=[0.5, 1.0], v0=0.0)
    assert "v0" not in rest.to_dict() and rest.effects == frozenset()
    for bad, match in ((dict(v0=math.nan), "v0 must not be NaN"),
                       (dict(u0=math.inf), "u0 must be finite"), (dict(v0="1"), "v0 must be")):
        with pytest.raises(ValueError, match=match):
            crandall.Scene(mu=0.3, h=1.0, t0=1.0, times=[1.0], **bad)
    # Without friction a moving body never stops, even without noise.
    with pytest.raises(ValueError, match="observe: 'stop' needs mu > 0"):
        crandall.Scene(mu=0.0, h=0.0, t0=1.0, times=[1.0], v0=1.0, observe=["stop"])


def test_a_scene_file_takes_the_start(tmp_path):
    path = tmp_path / "s.toml"
    path.write_text('[scene]\nunits = "SI"\nmu = 0.3\nh = 1.0\nt0 = 1.0\nv0 = 0.8\n'
                    'u0 = -0.02\ntimes = [1.0]\n')
    sc = crandall.Scene.from_toml(path)
    assert (sc.v0, sc.u0) == (0.8, -0.02)


def test_without_noise_the_coast_is_the_closed_form():
    # h = 0: the body coasts from v0 and stops at |v0| / (mu g) having travelled v0^2 / (2 mu g).
    # Deterministic: every path gives these to rounding, the variances are 0.
    v0, mu, g = -1.5, 0.4, 9.81
    c = mu * g
    sc = crandall.Scene(mu=mu, h=0.0, t0=0.0, times=[0.1, 0.3], v0=v0, u0=0.25,
                        observe=["velocity", "displacement", "distance", "stop"])
    r = crandall.simulate(sc, paths=100, seed=1, method="exact")
    np.testing.assert_allclose(r.mean("velocity"), v0 + c * np.array([0.1, 0.3]), rtol=1e-13)
    assert r.mean("stop_time") == pytest.approx(abs(v0) / c, rel=1e-13)
    assert r.mean("distance_at_stop") == pytest.approx(v0 ** 2 / (2 * c), rel=1e-13)
    assert r.mean("displacement_at_stop") == pytest.approx(0.25 - v0 ** 2 / (2 * c), rel=1e-13)
    assert r.var("stop_time") == pytest.approx(0.0, abs=1e-24)
    # The same in scaled units, against crandall.analytic.start.
    s = crandall.Scene.scaled(tau0=0.0, times=[0.2], v0=3.0, observe=["distance", "stop"])
    r = crandall.simulate(s, paths=10, seed=1, method="exact")
    assert r.mean("stop_time") == pytest.approx(analytic.coast_stop_time(3.0), rel=1e-13)
    assert r.mean("distance_at_stop") == pytest.approx(analytic.coast_distance(3.0), rel=1e-13)


def test_the_energy_law_from_a_start():
    # E U3(tau_s) = (v0^2 + 2 tau0) / 4: the start's kinetic energy and the noise's work.
    sc = crandall.Scene.scaled(tau0=1.0, times=[0.5, 1.0], v0=2.5,
                               observe=["velocity", "distance", "stop"])
    r = crandall.simulate(sc, paths=40_000, seed=5, method="exact", dt=0.01)
    ref = analytic.distance_at_stop_mean_from(2.5, 1.0)
    assert abs(r.mean("distance_at_stop") - ref) <= 4 * r.error("distance_at_stop")
    # The velocity statistics stay exact in law: their bias is 0, not estimated.
    assert r.exact("velocity", "var") and r.bias("velocity", "var").max() == 0.0


def test_a_run_to_an_accuracy_uses_the_identity_with_the_start():
    sc = crandall.Scene.scaled(tau0=1.0, times=[0.5, 1.0], v0=-2.0,
                               observe=["velocity", "distance", "stop"])
    a = crandall.simulate(sc, error=0.02, seed=3, threads=2)
    # The mean distance at the stop is the constant (v0^2 + 2 tau0) / 4, exact, no error.
    assert a.exact("distance_at_stop") and a.error("distance_at_stop") == 0.0
    assert a.mean("distance_at_stop") == pytest.approx(analytic.distance_at_stop_mean_from(-2.0, 1.0),
                                                      rel=1e-14)
    assert a.exact("distance")
    # The mean distance over time agrees with a fixed-step run of the same scene.
    f = crandall.simulate(sc, paths=40_000, seed=9, method="exact", dt=0.005)
    gap = np.abs(a.mean("distance") - f.mean("distance"))
    assert np.all(gap <= 4 * np.hypot(a.error("distance"), f.error("distance"))), gap


def test_a_displacement_start_shifts_the_displacement_only():
    # The same paths from u0 = 3 and from 0: the displacement moves by 3 (to rounding), its
    # variance and everything else stay; the peak |U| starts at |u0|.
    kw = dict(tau0=1.0, times=[0.5, 1.0], observe=["velocity", "displacement", "distance",
                                                     "peaks"])
    a = crandall.simulate(crandall.Scene.scaled(u0=3.0, **kw), paths=2000, seed=2,
                          method="exact")
    b = crandall.simulate(crandall.Scene.scaled(**kw), paths=2000, seed=2, method="exact")
    np.testing.assert_allclose(a.mean("displacement") - b.mean("displacement"), 3.0, rtol=1e-12)
    np.testing.assert_allclose(a.var("displacement"), b.var("displacement"), rtol=1e-8)
    np.testing.assert_array_equal(a.mean("distance"), b.mean("distance"))
    assert np.all(a.mean("peak_displacement") >= 3.0)


def test_the_paper_closed_forms_are_not_offered_for_a_start():
    sc = crandall.Scene.scaled(tau0=1.0, times=[1.0], v0=1.0)
    r = crandall.simulate(sc, paths=200, seed=1)
    with pytest.raises(ValueError, match="closed forms do not hold for a scene with initial_state"):
        paper.scaled_factors(r)


def test_the_closed_forms_of_a_start_agree_with_the_paper_at_rest():
    # From rest, the identity with the paper's Var U1 is the paper's mean distance, and the
    # energy law is eq7 (tau0 / 2).
    tau = np.array([0.3, 1.0, 2.5])
    ident = analytic.distance_mean_from_velocity(0.0, tau, 2.0, analytic.velocity_var(tau, 2.0))
    np.testing.assert_allclose(ident, analytic.distance_mean(tau, 2.0), rtol=1e-10)
    assert analytic.distance_at_stop_mean_from(0.0, 2.0) == pytest.approx(
        analytic.distance_at_stop_mean(2.0), rel=1e-15)
    with pytest.raises(ValueError, match="v0 must be finite"):
        analytic.coast_distance(math.inf)


def test_the_shipped_scene_of_a_crate_sliding_in(tmp_path, capsys):
    import pathlib
    from crandall import cli
    path = pathlib.Path(__file__).resolve().parent.parent / "scenes" / "crate_sliding_in.toml"
    sc = crandall.Scene.from_toml(path)
    assert sc.v0 == 0.8 and sc.effects == {model.INITIAL_STATE}
    r = crandall.simulate(sc, paths=20_000, seed=4)
    # The energy law: m v0^2 / 2 + m h^2 t0 / 2 = 32 + 100 J.
    assert abs(r.mean("dissipated_energy_at_stop") - 132.0) <= 4 * r.error(
        "dissipated_energy_at_stop")
    out = tmp_path / "out"
    assert cli.main(["run", str(path), "--paths", "2000", "--out", str(out)]) == 0
    assert (out / "result.nc").exists() and (out / "result.csv").exists()
    # Its figures are drawn in its units, without the paper's closed forms.
    assert (out / "fig2_distance_mean.png").exists()
    assert "figures not drawn" not in capsys.readouterr().err
