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
            v, s, rest = _body(x, xd, v, s, ag, mu_g, mus_g, dt)
            if rest:
                last_rest = (k + 1) * dt
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


@njit(cache=False)
def _body(x, xd, v, s, ag, mu_g, mus_g, dt):
    """One Euler step of the body from the step's a_g: (v, s) after it, and whether it came to
    rest."""
    rest = False
    if v == 0.0:
        if abs(ag) > mus_g:
            sg = -1.0 if ag > 0.0 else 1.0
            v = (-ag - sg * mu_g) * dt
    else:
        sg = 1.0 if v > 0.0 else -1.0
        vn = v + (-ag - sg * mu_g) * dt
        if vn * v <= 0.0 and abs(ag) <= mus_g:
            vn = 0.0
            rest = True
        s += 0.5 * (abs(v) + abs(vn)) * dt
        v = vn
    return v, s, rest


@njit(cache=False)
def _coupled(rng, paths, dt, t0, omega, zeta, h, mu_g, mus_g, fine, coarse):
    """The same paths at dt and 2 dt: the coarse step's noise is the sum of the two fine
    steps' (the shaking ends at t0, a multiple of 2 dt)."""
    w2 = omega * omega
    c1 = 2.0 * zeta * omega
    sq = h * math.sqrt(dt)
    n0 = int(round(t0 / dt))
    for p in range(paths):
        x = xd = v = s = 0.0
        xc = xdc = vc = sc = 0.0
        k = 0
        while k < n0:
            n1 = sq * rng.standard_normal()
            n2 = sq * rng.standard_normal()
            for noise in (n1, n2):
                ag = -(c1 * xd + w2 * x)
                v, s, _ = _body(x, xd, v, s, ag, mu_g, mus_g, dt)
                xn = x + xd * dt
                xd = xd + (-w2 * x - c1 * xd) * dt - noise
                x = xn
            ag = -(c1 * xdc + w2 * xc)
            vc, sc, _ = _body(xc, xdc, vc, sc, ag, mu_g, mus_g, 2 * dt)
            xn = xc + xdc * 2 * dt
            xdc = xdc + (-w2 * xc - c1 * xdc) * 2 * dt - (n1 + n2)
            xc = xn
            k += 2
        # The shaking has ended: each slides to rest (a_g = 0) at its own step.
        while v != 0.0:
            v, s, _ = _body(x, xd, v, s, 0.0, mu_g, mus_g, dt)
        while vc != 0.0:
            vc, sc, _ = _body(xc, xdc, vc, sc, 0.0, mu_g, mus_g, 2 * dt)
        fine[p] = s
        coarse[p] = sc


#: The control variates of ``coupled_at_controls``, per horizon (the output time, then t0):
#: sums over the fine steps before it of dt a_g^2, dt G^2, dt |a_g|, dt |G|, dt D^2 (G and D
#: the ground's velocity and displacement, integrals of a_g by the same Euler steps), then
#: G, G^2, D, D^2 at the horizon, then sums of the step's noise times V, S, sign V, 1 and
#: (horizon - t) V (the body before the step).
CONTROL_NAMES = ("sum_a2", "sum_g2", "sum_abs_a", "sum_abs_g", "sum_d2", "g", "g2", "d", "d2",
                 "noise_v", "noise_s", "noise_sign_v", "noise", "noise_left_v")
N_CONTROLS = len(CONTROL_NAMES)


