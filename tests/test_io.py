"""Results that keep: xarray, pandas, netCDF save/load (exact)."""

import json
import warnings
import math

import numpy as np
import pytest

import crandall
from conftest import same_result

xr = pytest.importorskip("xarray")
pd = pytest.importorskip("pandas")

# The runs below reach times when almost every path is at rest (the crate at 3 s, tau = 2):
# the variance's standard error there is withheld with this warning (tests/test_few_paths.py
# checks it); these tests are about the files' layout and values.
pytestmark = pytest.mark.filterwarnings(
    "ignore:the standard error of the (variance|mean) of [a-z_]+ is NaN. its spread is carried "
    "by fewer than:crandall.results.StatisticsWarning")


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
    # CF: one variable per quantity and statistic, each with its own units and long_name.
    assert ds.attrs["Conventions"] == "CF-1.10"
    np.testing.assert_array_equal(ds["time"].values, [0.5, 1.0, 2.0, 3.0])
    assert ds["time"].attrs["units"] == "s"
    units = {"velocity": ("m s-1", "m2 s-2"), "displacement": ("m", "m2"),
             "distance": ("m", "m2"), "kinetic_energy": ("J", "J2"),
             "dissipated_energy": ("J", "J2"), "stop_time": ("s", "s2")}
    for name, (first, second) in units.items():
        for stat in ("mean", "std", "stderr", "bias_mean", "error_mean"):
            assert ds[f"{name}_{stat}"].attrs["units"] == first, (name, stat)
        for stat in ("var", "var_stderr", "bias_var", "error_var"):
            assert ds[f"{name}_{stat}"].attrs["units"] == second, (name, stat)
        assert name.replace("_", " ").split()[0] in ds[f"{name}_mean"].attrs["long_name"]
    for name in ("velocity", "distance", "dissipated_energy"):
        assert ds[f"{name}_mean"].dims == ("time",)
        np.testing.assert_array_equal(ds[f"{name}_mean"].values, r.mean(name))
        np.testing.assert_array_equal(ds[f"{name}_var"].values, r.var(name))
        np.testing.assert_array_equal(ds[f"{name}_stderr"].values, r.stderr(name))
        np.testing.assert_array_equal(ds[f"{name}_var_stderr"].values, r.var_stderr(name))
    # The kinetic energy's variance's standard error, from the moments of V^2 (NaN where few
    # paths carry it: the result warns there, the file holds NaN).
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", crandall.StatisticsWarning)
        np.testing.assert_array_equal(ds["kinetic_energy_var_stderr"].values,
                                      r.var_stderr("kinetic_energy"))
    assert np.isfinite(ds["kinetic_energy_var_stderr"].values[:3]).all()
    assert ds["stop_time_mean"].dims == () and ds["stop_time_mean"] == r.mean("stop_time")
    assert json.loads(ds.attrs["scene"]) == r.scene.to_dict()
    assert ds.attrs["scene_mu"] == 0.3 and ds.attrs["scene_mass"] == 100.0
    assert ds.attrs["seed"] == "3" and ds.attrs["paths"] == 5000
    assert ds.attrs["method"] == crandall.methods.DEFAULT_METHOD and ds.attrs["dt"] == 0.05


def test_scaled_units_are_dimensionless(scaled_result):
    ds = scaled_result.to_xarray()
    assert {v.attrs["units"] for k, v in ds.data_vars.items() if "units" in v.attrs} == {"1"}
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
    assert back.estimate_bias().summary() == r.summary()  # the estimate is the seed's
    # Plain netCDF: any reader sees the statistics, with their units.
    with xr.open_dataset(path, engine="scipy") as ds:
        np.testing.assert_array_equal(ds["distance_var"].values, r.var("distance"))
        assert ds["distance_var"].attrs["units"] in ("m2", "1")


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
                                "var_stderr", "bias_mean", "error_mean", "bias_var", "error_var"]
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


# -- damaged and edited files --------------------------------------------------------------

@pytest.fixture(scope="module")
def saved(tmp_path_factory):
    """A saved result with output times and the stop (method "exact": plain sums), as bytes."""
    scene = crandall.Scene.scaled(tau0=1.0, times=[0.5, 1.0, 2.0])
    r = crandall.simulate(scene, paths=2000, seed=8, dt=0.05, method="exact")
    path = tmp_path_factory.mktemp("io") / "result.nc"
    r.save(path)
    return path.read_bytes()


def _attrs(**change):
    def fn(ds):
        for k, v in change.items():
            if v is None:
                del ds.attrs[k]
            else:
                ds.attrs[k] = v
        return ds
    return fn


def _drop(name):
    return lambda ds: ds.drop_vars(name)


