"""Numba Euler-Maruyama for eq3 with a NumPy Generator, the way a user writes it: a compiled
loop over paths and steps, ``rng.standard_normal()`` per step (Numba supports Generator
objects in nopython mode). Same output as numpy_em.simulate. Needs ``pip install numba``
(a dependency of this benchmark only, not of crandall).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit


@njit(cache=False)
def _kernel(rng, paths, dt, marks, n_total, tau0, vel, disp, dist, ts, sstop):
    sq = math.sqrt(2.0 * dt)
    for p in range(paths):
        x = 0.0
        u = 0.0
        s = 0.0
        j = 0
        for k in range(1, n_total + 1):
            u += x * dt
            s += abs(x) * dt
            sg = 1.0 if x > 0.0 else (-1.0 if x < 0.0 else 0.0)
            x += -2.0 * sg * dt + sq * rng.standard_normal()
            while j < marks.size and marks[j] == k:
                vel[j, p] = x
                disp[j, p] = u
                dist[j, p] = s
                j += 1
        ts[p] = tau0 + abs(x) / 2.0
        sstop[p] = s + x * x / 4.0


def simulate(paths: int, dt: float, times, tau0: float, seed: int):
    times = [float(t) for t in times]
    marks = np.array([round(t / dt) for t in times], dtype=np.int64)
    if any(abs(m * dt - t) > 1e-9 for m, t in zip(marks, times)) or times[-1] > tau0:
        raise ValueError("times must be multiples of dt and <= tau0")
    rng = np.random.default_rng(seed)
    out = {"velocity": np.empty((len(times), paths)), "displacement": np.empty((len(times), paths)),
           "distance": np.empty((len(times), paths)), "stop_time": np.empty(paths),
           "distance_at_stop": np.empty(paths)}
    _kernel(rng, paths, dt, marks, round(tau0 / dt), tau0, out["velocity"], out["displacement"],
            out["distance"], out["stop_time"], out["distance_at_stop"])
    return out


def warm_up() -> None:
    """Compile once, outside any timing."""
    simulate(10, 0.5, [1.0], 1.0, 0)
