"""Fragility curves (crandall.fragility): against separate crandall.tail runs and the stop
time's closed-form tail from rest; shared (scaled) runs against separate ones; the lognormal
fit and the hazard integral on synthetic cases with known answers; refusals, files, figure.

Tolerances: an estimate and an exact reference agree within Z = 3.5 of the estimate's
reported standard error; two independent estimates within Z times their combined standard
error (with the fixed seeds each check holds or not; a correct estimator fails one such check
with probability about 5e-4). The fit's parameters and the hazard agree with the values that
generated the synthetic data within Z of their reported standard errors. References: the
closed forms of crandall.analytic, separate crandall.tail runs on the grid point's own scene,
and formulas written out here (Phi, the power-law hazard integral).
"""

import importlib
import math

import numpy as np
import pytest
from scipy.special import ndtr

import crandall
from crandall import analytic
from crandall.errors import ParameterError
from crandall.model import SCALING, holds

F = importlib.import_module("crandall.fragility")  # the module (crandall.fragility is the function)
Z = 3.5
pytestmark = pytest.mark.filterwarnings("ignore:tail. relative error:crandall.results.StatisticsWarning")

MU, T0, G = 0.3, 2.0, 9.81
SCENE = crandall.Scene(mu=MU, h=1.0, t0=T0, times=[T0])


def stop_sf(h, mu, t, t0=T0):
    """P(t_s > t) from rest under one intensity h until t0: the closed form in scaled units
    (crandall.analytic.stop_time_sf), with the time scale 2 h^2 / (mu g)^2 of eq8."""
    scale = 2.0 * (h / (mu * G)) ** 2
    return float(analytic.stop_time_sf(t / scale, t0 / scale))


def test_stop_time_fragility_against_the_closed_form_from_1e_6_to_1e_1():
    hs = [0.8, 1.2, 2.0]
    exact = [stop_sf(h, MU, 2.5) for h in hs]
    assert 1e-7 < exact[0] < 1e-5 and exact[-1] > 0.05  # the span the check is meant to cover
    # The stop time is exact on any grid: a coarse one (50 steps) costs less.
    r = crandall.fragility(SCENE, "stop_time", [2.5], intensities=hs, seed=3, dt=T0 / 50,
                           threads=1, progress=False)
    assert r.probability.shape == (3, 1) and r.reliable.all()
    for j, p in enumerate(exact):
        assert abs(r.probability[j, 0] - p) <= Z * r.stderr[j, 0], (j, r.probability[j], p)
        assert r.low[j, 0] < r.probability[j, 0] < r.high[j, 0]


def test_fragility_agrees_with_separate_tail_runs():
    scene = crandall.Scene(mu=MU, h=1.0, t0=1.0, times=[1.0])
    hs, d = [1.0, 1.6], [0.6, 1.2]
    r = crandall.fragility(scene, "distance_at_stop", d, intensities=hs, seed=5, threads=1,
                           progress=False)
    for j, h in enumerate(hs):
        own = crandall.tail(crandall.Scene(mu=MU, h=h, t0=1.0, times=[1.0]), "distance_at_stop",
                            d, seed=100 + j, threads=1, progress=False)
        for k in range(len(d)):
            both = math.hypot(r.stderr[j, k], own.stderr[k])
            assert abs(r.probability[j, k] - own.probability[k]) <= Z * both, (j, k)
    assert 1e-7 < r.probability.min() and r.probability.max() < 0.5  # P from about 1e-5 to 0.2


