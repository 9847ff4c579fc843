"""The table of quantities: every module reads it, and a new row is all a new quantity takes."""

import math

import numpy as np
import pytest

import importlib

import crandall
import recipe_workers
from conftest import same_result
from crandall import _core, quantities
from crandall.errors import ParameterError
from crandall.quantities import Quantity, VELOCITY
from crandall.tail import TAIL_QUANTITIES

TAIL_PROBLEM = importlib.import_module("crandall.tail.problem")


def test_public_names_still_where_they_were():
    from crandall.scene import OBSERVABLES, STOP_QUANTITIES

    assert OBSERVABLES == ("velocity", "displacement", "distance", "kinetic_energy",
                           "dissipated_energy", "stop", "peaks", "residual")
    assert crandall.OBSERVABLES is OBSERVABLES
    assert STOP_QUANTITIES == {"stop_time": None, "displacement_at_stop": "displacement",
                               "distance_at_stop": "distance",
                               "dissipated_energy_at_stop": "dissipated_energy",
                               "peak_speed_at_stop": "peaks",
                               "peak_displacement_at_stop": "peaks",
                               "residual_displacement": "displacement"}
    # The peaks and the residual's magnitude are asked for: a scene's default observables are
    # those it had before them.
    assert crandall.Scene.scaled(tau0=1.0, times=[1.0]).observe == OBSERVABLES[:-2]


def test_twins_point_at_each_other():
    for q in quantities.QUANTITIES:
        if q.twin is not None:
            twin = quantities.quantity(q.twin)
            assert twin.twin == q.name and twin.at_stop != q.at_stop
            assert (twin.variable, twin.si_unit, twin.factor) == (q.variable, q.si_unit, q.factor)


def test_core_flags():
    f = quantities.core_flags
    assert f(["stop"]) == {"velocity": True, "displacement": False, "distance": False,
                           "stop": True}
    assert f(["dissipated_energy"]) == {"velocity": False, "displacement": False,
                                        "distance": True, "stop": False}
    # The kinetic energy also asks for the moments of V^2 (its variance's standard error).
    assert f(["kinetic_energy", "displacement"]) == {"velocity": True, "displacement": True,
                                                     "distance": False, "stop": False,
                                                     "energy": True}


def test_units_and_long_names_come_from_the_table(physical_scene):
    r = crandall.simulate(physical_scene, paths=50, seed=1, dt=0.1)
    for name in r.names:
        assert physical_scene.units_of(name) == quantities.quantity(name).si_unit
    assert quantities.quantity("distance_at_stop").long_name_in("scaled") == (
        "distance travelled U3 at the stop")
    assert quantities.quantity("dissipated_energy").long_name_in("SI") == (
        "energy dissipated by friction")


def test_a_new_quantity_is_one_row(monkeypatch, physical_scene, tmp_path):
    """The worked example of docs/architecture.md: the momentum m V, added by one row."""
    def momentum_factor(scene):
        return scene.mass

    row = Quantity("momentum", VELOCITY, "kg m/s", "momentum", ("velocity",),
                   factor=momentum_factor)
    scene = crandall.Scene(mu=0.3, h=1.0, t0=2.0, mass=4.0, times=[0.5, 1.0],
                           observe=["velocity", "stop"])
    assert "momentum" not in crandall.simulate(scene, paths=20, seed=3, dt=0.1).names
    monkeypatch.setattr(quantities, "QUANTITIES", quantities.QUANTITIES + (row,))
    r = crandall.simulate(scene, paths=200, seed=3, dt=0.1)
    assert "momentum" in r.names
    # Exactly 4 times the velocity's statistics (a power of 2: no rounding).
    assert np.array_equal(r.mean("momentum"), 4.0 * r.mean("velocity"))
    assert np.array_equal(r.var("momentum"), 16.0 * r.var("velocity"))
    assert np.array_equal(r.var_stderr("momentum"), 16.0 * r.var_stderr("velocity"))
    assert scene.units_of("momentum") == "kg m/s"
    assert "momentum [kg m/s]" in r.summary()
    pd = pytest.importorskip("pandas")
    table = r.to_pandas()
    assert isinstance(table, pd.DataFrame)
    assert set(table.loc[table.quantity == "momentum", "units"]) == {"kg m/s"}
    assert not math.isnan(table.loc[table.quantity == "momentum", "var_stderr"].iloc[0])
    # The other entry points and the result file hold it too.
    many = crandall.simulate_many([scene, scene], paths=200, seed=3, dt=0.1)
    assert all(np.array_equal(m.mean("momentum"), 4.0 * m.mean("velocity")) for m in many)
    accurate = crandall.simulate(scene, error=0.05, seed=3, threads=1)
    assert np.array_equal(accurate.mean("momentum"), 4.0 * accurate.mean("velocity"))
    pytest.importorskip("xarray")
    r.save(tmp_path / "momentum.nc")
    loaded = crandall.load(tmp_path / "momentum.nc")
    assert np.array_equal(loaded.mean("momentum"), r.mean("momentum"))
    # A row without a tail score is not a tail quantity: crandall.tail (and crandall.fragility,
    # which checks against the same view) refuses it naming the quantity, before any path.
    assert "momentum" not in TAIL_QUANTITIES
    with pytest.raises(ParameterError, match="momentum has no tail score") as exc:
        crandall.tail(scene, "momentum", [8.0], time=1.0, seed=3, threads=1)
    assert exc.value.name == "quantity"
    with pytest.raises(ParameterError) as exc:
        crandall.fragility(scene, "momentum", [8.0], intensities=[1.0], seed=3, threads=1,
                           progress=False)
    assert exc.value.name == "quantity"