@njit(cache=False)
def _coupled_at(rng, paths, dt, t0, n_out, omega, zeta, h, mu_g, mus_g, fine, coarse,
                controls, keep):
    """``_coupled`` that also keeps, per path, the distance and the velocity at fine step
    ``n_out`` (an even number of fine steps, so a coarse step ends there too): columns 0, 1,
    2 of ``fine`` and ``coarse`` are the distance at the stop, the distance at the output time
    and the velocity there; with ``keep``, also the control variates of CONTROL_NAMES on the
    fine steps in ``controls``: columns 0-13 up to the output time, 14-27 up to t0."""
    w2 = omega * omega
    c1 = 2.0 * zeta * omega
    sq = h * math.sqrt(dt)
    n0 = int(round(t0 / dt))
    nc = N_CONTROLS
    for p in range(paths):
        x = xd = v = s = 0.0
        g = d = 0.0
        xc = xdc = vc = sc = 0.0
        if keep:
            for j in range(2 * nc):
                controls[p, j] = 0.0
        k = 0
        while k < n0:
            n1 = sq * rng.standard_normal()
            n2 = sq * rng.standard_normal()
            for noise in (n1, n2):
                ag = -(c1 * xd + w2 * x)
                t = k * dt
                sgn = 0.0 if v == 0.0 else (1.0 if v > 0.0 else -1.0)
                for hz in range(2 if keep else 0):
                    if hz == 0 and k >= n_out:
                        continue
                    o = hz * nc
                    left = (n_out * dt if hz == 0 else t0) - t
                    controls[p, o + 0] += dt * ag * ag
                    controls[p, o + 1] += dt * g * g
                    controls[p, o + 2] += dt * abs(ag)
                    controls[p, o + 3] += dt * abs(g)
                    controls[p, o + 4] += dt * d * d
                    controls[p, o + 9] += noise * v
                    controls[p, o + 10] += noise * s
                    controls[p, o + 11] += noise * sgn
                    controls[p, o + 12] += noise
                    controls[p, o + 13] += noise * left * v
                v, s, _ = _body(x, xd, v, s, ag, mu_g, mus_g, dt)
                xn = x + xd * dt
                xd = xd + (-w2 * x - c1 * xd) * dt - noise
                x = xn
                d += g * dt
                g += ag * dt
                k += 1
                if keep and (k == n_out or k == n0):
                    o = 0 if k == n_out else nc
                    controls[p, o + 5] = g
                    controls[p, o + 6] = g * g
                    controls[p, o + 7] = d
                    controls[p, o + 8] = d * d
            ag = -(c1 * xdc + w2 * xc)
            vc, sc, _ = _body(xc, xdc, vc, sc, ag, mu_g, mus_g, 2 * dt)
            xn = xc + xdc * 2 * dt
            xdc = xdc + (-w2 * xc - c1 * xdc) * 2 * dt - (n1 + n2)
            xc = xn
            if k == n_out:
                fine[p, 1] = s
                fine[p, 2] = v
                coarse[p, 1] = sc
                coarse[p, 2] = vc
        while v != 0.0:
            v, s, _ = _body(x, xd, v, s, 0.0, mu_g, mus_g, dt)
        while vc != 0.0:
            vc, sc, _ = _body(xc, xdc, vc, sc, 0.0, mu_g, mus_g, 2 * dt)
        fine[p, 0] = s
        coarse[p, 0] = sc


def control_means(dt: float, t_out: float, *, t0: float, omega: float, zeta: float,
                  h: float) -> np.ndarray:
    """The exact means of ``coupled_at_controls``' controls: the fine steps' state (x, x', G, D)
    is a linear Gaussian recursion z' = F z + noise, whose covariance P' = F P F^T + Q is
    propagated here step by step from P = 0; a_g = c.z, so E a_g^2 = c P c^T and E |a_g| =
    sqrt(2 / pi) sqrt(c P c^T) (a centred Gaussian), and likewise for G and D. The noise
    sums have mean 0: each step's noise is independent of the body before the step."""
    w2, c1 = omega * omega, 2.0 * zeta * omega
    f = np.array([[1.0, dt, 0.0, 0.0],
                  [-w2 * dt, 1.0 - c1 * dt, 0.0, 0.0],
                  [-w2 * dt, -c1 * dt, 1.0, 0.0],
                  [0.0, 0.0, dt, 1.0]])
    q = np.zeros((4, 4))
    q[1, 1] = h * h * dt
    c = np.array([-w2, -c1, 0.0, 0.0])
    n0, n_out = int(round(t0 / dt)), int(round(t_out / dt))
    out = np.zeros(2 * N_CONTROLS)
    p = np.zeros((4, 4))
    root = math.sqrt(2.0 / math.pi)
    for k in range(n0 + 1):
        if k == n_out or k == n0:
            o = 0 if k == n_out else N_CONTROLS
            out[o + 6], out[o + 8] = p[2, 2], p[3, 3]
        if k == n0:
            break
        va = c @ p @ c
        step = np.array([dt * va, dt * p[2, 2], dt * root * math.sqrt(max(va, 0.0)),
                         dt * root * math.sqrt(max(p[2, 2], 0.0)), dt * p[3, 3]])
        out[N_CONTROLS:N_CONTROLS + 5] += step
        if k < n_out:
            out[:5] += step
        p = f @ p @ f.T + q
    return out


