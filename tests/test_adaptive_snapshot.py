"""Runs to an accuracy give the same bits from the same seed: every statistic (estimate,
standard error, bias) of a fixed set of runs, stored as hex in
tests/data/adaptive_snapshot.json, and a run resumed from a checkpoint gives the same.

A guard for changes that must not change any result (a faster feature or control pass, a
reorganisation). When a change is *meant* to change the numbers, regenerate the file with
``python tests/test_adaptive_snapshot.py --regenerate`` in the same commit and say why.
"""

from __future__ import annotations

import json
import pathlib
import sys

import numpy as np
import pytest

import crandall

DATA = pathlib.Path(__file__).parent / "data" / "adaptive_snapshot.json"


def _runs():
    paper = crandall.Scene.scaled(tau0=2.0, times=[1.0, 2.0],
                                  observe=["velocity", "displacement", "distance", "stop"])
    si = crandall.Scene(mu=0.3, h=0.5, t0=1.0, mass=2.0, times=[0.5, 1.0, 1.5],
                        observe=["velocity", "distance", "kinetic_energy",
                                 "dissipated_energy", "stop"])
    many = crandall.Scene.scaled(tau0=1.0, times=np.linspace(0.02, 1.0, 50),
                                 observe=["velocity", "displacement", "distance"])
    return [
        ("paper-error", paper, dict(error=0.05, seed=3)),
        ("paper-distance-var", paper, dict(rel_error=0.05, seed=4,
                                           statistics=["distance:var"])),
        ("si-energies", si, dict(error=0.02, seed=5)),
        ("fifty-times", many, dict(error=0.1, seed=6)),
    ]


def _table(r):
    out = {}
    for name in r.names:
        for stat in ("mean", "var"):
            try:
                value = r.mean(name) if stat == "mean" else r.var(name)
            except ValueError:
                continue  # not asked for
            for field, v in (("estimate", value), ("stderr", r.stderr(name, stat)),
                             ("bias", r.bias(name, stat))):
                out[f"{name}:{stat}:{field}"] = [float(x).hex() for x in np.atleast_1d(v)]
    out["paths"] = list(r.cost["paths"])
    return out


def _snapshot():
    return {label: _table(crandall.simulate(scene, threads=2, **kw))
            for label, scene, kw in _runs()}


@pytest.fixture(scope="module")
def stored():
    return json.loads(DATA.read_text())


@pytest.mark.parametrize("label", [label for label, _, _ in _runs()])
def test_same_bits_as_stored(stored, label):
    scene, kw = next((s, k) for lab, s, k in _runs() if lab == label)
    assert _table(crandall.simulate(scene, threads=2, **kw)) == stored[label]


def test_resumed_run_has_the_stored_bits(stored, tmp_path, monkeypatch):
    from crandall import adaptive
    label, scene, kw = _runs()[0]
    real = adaptive._core.run_samples
    calls = {"n": 0}

    def interrupted(*args, **kwargs):
        calls["n"] += 1
        if calls["n"] > 2:
            raise KeyboardInterrupt
        return real(*args, **kwargs)

    ckpt = tmp_path / "run.json"
    monkeypatch.setattr(adaptive.entry, "CHECKPOINT_SECONDS", 0.0)
    monkeypatch.setattr(adaptive._core, "run_samples", interrupted)
    with pytest.raises(KeyboardInterrupt):
        crandall.simulate(scene, threads=1, checkpoint=ckpt, **kw)
    monkeypatch.setattr(adaptive._core, "run_samples", real)
    assert _table(crandall.simulate(scene, threads=1, checkpoint=ckpt, **kw)) == stored[label]


if __name__ == "__main__" and "--regenerate" in sys.argv:
    DATA.write_text(json.dumps(_snapshot(), indent=1, sort_keys=True) + "\n")