def test_points_of_one_scaled_duration_share_a_run_that_agrees_with_separate_runs():
    # (h, mu) = (1, 0.3) and (2, 0.6): h / (mu g) is the same, so is tau0 = t0 (mu g)^2 / (2 h^2);
    # (1.5, 0.3) has another.
    points = [(1.0, 0.3), (2.0, 0.6), (1.5, 0.3)]
    scenes = [crandall.Scene(mu=m, h=h, t0=T0, times=[T0]) for h, m in points]
    thr = np.array([2.5, 3.0])
    runs = F.plan(SCENE, "stop_time", thr, scenes)
    assert [run.points for run in runs] == [[0, 1], [2]] and all(r.scaled for r in runs)
    args = dict(rel_error=0.1, seed=7, threads=1, progress=False, time=None, dt=T0 / 50,
                method="splitting", max_seconds=600.0)
    values = np.array([1.0, 2.0, 1.5])
    shared = F.run_grid(SCENE, "stop_time", thr, scenes, "intensity", values, share=True, **args)
    separate = F.run_grid(SCENE, "stop_time", thr, scenes, "intensity", values, share=False,
                          **{**args, "seed": 8})
    assert shared.shared and list(shared.run) == [0, 0, 1]
    assert not separate.shared and list(separate.run) == [0, 1, 2]
    for j, (h, m) in enumerate(points):
        for k, t in enumerate(thr):
            both = math.hypot(shared.stderr[j, k], separate.stderr[j, k])
            assert abs(shared.probability[j, k] - separate.probability[j, k]) <= Z * both
            assert abs(separate.probability[j, k] - stop_sf(h, m, t)) <= Z * separate.stderr[j, k]
            assert abs(shared.probability[j, k] - stop_sf(h, m, t)) <= Z * shared.stderr[j, k]
    # One scaled run: the stop time's scaled unit is the same at both points, so the two
    # points read the same levels of it.
    assert np.array_equal(shared.probability[0], shared.probability[1])


def test_the_identity_is_refused_for_an_envelope_a_start_in_motion_and_a_schedule():
    env = crandall.Scene(mu=MU, envelope=crandall.envelopes.amin_ang(1.0, 0.5, 1.0, 1.0, pieces=4),
                         times=[1.0])
    moving = crandall.Scene(mu=MU, h=1.0, t0=T0, v0=0.5, times=[T0])
    pieces = crandall.Scene(mu=MU, h=[1.0, 0.5], t0=[1.0, T0], times=[T0])
    assert holds(SCENE, SCALING)
    for scene in (env, moving, pieces):
        assert not holds(scene, SCALING)
        # Two points of one scaled duration (h and mu doubled): not shared.
        two = [F.point_scene(F.point_scene(scene, "intensity", 2 * F.scene_intensity(scene)),
                             "mu", 2 * MU), scene]
        runs = F.plan(scene, "stop_time", np.array([2.5]), two)
        assert [run.points for run in runs] == [[0], [1]] and not any(r.scaled for r in runs)
    # The envelope's scale is its h; the schedule's pieces scale together.
    assert F.point_scene(env, "intensity", 2.0).params["envelope"]["h"] == 2.0
    assert F.point_scene(pieces, "intensity", 2.0).params["h"] == [2.0, 1.0]


def synthetic(median, beta, xs, rel, seed, thresholds=(1.0,)):
    """A FragilityResult whose estimates are the lognormal curve times exp(rel * N(0, 1)),
    reported with relative error rel."""
    rng = np.random.default_rng(seed)
    p = ndtr(np.log(np.asarray(xs) / median) / beta)[:, None] * np.ones(len(thresholds))
    est = p * np.exp(rel * rng.standard_normal(p.shape))
    return F.FragilityResult(quantity="distance_at_stop", axis="intensity", values=xs,
                             thresholds=list(thresholds), probability=est, stderr=rel * est,
                             low=est * (1 - 2 * rel), high=est * (1 + 2 * rel),
                             reliable=np.ones(p.shape, bool), units="m")