def _values(name, edit):
    def fn(ds):
        values = ds[name].values.copy()
        edit(values)
        ds[name] = (ds[name].dims, values)
        return ds
    return fn


def _reshape(name, dims, values):
    def fn(ds):
        return ds.drop_vars(name).assign({name: (dims, values)})
    return fn


def _set(index, value):
    def fn(a):
        a[index] = value
    return fn


def _scene_attr(**change):
    def fn(ds):
        scene = json.loads(ds.attrs["scene"])
        scene.update(change)
        ds.attrs["scene"] = json.dumps(scene)
        return ds
    return fn


def _times(ds):
    name = "tau" if "tau" in ds.coords else "time"  # a scaled file's time is tau
    return ds.assign_coords({name: ds[name].values * 2})


class Raw:
    """A damage done to the file's bytes (the others edit the Dataset)."""

    def __init__(self, fn):
        self.fn = fn


# (id, damage: Raw(bytes -> bytes), or Dataset -> Dataset, what the message must name)
LOAD_CORRUPTIONS = [
    ("truncated-20-bytes", Raw(lambda b: b[:20]), "cannot read"),
    ("truncated-half", Raw(lambda b: b[: len(b) // 2]), "cannot read"),
    ("empty", Raw(lambda b: b""), "cannot read"),
    ("random-bytes", Raw(lambda b: np.random.default_rng(2).bytes(3000)), "cannot read"),
    ("format", _attrs(format="something"), "not a saved crandall result"),
    ("scene-not-json", _attrs(scene="{units"), "scene"),
    ("scene-a-list", _attrs(scene="[1, 2]"), "scene"),
    ("scene-bad-tau0", _scene_attr(tau0=-1.0), "scene"),
    ("scene-bad-units", _scene_attr(units="furlongs"), "scene"),
    ("scene-other-times", _scene_attr(times=[0.5, 1.0, 2.0, 3.0]), "slots"),
    ("scene-without-stop", _scene_attr(observe=["velocity", "distance"]), "stop_counts"),
    ("paths-text", _attrs(paths="many"), "paths"),
    ("paths-zero", _attrs(paths=0), "paths"),
    ("paths-negative", _attrs(paths=-3), "paths"),
    ("paths-float", _attrs(paths=2000.5), "paths"),
    ("paths-tampered", _attrs(paths=4000), "counts"),
    ("seed-text", _attrs(seed="x"), "seed"),
    ("seed-negative", _attrs(seed="-1"), "seed"),
    ("seed-too-big", _attrs(seed=str(2**64)), "seed"),
    ("seed-float", _attrs(seed=8.5), "seed"),
    ("dt-text", _attrs(dt="0.05"), "dt"),
    ("dt-nan", _attrs(dt=math.nan), "dt"),
    ("dt-negative", _attrs(dt=-0.05), "dt"),
    ("method", _attrs(method="rk4"), "method"),
    ("steps_per_path-negative", _attrs(steps_per_path=-1), "steps_per_path"),
    ("steps_per_path-text", _attrs(steps_per_path="lots"), "steps_per_path"),
    ("slots-wrong", _attrs(slots=2), "slots"),
    ("time-coordinate", _times, "time"),
    ("counts-nan", _values("counts", _set(0, math.nan)), "counts"),
    ("counts-tampered", _values("counts", _set(1, 5.0)), "counts"),
    ("counts-zero", _values("counts", lambda a: a.fill(0.0)), "counts"),
    ("means-nan", _values("means", _set((2, 1), math.nan)), "means"),
    ("central-inf", _values("central", _set((0, 9), math.inf)), "central"),
    ("central-negative-variance", _values("central", _set((1, 9), -2.0)), "central"),
    ("central-count-column", _values("central", _set((1, 0), 3.0)), "central"),
    ("stop_means-nan", _values("stop_means", _set((0, 0), math.nan)), "stop_means"),
    ("stop_counts-tampered", _values("stop_counts", _set(0, 1.0)), "stop_counts"),
    ("counts-short", _reshape("counts", ("slot2",), np.full(2, 2000.0)), "counts"),
    ("means-wide", _reshape("means", ("slot", "var4"), np.zeros((3, 4))), "means"),
    ("central-narrow", _reshape("central", ("slot", "m34"), np.zeros((3, 34))), "central"),
    ("stop_central-two-slots", _reshape("stop_central", ("s2", "monomial"),
                                        np.zeros((2, 35))), "stop_central"),
    ("means-text", _reshape("means", ("slot", "variable"), np.full((3, 3), "x")), "means"),
]
LOAD_CORRUPTIONS += [(f"missing-attribute-{k}", _attrs(**{k: None}), k)
                     for k in ("format", "scene", "paths", "seed", "dt", "method",
                               "steps_per_path", "slots")]
LOAD_CORRUPTIONS += [(f"missing-{k}", _drop(k), k)
                     for k in ("counts", "means", "central", "stop_counts", "stop_means",
                               "stop_central")]


@pytest.mark.parametrize("damage, field", [c[1:] for c in LOAD_CORRUPTIONS],
                         ids=[c[0] for c in LOAD_CORRUPTIONS])
def test_damaged_file_is_a_value_error_naming_file_and_field(tmp_path, saved, damage, field):
    source = tmp_path / "good.nc"
    source.write_bytes(saved)
    path = tmp_path / "damaged.nc"
    if isinstance(damage, Raw):
        path.write_bytes(damage.fn(saved))
    else:
        with xr.open_dataset(source, engine="scipy") as ds:
            out = damage(ds.load())
        out.to_netcdf(path, engine="scipy", format="NETCDF3_64BIT")
    with pytest.raises(ValueError) as info:
        crandall.load(path)
    message = str(info.value)
    assert message.startswith(f"path: ") and str(path) in message
    assert field in message


def test_the_undamaged_file_loads(tmp_path, saved):
    """The table's starting point is valid, and survives the rewrite the table uses."""
    source = tmp_path / "good.nc"
    source.write_bytes(saved)
    with xr.open_dataset(source, engine="scipy") as ds:
        ds.load().to_netcdf(tmp_path / "copy.nc", engine="scipy", format="NETCDF3_64BIT")
    assert same_result(crandall.load(source), crandall.load(tmp_path / "copy.nc"))


def test_counts_beyond_netcdf3_integers_round_trip(tmp_path, scaled_result):
    """netCDF-3 integers have 32 bits: paths and steps per path beyond them are kept exactly
    (as text, like the seed) instead of failing after the run."""
    big = 3_000_000_001
    slots = scaled_result.accumulators.times.slots
    moments = crandall._core.Moments(slots, np.full(slots, float(big)),
                                     scaled_result.accumulators.times.means,
                                     scaled_result.accumulators.times.central * big / 3000)
    stop = crandall._core.Moments(1, np.full(1, float(big)), scaled_result.accumulators.stop.means,
                                  scaled_result.accumulators.stop.central * big / 3000)
    moments.central[:, 0] = big
    r = crandall.Result(scene=scaled_result.scene, paths=big, seed=scaled_result.seed,
                        dt=scaled_result.dt, method=scaled_result.method, moments=moments,
                        stop_moments=stop, steps_per_path=2**33)
    r.save(tmp_path / "big.nc")
    back = crandall.load(tmp_path / "big.nc")
    assert back.paths == big and back.steps_per_path == 2**33
    assert same_result(r, back)


def test_save_is_atomic_and_durable(tmp_path, scaled_result, monkeypatch):
    """Saved through the shared writer: fsync of the file and of its folder, no temporary
    file left, a failed write leaves the previous file whole."""
    import os

    path = tmp_path / "r.nc"
    fsyncs = []
    real = os.fsync
    monkeypatch.setattr(os, "fsync", lambda fd: fsyncs.append(fd) or real(fd))
    scaled_result.save(path)
    assert len(fsyncs) == 2
    assert [p.name for p in tmp_path.iterdir()] == ["r.nc"]
    before = path.read_bytes()
    monkeypatch.setattr(crandall._dataset, "to_xarray", lambda r: 1 / 0)
    with pytest.raises(ZeroDivisionError):
        scaled_result.save(path)
    assert path.read_bytes() == before and [p.name for p in tmp_path.iterdir()] == ["r.nc"]


def test_a_file_in_the_earlier_layout_still_loads(tmp_path, physical_result):
    # Files of 0.2.0 held the statistics as one mixed table (time x observable x statistic)
    # and no run_spec: load rebuilds a result from the accumulators, so they load bitwise.
    r = physical_result
    ds = r.to_xarray()
    names = [k for k in ds.data_vars if any(k.startswith(n + "_") for n in r.names)]
    old = ds.drop_vars(names)
    old.attrs = {k: v for k, v in ds.attrs.items() if k not in ("run_spec", "Conventions")}
    old["statistics"] = (("time", "observable", "statistic"), np.zeros((4, 2, 5)))
    old = old.assign_coords(observable=["velocity", "distance"],
                            statistic=["mean", "var", "std", "stderr", "var_stderr"])
    path = tmp_path / "old.nc"
    old.to_netcdf(path, engine="scipy", format="NETCDF3_64BIT")
    back = crandall.load(path)
    assert same_result(r, back) and back.spec.to_dict() == r.spec.to_dict()


def test_a_sweep_as_one_dataset():
    scenes = [crandall.Scene(mu=mu, h=1.0, t0=2.0, times=[1.0, 2.0]) for mu in (0.2, 0.3)]
    ds = crandall.simulate_many(scenes, paths=2000, seed=4, dataset=True)
    assert ds["distance_mean"].dims == ("scene", "time")
    np.testing.assert_array_equal(ds["mu"].values, [0.2, 0.3])
    each = crandall.simulate_many(scenes, paths=2000, seed=4)
    for i, r in enumerate(each):
        np.testing.assert_array_equal(ds["distance_var"].values[i], r.var("distance"))
        assert float(ds["stop_time_mean"][i]) == r.mean("stop_time")
    assert ds["distance_var"].attrs["units"] == "m2" and ds.attrs["Conventions"] == "CF-1.10"
    with pytest.raises(ValueError, match="dataset must be True or False"):
        crandall.simulate_many(scenes, paths=10, dataset="yes")
    other = crandall.Scene(mu=0.3, h=1.0, t0=2.0, times=[1.0, 3.0])
    with pytest.raises(ValueError, match="same quantities at the same output times"):
        crandall.simulate_many(scenes + [other], paths=100, seed=1, dataset=True)


def _cf_failures(path):
    """compliance-checker's CF 1.10 findings on a file: {priority: [(section, messages)]}."""
    import pathlib
    import subprocess
    import sys
    pytest.importorskip("compliance_checker")
    # Its console script, installed beside this Python (make test installs it).
    script = pathlib.Path(sys.executable).parent / "compliance-checker"
    out = subprocess.run([str(script), "--test=cf:1.10", "-f", "json", "-o", "-", str(path)],
                         capture_output=True, text=True).stdout
    report = json.loads(out)["cf:1.10"]
    return {p: [(c["name"], c["msgs"]) for c in report[f"{p}_priorities"]
                if c["value"][0] < c["value"][1]] for p in ("high", "medium", "low")}


@pytest.mark.parametrize("kind", ["SI", "scaled", "accuracy"])
def test_saved_files_have_no_cf_error(physical_result, tmp_path, kind):
    if kind == "SI":
        scene = crandall.Scene.from_dict({**physical_result.scene.to_dict(),
                                          "distributions": ["distance"]})
        r = crandall.simulate(scene, paths=2000, seed=3, dt=0.05)
    elif kind == "scaled":
        r = crandall.simulate(crandall.Scene.scaled(tau0=1.0, times=[0.5, 2.0],
                                                    distributions=True), paths=2000, seed=1)
    else:
        r = crandall.simulate(crandall.Scene.scaled(tau0=1.0, times=[0.5, 2.0],
                                                    observe=["distance", "stop"]),
                              error=0.05, seed=1)
    r.save(tmp_path / "r.nc")
    found = _cf_failures(tmp_path / "r.nc")
    assert found["high"] == [], found["high"]
    # The only medium finding left: CF recommends the time dimension rightmost, while a
    # histogram's bins follow its time (kept: the arrays are one histogram per row).
    assert {name for name, _ in found["medium"]} <= {"§2.4 Dimensions"}, found["medium"]
    back = crandall.load(tmp_path / "r.nc")
    assert back.to_pandas().equals(r.to_pandas())
    ds = xr.open_dataset(tmp_path / "r.nc", decode_times=False)
    assert ds.attrs["history"].startswith(f"crandall {crandall.__version__}: simulate(scene, ")
    if kind != "accuracy":  # the fixed-step runs' accumulators: counts in units of 1
        assert ds["counts"].attrs["units"] == "1"
    assert ("tau" in ds.coords) == (kind != "SI") and ("time" in ds.coords) == (kind == "SI")
    ds.close()


def test_tidy_table_has_one_row_per_statistic_with_its_unit(physical_result):
    df = physical_result.to_pandas(tidy=True)
    assert list(df.columns) == ["quantity", "time", "time_units", "statistic", "value", "units"]
    row = df[(df.quantity == "velocity") & (df.time == 1.0) & (df.statistic == "var")]
    assert row["value"].item() == physical_result.var("velocity")[1]
    assert row["units"].item() == "m2 s-2" and row["time_units"].item() == "s"
    stop = df[(df.quantity == "stop_time") & (df.statistic == "stderr")]
    assert np.isnan(stop["time"].item()) and stop["units"].item() == "s"
    assert stop["value"].item() == physical_result.stderr("stop_time")
    wide = physical_result.to_pandas()
    assert len(df) == len(wide) * 9
