"""The same seed gives the same bits for filtered excitations: every statistic of a few
filtered runs, and the bias estimate from their coupled grids, stored as hex.

A guard for changes to the filtered walker that must not change any result (its products'
data layout, a reorganisation): tests/data/filtered_snapshot.json holds ``float.hex`` of the
mean, variance and standard errors of every quantity, and of the bias estimate of each mean
(run_samples' three coupled grids), for Kanai-Tajimi (static friction, a start in motion, the
ring-down) and Clough-Penzien scenes. When a change is *meant* to change filtered numbers
(their random stream, the event search), regenerate the file with
``python tests/test_filtered_snapshot.py --regenerate`` in the same commit, and say why in
its message.
"""

from __future__ import annotations

import pathlib
import warnings

import numpy as np

import crandall
from snapshot_files import assert_same_bits, regenerate

DATA = pathlib.Path(__file__).parent / "data" / "filtered_snapshot.json"

OBSERVE = ["velocity", "displacement", "distance", "stop"]


def _runs():
    """(label, scene, simulate keyword arguments) of every run in the snapshot."""
    kt = crandall.KanaiTajimi(omega=2.0, zeta=0.6, h=1.0)
    ring = crandall.KanaiTajimi(omega=8.0, zeta=0.6, h=1.0, ring_down=True)
    cp = crandall.CloughPenzien(omega=2.0, zeta=0.6, omega_f=0.3, zeta_f=0.6, h=1.0)
    return [
        ("kanai-tajimi", crandall.Scene(mu=1.0, g=1.0, excitation=kt, t0=4.0,
                                        times=[1.0, 4.0], observe=OBSERVE),
         dict(paths=300, seed=21)),
        ("kanai-tajimi-static-moving-start",
         crandall.Scene(mu=0.8, mu_static=1.1, g=1.0, excitation=kt, t0=3.0, v0=0.5,
                        times=[0.5, 3.0], observe=OBSERVE),
         dict(paths=300, seed=22, dt=0.05)),
        ("kanai-tajimi-ring-down", crandall.Scene(mu=1.0, g=1.0, excitation=ring, t0=2.0,
                                                  times=[2.0], observe=OBSERVE),
         dict(paths=200, seed=23)),
        ("clough-penzien", crandall.Scene(mu=1.0, g=1.0, excitation=cp, t0=3.0,
                                          times=[3.0], observe=OBSERVE),
         dict(paths=200, seed=24)),
    ]


def _hex(values):
    return [float(v).hex() for v in np.atleast_1d(np.asarray(values, dtype=float)).ravel()]


def _statistics(result):
    stats = {}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # NaN statistics of small runs are part of the record
        for name in result.names:
            for stat in ("mean", "var", "stderr", "var_stderr"):
                stats[f"{name}.{stat}"] = _hex(getattr(result, stat)(name))
            stats[f"{name}.bias"] = _hex(result.bias(name))
    return stats


def snapshot():
    return {label: _statistics(crandall.simulate(scene, threads=2, **kw))
            for label, scene, kw in _runs()}


def test_every_filtered_statistic_has_its_stored_bits():
    assert_same_bits(DATA, snapshot())


if __name__ == "__main__":
    regenerate(DATA, snapshot, pathlib.Path(__file__).name)