def test_the_lognormal_fit_recovers_a_known_curve_within_its_uncertainty():
    xs = np.geomspace(0.4, 4.0, 9)
    for seed in (1, 2, 3):
        fit = synthetic(1.3, 0.45, xs, 0.05, seed).fit_lognormal()
        assert fit.points[0] == 9 and fit.dof[0] == 7
        assert abs(math.log(fit.median[0]) - math.log(1.3)) <= Z * math.sqrt(fit.covariance[0, 0, 0])
        assert abs(fit.beta[0] - 0.45) <= Z * fit.beta_stderr[0]
        assert fit.median_low[0] < fit.median[0] < fit.median_high[0]
        assert 0.05 < fit.chi2[0] / fit.dof[0] < 4.0
    exact = synthetic(1.3, 0.45, xs, 1e-9, 1).fit_lognormal()
    assert exact.median[0] == pytest.approx(1.3, rel=1e-6)
    assert exact.beta[0] == pytest.approx(0.45, rel=1e-6)
    # Over mu the curve falls: P = Phi(ln(median / mu) / beta).
    r = synthetic(1.3, 0.45, xs, 1e-9, 1)
    r.axis = "mu"
    r.probability = r.probability[::-1].copy()
    r.values = 1.3 ** 2 / xs[::-1]  # P(1.3^2 / x) = Phi(ln(x / 1.3) / beta)
    r.stderr = 1e-9 * r.probability
    fall = r.fit_lognormal()
    assert fall.median[0] == pytest.approx(1.3, rel=1e-6)
    assert fall.beta[0] == pytest.approx(0.45, rel=1e-6)


def test_a_curve_that_falls_where_it_should_rise_leaves_the_fit_nan_with_a_warning():
    # Over intensity P must rise; estimates that fall send the median off beyond doubles.
    xs = np.geomspace(0.4, 4.0, 9)
    r = synthetic(1.3, 0.45, xs, 1e-9, 1)
    r.probability = r.probability[::-1].copy()
    r.stderr = 1e-9 * r.probability
    with pytest.warns(crandall.StatisticsWarning, match="no lognormal curve fits"):
        fit = r.fit_lognormal()
    assert np.isnan(fit.median[0]) and np.isnan(fit.beta[0])


def test_the_hazard_of_a_lognormal_curve_under_a_power_law():
    # lambda(x) = k0 x^-k and P = Phi(ln(x / m) / beta): int P |d lambda| = k0 m^-k exp(k^2 beta^2 / 2).
    k0, k, m, beta = 1e-3, 2.5, 1.3, 0.45
    exact = k0 * m ** -k * math.exp(k * k * beta * beta / 2)
    im = np.geomspace(1e-3, 1e3, 7)
    curve = (im, k0 * im ** -k)
    xs = np.geomspace(0.4, 4.0, 9)
    clean = synthetic(m, beta, xs, 1e-9, 1).hazard(curve)
    assert clean.rate[0] == pytest.approx(exact, rel=1e-4)
    for seed in (1, 2, 3):
        hz = synthetic(m, beta, xs, 0.05, seed).hazard(curve)
        assert abs(hz.rate[0] - exact) <= Z * hz.stderr[0], (hz.rate, hz.stderr, exact)
        assert hz.low[0] < hz.rate[0] < hz.high[0]


