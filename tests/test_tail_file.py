"""A tail result is saved, loaded and shown like the other results (TailResult.save,
crandall.load, summary, HTML, pandas)."""

from __future__ import annotations

import numpy as np
import pytest

import crandall
from crandall import TailResult

pytest.importorskip("xarray")


@pytest.fixture(scope="module")
def result():
    scene = crandall.Scene(mu=0.3, h=1.0, t0=2.0, times=[2.0])
    return crandall.tail(scene, "residual_displacement", [0.05, 0.2], seed=5, min_samples=3,
                         max_samples=3, particles=40, threads=1, progress=False)


def test_saved_tail_loads_with_the_same_bits(result, tmp_path):
    path = tmp_path / "tail.nc"
    result.save(path)
    back = crandall.load(path)
    assert isinstance(back, TailResult)
    for name in ("levels", "probability", "stderr", "rel_error", "reliable"):
        assert np.array_equal(getattr(back, name), getattr(result, name)), name
        assert getattr(back, name).dtype == np.asarray(getattr(result, name)).dtype, name
    for name in ("quantity", "units", "method", "samples", "seconds", "steps"):
        assert getattr(back, name) == getattr(result, name), name
    assert back.diagnostics == result.diagnostics
    assert back.spec == result.spec
    assert back.summary() == result.summary() == str(result)
    assert back._repr_html_() == result._repr_html_()
    assert back.to_pandas().equals(result.to_pandas())
    lo, hi = back.interval()
    assert np.array_equal(lo, result.interval()[0]) and np.array_equal(hi, result.interval()[1])


def test_a_damaged_tail_file_is_refused_naming_the_path(result, tmp_path):
    ds = result.to_xarray()
    del ds.attrs["samples"]
    path = tmp_path / "bad.nc"
    ds.to_netcdf(path, engine="scipy")
    with pytest.raises(ValueError, match=r"path: .*bad\.nc is a damaged crandall tail result"):
        crandall.load(path)


def test_a_fixed_step_result_still_loads(tmp_path):
    r = crandall.simulate(crandall.Scene.scaled(tau0=1.0, times=[1.0]), paths=100, seed=1)
    r.save(tmp_path / "r.nc")
    assert isinstance(crandall.load(tmp_path / "r.nc"), crandall.Result)
