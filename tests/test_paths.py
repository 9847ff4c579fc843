"""crandall.paths: a few sample paths to look at, and plots.paths to draw them."""

from __future__ import annotations

import math

import numpy as np
import pytest

import crandall
from crandall import analytic

xr = pytest.importorskip("xarray")


def test_paths_are_the_seeds_whatever_the_threads():
    scene = crandall.Scene(mu=0.3, h=1.0, t0=2.0, times=[1.0, 3.0])
    a = crandall.paths(scene, 4, seed=3, threads=1)
    b = crandall.paths(scene, 4, seed=3, threads=2)
    assert a.equals(b) and a.attrs["seed"] == "3"
    assert a["velocity"].dims == ("path", "time") and a["velocity"].attrs["units"] == "m/s"
    assert a["time"].values[0] == 0.0 and a["time"].values[-1] >= a["stop_time"].max()
    assert not a.equals(crandall.paths(scene, 4, seed=4))
    drawn = crandall.paths(scene, 2)
    assert int(drawn.attrs["seed"]) >= 0
    # The body is at rest after its stop, and starts at rest.
    t = a["time"].values
    for i in range(4):
        after = t > a["stop_time"].values[i]
        assert (a["velocity"].values[i, after] == 0).all()
    assert (a["velocity"].values[:, 0] == 0).all()


def test_a_start_in_motion_without_noise_is_the_closed_form_coast():
    c = 0.3 * 9.81
    scene = crandall.Scene(mu=0.3, h=[0.0], t0=[2.0], v0=1.5, u0=0.2, times=[1.0])
    ds = crandall.paths(scene, 3, seed=1, times=[0.0, 0.1, 0.3, 1.0])
    t = np.array([0.0, 0.1, 0.3, 1.0])
    moving = np.minimum(t, 1.5 / c)
    np.testing.assert_allclose(ds["velocity"].values, np.broadcast_to(
        np.maximum(1.5 - c * t, 0.0), (3, 4)), rtol=1e-14, atol=1e-15)
    np.testing.assert_allclose(ds["distance"].values, np.broadcast_to(
        1.5 * moving - c * moving ** 2 / 2, (3, 4)), rtol=1e-14, atol=1e-15)
    np.testing.assert_allclose(ds["displacement"].values[:, -1], 0.2 + 1.5 ** 2 / (2 * c),
                               rtol=1e-14)
    np.testing.assert_allclose(ds["stop_time"].values, 1.5 / c, rtol=1e-14)


def test_the_paths_have_the_law_of_the_scene():
    # Scaled units, tau0 = 1: Var U1(1) and the mean stop time 1 + E|U1(1)|/2 in closed form.
    n = 20_000
    ds = crandall.paths(crandall.Scene.scaled(tau0=1.0, times=[1.0]), n, seed=5,
                        times=[0.5, 1.0], dt=0.25)
    v = ds["velocity"].values[:, 1]
    var = float(analytic.velocity_var(1.0))
    # The sample variance's standard error: sqrt((m4 - var^2) / n), m4 from the sample; 4 sd.
    se = math.sqrt((np.mean((v - v.mean()) ** 4) - v.var() ** 2) / n)
    assert abs(v.var(ddof=1) - var) < 4 * se
    stops = ds["stop_time"].values
    mean = float(analytic.stop_time_mean(1.0))
    assert abs(stops.mean() - mean) < 4 * stops.std() / math.sqrt(n)


def test_bad_input_names_the_parameter():
    scene = crandall.Scene.scaled(tau0=1.0, times=[1.0])
    for kwargs, name in [({"n": 0}, "n"), ({"n": 2.5}, "n"), ({"n": 2, "seed": -1}, "seed"),
                         ({"n": 2, "times": [1.0, 0.5]}, "times"),
                         ({"n": 2, "times": "0 1"}, "times"), ({"n": 2, "dt": 0.0}, "dt"),
                         ({"n": 2, "points": 1}, "points")]:
        with pytest.raises(crandall.errors.ParameterError) as info:
            crandall.paths(scene, **kwargs)
        assert info.value.name == name, kwargs
    with pytest.raises(crandall.errors.ParameterError, match="scene"):
        crandall.paths("crate", 2)


def test_plots_draw_the_paths_with_the_pieces_above(tmp_path):
    pytest.importorskip("matplotlib")
    from crandall import plots
    scene = crandall.Scene(mu=0.3, h=[1.0, 0.0, 0.5], t0=[1.0, 3.0, 4.0], times=[1.0])
    fig = plots.paths(crandall.paths(scene, 5, seed=2))
    assert len(fig.axes) == 4  # the pieces, velocity, displacement, distance
    assert sum(len(ax.get_lines()) for ax in fig.axes[1:]) >= 3 * 5
    fig.savefig(tmp_path / "paths.png")
    with pytest.raises(ValueError, match="crandall.paths"):
        plots.paths(xr.Dataset())


@pytest.mark.parametrize("name", sorted(crandall.Scene.shipped()))
def test_every_shipped_scene_gives_paths(name):
    scene = crandall.Scene.from_toml(name)
    ds = crandall.paths(scene, 3, seed=1, points=100)
    for var in ("velocity", "displacement", "distance"):
        assert np.isfinite(ds[var].values).all(), var
    assert (np.diff(ds["distance"].values, axis=1) >= -1e-12).all()  # the distance only grows
    if "stop" in scene.observe:
        assert (ds["stop_time"].values >= scene.t0).all()
