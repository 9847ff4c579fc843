"""The kinetic energy's variance has a standard error in fixed-step runs: the run keeps the
moments of V^2 (Accumulators.energy), whose fourth central moment is the velocity's eighth."""

import numpy as np
import pytest

import crandall
from crandall import Scene, _core


def _scene(**kw):
    # Over time and after the switch-off (tau0 = 1): the coast slots take the same moments.
    return Scene.scaled(tau0=1.0, times=[0.25, 1.0, 1.2], observe=["velocity", "kinetic_energy"],
                        **kw)


def test_the_variance_of_the_kinetic_energy_has_a_standard_error_that_matches_its_spread():
    # R independent runs: the spread of their estimates of Var(KE) against the standard error
    # each run reports. With R = 40 the sample standard deviation's relative error is about
    # 1 / sqrt(2 (R - 1)) = 11 %; 0.35 is three of those.
    runs, paths = 40, 4000
    results = [crandall.simulate(_scene(), paths=paths, seed=1000 + i, threads=1)
               for i in range(runs)]
    values = np.array([r.var("kinetic_energy") for r in results])
    reported = np.array([r.var_stderr("kinetic_energy") for r in results])
    assert np.isfinite(reported).all() and (reported > 0).all()
    spread = values.std(axis=0, ddof=1)
    ratio = reported.mean(axis=0) / spread
    assert np.all(np.abs(ratio - 1.0) < 0.35), ratio


def test_it_comes_from_the_squared_velocitys_own_moments():
    r = crandall.simulate(_scene(), paths=20000, seed=3, threads=1)
    e = r.accumulators.energy
    assert e is not None and e.slots == 3
    # The mean of V^2 the energy slots hold is the velocity's second raw moment (the same
    # paths): the two agree to rounding.
    assert np.allclose(e.means[:, 0], r.mean("velocity") ** 2 + r.var("velocity") *
                       (r.paths - 1) / r.paths, rtol=1e-10)
    # sqrt((m4(W) - m2(W)^2) / n) with W = V^2, scaled by the energy's factor 1/2 squared.
    n = e.counts
    from crandall.results import _e
    m2w = e.central[:, _e(0, 2)] / n
    m4w = e.central[:, _e(0, 4)] / n
    assert np.allclose(r.var_stderr("kinetic_energy"), 0.25 * np.sqrt((m4w - m2w ** 2) / n),
                       rtol=1e-12)


def test_a_scene_without_the_kinetic_energy_keeps_no_extra_moments():
    sc = Scene.scaled(tau0=1.0, times=[0.5], observe=["velocity"])
    r = crandall.simulate(sc, paths=1000, seed=1, threads=1)
    assert r.accumulators.energy is None


def _interrupt_after_the_first_chunk(sc, ck, monkeypatch):
    """A run of two chunks with checkpoint ``ck``, interrupted after its first chunk."""
    real = _core.run_chunk

    def failing(plan, chunk, threads):
        if chunk == 1:
            raise KeyboardInterrupt
        return real(plan, chunk, threads)

    monkeypatch.setattr(_core, "run_chunk", failing)
    with pytest.raises(KeyboardInterrupt):
        crandall.simulate(sc, paths=70000, seed=5, threads=1, checkpoint=ck)
    monkeypatch.setattr(_core, "run_chunk", real)


def test_the_moments_travel_with_files_and_checkpoints(tmp_path, monkeypatch):
    pytest.importorskip("xarray")
    pytest.importorskip("scipy")
    sc = _scene()
    r = crandall.simulate(sc, paths=70000, seed=5, threads=1)
    path = tmp_path / "r.nc"
    r.save(path)
    back = crandall.load(path)
    assert np.array_equal(back.var_stderr("kinetic_energy"), r.var_stderr("kinetic_energy"))
    # A run interrupted after its first chunk and resumed from the checkpoint gives the
    # same bits (the moments of V^2 are part of the checkpoint's state).
    ck = tmp_path / "run.ckpt"
    _interrupt_after_the_first_chunk(sc, ck, monkeypatch)
    resumed = crandall.simulate(sc, paths=70000, seed=5, threads=1, checkpoint=ck)
    assert np.array_equal(resumed.var_stderr("kinetic_energy"), r.var_stderr("kinetic_energy"))


def test_a_checkpoint_written_without_them_still_resumes(tmp_path, monkeypatch):
    sc = _scene()
    ck = tmp_path / "run.ckpt"
    _interrupt_after_the_first_chunk(sc, ck, monkeypatch)
    # As a checkpoint of the version before the moments of V^2 were kept.
    with np.load(ck, allow_pickle=False) as f:
        arrays = {k: f[k] for k in f.files if not k.startswith("energy_")}
    with open(ck, "wb") as out:
        np.savez(out, **arrays)
    resumed = crandall.simulate(sc, paths=70000, seed=5, threads=1, checkpoint=ck)
    whole = crandall.simulate(sc, paths=70000, seed=5, threads=1)
    assert np.array_equal(resumed.var("kinetic_energy"), whole.var("kinetic_energy"))
    assert resumed.accumulators.energy is None
    with pytest.raises(ValueError, match="order 8"):
        resumed.var_stderr("kinetic_energy")


def test_a_file_saved_without_them_still_loads(tmp_path):
    pytest.importorskip("xarray")
    pytest.importorskip("scipy")
    import xarray as xr
    r = crandall.simulate(_scene(), paths=2000, seed=5, threads=1)
    path = tmp_path / "r.nc"
    r.save(path)
    with xr.open_dataset(path) as ds:
        old = ds.drop_vars(["energy_counts", "energy_means", "energy_central"]).load()
    old_path = tmp_path / "old.nc"
    old.to_netcdf(old_path, engine="scipy", format="NETCDF3_64BIT")
    back = crandall.load(old_path)
    assert back.var("kinetic_energy") == pytest.approx(r.var("kinetic_energy"), rel=0, abs=0)
    with pytest.raises(ValueError, match="order 8"):
        back.var_stderr("kinetic_energy")
