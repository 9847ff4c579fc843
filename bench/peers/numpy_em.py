"""NumPy vectorised Euler-Maruyama for eq3, the way a user writes it: one array per variable
over a batch of paths, one Python-level loop over the steps, a NumPy Generator for the noise.

    dU1 = -2 sign(U1) dtau + sqrt(2) dW,  dU2 = U1 dtau,  dU3 = |U1| dtau   (tau < tau0)

After tau0 the coast is closed form, as in the paper (eq13a-eq14): stop at tau0 + |U1|/2, the
distance grows by U1^2/4. Returns per-path values, so that any statistic can be formed.
"""

from __future__ import annotations

import math

import numpy as np


def simulate(paths: int, dt: float, times, tau0: float, seed: int, batch: int = 100_000):
    """Per-path (velocity, displacement, distance) at each time <= tau0, the stop time and the
    distance at the stop. ``times`` must be multiples of the step (checked)."""
    times = [float(t) for t in times]
    marks = [round(t / dt) for t in times]
    if any(abs(m * dt - t) > 1e-9 for m, t in zip(marks, times)) or times[-1] > tau0:
        raise ValueError("times must be multiples of dt and <= tau0")
    n_total = round(tau0 / dt)
    rng = np.random.default_rng(seed)
    out = {"velocity": np.empty((len(times), paths)), "displacement": np.empty((len(times), paths)),
           "distance": np.empty((len(times), paths)), "stop_time": np.empty(paths),
           "distance_at_stop": np.empty(paths)}
    sq = math.sqrt(2.0 * dt)
    for start in range(0, paths, batch):
        n = min(batch, paths - start)
        x = np.zeros(n)
        u = np.zeros(n)
        s = np.zeros(n)
        j = 0
        for k in range(1, n_total + 1):
            u += x * dt
            s += np.abs(x) * dt
            x += -2.0 * np.sign(x) * dt + sq * rng.standard_normal(n)
            while j < len(marks) and marks[j] == k:
                out["velocity"][j, start:start + n] = x
                out["displacement"][j, start:start + n] = u
                out["distance"][j, start:start + n] = s
                j += 1
        out["stop_time"][start:start + n] = tau0 + np.abs(x) / 2.0
        out["distance_at_stop"][start:start + n] = s + x * x / 4.0
    return out
