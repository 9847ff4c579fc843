"""Figures: each one is produced, holds the right data, and is not blank."""

import math

import numpy as np
import pytest

import crandall
from crandall import analytic

pytest.importorskip("matplotlib")
from crandall import plots  # noqa: E402
from matplotlib.image import imread  # noqa: E402


@pytest.fixture(scope="module")
def result():
    # 20 000 paths: at tau = 3, a scaled time after the switch-off, about 70 carry the
    # velocity's spread (Result.carriers; 4000 gave 10, fewer than MIN_CARRIERS, and no error
    # bar there: tests/test_few_paths.py draws such points).
    scene = crandall.Scene.scaled(tau0=2.0, times=[0.25, 0.5, 1.0, 2.0, 2.5, 3.0])
    return crandall.simulate(scene, paths=20_000, seed=9, dt=0.05)


def not_blank(path):
    img = imread(path)
    assert img.shape[0] > 200 and img.shape[1] > 300
    ink = (img[..., :3] < 0.9).any(axis=-1).mean()
    assert ink > 0.02, f"{path}: only {ink:.3%} of the pixels are drawn"
    return True


def test_write_figures_writes_every_figure(result, tmp_path):
    written = plots.write_figures(result, tmp_path / "figs", paths=2000)
    names = sorted(p.rsplit("/", 1)[-1] for p in written)
    assert names == sorted(["fig2_distance_mean.png", "fig3_velocity_var.png",
                            "fig4_displacement_var.png", "fig5_distance_var.png",
                            "velocity_density.png", "stop_time_density.png"])
    for path in written:
        assert not_blank(path)


def test_a_figure_that_cannot_be_written_names_its_file(result, tmp_path, monkeypatch):
    """A full disk while a figure is written: the error names the figure's file (matplotlib's
    write error named none), and no torn or temporary file is left."""
    import errno
    import os

    from matplotlib.backends.backend_agg import FigureCanvasAgg

    def no_space(self, f, *args, **kwargs):
        f.write(b"\x89PNG partial")
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    monkeypatch.setattr(FigureCanvasAgg, "print_png", no_space)
    with pytest.raises(OSError, match="No space left") as info:
        plots.write_figures(result, tmp_path, paths=2000)
    path = str(info.value.filename)
    assert os.path.dirname(path) == str(tmp_path) and path.endswith(".png")
    assert path in str(info.value)
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("func, name, kind, ref", [
    (plots.distance_mean, "distance", "mean", analytic.distance_mean),
    (plots.velocity_var, "velocity", "var", analytic.velocity_var),
    (plots.displacement_var, "displacement", "var", analytic.displacement_var),
    (plots.distance_var, "distance", "var", analytic.distance_var),
])
def test_moment_figures_show_the_curve_and_the_points(result, func, name, kind, ref):
    fig = func(result)
    ax = fig.axes[0]
    curve = ax.get_lines()[0]
    x, y = curve.get_data()
    np.testing.assert_allclose(y, ref(x, 2.0), rtol=1e-12)
    assert x.max() >= 3.0  # every curve goes on past the switch-off (tau0 = 2)
    # The simulated points: the result's statistics at its times.
    points = [c for c in ax.containers if hasattr(c, "lines")][0]
    px, py = points.lines[0].get_data()
    np.testing.assert_array_equal(px, result.times)
    sim = result.mean(name) if kind == "mean" else result.var(name)
    np.testing.assert_array_equal(py, sim)


def test_physical_scene_is_drawn_in_its_units_or_scaled(tmp_path):
    scene = crandall.Scene(mu=0.3, h=1.0, t0=2.0, times=[0.5, 1.0, 2.0, 3.0])
    r = crandall.simulate(scene, paths=2000, seed=1, dt=0.01)
    s = scene.scaling
    # Its own units (default): seconds and metres, the analytic curve converted, and a residual
    # panel of z = (simulated - analytic) / stderr.
    fig = plots.distance_mean(r)
    ax, rax = fig.axes
    px, py = [c for c in ax.containers if hasattr(c, "lines")][0].lines[0].get_data()
    np.testing.assert_array_equal(px, scene.times)
    np.testing.assert_array_equal(py, r.mean("distance"))
    x, y = ax.get_lines()[0].get_data()
    np.testing.assert_allclose(y, analytic.distance_mean(s.to_tau(x), s.to_tau(2.0))
                               * s.length_scale, rtol=1e-12)
    zx, z = [ln for ln in rax.get_lines() if ln.get_marker() == "o"][0].get_data()
    ref = analytic.distance_mean(s.to_tau(scene.times), s.to_tau(2.0)) * s.length_scale
    np.testing.assert_allclose(z, (r.mean("distance") - ref) / r.stderr("distance"), rtol=1e-9)
    assert ax.get_title() == "Mean distance" and "(s)" in rax.get_xlabel()
    assert ax.get_ylabel() == "mean distance (m)"
    # The paper's scaled units on request.
    ax = plots.distance_mean(r, units="scaled").axes[0]
    px, py = [c for c in ax.containers if hasattr(c, "lines")][0].lines[0].get_data()
    np.testing.assert_allclose(px, scene.times / s.time_scale, rtol=1e-14)
    np.testing.assert_allclose(py, r.mean("distance") / s.length_scale, rtol=1e-14)
    with pytest.raises(ValueError, match="units must be one of"):
        plots.distance_mean(r, units="imperial")


