"""NumPy vectorised Euler-Maruyama for the body on a floor shaken with a piecewise-constant
intensity, in SI units, the way a user writes it: one array per variable over a batch of
paths, one Python-level loop over the steps, a NumPy Generator for the noise.

    dV = -mu g sign(V) dt + h_i dW,  dS = |V| dt   (t in piece i: [e_{i-1}, e_i), e_0 = 0)

Every piece is cut into equal steps of at most ``dt`` (so no step straddles a piece end and
each step uses its own piece's intensity); the distance takes the velocity at the start of
the step, as the velocity's Euler step does. After the last piece end the coast is closed
form: the body stops at e_last + |V| / (mu g) and the distance grows by V^2 / (2 mu g).
Returns per-path values, so that any statistic can be formed; with ``quadratic=True`` also
the quadratic variation sum_k h_k^2 V_k^2 dt_k (the velocity at each step's start, as Ito's
sums take it), whose mean over (mu g)^2 is the variance of the distance at the stop by Ito's
isometry, up to the scheme's bias. Independent of crandall.
"""

from __future__ import annotations

import math
from typing import Dict, List, Sequence

import numpy as np


def grid(ends: Sequence[float], dt: float) -> List[tuple]:
    """The steps as (count, step length, piece index): each piece cut into equal steps <= dt."""
    out, start = [], 0.0
    for i, e in enumerate(ends):
        length = float(e) - start
        n = max(1, math.ceil(length / dt - 1e-9))
        out.append((n, length / n, i))
        start = float(e)
    return out


def steps(ends: Sequence[float], dt: float) -> int:
    """Steps per path on that grid."""
    return sum(n for n, _, _ in grid(ends, dt))


def simulate(paths: int, dt: float, h: Sequence[float], ends: Sequence[float], mu: float,
             g: float = 9.81, seed: int = 0, v0: float = 0.0,
             batch: int = 100_000, quadratic: bool = False) -> Dict[str, np.ndarray]:
    """Per-path velocity at the last piece end, distance there, stop time and distance at
    the stop, for intensities ``h[i]`` (m s^-3/2) on the pieces ending at ``ends[i]`` (s);
    with ``quadratic`` the quadratic variation too (its arithmetic only then)."""
    if len(h) != len(ends) or not len(h):
        raise ValueError("h and ends must have the same, nonzero length")
    a = mu * g
    rng = np.random.default_rng(seed)
    plan = grid(ends, dt)
    out = {"velocity": np.empty(paths), "distance": np.empty(paths),
           "stop_time": np.empty(paths), "distance_at_stop": np.empty(paths)}
    if quadratic:
        out["quadratic_variation"] = np.empty(paths)
    for start in range(0, paths, batch):
        n = min(batch, paths - start)
        v = np.full(n, float(v0))
        s = np.zeros(n)
        q = np.zeros(n) if quadratic else None
        for count, step, i in plan:
            drift = a * step
            noise = float(h[i]) * math.sqrt(step)
            weight = float(h[i]) ** 2 * step
            for _ in range(count):
                s += np.abs(v) * step
                if quadratic:
                    q += weight * (v * v)
                v += -drift * np.sign(v) + noise * rng.standard_normal(n)
        sl = slice(start, start + n)
        out["velocity"][sl] = v
        out["distance"][sl] = s
        out["stop_time"][sl] = float(ends[-1]) + np.abs(v) / a
        out["distance_at_stop"][sl] = s + v * v / (2.0 * a)
        if quadratic:
            out["quadratic_variation"][sl] = q
    return out


def mean_distance_at_stop(dt: float, h: Sequence[float], ends: Sequence[float], mu: float,
                          g: float = 9.81, v0: float = 0.0) -> float:
    """What this scheme's mean distance at the stop is, exactly: Ito's formula for the Euler
    step, E V_{k+1}^2 = E V_k^2 - 2 a E|V_k| dt_k + h_k^2 dt_k + a^2 dt_k^2 P(V_k != 0),
    summed and closed by the coast, gives
    E S_stop = (v0^2 + sum h_k^2 dt_k + a^2 sum dt_k^2) / (2 a), where the last sum leaves
    out the first step when v0 = 0 (sign(0) = 0 there). The exact model's value lacks the
    a^2 dt^2 terms: their sum, about a T dt / 2 in distance, is the scheme's bias."""
    a = mu * g
    energy, chatter, first = float(v0) ** 2, 0.0, True
    for count, step, i in grid(ends, dt):
        energy += float(h[i]) ** 2 * step * count
        k = count - 1 if (first and v0 == 0.0) else count
        chatter += a * a * step * step * k
        first = False
    return (energy + chatter) / (2.0 * a)