def test_the_hazard_from_the_grid_estimates_of_a_power_law_curve():
    # P(x) = (x / 4)^3 on [0.2, 4] (linear in (ln x, ln P), as the estimates are interpolated)
    # and lambda(x) = k0 x^-2: int_0.2^4 P |d lambda| + lambda(4) P(4)
    #   = 2 k0 4^-3 (4 - 0.2) + k0 / 16.
    k0, top = 1e-3, 4.0
    exact = 2 * k0 * top ** -3 * (top - 0.2) + k0 * top ** -2
    xs = np.geomspace(0.2, top, 9)
    im = np.geomspace(0.2, top, 5)
    curve = (im, k0 * im ** -2.0)
    rng = np.random.default_rng(4)
    for rel in (1e-9, 0.05, 0.05, 0.05):
        p = (xs / top) ** 3 * np.exp(rel * rng.standard_normal(xs.size))
        r = F.FragilityResult(quantity="distance_at_stop", axis="intensity", values=xs,
                              thresholds=[1.0], probability=p[:, None], stderr=rel * p[:, None],
                              low=p[:, None], high=p[:, None], reliable=np.ones((9, 1), bool))
        hz = r.hazard(curve, use="estimates")
        if rel < 1e-6:
            assert hz.rate[0] == pytest.approx(exact, rel=1e-5) and hz.outside[0] < 1e-12
        else:
            assert abs(hz.rate[0] - exact) <= Z * hz.stderr[0], (hz.rate, hz.stderr, exact)
    # A hazard curve wider than the grid: the part above is counted with P at the grid's end,
    # the part below left out; `outside` is the most they could add.
    wide = (np.geomspace(0.1, 8.0, 6), k0 * np.geomspace(0.1, 8.0, 6) ** -2.0)
    r.probability[:] = ((xs / top) ** 3 * 0.5)[:, None]
    hz = r.hazard(wide, use="estimates")
    inside = 0.5 * (2 * k0 * top ** -3 * (top - 0.2) + k0 * top ** -2)
    assert hz.rate[0] == pytest.approx(inside, rel=1e-5)
    most = 0.5 * k0 * top ** -2 + 0.5 * (0.2 / top) ** 3 * (k0 * 0.1 ** -2 - k0 * 0.2 ** -2)
    assert hz.outside[0] == pytest.approx(most, rel=1e-6)


def test_refusals_name_the_parameter():
    cases = [
        (dict(thresholds=[]), "thresholds"),
        (dict(thresholds=[-1.0, 1.0]), "thresholds"),
        (dict(thresholds=[2.0, 1.0]), "thresholds"),
        (dict(intensities=None), "intensities, mu"),
        (dict(mu=[0.2, 0.1]), "mu"),
        (dict(intensities=[]), "intensities"),
        (dict(intensities=[0.0, 1.0]), "intensities"),
        (dict(quantity="kinetic_energy"), "quantity"),
        (dict(quantity="nonesuch"), "quantity"),
        (dict(scene=crandall.Scene.scaled(tau0=5, times=[5])), "scene"),
    ]
    for change, name in cases:
        args = dict(scene=SCENE, quantity="stop_time", thresholds=[2.5], intensities=[1.0])
        args.update(change)
        with pytest.raises(ParameterError) as info:
            crandall.fragility(**args)
        assert info.value.name == name, (change, info.value)
    r = synthetic(1.0, 0.5, [0.5, 1.0, 2.0], 0.05, 1)
    for curve in ([1.0], ([1.0, 2.0], [1e-3, 1e-2]), ([1.0, 2.0], [1e-3])):
        with pytest.raises(ParameterError) as info:
            r.hazard(curve)
        assert info.value.name == "curve"
    with pytest.raises(ParameterError) as info:
        r.hazard(([1.0, 2.0], [1e-2, 1e-3]), use="grid")
    assert info.value.name == "use"


def test_files_table_and_figure(tmp_path):
    pytest.importorskip("xarray")
    r = synthetic(1.0, 0.5, [0.5, 1.0, 2.0], 0.05, 1, thresholds=(0.1, 0.2))
    r.reliable[0, 1] = False
    path = tmp_path / "fragility.nc"
    r.save(path)
    back = crandall.FragilityResult.load(path)
    for name in ("values", "thresholds", "probability", "stderr", "low", "high", "reliable", "run"):
        assert np.array_equal(getattr(back, name), getattr(r, name)), name
    assert (back.quantity, back.axis, back.units) == (r.quantity, r.axis, r.units)
    assert "UNRELIABLE" in str(r) and "unreliable" in r._repr_html_()
    pytest.importorskip("matplotlib")
    import matplotlib
    matplotlib.use("Agg")
    from crandall import plots
    curve = (np.geomspace(0.1, 10, 5), 1e-2 * np.geomspace(0.1, 10, 5) ** -2.0)
    for use in ("fit", "estimates"):
        fig = plots.fragility(r, hazard=curve, use=use)
        assert len(fig.axes) == 2


