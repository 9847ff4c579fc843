"""The same seed gives the same bits: every statistic of a fixed set of runs, stored as hex.

A guard for changes that must not change any result (a reorganisation of the code, a new
build variant): tests/data/bitwise_snapshot.json holds ``float.hex`` of every public statistic
(mean, var, stderr, var_stderr of every quantity, and every mixed moment up to order 4) for
each method and several observable sets, in scaled and SI units, one run spanning two chunks.

When a change is *meant* to change the numbers (a new random stream, a different default grid),
regenerate the file with ``python tests/test_bitwise_snapshot.py --regenerate`` in the same
commit, and say why in its message.
"""

from __future__ import annotations

import math
import pathlib
import warnings

import crandall
from snapshot_files import assert_same_bits, regenerate

DATA = pathlib.Path(__file__).parent / "data" / "bitwise_snapshot.json"

ALL = ["velocity", "displacement", "distance", "kinetic_energy", "dissipated_energy", "stop"]


def _runs():
    """(label, scene, simulate keyword arguments) of every run in the snapshot."""
    paper = crandall.Scene.scaled(tau0=2.0, times=[0.25, 2.0, 2.5], observe=ALL)
    out = []
    for method in crandall.METHODS:
        out.append((f"scaled-all-{method}", paper, dict(paths=600, seed=11, dt=0.05,
                                                       method=method)))
    out.append(("scaled-all-default-grid", paper, dict(paths=300, seed=12)))
    out.append(("velocity-stop-two-chunks",
                crandall.Scene.scaled(tau0=1.0, times=[0.5, 1.0, 1.5],
                                      observe=["velocity", "stop"]),
                dict(paths=70_000, seed=13)))
    out.append(("displacement-only",
                crandall.Scene.scaled(tau0=math.inf, times=[0.5, 1.0], observe=["displacement"]),
                dict(paths=500, seed=14, dt=0.02, method="exact")))
    out.append(("distance-stop",
                crandall.Scene.scaled(tau0=1.0, times=[1.0], observe=["distance", "stop"]),
                dict(paths=500, seed=15, dt=0.02, method="richardson")))
    out.append(("si-crate",
                crandall.Scene(mu=0.3, h=1.0, t0=2.0, mass=100.0, times=[0.5, 2.0, 3.0],
                               observe=ALL),
                dict(paths=400, seed=16)))
    # Pauses: before the shaking (the body at rest), between two shocks (where bodies come to
    # rest and stay there) and with a start in motion; peaks on.
    pauses = crandall.Scene(mu=0.3, h=[0.0, 1.0, 0.0, 0.7], t0=[0.5, 1.5, 3.0, 3.5],
                            times=[0.25, 1.0, 2.0, 2.8, 4.0], observe=ALL + ["peaks"])
    for method in ("richardson", "exact", "euler", "refine"):
        out.append((f"si-pauses-{method}", pauses, dict(paths=700, seed=17, dt=0.01,
                                                       method=method)))
    out.append(("si-pauses-moving-start",
                crandall.Scene(mu=0.3, h=[0.0, 1.0, 0.0], t0=[0.5, 1.5, 3.0], v0=0.6,
                               times=[0.1, 1.0, 2.0], observe=["velocity", "stop"]),
                dict(paths=400, seed=18)))
    return out


def _hex(values):
    if isinstance(values, float):
        return values.hex()
    return [float(v).hex() for v in values]


def _statistics(result):
    stats = {}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # NaN statistics of small runs are part of the record
        for name in result.names:
            for stat in ("mean", "var", "stderr"):
                stats[f"{name}.{stat}"] = _hex(getattr(result, stat)(name))
            if name != "kinetic_energy":
                stats[f"{name}.var_stderr"] = _hex(result.var_stderr(name))
        obs = set(result.scene.observe)
        if result.scene.units == "scaled" and result.times.size:
            has_u = "displacement" in obs
            has_s = bool(obs & {"distance", "dissipated_energy"})
            for j in range(5):
                for k in range(5 - j):
                    for l in range(5 - j - k):  # noqa: E741 - the paper's index
                        if (k and not has_u) or (l and not has_s):
                            continue
                        stats[f"moment{j}{k}{l}"] = _hex(result.moment(j, k, l))
    return stats


def snapshot():
    return {label: _statistics(crandall.simulate(scene, threads=2, **kw))
            for label, scene, kw in _runs()}


def test_every_statistic_has_its_stored_bits():
    assert_same_bits(DATA, snapshot())


if __name__ == "__main__":
    regenerate(DATA, snapshot, pathlib.Path(__file__).name)