def test_a_new_quantity_with_a_tail_score_reaches_the_tail(monkeypatch, tmp_path):
    """The same row with a tail score (the velocity's, times its factor m): crandall.tail
    estimates P(m V > 4 L) as P(V > L), bit for bit (a power of 2: no rounding), with splitting's
    Python loop (the core's loop has no score of its own for it), and saves its unit."""
    def momentum_factor(scene):
        return scene.mass

    row = Quantity("momentum", VELOCITY, "kg m/s", "momentum", ("velocity",),
                   factor=momentum_factor, tail="velocity")
    scene = crandall.Scene(mu=0.3, h=1.0, t0=2.0, mass=4.0, times=[1.0])
    kw = dict(time=1.0, seed=3, threads=1, dt=0.1, rel_error=0.3, max_samples=40)
    velocity = crandall.tail(scene, "velocity", [1.2, 1.6], **kw)
    monkeypatch.setattr(quantities, "QUANTITIES", quantities.QUANTITIES + (row,))
    assert "momentum" in TAIL_QUANTITIES and "momentum" not in _core.SPLIT_QUANTITIES
    momentum = crandall.tail(scene, "momentum", [4.8, 6.4], **kw)
    assert np.array_equal(momentum.probability, velocity.probability)
    assert np.array_equal(momentum.stderr, velocity.stderr)
    assert momentum.samples == velocity.samples and momentum.units == "kg m/s"
    pytest.importorskip("xarray")
    path = tmp_path / "momentum.nc"
    momentum.save(path)
    loaded = crandall.load(path)
    assert loaded.quantity == "momentum" and loaded.units == "kg m/s"
    assert np.array_equal(loaded.probability, momentum.probability)


def test_a_new_quantity_reaches_a_cluster_a_scene_file_and_every_file(monkeypatch, tmp_path,
                                                                      worker_client):
    """The row on a cluster (simulate, simulate(error=), simulate_many, crandall.tail given a
    client: the local run's bits), in a scene file (its distribution asked for by name) and in
    the files of a run to an accuracy. The row is the package's source, so a worker's process
    has it too (recipe_workers makes it there): a tail's Dask task looks the quantity up in
    its own process's table."""
    def momentum_factor(scene):
        return scene.mass

    row = Quantity("momentum", VELOCITY, "kg m/s", "momentum", ("velocity",),
                   factor=momentum_factor, tail="velocity")
    table = quantities.QUANTITIES + (row,)
    monkeypatch.setattr(quantities, "QUANTITIES", table)
    path = tmp_path / "momentum.toml"
    path.write_text("[scene]\nmu = 0.3\nh = 1.0\nt0 = 2.0\nmass = 4.0\ntimes = [0.5, 1.0]\n"
                    'observe = ["velocity", "stop"]\ndistributions = ["momentum", "velocity"]\n')
    scene = crandall.Scene.from_toml(path)
    plain = crandall.Scene(mu=0.3, h=1.0, t0=2.0, mass=4.0, times=[0.5, 1.0],
                           observe=["velocity", "stop"])
    assert set(scene.distributions) == {"momentum", "velocity"}
    tail_kw = dict(time=1.0, seed=3, dt=0.02, rel_error=0.5, min_samples=4, max_samples=4,
                   particles=50)
    local = crandall.simulate(scene, paths=2000, seed=3, dt=0.1, threads=1)
    local_many = crandall.simulate_many([scene, plain], paths=2000, seed=3, dt=0.1, threads=1)
    local_accurate = crandall.simulate(plain, error=0.1, seed=3, threads=1)
    local_tail = crandall.tail(plain, "momentum", [4.8], threads=1, **tail_kw)
    with recipe_workers.on_workers(worker_client, [("crandall.quantities", "QUANTITIES", table)]):
        remote = crandall.simulate(scene, paths=2000, seed=3, dt=0.1, client=worker_client)
        many = crandall.simulate_many([scene, plain], paths=2000, seed=3, dt=0.1,
                                      client=worker_client)
        accurate = crandall.simulate(plain, error=0.1, seed=3, client=worker_client)
        tail = crandall.tail(plain, "momentum", [4.8], client=worker_client, **tail_kw)
    assert same_result(remote, local) and "momentum" in remote.names
    assert all(same_result(m, l) for m, l in zip(many, local_many))
    # The histogram of m V is the velocity's with its edges times m (4: no rounding).
    q = remote.quantile("momentum", 0.9, time=1.0)
    assert q == local.quantile("momentum", 0.9, time=1.0)
    assert q.value == 4.0 * remote.quantile("velocity", 0.9, time=1.0).value
    assert accurate.to_pandas().equals(local_accurate.to_pandas())
    assert np.array_equal(accurate.var("momentum"), 16.0 * accurate.var("velocity"))
    assert tail.probability.tobytes() == local_tail.probability.tobytes()
    assert tail.samples == local_tail.samples
    pytest.importorskip("xarray")
    accurate.save(tmp_path / "accurate.nc")
    loaded = crandall.load(tmp_path / "accurate.nc")
    for stat in ("mean", "var"):
        assert np.array_equal(getattr(loaded, stat)("momentum"),
                              getattr(accurate, stat)("momentum"))