def _run_at(paths, dt, t_out, t0, omega, zeta, h, mu_g, mus_g, seed, keep):
    """The coupled paths with an output time (``_coupled_at``): (fine, coarse, controls)."""
    for name, t in (("t0", t0), ("t_out", t_out)):
        if abs(round(t / (2 * dt)) * 2 * dt - t) > 1e-9 * t:
            raise ValueError(f"{name} must be a multiple of 2 dt")
    if not 0.0 < t_out < t0:
        raise ValueError("t_out must lie in (0, t0)")
    rng = np.random.default_rng(seed)
    fine, coarse = np.empty((paths, 3)), np.empty((paths, 3))
    controls = np.empty((paths if keep else 1, 2 * N_CONTROLS))
    _coupled_at(rng, paths, dt, t0, int(round(t_out / dt)), omega, zeta, h, mu_g,
                mu_g if mus_g is None else mus_g, fine, coarse, controls, keep)
    return fine, coarse, controls


def coupled_at_controls(paths: int, dt: float, t_out: float, *, t0: float, omega: float,
                        zeta: float, h: float, mu_g: float, mus_g: float = None,
                        seed: int = 0):
    """``coupled_at`` and, per path, the control variates of CONTROL_NAMES (columns 0-13 up
    to t_out, 14-27 up to t0) minus their exact means (``control_means``): each column has
    mean 0, so any multiple of it subtracted from a path's values leaves their mean
    unchanged and, with the regression's coefficients, shrinks its variance."""
    fine, coarse, controls = _run_at(paths, dt, t_out, t0, omega, zeta, h, mu_g, mus_g, seed,
                                     True)
    controls -= control_means(dt, t_out, t0=t0, omega=omega, zeta=zeta, h=h)
    return fine, coarse, controls


def coupled_at(paths: int, dt: float, t_out: float, *, t0: float, omega: float, zeta: float,
               h: float, mu_g: float, mus_g: float = None, seed: int = 0):
    """``coupled`` with the distance and the velocity at an output time t_out < t0 as well:
    arrays (paths, 3) at dt and at 2 dt of the distance at the stop, the distance at t_out and
    the velocity at t_out, on the same noise."""
    return _run_at(paths, dt, t_out, t0, omega, zeta, h, mu_g, mus_g, seed, False)[:2]


def coupled(paths: int, dt: float, *, t0: float, omega: float, zeta: float, h: float,
            mu_g: float, mus_g: float = None, seed: int = 0):
    """Distances at the stop of the same ``paths`` paths at steps dt and 2 dt (the shaking
    ends at t0): their paired difference measures Euler's step bias with a small variance."""
    if abs(round(t0 / (2 * dt)) * 2 * dt - t0) > 1e-9 * t0:
        raise ValueError("t0 must be a multiple of 2 dt")
    rng = np.random.default_rng(seed)
    fine, coarse = np.empty(paths), np.empty(paths)
    _coupled(rng, paths, dt, t0, omega, zeta, h, mu_g, mu_g if mus_g is None else mus_g,
             fine, coarse)
    return fine, coarse


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
    coupled(10, 0.1, t0=1.0, omega=1.0, zeta=0.5, h=1.0, mu_g=1.0)
    coupled_at(10, 0.1, 0.4, t0=1.0, omega=1.0, zeta=0.5, h=1.0, mu_g=1.0)


# --- The stop time with the at-rest touches of the barrier (bench/stop_time_reference.py) ---


@njit(cache=False)
def _touch_step(urng, x, xd, v, s, last, k, dt, noise, c1, w2, mu_g, mus_g, r, touch):
    """One Euler step k (from k dt to (k + 1) dt) of the filter and the body, as in
    ``_kernel``, with the last rest time ``last``; with ``touch``, a body at rest at both ends
    of the step with |a_g| < mus_g at both ends touches the barrier +-mus_g inside it with the
    Brownian bridge's probability (a_g's noise has variance rate r), which moves ``last`` to
    the middle of the step. The body's state is unchanged by a touch."""
    ag = -(c1 * xd + w2 * x)
    was_rest = v == 0.0
    v, s, rest = _body(x, xd, v, s, ag, mu_g, mus_g, dt)
    xn = x + xd * dt
    xd = xd + (-w2 * x - c1 * xd) * dt - noise
    x = xn
    if rest:
        last = (k + 1) * dt
    elif touch and was_rest and v == 0.0:
        a1 = -(c1 * xd + w2 * x)
        if abs(ag) < mus_g and abs(a1) < mus_g:
            q = 2.0 / (r * dt)
            e1 = q * (mus_g - ag) * (mus_g - a1)
            e2 = q * (mus_g + ag) * (mus_g + a1)
            # Below exp(-45) ~ 3e-20 a touch is never drawn in practice: skip the uniform.
            if e1 < 45.0 or e2 < 45.0:
                p = math.exp(-e1) + math.exp(-e2)
                if urng.random() < p:
                    last = (k + 0.5) * dt
    return x, xd, v, s, last


