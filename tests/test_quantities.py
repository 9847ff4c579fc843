"""The table of quantities: every module reads it, and a new row is all a new quantity takes."""

import math

import numpy as np
import pytest

import crandall
from crandall import quantities
from crandall.quantities import Quantity, VELOCITY


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


def test_a_new_quantity_is_one_row(monkeypatch, physical_scene):
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
