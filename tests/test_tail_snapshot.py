"""The same seed gives the same bits for tail runs: probability, standard error, samples and
path-steps of a fixed set of crandall.tail runs, stored as hex.

A guard for changes that must not change a tail's result (a reorganisation of the tail's code,
a faster particle loop): tests/data/tail_snapshot.json. When a change is *meant* to change the
numbers (a new random stream for the particles' choices, a different default grid),
regenerate the file with ``python tests/test_tail_snapshot.py --regenerate`` in the same
commit, and say why in its message.
"""

from __future__ import annotations

import pathlib
import warnings

import crandall
from snapshot_files import assert_same_bits, regenerate

DATA = pathlib.Path(__file__).parent / "data" / "tail_snapshot.json"


def _runs():
    """(label, scene, quantity, levels, tail keyword arguments) of every run in the snapshot:
    splitting with the plain and the normalised score, importance sampling, a start in motion
    and pieces, a quantity at an output time; each a few replicas or batches."""
    paper = crandall.Scene.scaled(tau0=2.0, times=[2.0])
    pieces = crandall.Scene(mu=0.3, h=[1.0, 0.5], t0=[1.0, 2.0], v0=0.2, times=[2.0])
    small = dict(min_samples=3, max_samples=3, particles=40)
    return [
        ("stop-time-splitting-curve", paper, "stop_time", [3.0, 4.0],
         dict(seed=21, **small)),
        ("distance-splitting-normalised", paper, "distance_at_stop", [6.0],
         dict(seed=22, **small)),
        ("stop-time-importance", paper, "stop_time", [4.0],
         dict(seed=23, method="importance", particles=50, min_samples=100, max_samples=200)),
        ("residual-pieces-moving-start", pieces, "residual_displacement", [0.05, 0.2],
         dict(seed=24, **small)),
        ("speed-at-a-time", paper, "speed", [1.5], dict(seed=25, time=1.0, **small)),
    ]


def _hex(values):
    return [float(v).hex() for v in values]


def snapshot():
    out = {}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # a short run's StatisticsWarning is part of the record
        for label, scene, quantity, levels, kw in _runs():
            r = crandall.tail(scene, quantity, levels, threads=2, progress=False, **kw)
            out[label] = {"probability": _hex(r.probability), "stderr": _hex(r.stderr),
                          "samples": int(r.samples), "steps": int(r.steps)}
    return out


def test_every_tail_run_has_its_stored_bits():
    assert_same_bits(DATA, snapshot())


if __name__ == "__main__":
    regenerate(DATA, snapshot, pathlib.Path(__file__).name)