def test_reproducible_and_on_the_command_line(capsys):
    args = dict(intensities=[2.0], seed=11, dt=T0 / 50, threads=1, progress=False)
    one = crandall.fragility(SCENE, "stop_time", [2.5], **args)
    two = crandall.fragility(SCENE, "stop_time", [2.5], **args)
    assert np.array_equal(one.probability, two.probability)
    from crandall import cli
    # The crate: mu = 0.3, h = 1 for 2 s; its stop after 2.5 s at h = 1.5 and 2 (P about 0.02
    # and 0.1), on a coarse grid (the stop time is exact on any).
    code = cli.main(["fragility", "crate", "--quantity", "stop_time", "--thresholds", "2.5",
                     "--intensities", "1.5,2", "--seed", "1", "--threads", "1", "--dt", "0.04",
                     "--no-progress"])
    out = capsys.readouterr()
    assert code == 0, out.err
    assert "probability" in out.out and "lognormal" in out.out
    assert "crate: [run] paths = 200000, seed = 7 not used" in out.err  # crandall run's
    assert cli.main(["fragility", "crate", "--quantity", "stop_time", "--thresholds", "2.5"]) == 2
    assert "intensities, mu" in capsys.readouterr().err


def test_a_grid_over_intensity_and_mu_shares_the_runs_of_one_scaled_duration():
    # (h, mu) = (1.5, 0.3) and (2, 0.4) have one h / mu, so one tau0 = t0 (mu g)^2 / (2 h^2):
    # one scaled run; (1.5, 0.4) and (2, 0.3) one each. P from 2e-5 to 0.11.
    hs, ms, thr = [1.5, 2.0], [0.3, 0.4], [2.5, 2.8]
    args = dict(intensities=hs, mu=ms, dt=T0 / 50, threads=1, progress=False)
    r = crandall.fragility(SCENE, "stop_time", thr, seed=7, **args)
    assert (r.axis, r.by) == ("intensity", "mu") and r.probability.shape == (2, 2, 2)
    assert r.runs == 3 and r.shared and r.run[0, 0] == r.run[1, 1]
    assert "3 tail runs for 4 points" in str(r)
    # The stop time's scaled unit 2 h^2 / (mu g)^2 is the same at both points: one run, one
    # level per threshold, the same numbers.
    assert np.array_equal(r.probability[0, 0], r.probability[1, 1])
    separate = crandall.fragility(SCENE, "stop_time", thr, seed=8, share=False, **args)
    assert separate.runs == 4 and not separate.shared
    for i, h in enumerate(hs):
        for j, m in enumerate(ms):
            for k, t in enumerate(thr):
                exact = stop_sf(h, m, t)
                assert abs(r.probability[i, j, k] - exact) <= Z * r.stderr[i, j, k], (h, m, t)
                both = math.hypot(r.stderr[i, j, k], separate.stderr[i, j, k])
                assert abs(r.probability[i, j, k] - separate.probability[i, j, k]) <= Z * both
    # A section is the curve over h at one mu, its scene's mu set; the fits are one per mu.
    sec = r.section(1)
    assert sec.by is None and sec.scene["mu"] == 0.4
    assert np.array_equal(sec.probability, r.probability[:, 1])
    fits = r.fit_lognormal()
    assert len(fits) == 2 and fits[1].median[0] == sec.fit_lognormal().median[0]
    curve = (np.geomspace(0.5, 5, 4), 1e-2 * np.geomspace(0.5, 5, 4) ** -3.0)
    assert [h.rate[0] for h in r.hazard(curve)] == [s.hazard(curve).rate[0] for s in r.sections()]


