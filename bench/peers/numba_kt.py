"""Numba Euler-Maruyama for a body on a foundation shaken by Kanai-Tajimi filtered white
noise, written the way users write it (bench and tests only; numba is not a dependency of
crandall): a compiled loop over paths and steps, ``rng.standard_normal()`` per step.

    x'' + 2 zeta omega x' + omega^2 x = -h xi(t)  (t < t0; no noise after),
    a_g = -(2 zeta omega x' + omega^2 x),
    V' = -a_g - mu g sign(V) while sliding; at rest while |a_g| <= mu_s g.

Each step: the filter by Euler-Maruyama, then the body by Euler from the step's a_g; a
sliding body whose velocity would change sign comes to rest if |a_g| <= mu_s g (else it
slides on the other way); a body at rest starts to slide, away from a_g, once |a_g| > mu_s g.
At t0 the shaking ends (a_g = 0 afterwards, crandall's default): the body slides to rest.
With ``ring_down`` only the driving noise ends and the filter rings down; a path then ends
at rest once the filter's energy bounds every later |a_g| by mu_s g
(|a_g| <= omega (1 + 2 zeta) sqrt(x'^2 + omega^2 x^2)).
Returns the distance and the time at the stop per path.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit


@njit(cache=False)
def _kernel(rng, paths, dt, t0, omega, zeta, h, mu_g, mus_g, ring_down, dist, stop):
    w2 = omega * omega
    c1 = 2.0 * zeta * omega
    sq = h * math.sqrt(dt)
    n0 = int(round(t0 / dt))
    bound = omega * (1.0 + 2.0 * zeta)
    for p in range(paths):
        x = 0.0
        xd = 0.0
        v = 0.0
        s = 0.0
        last_rest = 0.0
        k = 0
        while True:
            ag = -(c1 * xd + w2 * x) if k < n0 or ring_down else 0.0
            if v == 0.0:
                if abs(ag) > mus_g:
                    sg = -1.0 if ag > 0.0 else 1.0
                    v = (-ag - sg * mu_g) * dt
            else:
                sg = 1.0 if v > 0.0 else -1.0
                vn = v + (-ag - sg * mu_g) * dt
                if vn * v <= 0.0 and abs(ag) <= mus_g:
                    vn = 0.0
                    last_rest = (k + 1) * dt
                s += 0.5 * (abs(v) + abs(vn)) * dt
                v = vn
            noise = sq * rng.standard_normal() if k < n0 else 0.0
            xn = x + xd * dt
            xd = xd + (-w2 * x - c1 * xd) * dt - noise
            x = xn
            k += 1
            if k >= n0 and v == 0.0 and (
                    not ring_down or bound * math.sqrt(xd * xd + w2 * x * x) <= mus_g):
                break
        dist[p] = s
        # The last time the body came to rest (before t0 for one at rest from then on).
        stop[p] = last_rest


def simulate(paths: int, dt: float, *, t0: float, omega: float, zeta: float, h: float,
             mu_g: float, mus_g: float = None, ring_down: bool = False, seed: int = 0):
    """Distances and stop times at the stop of ``paths`` paths."""
    rng = np.random.default_rng(seed)
    dist, stop = np.empty(paths), np.empty(paths)
    _kernel(rng, paths, dt, t0, omega, zeta, h, mu_g, mu_g if mus_g is None else mus_g,
            ring_down, dist, stop)
    return {"distance_at_stop": dist, "stop_time": stop}


def warm_up() -> None:
    """Compile once, outside any timing."""
    simulate(10, 0.1, t0=1.0, omega=1.0, zeta=0.5, h=1.0, mu_g=1.0)
