"""Splitting's loop in the core (``_core.split_replica``, cpp/src/split.cpp) for a white-noise
scene: the same iterations as splitting.py's Python loop, operation by operation, so the same
bits (tests/test_tail_split_core.py), at the core's speed."""

from __future__ import annotations

from typing import Any, Dict, List, Optional, Sequence, Tuple

import numpy as np

from .. import _core
from .problem import _Problem


def core_replicas(problem: _Problem, levels: np.ndarray, particles: int, kill: int, key: int,
                  replicas: Sequence[int], threads: int, max_iterations: int,
                  top: Optional[float], first: int, thresholds: np.ndarray, uncoast: bool,
                  deadline: Optional[float]) -> List[Tuple[np.ndarray, Dict[str, Any]]]:
    """_splitting_replica's result (estimates, info) for each of ``replicas``, from the core's
    loop, which runs them in step (their clones share the vector lanes; each replica's bits are
    those it has alone)."""
    scene = problem.scene
    normaliser = None
    if top is not None:
        points, cum, stationary, step = problem._normaliser()
        normaliser = (points, cum[0], cum[1], cum[2], stationary, step, problem.floor2(),
                      problem._scale())
    outcomes = _core.split_replica(
        problem.lengths, problem.noises, problem.drifts, key, [int(r) for r in replicas],
        particles, kill, max_iterations, deadline, float(scene.v0), float(scene.u0), first,
        np.asarray(levels, dtype=np.float64), np.asarray(thresholds, dtype=np.float64),
        problem.core_quantity, float(scene.drift), float(problem.horizon),
        # The scene's mass: the core's energy score is the distance's times mass * c (the
        # energy row's factor); no other score reads it.
        float(problem.coast), float(scene.mass), problem.remaining,
        bool(uncoast), top, normaliser, threads)
    out = []
    for est, iterations, steps, log_weight, extinct, timed_out in outcomes:
        info: Dict[str, Any] = {"iterations": int(iterations), "steps": int(steps),
                                "log_weight": float(log_weight)}
        if timed_out:
            info["timed_out"] = True
        else:
            info["extinct"] = float(log_weight) if extinct else None
        out.append((est, info))
    return out
