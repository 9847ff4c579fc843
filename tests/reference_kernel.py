"""A slow, plain NumPy reference of the whole path: the grid, the exact skeleton, the trapezoid
integrals, Richardson's coarse grids, the coast after the switch-off and the stop.

Written from the documents (docs/exact-step.md, docs/integrals.md, docs/methods/richardson.md)
and the plan's rules, not from the kernel's code paths: every path is a row of NumPy arrays,
every step one line. ``tests/test_reference_kernel.py`` computes the statistics of these paths
in NumPy and compares them with the kernel's accumulators (msprime's algorithms.py habit: a
slow oracle kept beside the fast code).
"""

from __future__ import annotations

import math
from typing import Dict, List, Tuple

import numpy as np

import reference_rng as rng

GRIDS = {"exact": 1, "richardson2": 2, "richardson": 3}


def segments(times, t0: float, dt: float, method: str, *, integrals: bool,
             stop: bool) -> Tuple[List[Tuple[float, int, int]], List[int]]:
    """The plan's grid: (step length, steps, output slot or -1) per segment up to the switch-off
    (or the last output time), and the output slots after it (reached by the coast)."""
    times = list(times)
    after = bool(times) and times[-1] > t0
    end = t0 if (stop or after) else times[-1]
    group = 1 << (GRIDS[method] - 1)  # coarse grids need step counts in multiples of 2 (4)
    out, previous = [], 0.0

    def add(until, slot):
        nonlocal previous
        gap = until - previous
        n = 0
        if gap > 0:
            n = math.ceil(gap / dt * (1.0 - 1e-12)) if integrals else 1
            n = max(n, 1)
            if integrals:
                n = (n + group - 1) // group * group
        out.append((gap / n if n else 0.0, n, slot))
        previous = until

    slot = 0
    while slot < len(times) and times[slot] <= end:
        add(times[slot], slot)
        slot += 1
    if previous < end:
        add(end, -1)
    return out, list(range(slot, len(times)))


def coast(x, u, s, drift: float, elapsed):
    """The deterministic motion after the switch-off (paper eq13a-eq14): deceleration at rate
    ``drift`` to rest, then rest."""
    speed, sign = np.abs(x), np.sign(x)
    stopped = elapsed * drift >= speed
    travelled = np.where(stopped, 0.5 * speed * speed / drift,
                         elapsed * (speed - 0.5 * drift * elapsed))
    velocity = np.where(stopped, 0.0, sign * (speed - drift * elapsed))
    return velocity, u + sign * travelled, s + travelled


def run(*, seed: int, paths: int, times, t0: float, dt: float, method: str,
        drift: float = 2.0, noise: float = math.sqrt(2.0)) -> Dict[str, np.ndarray]:
    """Every path of a run observing velocity, displacement, distance and the stop.

    Returns per grid g (0: step h; 1, 2: Richardson's 2h, 4h) arrays ``x``, ``u``, ``s`` of
    shape (grids, slots, paths) and the stop triple ``stop`` of shape (grids, 3, paths): the
    time from the switch-off to the stop, and the displacement and distance there.
    """
    grids = GRIDS[method]
    segs, coasting = segments(times, t0, dt, method, integrals=True, stop=True)
    idx = np.arange(paths, dtype=np.uint64)
    x = np.zeros(paths)
    u = np.zeros((grids, paths))
    s = np.zeros((grids, paths))
    start = [x.copy() for _ in range(grids)]  # where each coarse step began
    slots = len(times)
    out_x = np.zeros((slots, paths))
    out_u = np.zeros((grids, slots, paths))
    out_s = np.zeros((grids, slots, paths))
    k = 0
    noise_pair = None
    for h, n, slot in segs:
        for _ in range(n):
            if k % 2 == 0:
                noise_pair = rng.draw_pairs(seed, idx, k // 2)
            j = k % 2
            x1 = rng.exact_step(x, h, drift, noise, noise_pair[j], noise_pair[2 + j],
                                noise_pair[4 + j])
            # Trapezoid rule on the exact skeleton (docs/integrals.md).
            u[0] += 0.5 * h * (x + x1)
            s[0] += 0.5 * h * (np.abs(x) + np.abs(x1))
            for g in range(1, grids):
                span = 1 << g
                if k % span == 0:
                    start[g] = x.copy()
                if k % span == span - 1:
                    hg = 0.5 * h * span
                    u[g] += hg * (start[g] + x1)
                    s[g] += hg * (np.abs(start[g]) + np.abs(x1))
            x = x1
            k += 1
        if slot >= 0:
            out_x[slot] = x
            out_u[:, slot] = u
            out_s[:, slot] = s
    stop = np.zeros((grids, 3, paths))
    for g in range(grids):
        for slot in coasting:
            cx, cu, cs = coast(x, u[g], s[g], drift, times[slot] - t0)
            out_x[slot], out_u[g, slot], out_s[g, slot] = cx, cu, cs
        to_stop = np.abs(x) / drift
        _, su, ss = coast(x, u[g], s[g], drift, to_stop)
        stop[g] = to_stop, su, ss
    return {"x": np.broadcast_to(out_x, (grids,) + out_x.shape), "u": out_u, "s": out_s,
            "stop": stop, "steps": k}


def weights(method: str) -> np.ndarray:
    """Richardson's weights: sum w_j = 1, sum w_j 2^(j p) = 0 for p in {3/2, 2} (richardson)
    or p = 3/2 (richardson2) (docs/methods/richardson.md)."""
    grids = GRIDS[method]
    powers = [1.5, 2.0][:grids - 1]
    a = np.array([[1.0] * grids] + [[2.0 ** (j * p) for j in range(grids)] for p in powers])
    b = np.zeros(grids)
    b[0] = 1.0
    return np.linalg.solve(a, b)


def mean_and_var(values: np.ndarray, method: str) -> Tuple[np.ndarray, np.ndarray]:
    """Mean and unbiased variance over paths (last axis) of per-grid values (first axis),
    extrapolated with Richardson's weights: every raw moment is the weighted sum of the
    grids' moments, so the variance is sum_j w_j mean((X_j - m)^2), m = sum_j w_j mean(X_j)."""
    w = weights(method)
    n = values.shape[-1]
    mean = np.tensordot(w, values.mean(axis=-1), axes=1)
    second = np.tensordot(w, ((values - mean[..., None]) ** 2).mean(axis=-1), axes=1)
    return mean, second * n / (n - 1)