def test_the_tail_quantities_are_the_rows_with_a_tail_score():
    # The tail's facts, as its own table had them: unit, at the stop, velocity only, peak.
    facts = {"stop_time": ("s", True, True, False), "velocity": ("m/s", False, True, False),
             "speed": ("m/s", False, True, False),
             "distance_at_stop": ("m", True, False, False),
             "dissipated_energy_at_stop": ("J", True, False, False),
             "displacement_at_stop": ("m", True, False, False),
             "residual_displacement": ("m", True, False, False),
             "peak_displacement_at_stop": ("m", True, False, True),
             "peak_speed_at_stop": ("m/s", True, True, True)}
    assert set(TAIL_QUANTITIES) == set(facts)
    for name, (unit, at_stop, velocity_only, peak) in facts.items():
        q = TAIL_QUANTITIES[name]
        assert q is quantities.quantity(name)
        assert (q.si_unit, q.at_stop, q.velocity_only, q.peak) == (unit, at_stop, velocity_only,
                                                                  peak), name
        assert q.tail in TAIL_PROBLEM.SCORES
    # The core's splitting loop scores them all, indexed by the names it exposes.
    assert set(_core.SPLIT_QUANTITIES) == set(facts)
    assert len(_core.SPLIT_QUANTITIES) == len(facts)
    # The speed is a tail quantity only: no result holds it (the core keeps no moments of it).
    assert "speed" not in quantities.names_for(quantities.OBSERVABLES)


def test_accumulators_are_public(paper_scene):
    r = crandall.simulate(paper_scene, paths=100, seed=2, dt=0.1)
    acc = r.accumulators
    assert acc.times.slots == paper_scene.times.size and acc.stop.slots == 1
    assert np.array_equal(acc.times.counts, np.full(paper_scene.times.size, 100.0))
    # The statistics are those of the accumulators: the mean velocity is their mean.
    assert np.array_equal(r.mean("velocity"), acc.times.means[:, 0])
    no_stop = crandall.simulate(crandall.Scene.scaled(tau0=1.0, times=[1.0],
                                                      observe=["velocity"]), paths=10, seed=1)
    assert no_stop.accumulators.stop is None


def test_one_unit_convention(physical_scene):
    s = physical_scene.scaling
    # to_si multiplies by the scale, to_scaled divides, one factor at a time.
    assert s.to_si(3.0, "length", 2) == 3.0 * s.length_scale * s.length_scale
    assert s.to_scaled(3.0, "velocity", 2) == 3.0 / s.velocity_scale / s.velocity_scale
    assert s.to_tau(2.0) == 2.0 / s.time_scale and s.to_t(2.0) == 2.0 * s.time_scale
    with pytest.raises(ValueError, match="kind"):
        s.to_si(1.0, "mass")
    r = crandall.simulate(physical_scene, paths=100, seed=1, dt=0.1)
    assert np.allclose(r.moment(0, 0, 1), r.mean("distance") / s.length_scale, rtol=1e-14)
