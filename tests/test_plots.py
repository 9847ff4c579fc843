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
    scene = crandall.Scene.scaled(tau0=2.0, times=[0.25, 0.5, 1.0, 2.0, 2.5, 3.0])
    return crandall.simulate(scene, paths=4000, seed=9, dt=0.05)


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


def test_physical_scene_is_drawn_in_scaled_units(tmp_path):
    scene = crandall.Scene(mu=0.3, h=1.0, t0=2.0, times=[0.5, 1.0, 2.0, 3.0])
    r = crandall.simulate(scene, paths=2000, seed=1, dt=0.01)
    ax = plots.distance_mean(r).axes[0]
    px, py = [c for c in ax.containers if hasattr(c, "lines")][0].lines[0].get_data()
    s = scene.scaling
    np.testing.assert_allclose(px, scene.times / s.time_scale, rtol=1e-14)
    np.testing.assert_allclose(py, r.mean("distance") / s.length_scale, rtol=1e-14)
    assert "scaled units" in ax.get_title()


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
    with pytest.raises(ValueError, match="mu > 0"):
        plots.figures(free)
