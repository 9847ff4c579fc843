"""Provenance: the random-stream version and the grid travel with every result, checkpoint and
saved file, and numbers of another stream are never mixed in (docs/random-numbers.md)."""

import json

import numpy as np
import pytest

import crandall
from crandall import _core, engine
from crandall.spec import RunSpec
SCENE = crandall.Scene.scaled(tau0=1.0, times=[0.5, 1.0])


def test_result_records_the_stream_and_the_grid():
    r = crandall.simulate(SCENE, paths=200, seed=1)
    assert r.random_stream == _core.RANDOM_STREAM == _core.build_info()["random_stream"]
    assert r.min_steps == crandall.methods.DEFAULT_MIN_STEPS  # the default grid is graded
    assert f"random_stream={_core.RANDOM_STREAM}" in r.summary()
    assert crandall.simulate(SCENE, paths=200, seed=1, dt=0.01).min_steps == 0


def test_saved_file_keeps_stream_and_grid_and_refuses_another_stream(tmp_path):
    pytest.importorskip("xarray")
    # 1000 paths: with 200, fewer than 30 carried the distance's spread (Result.carriers), and
    # its tables warned of the variance's withheld standard error.
    r = crandall.simulate(SCENE, paths=1000, seed=1)
    path = tmp_path / "r.nc"
    r.save(path)
    back = crandall.load(path)
    assert (back.random_stream, back.min_steps) == (r.random_stream, r.min_steps)
    ds = r.to_xarray()
    assert ds.attrs["random_stream"] == _core.RANDOM_STREAM
    for stream in (_core.RANDOM_STREAM - 1, None):
        ds = r.to_xarray()
        if stream is None:
            del ds.attrs["random_stream"]  # a file from before streams were recorded
        else:
            ds.attrs["random_stream"] = stream
        other = tmp_path / f"other-{stream}.nc"
        ds.to_netcdf(other, engine="scipy", format="NETCDF3_64BIT")
        with pytest.raises(ValueError, match="random stream"):
            crandall.load(other)


def test_checkpoint_of_another_stream_is_refused(tmp_path):
    path = tmp_path / "run.ckpt"
    crandall.simulate(SCENE, paths=100, seed=3, checkpoint=path)
    with np.load(path) as data:
        arrays = {k: data[k] for k in data.files}
    ident = json.loads(str(arrays["identity"]))
    assert ident["random_stream"] == _core.RANDOM_STREAM
    ident["random_stream"] = _core.RANDOM_STREAM - 1
    arrays["identity"] = np.array(json.dumps(ident))
    with open(path, "wb") as f:
        np.savez(f, **arrays)
    with pytest.raises(ValueError, match="random stream 1.*cannot be continued"):
        crandall.simulate(SCENE, paths=100, seed=3, checkpoint=path)


def test_worker_of_another_stream_refuses_the_task():
    args = (RunSpec(SCENE, 100, 1, 0.01, "exact").to_dict(), 0, 1, 1)
    parts = engine.run_chunks(*args, _core.RANDOM_STREAM)
    assert len(parts) == 1
    with pytest.raises(ValueError, match="random_stream"):
        engine.run_chunks(*args, _core.RANDOM_STREAM + 1)
