"""The results whose shown forms tests/test_table_snapshot.py keeps (tests/data/table_snapshot.json):
a few results of each kind, fixed seeds, and the text of each of their forms (summary, HTML,
pandas, CSV, xarray). Run as a script to write the snapshot again."""

from __future__ import annotations

import dataclasses
import json
import pathlib
import sys
import warnings

import numpy as np

import crandall

SNAPSHOT = pathlib.Path(__file__).with_name("data") / "table_snapshot.json"

#: What a run's wall time is replaced with, so that the forms that show it are the same bits.
SECONDS = 1.25

_SCALED = crandall.Scene.scaled(tau0=5.0, times=[1.0, 5.0, 40.0],
                                observe=["velocity", "displacement", "distance",
                                         "kinetic_energy", "stop", "peaks"])
_SI = crandall.Scene(mu=0.3, h=1.0, t0=2.0, times=[0.5, 2.0],
                     observe=["velocity", "displacement", "distance", "stop", "residual"])


def _fixed(result):
    result._wall_time = SECONDS
    return result


def results():
    """(name, result) of every kind: fixed-step (bias not estimated yet, estimated, a method
    without a bias estimate, one path, distributions, a stop time the scene sets), runs to an accuracy (every statistic, a few) and
    tails (a run, and one made by hand with an unreliable level)."""
    out = []
    r = _fixed(crandall.simulate(_SCALED, paths=400, seed=3, method="exact", threads=1))
    out.append(("fixed_pending", r))
    r = _fixed(crandall.simulate(_SCALED, paths=400, seed=3, method="exact", threads=1))
    out.append(("fixed_estimated", r.estimate_bias()))
    out.append(("fixed_si_euler", _fixed(crandall.simulate(
        _SI, paths=64, seed=4, method="euler", dt=0.05, threads=1))))
    out.append(("fixed_one_path", _fixed(crandall.simulate(
        _SI, paths=1, seed=5, method="exact", dt=0.05, threads=1))))
    binned = crandall.Scene(mu=0.3, h=1.0, t0=2.0, times=[1.0, 2.0],
                            observe=["velocity", "stop"],
                            distributions=["velocity", "stop_time"])
    rests = crandall.Scene(mu=5.0, h=1.0, t0=2.0, times=[1.0], observe=["velocity", "stop"])
    out.append(("fixed_stop_set_by_scene", _fixed(crandall.simulate(
        rests, paths=200, seed=7, method="exact", dt=0.05, threads=1))))
    out.append(("fixed_distributions", _fixed(crandall.simulate(
        binned, paths=300, seed=6, method="exact", dt=0.05, threads=1))))
    scene = crandall.Scene.scaled(tau0=5.0, times=[1.0, 5.0],
                                  observe=["velocity", "displacement", "distance",
                                           "kinetic_energy", "stop"])
    out.append(("accuracy", _fixed(crandall.simulate(scene, error=5e-2, seed=11,
                                                     threads=1))))
    out.append(("accuracy_some", _fixed(crandall.simulate(
        scene, error=5e-2, seed=12, threads=1,
        statistics=["velocity:var", "distance:mean", "stop_time:mean"]))))
    tail = crandall.tail(crandall.Scene(mu=0.3, h=1.0, t0=2.0, times=[2.0]),
                         "residual_displacement", [0.05, 0.2], seed=5, min_samples=3,
                         max_samples=3, particles=40, threads=1, progress=False)
    out.append(("tail", dataclasses.replace(tail, seconds=SECONDS)))
    out.append(("tail_by_hand", crandall.TailResult(
        quantity="stop_time", levels=np.array([1.0, 2.5, 4.0]), units="",
        probability=np.array([0.5, 0.01, 0.0]), stderr=np.array([0.02, 0.004, 0.0]),
        rel_error=np.array([0.04, 0.4, np.nan]), method="importance", samples=150,
        seconds=SECONDS, steps=123456, diagnostics={"proposal": "by hand"},
        reliable=np.array([True, True, False]), spec={"seed": 1})))
    return out


def _plain(x):
    if isinstance(x, np.ndarray):
        return x.tolist()
    if isinstance(x, np.generic):
        return x.item()
    raise TypeError(type(x).__name__)


def _xarray_text(ds) -> str:
    ds = ds.to_dict(data="list")
    ds["attrs"].pop("crandall_version", None)
    history = ds["attrs"].get("history")
    if history is not None:
        ds["attrs"]["history"] = history.replace(crandall.__version__, "VERSION")
    return json.dumps(ds, sort_keys=True, default=_plain, indent=0)


#: Every shown form of a result, in the order they are made (a fixed-step result's pandas and
#: xarray tables make its bias estimate, which its summary shows from then on).
FORMS = {
    "summary": lambda r: r.summary(),
    "str": str,
    "html": lambda r: r._repr_html_(),
    "pandas": lambda r: r.to_pandas().to_csv(index=False),
    "csv": lambda r: r.to_pandas(tidy=True).to_csv(index=False),
    "xarray": lambda r: _xarray_text(r.to_xarray()),
    "summary_after": lambda r: r.summary(),
}


def forms(result) -> dict:
    """Every shown form of a result as text, with the warnings making it gave."""
    out = {}
    for name, form in FORMS.items():
        if name == "csv" and isinstance(result, crandall.TailResult):
            continue  # a tail's table has no tidy form
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            out[name] = form(result)
        out[name + "_warnings"] = [f"{w.category.__name__}: {w.message}" for w in caught]
    return out


def snapshot() -> dict:
    return {name: forms(r) for name, r in results()}


if __name__ == "__main__":
    SNAPSHOT.write_text(json.dumps(snapshot(), indent=1, sort_keys=True) + "\n")
    sys.stdout.write(f"wrote {SNAPSHOT}\n")