def test_scenes_without_closed_forms_are_drawn_without_them(tmp_path):
    # A piecewise scene: the simulated points, the intensity strip above, no analytic curve or
    # residual panel; written in each format at the asked resolution.
    sc = crandall.Scene(mu=0.3, h=[1.0, 0.0, 0.6], t0=[1.0, 1.5, 2.5], times=[0.5, 1.0, 2.0, 3.0],
                        distributions=["distance_at_stop"])
    r = crandall.simulate(sc, paths=2000, seed=1)
    fig = plots.distance_mean(r)
    strip, ax = fig.axes
    assert "no closed form" in ax.get_title()
    xs, ys = strip.get_lines()[0].get_data()
    assert max(ys) == 1.0 and 0.0 in ys
    # At t = 3, 0.5 s after the noise, every one of the 2000 paths is at rest: the velocity's
    # variance there is drawn hollow, without an error bar (tests/test_few_paths.py).
    figs = plots.figures(r)
    hollow = [ln for ln in figs["fig3_velocity_var"].axes[1].get_lines()
              if ln.get_markerfacecolor() == "none"]
    assert [list(ln.get_xdata()) for ln in hollow] == [[3.0]]
    assert "velocity_density" not in figs and "distance_at_stop_distribution" in figs
    for fmt in plots.FORMATS:
        written = plots.write_figures(r, tmp_path / fmt, format=fmt, dpi=80)
        assert written and all(p.endswith("." + fmt) for p in written)
    with pytest.raises(ValueError, match="format must be one of"):
        plots.write_figures(r, tmp_path / "x", format="gif")
    with pytest.raises(ValueError, match="dpi must be"):
        plots.write_figures(r, tmp_path / "x", dpi=5)


def test_an_envelope_scene_draws_the_envelope_over_its_pieces():
    from crandall import envelopes
    env = envelopes.amin_ang(0.6, t1=2.0, t2=8.0, c=0.4, end=14.0, pieces=8)
    sc = crandall.Scene(mu=0.35, envelope=env, times=[1.0, 5.0, 10.0],
                        observe=["velocity", "distance", "stop"])
    r = crandall.simulate(sc, paths=500, seed=1)
    strip, _ = plots.distance_mean(r).axes
    pieces, smooth = strip.get_lines()
    # The pieces the run used (it refines the 8 given: crandall.pieces).
    assert smooth.get_label() == f"envelope (amin_ang, {r.scene.envelope.pieces} pieces)"
    assert r.scene.envelope.pieces > 8
    xs, ys = smooth.get_data()
    # The envelope itself: the build-up (t / t1) h at t = 1 s is 0.3, the strong phase 0.6.
    assert np.interp(1.0, xs, ys) == pytest.approx(0.3, rel=1e-2) and max(ys) == pytest.approx(0.6)
    assert max(pieces.get_data()[1]) == pytest.approx(0.6)


def test_velocity_density_matches_the_analytic_density():
    fig = plots.velocity_density([0.5, 3.0], paths=100_000, seed=4)
    assert len(fig.axes) == 2
    for ax, tau in zip(fig.axes, (0.5, 3.0)):
        x, y = ax.get_lines()[0].get_data()
        np.testing.assert_allclose(y, analytic.velocity_pdf(x, tau), rtol=1e-12)
        # The histogram (one filled polygon) reaches the analytic peak within sampling error.
        poly = ax.patches[0].get_xy()
        peak = poly[:, 1].max()
        assert abs(peak - analytic.velocity_pdf(0.0, tau)) < 0.15 * analytic.velocity_pdf(0.0, tau)


def test_stop_time_density_histogram_has_the_analytic_mean(tmp_path):
    fig = plots.stop_time_density(1.0, paths=50_000, seed=2)
    ax = fig.axes[0]
    x, y = ax.get_lines()[0].get_data()
    np.testing.assert_allclose(y, analytic.stop_time_pdf(x, 1.0), rtol=1e-12)
    # The histogram integrates to about 1 over the window (mean + 5 sd holds nearly all mass).
    poly = ax.patches[0].get_xy()
    xs, ys = poly[:, 0], poly[:, 1]
    area = np.sum(np.diff(xs) * ys[:-1])
    assert 0.97 < area < 1.01
    fig.savefig(tmp_path / "stop.png")
    assert not_blank(tmp_path / "stop.png")


