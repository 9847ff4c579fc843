"""Results that keep: xarray, pandas, netCDF save/load (exact)."""

import json
import math

import numpy as np
import pytest

import crandall
from conftest import same_result

xr = pytest.importorskip("xarray")
pd = pytest.importorskip("pandas")


@pytest.fixture(scope="module")
def physical_result():
    scene = crandall.Scene(mu=0.3, h=1.0, t0=2.0, mass=100.0, times=[0.5, 1.0, 2.0, 3.0])
    return crandall.simulate(scene, paths=5000, seed=3, dt=0.05)


@pytest.fixture(scope="module")
def scaled_result():
    scene = crandall.Scene.scaled(tau0=1.0, times=[0.5, 1.0, 2.0])
    return crandall.simulate(scene, paths=3000, seed=(1 << 64) - 1, dt=0.05)


def test_xarray_layout_units_and_scene(physical_result):
    r = physical_result
    ds = r.to_xarray()
    stats = ds["statistics"]
    assert stats.dims == ("time", "observable", "statistic")
    assert list(ds["observable"].values) == [n for n in r.names if not n.endswith("stop_time")
                                             and "_at_stop" not in n]
    assert list(ds["statistic"].values) == ["mean", "var", "std", "stderr", "var_stderr"]
    np.testing.assert_array_equal(ds["time"].values, [0.5, 1.0, 2.0, 3.0])
    assert ds["time"].attrs["units"] == "s"
    units = dict(zip(ds["observable"].values, ds["units"].values))
    assert units == {"velocity": "m/s", "displacement": "m", "distance": "m",
                     "kinetic_energy": "J", "dissipated_energy": "J"}
    for name in ("velocity", "distance", "dissipated_energy"):
        cell = stats.sel(observable=name)
        np.testing.assert_array_equal(cell.sel(statistic="mean").values, r.mean(name))
        np.testing.assert_array_equal(cell.sel(statistic="var").values, r.var(name))
        np.testing.assert_array_equal(cell.sel(statistic="stderr").values, r.stderr(name))
        np.testing.assert_array_equal(cell.sel(statistic="var_stderr").values, r.var_stderr(name))
    assert np.isnan(stats.sel(observable="kinetic_energy", statistic="var_stderr")).all()
    stop = ds["stop_statistics"]
    assert stop.sel(stop_quantity="stop_time", statistic="mean") == r.mean("stop_time")
    assert json.loads(ds.attrs["scene"]) == r.scene.to_dict()
    assert ds.attrs["scene_mu"] == 0.3 and ds.attrs["scene_mass"] == 100.0
    assert ds.attrs["seed"] == "3" and ds.attrs["paths"] == 5000
    assert ds.attrs["method"] == crandall.methods.DEFAULT_METHOD and ds.attrs["dt"] == 0.05


def test_scaled_units_are_dimensionless(scaled_result):
    ds = scaled_result.to_xarray()
    assert set(ds["units"].values) == {"1"}
    assert ds["time"].attrs["long_name"] == "scaled time tau"


@pytest.mark.parametrize("which", ["physical_result", "scaled_result"])
def test_save_load_is_exact(tmp_path, request, which):
    r = request.getfixturevalue(which)
    path = tmp_path / "result.nc"
    r.save(path)
    back = crandall.load(path)
    assert same_result(r, back)
    assert back.seed == r.seed and back.paths == r.paths and back.dt == r.dt
    assert back.method == r.method and back.steps_per_path == r.steps_per_path
    assert back.scene.to_dict() == r.scene.to_dict()
    np.testing.assert_array_equal(back.moment(2, 1, 1), r.moment(2, 1, 1))
    assert back.summary() == r.summary()
    # Plain netCDF: any reader sees the table.
    with xr.open_dataset(path, engine="scipy") as ds:
        np.testing.assert_array_equal(ds["statistics"].values, r.to_xarray()["statistics"].values)


def test_save_load_stop_only_and_velocity_only(tmp_path):
    for scene in (crandall.Scene.scaled(tau0=1.0, times=[], observe=["stop"]),
                  crandall.Scene(mu=0.0, h=1.0, t0=math.inf, times=[1.0], observe="velocity")):
        r = crandall.simulate(scene, paths=500, seed=2)
        r.save(tmp_path / "r.nc")
        assert same_result(r, crandall.load(tmp_path / "r.nc"))


def test_pandas_table(physical_result):
    r = physical_result
    df = r.to_pandas()
    assert list(df.columns) == ["quantity", "t", "units", "mean", "var", "std", "stderr",
                                "var_stderr"]
    assert len(df) == 5 * 4 + 4
    rows = df[df.quantity == "distance"]
    np.testing.assert_array_equal(rows["t"].values, r.times)
    np.testing.assert_array_equal(rows["mean"].values, r.mean("distance"))
    stop = df[df.quantity == "stop_time"].iloc[0]
    assert math.isnan(stop["t"]) and stop["units"] == "s" and stop["mean"] == r.mean("stop_time")


def test_load_rejects_other_files(tmp_path):
    other = tmp_path / "other.nc"
    xr.Dataset({"x": ("a", [1.0, 2.0])}).to_netcdf(other, engine="scipy")
    with pytest.raises(ValueError, match="not a saved crandall result"):
        crandall.load(other)
    junk = tmp_path / "junk.nc"
    junk.write_text("hello")
    with pytest.raises(ValueError, match="path: cannot read"):
        crandall.load(junk)