def test_two_axis_files_table_and_figure(tmp_path):
    pytest.importorskip("xarray")
    a, b = synthetic(1.0, 0.5, [0.5, 1.0, 2.0], 0.05, 1), synthetic(1.4, 0.5, [0.5, 1.0, 2.0], 0.05, 2)
    stack = {n: np.stack([getattr(a, n), getattr(b, n)], axis=1)
             for n in ("probability", "stderr", "low", "high", "reliable")}
    r = F.FragilityResult(quantity="distance_at_stop", axis="intensity", values=a.values,
                          thresholds=[1.0], by="mu", by_values=[0.3, 0.4], units="m",
                          run=[[0, 1], [2, 0], [3, 4]], **stack)
    assert r.runs == 5 and r.section(0).fit_lognormal().median[0] == a.fit_lognormal().median[0]
    r.save(tmp_path / "two.nc")
    back = crandall.FragilityResult.load(tmp_path / "two.nc")
    for name in ("values", "by_values", "thresholds", "probability", "stderr", "low", "high",
                 "reliable", "run"):
        assert np.array_equal(getattr(back, name), getattr(r, name)), name
    assert back.by == "mu" and "mu = 0.4" in r._repr_html_() and len(str(r).splitlines()) == 8
    pytest.importorskip("matplotlib")
    from crandall import plots
    curve = (np.geomspace(0.1, 10, 5), 1e-2 * np.geomspace(0.1, 10, 5) ** -2.0)
    fig = plots.fragility(r, hazard=curve)
    assert len(fig.axes) == 2 and len(fig.axes[1].lines) >= 2


def test_the_hazard_on_the_command_line(tmp_path, capsys):
    # A power-law curve lambda(h) = 1e-2 (h / 0.5)^-3 per year in a CSV with a header and a
    # comment; the printed rate and the CSV written equal FragilityResult.hazard's.
    h = np.geomspace(0.5, 20.0, 12).tolist()
    path = tmp_path / "hazard.csv"
    path.write_text("# illustrative\nh,rate\n" + "".join(f"{x},{1e-2 * (x / 0.5) ** -3.0}\n"
                                                         for x in h))
    saved, rates = tmp_path / "f.nc", tmp_path / "rates.csv"
    from crandall import cli
    base = ["fragility", "crate", "--quantity", "stop_time", "--thresholds", "2.5,2.8",
            "--intensities", "1.5,2", "--seed", "1", "--threads", "1", "--dt", "0.04",
            "--no-progress"]
    assert cli.main(base + ["--hazard", str(path), "--hazard-save", str(rates),
                            "--save", str(saved)]) == 0, capsys.readouterr().err
    out = capsys.readouterr().out
    assert "annual rate of exceedance (the lognormal fit)" in out
    r = crandall.FragilityResult.load(saved)
    hz = r.hazard(F.read_hazard_curve(path))
    table = np.loadtxt(rates, delimiter=",", skiprows=2, ndmin=2)
    assert np.array_equal(table[:, 0], r.thresholds) and np.array_equal(table[:, 1], hz.rate)
    assert np.array_equal(table[:, 3:5], np.stack([hz.low, hz.high], axis=1))
    assert (hz.low < hz.rate).all() and (hz.rate < hz.high).all()
    # Over both axes: a block per mu.
    assert cli.main(base + ["--mu", "0.3,0.4", "--hazard", str(path),
                            "--hazard-use", "estimates"]) == 0
    out = capsys.readouterr().out
    assert "mu = 0.3:" in out and "mu = 0.4:" in out and "the grid estimates" in out
    # Refusals name what is wrong.
    bad = tmp_path / "bad.csv"
    for text in ("h,rate\n1,1e-2\n2,x\n", "1,1e-3\n2,1e-2\n", "1,2,3\n"):
        bad.write_text(text)
        with pytest.raises(ParameterError) as info:
            F.read_hazard_curve(bad)
        assert info.value.name == "hazard"
        assert cli.main(base + ["--hazard", str(bad)]) == 2
        assert "hazard" in capsys.readouterr().err
    assert cli.main(base[:6] + ["--mu", "0.3", "--hazard", str(path)]) == 2
    assert "--intensities" in capsys.readouterr().err