@pytest.mark.parametrize("call, word", [
    (lambda: plots.velocity_density([0.0]), "times"),
    (lambda: plots.velocity_density("abc"), "times"),
    (lambda: plots.velocity_density([1.0], paths=10), "paths"),
    (lambda: plots.stop_time_density(math.inf), "tau0"),
    (lambda: plots.stop_time_density(1.0, seed=-1), "seed"),
    (lambda: plots.distance_mean("result"), "result"),
])
def test_bad_input(call, word):
    with pytest.raises(ValueError, match=word):
        call()


def test_unobserved_quantity_and_unscalable_scene():
    r = crandall.simulate(crandall.Scene.scaled(tau0=1.0, times=[1.0], observe="velocity"),
                          paths=100, seed=1)
    with pytest.raises(ValueError, match="distance"):
        plots.distance_mean(r)
    assert sorted(plots.figures(r, paths=200)) == ["fig3_velocity_var", "velocity_density"]
    free = crandall.simulate(crandall.Scene(mu=0.0, h=1.0, t0=1.0, times=[1.0]), paths=100, seed=1)
    # A frictionless scene has no scaled units: drawn in its own, without closed forms.
    figs = plots.figures(free)
    assert "no closed form" in figs["fig3_velocity_var"].axes[0].get_title()
    with pytest.raises(ValueError, match="mu > 0"):
        plots.figures(free, units="scaled")


def test_density_panels_show_where_the_mass_is():
    # 1e6 paths in a narrow bulk and one path far out: the panel spans the bulk's bins.
    counts = np.zeros(200, dtype=np.uint64)
    counts[90:110] = 50_000
    counts[199] = 1
    lo, hi = plots._shown_range(counts)
    assert (lo, hi) == (90, 110)
    assert plots._shown_range(np.zeros(5)) == (0, 5)
    single = np.zeros(10)
    single[7] = 3
    assert plots._shown_range(single) == (7, 8)


def test_figures_need_matplotlib_alone(tmp_path, monkeypatch):
    # pip install 'crandall[plots]' brings matplotlib, not boost-histogram (the hist extra):
    # the distributions' figures are drawn from the run's counts all the same.
    scene = crandall.Scene.scaled(tau0=1.0, times=[0.5, 2.0],
                                  distributions=["velocity", "distance_at_stop"])
    r = crandall.simulate(scene, paths=3000, seed=2)
    monkeypatch.setitem(__import__("sys").modules, "boost_histogram", None)
    with pytest.raises(ImportError, match="boost-histogram"):
        r.histogram("velocity", 0.5)
    written = plots.write_figures(r, tmp_path, paths=2000)
    names = [p.rsplit("/", 1)[-1] for p in written]
    assert "velocity_density.png" in names and "distance_at_stop_distribution.png" in names
    for path in written:
        assert not_blank(path)
    edges, counts, label = r.histogram_counts("distance_at_stop")
    assert counts.size == edges.size + 1 and counts.sum() == 3000
    assert label == "distance_at_stop"


def test_an_si_scene_draws_its_densities_in_seconds_and_metres():
    scene = crandall.Scene(mu=0.3, h=1.0, t0=2.0, times=[0.5, 1.0, 2.0, 3.0])
    r = crandall.simulate(scene, paths=2000, seed=1, dt=0.01)
    s = scene.scaling
    shown = plots.figures(r, paths=2000)
    axes = shown["velocity_density"].axes
    assert [ax.get_title() for ax in axes] == [f"t = {t:.4g} s" for t in (0.5, 1.0, 2.0)]
    assert all(ax.get_xlabel() == "velocity [m/s]" for ax in axes)
    # The analytic curve converted: f(y, tau) / v_scale at v = y v_scale.
    x, y = axes[0].get_lines()[0].get_data()
    tau = s.to_tau(0.5)
    np.testing.assert_allclose(y, analytic.velocity_pdf(x / s.velocity_scale, tau)
                               / s.velocity_scale, rtol=1e-12)
    ax = shown["stop_time_density"].axes[0]
    assert ax.get_xlabel() == "stop time [s]" and "t0 = 2 s" in ax.get_title()
    x, y = ax.get_lines()[0].get_data()
    assert x[0] == pytest.approx(2.0, rel=1e-12)
    # A density in 1/s: it integrates to 1 over seconds (the curve reaches 5 sd past the mean).
    assert np.trapezoid(y, x) == pytest.approx(1.0, abs=0.02)
    # Scaled units on request, as before.
    scaled = plots.figures(r, paths=2000, units="scaled")
    assert scaled["velocity_density"].axes[0].get_title().startswith(r"$\tau$ = ")