@njit(cache=False)
def _coupled_touch(rng, urng, paths, dt, t0, omega, zeta, h, mu_g, mus_g, touch, fine,
                   coarse):
    """``_coupled`` (the same paths at dt and 2 dt, the coarse step's noise the sum of the two
    fine steps') for the stop time: per path the last rest time on each grid (column 0) and
    the distance at the stop (column 1). With ``touch``, both grids count the barrier touches
    of a body at rest (``_touch_step``), their uniforms from ``urng``, apart from the noise."""
    w2 = omega * omega
    c1 = 2.0 * zeta * omega
    sq = h * math.sqrt(dt)
    r = (c1 * h) ** 2
    n0 = int(round(t0 / dt))
    dc = 2.0 * dt
    for p in range(paths):
        x = xd = v = s = last = 0.0
        xc = xdc = vc = sc = lastc = 0.0
        k = 0
        while k < n0:
            n1 = sq * rng.standard_normal()
            n2 = sq * rng.standard_normal()
            x, xd, v, s, last = _touch_step(urng, x, xd, v, s, last, k, dt, n1, c1, w2,
                                            mu_g, mus_g, r, touch)
            x, xd, v, s, last = _touch_step(urng, x, xd, v, s, last, k + 1, dt, n2, c1, w2,
                                            mu_g, mus_g, r, touch)
            xc, xdc, vc, sc, lastc = _touch_step(urng, xc, xdc, vc, sc, lastc, k // 2, dc,
                                                 n1 + n2, c1, w2, mu_g, mus_g, r, touch)
            k += 2
        # The shaking has ended (a_g = 0): each slides to rest at its own step.
        kf = n0
        while v != 0.0:
            v, s, rest = _body(x, xd, v, s, 0.0, mu_g, mus_g, dt)
            kf += 1
            if rest:
                last = kf * dt
        kc = n0 // 2
        while vc != 0.0:
            vc, sc, rest = _body(xc, xdc, vc, sc, 0.0, mu_g, mus_g, dc)
            kc += 1
            if rest:
                lastc = kc * dc
        fine[p, 0] = last
        fine[p, 1] = s
        coarse[p, 0] = lastc
        coarse[p, 1] = sc


def coupled_stop_at(paths: int, dt: float, omega: float, seed: int = 0, *, t0: float = 10.0,
                    zeta: float = 0.6, h: float = 1.0, mu_g: float = 1.0,
                    mus_g: float = None, touch: bool = True):
    """Stop times (the last time the body came to rest) of the same ``paths`` paths at steps
    dt and 2 dt on the same Brownian increments (``_coupled_touch``): arrays (paths, 2) at dt
    and at 2 dt of the stop time and the distance at the stop. With ``touch`` (the default)
    a body at rest over a step touches the barrier inside it with the Brownian bridge's
    probability, drawn from a generator of its own (seeded from ``seed``'s SeedSequence
    child), which removes Euler's sqrt(dt) bias of the stop time; without it, plain Euler on
    the very same increments."""
    if abs(round(t0 / (2 * dt)) * 2 * dt - t0) > 1e-9 * t0:
        raise ValueError("t0 must be a multiple of 2 dt")
    rng = np.random.default_rng(seed)
    urng = np.random.default_rng(np.random.SeedSequence(seed).spawn(1)[0])
    fine, coarse = np.empty((paths, 2)), np.empty((paths, 2))
    _coupled_touch(rng, urng, paths, dt, t0, omega, zeta, h, mu_g,
                   mu_g if mus_g is None else mus_g, touch, fine, coarse)
    return fine, coarse
