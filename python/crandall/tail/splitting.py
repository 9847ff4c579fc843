"""Adaptive multilevel splitting: one replica, an unbiased estimate of P(Q > L) for each level L
(docs/methods/tails.md)."""

from __future__ import annotations

import time as _time
from typing import Optional, Sequence

import numpy as np

from .. import _core
from . import detmath
from .problem import _extend, _Problem
from .split_core import core_replicas
#: A replica's path streams: replica r uses streams r * 2^40 + 0, 1, ...
_REPLICA_STREAMS = 1 << 40


def _normalised_top(problem: _Problem, levels: np.ndarray, schedule: bool = True) -> Optional[float]:
    """The level splitting's score is normalised towards: the one level of a run of one level
    of a quantity whose score is ``normalised`` (problem.SCORES) under one intensity (None: the
    plain score). ``schedule=False`` drops the schedule's condition (bench/tails_score.py)."""
    return float(levels[0]) if len(levels) == 1 and problem.normalisable(schedule) else None


def _splitting_replicas(problem: _Problem, levels: np.ndarray, particles: int, kill: int,
                        key: int, replicas: Sequence[int], threads: int, max_iterations: int,
                        deadline: Optional[float] = None):
    """_splitting_replica's (estimates, info) for each of ``replicas``: a white-noise problem's
    in the core at once, in step (the same bits as one by one: tests/test_tail_split_core.py),
    others one by one."""
    if not problem.in_core:
        return [_splitting_replica(problem, levels, particles, kill, key, r, threads,
                                   max_iterations, deadline=deadline) for r in replicas]
    top, first, thresholds, uncoast = _score_form(problem, levels, None)
    return core_replicas(problem, levels, particles, kill, key, replicas, threads,
                         max_iterations, top, first, thresholds, uncoast, deadline)


def _score_form(problem: _Problem, levels: np.ndarray, normalise: Optional[bool]):
    """What a replica ranks its paths by: the normalised score's level (or None), the first
    point of the path maxima, the levels on the rank's scale, and whether the velocity is
    ranked before the coast's clip."""
    top = None if normalise is False else _normalised_top(problem, levels, normalise is None)
    first = problem.first_random_point() if top is not None else 0
    thresholds = (np.array([problem.split_threshold(float(x), top) for x in levels])
                  if top is not None else levels)
    uncoast = top is None and problem.coasts_to_rest(levels)
    return top, first, thresholds, uncoast


def _splitting_replica(problem: _Problem, levels: np.ndarray, particles: int, kill: int,
                       key: int, replica: int, threads: int, max_iterations: int,
                       normalise: Optional[bool] = None, deadline: Optional[float] = None,
                       core: bool = True):
    """One run of adaptive multilevel splitting: an unbiased estimate of P(Q > L) for each L.

    The estimate for L is taken at the first iteration whose kill level z (the kill-th smallest
    path maximum of the score) reaches L: prod(1 - K_j / n) times the fraction of the particles
    with Q > L, K_j the number killed at iteration j (every particle at or below z, so ties are
    killed together: Bréhier et al. 2016). If every particle sits at z the estimate is 0.

    A run of one level of a quantity whose score is ``normalised`` (problem.SCORES) under one intensity ranks the paths by the
    normalised score (_Problem.split_score) over the points from the first random one on (the
    points before are every path's, so a maximum there would tie them all); the level is then
    its threshold.
    ``normalise``: None, the rule above (crandall.tail's); False, the plain score; True, the
    normalised one whatever the schedule (bench/tails_score.py compares them).
    The velocity and speed after the switch-off rank the paths before the coast's clip at rest
    (_Problem.coasts_to_rest).

    ``deadline`` (a ``time.time()``): past it, between iterations, the replica stops and its
    info says so (``timed_out``, with the iterations and log weight it reached); its estimates
    are then NaN and no sample. The info's ``extinct`` is the log weight at an extinction.

    The weight prod_j (1 - K_j / n) is computed as the running product of the fractions
    (n - K_j) / n, each a correctly rounded division, multiplied in iteration order: the same
    bits on every CPU (an exp of a sum of logs would not be: library exp and log1p round
    differently from one CPU to another). Each factor is at least 1 / n, so the product stays a
    normal double down to about 1e-308, far below any level a run reaches. The log weight (for
    messages and extinctions) is the sum of detmath.log1p(-K_j / n), the core's.

    The parents of iteration j's clones are ``_core.split_parents(key, replica, j, ...)``.
    A white-noise problem runs the same loop in the core (split_core.py; ``core=False``: this
    one, the reference the core's is tested against).
    """
    n = particles
    top, first, thresholds, uncoast = _score_form(problem, levels, normalise)
    if core and problem.in_core:
        return core_replicas(problem, levels, n, kill, key, [replica], threads, max_iterations,
                             top, first, thresholds, uncoast, deadline)[0]
    base = replica * _REPLICA_STREAMS
    states = problem.start_states(n)
    _extend(problem, states, np.arange(n), np.zeros(n), base + np.arange(n), key, threads)
    branches = n
    steps = n * problem.steps
    score, plain = problem.split_score(states, top, uncoast)
    level = score[:, first:].max(axis=1)
    value = problem.value(plain)
    order = np.argsort(levels, kind="stable")
    estimates = np.full(len(levels), np.nan)
    weight = 1.0
    log_weight = 0.0
    done = 0
    iterations = 0
    extinct = None
    while True:
        if deadline is not None and _time.time() > deadline:
            return estimates, {"iterations": iterations, "steps": steps,
                               "log_weight": log_weight, "timed_out": True}
        z = np.partition(level, kill - 1)[kill - 1]
        while done < len(order) and thresholds[order[done]] <= z:
            estimates[order[done]] = weight * np.mean(value > levels[order[done]])
            done += 1
        if done == len(order):
            break
        killed = np.flatnonzero(level <= z)
        if len(killed) == n:
            estimates[order[done:]] = 0.0  # extinction: every particle at the same level
            extinct = log_weight
            break
        if iterations >= max_iterations:
            raise RuntimeError(f"splitting did not reach the level after {iterations} iterations")
        weight = weight * ((n - len(killed)) / n)
        log_weight += detmath.scalar(detmath.log1p, -len(killed) / n)
        survivors = np.flatnonzero(level > z)
        parents = survivors[_core.split_parents(key, replica, iterations, len(survivors),
                                                len(killed))]
        branch = np.argmax(score[parents, first:] > z, axis=1) + first
        states[killed] = states[parents]
        _extend(problem, states, killed, branch, base + branches + np.arange(len(killed)), key,
                threads)
        branches += len(killed)
        steps += int(np.sum(problem.steps - branch))
        score[killed], plain = problem.split_score(states[killed], top, uncoast)
        level[killed] = score[killed, first:].max(axis=1)
        value[killed] = problem.value(plain)
        iterations += 1
    return estimates, {"iterations": iterations, "steps": steps, "log_weight": log_weight,
                       "extinct": extinct}
