"""The velocity's law for any intensity schedule and any start, by chaining the closed-form
transition density of the sign-drift diffusion across the pieces (docs/analytic.md,
"Schedules").

On a piece of intensity sigma > 0 the velocity obeys dX = -c sign(X) dt + sigma dW, whose
transition density over a time t from x0 is closed form (:func:`log_transition_density`, for
any real c). A piece without noise is the deterministic coast X -> sign(X) (|X| - c t)_+, which
puts mass on X = 0 (bodies at rest) and stays there until the noise returns. So the law of X
at any time is the start (a point mass at v0) carried through the pieces: one exact kernel per
noisy piece (a quadrature over a uniform grid of velocities), one shift per pause. From it
come E X^k, the survival function and quantiles of X and |X|, the stop time's law
(t_s = T + |X(T)| / c, T the end of the last piece), and the mean distance through the energy
identity E S(t) = (v0^2 + int_0^t sigma(s)^2 ds - E X(t)^2) / (2c), which holds for any
schedule and start (Ito's formula for X^2 with dS = |X| dt).

Units are the caller's: pieces ((end, sigma), ...) with ends increasing, the drift c, times and
velocities in the same units (``Scene.pieces`` or ``[(scene.t0, scene.noise)]``,
``scene.drift`` and ``scene.v0`` of a crandall.Scene).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Sequence, Tuple

import numpy as np
from scipy.special import log_ndtr

from ..errors import ParameterError
from ._check import ArrayLike, Values

__all__ = ["log_transition_density", "VelocityLaw", "velocity_law", "stop_time_sf",
           "distance_mean", "noise_energy"]

#: Most grid points of the quadrature (a piece far shorter than the others needs a fine grid).
MAX_POINTS = 8001


def log_transition_density(x: ArrayLike, x0: ArrayLike, t: ArrayLike,
                           c: ArrayLike, sigma: ArrayLike) -> Values:
    """log p(x, t | x0) of dX = -c sign(X) dt + sigma dW (any real c, sigma > 0, t > 0):

        p = exp(-(x - x0)^2 / (2 s2 t) - c (|x| - |x0|) / s2 - c^2 t / (2 s2)) / sqrt(2 pi s2 t)
            + c / (2 s2) exp(-2 c |x| / s2) erfc((|x| + |x0| - c t) / sqrt(2 s2 t)),  s2 = sigma^2

    the sign-drift diffusion's propagator (from rest with c = 2, sigma = sqrt 2 it is the
    paper's velocity density). For c < 0 (a drift away from 0) the second term is negative and
    below the first: its ratio to it is below |c| t / (|x| + |x0| + |c| t) < 1. Evaluated in
    logs (log_ndtr for the erfc), so that steps of any length and far tails keep their digits.
    """
    x, x0 = np.asarray(x, dtype=float), np.asarray(x0, dtype=float)
    s2 = sigma * sigma
    ax, a0 = np.abs(x), np.abs(x0)
    first = (-0.5 * np.log(2 * np.pi * s2 * t) - (x - x0) ** 2 / (2 * s2 * t)
             - c * (ax - a0) / s2 - c * c * t / (2 * s2))
    if c == 0:
        return first
    z = (ax + a0 - c * t) / np.sqrt(2 * s2 * t)
    second = (math.log(abs(c) / (2 * s2)) - 2 * c * ax / s2 + math.log(2.0)
              + log_ndtr(-z * math.sqrt(2.0)))
    if c > 0:
        return np.logaddexp(first, second)
    return first + np.log1p(-np.exp(second - first))


def _check(pieces, drift, v0) -> Tuple[list, float, float]:
    try:
        ps = [(float(e), float(s)) for e, s in pieces]
    except (TypeError, ValueError):
        raise ParameterError("pieces", "pieces must be a sequence of (end, sigma) pairs") from None
    if not ps:
        raise ParameterError("pieces", "pieces must hold at least one (end, sigma) pair")
    ends = [e for e, _ in ps]
    if any(not (math.isfinite(e) and e >= 0) for e in ends) or any(b <= a for a, b in zip(ends, ends[1:])):
        raise ParameterError("pieces", "pieces: the ends must be finite, >= 0 and increasing, "
                                       f"got {ends}")
    if any(not (math.isfinite(s) and s >= 0) for _, s in ps):
        raise ParameterError("pieces", "pieces: every sigma must be finite and >= 0")
    drift = float(drift)
    if not (math.isfinite(drift) and drift > 0):
        raise ParameterError("drift", f"drift must be finite and > 0, got {drift}")
    v0 = float(v0)
    if not math.isfinite(v0):
        raise ParameterError("v0", f"v0 must be finite, got {v0}")
    return ps, drift, v0


def _steps(ps, time):
    """(length, sigma) of each part of [0, time], the noise off after the last end."""
    out, a = [], 0.0
    for e, s in ps:
        b = min(e, time)
        if b > a:
            out.append((b - a, s))
        a = max(a, e)
        if a >= time:
            break
    if time > a:
        out.append((time - a, 0.0))
    return out


def noise_energy(pieces: Sequence[Tuple[float, float]], time: ArrayLike) -> Values:
    """int_0^time sigma(s)^2 ds: twice the kinetic energy per unit mass the noise feeds in."""
    ps, _, _ = _check(pieces, 1.0, 0.0)
    return sum(length * s * s for length, s in _steps(ps, float(time)))


@dataclass(frozen=True)
class VelocityLaw:
    """The law of X at one time: a density on a uniform grid (trapezoid weights) plus an atom
    at 0 (bodies at rest), or a single point (no noise yet)."""

    grid: np.ndarray
    density: np.ndarray
    atom: float
    point: float  # the velocity when the law is a point mass (nan otherwise)

    @property
    def weights(self) -> np.ndarray:
        h = self.grid[1] - self.grid[0]
        w = np.full(len(self.grid), h)
        w[0] = w[-1] = h / 2
        return w * self.density

    def moment(self, k: int) -> float:
        """E X^k (k >= 1)."""
        if math.isfinite(self.point):
            return self.point ** k
        return float(np.sum(self.weights * self.grid ** k))

    def sf(self, y: float) -> float:
        """P(X > y): the density's mass above y (linear within the cell of y) plus the atom."""
        if math.isfinite(self.point):
            return float(self.point > y)
        atom = self.atom if 0.0 > y else 0.0
        return float(atom + self._mass_above(y))

    def speed_sf(self, y: float) -> float:
        """P(|X| > y): 1 for y < 0 (the atom is at rest, |X| = 0)."""
        if math.isfinite(self.point):
            return float(abs(self.point) > y)
        if y < 0:
            return 1.0
        return float(self._mass_above(y) + self._mass_below(-y))

    def _cells(self):
        x, f = self.grid, self.density
        return 0.5 * (x[1] - x[0]) * (f[1:] + f[:-1])

    def _partial(self, y):
        """(j, mass of [x_j, y]) for x_j <= y < x_{j+1}, linear density within the cell."""
        x, f = self.grid, self.density
        j = int(np.searchsorted(x, y, side="right") - 1)
        t = y - x[j]
        fy = f[j] + (f[j + 1] - f[j]) * t / (x[j + 1] - x[j])
        return j, 0.5 * t * (f[j] + fy)

    def _mass_above(self, y):
        """The density's mass above y, summed from the top (small tails keep their digits)."""
        x = self.grid
        if y >= x[-1]:
            return 0.0
        cells = self._cells()
        if y <= x[0]:
            return float(np.sum(cells))
        j, part = self._partial(y)
        return float(np.sum(cells[j + 1:][::-1]) + (cells[j] - part))

    def _mass_below(self, y):
        """The density's mass below y, summed from the bottom."""
        x = self.grid
        if y <= x[0]:
            return 0.0
        cells = self._cells()
        if y >= x[-1]:
            return float(np.sum(cells))
        j, part = self._partial(y)
        return float(np.sum(cells[:j]) + part)


def _grid(ps, drift, v0, steps):
    noisy = [(length, s) for length, s in steps if s > 0]
    smax = max(s for _, s in noisy)
    total = sum(length for length, _ in noisy)
    # The range: the start plus what the noise can add, the smaller of 12 free spreads
    # sigma sqrt(t) and 40 stationary scales sigma^2 / (2c) (the stationary density falls like
    # exp(-2c|x|/sigma^2): e^-40 there); the largest sigma bounds both.
    reach = abs(v0) + min(12.0 * smax * math.sqrt(total), 40.0 * smax * smax / (2 * drift))
    width = min(s * math.sqrt(length) for length, s in noisy)
    h = min(reach / 1500.0, width / 8.0)
    n = int(math.ceil(reach / h))
    if 2 * n + 1 > MAX_POINTS:
        raise ParameterError("pieces", f"pieces: a noisy piece of {width:.3g} spread against a "
                                       f"range of {reach:.3g} needs more than {MAX_POINTS} "
                                       "quadrature points")
    return np.linspace(-n * h, n * h, 2 * n + 1)


def velocity_law(pieces: Sequence[Tuple[float, float]], drift: float, time: float,
                 v0: float = 0.0) -> VelocityLaw:
    """The law of X(time) for the schedule ``pieces`` ((end, sigma), ...), friction deceleration
    ``drift`` > 0 and start ``v0``; the noise is off after the last end."""
    ps, drift, v0 = _check(pieces, drift, v0)
    time = float(time)
    if not (math.isfinite(time) and time >= 0):
        raise ParameterError("time", f"time must be finite and >= 0, got {time}")
    steps = _steps(ps, time)
    if not any(s > 0 for _, s in steps):
        v = v0
        for length, _ in steps:
            v = math.copysign(max(abs(v) - drift * length, 0.0), v) if v != 0 else 0.0
        return VelocityLaw(np.array([0.0, 1.0]), np.zeros(2), 1.0 if v == 0 else 0.0, v)
    x = _grid(ps, drift, v0, steps)
    h = x[1] - x[0]
    point, atom, f = v0, 0.0, None
    for length, s in steps:
        if s > 0:
            new = np.zeros_like(x)
            w = np.full(len(x), h)
            w[0] = w[-1] = h / 2
            if f is None:  # from the point mass (or the atom of a body at rest)
                new += np.exp(log_transition_density(x, point, length, drift, s))
                new /= w @ new  # a density with kinks: exactly 1 in the trapezoid sense
            else:
                kernel = np.exp(log_transition_density(x[:, None], x[None, :], length, drift, s))
                # Each column is a density in x with a kink at 0: its trapezoid sum is 1 only
                # to O(h^2). Scaled to sum to exactly 1, mass is carried without that loss
                # (1e-4 relative at the default grid before, 1e-6 after, on the paper's scene).
                kernel /= w @ kernel
                new += kernel @ (w * f)
                if atom > 0:
                    from_rest = np.exp(log_transition_density(x, 0.0, length, drift, s))
                    new += atom * from_rest / (w @ from_rest)
            f, atom, point = new, 0.0, math.nan
        elif f is None:
            point = math.copysign(max(abs(point) - drift * length, 0.0), point) if point != 0 else 0.0
        else:
            # The coast: |X| falls by c L; what reaches 0 stays there. The density moves towards
            # 0; at 0 the two one-sided limits differ, and the node holds their mean (so the
            # trapezoid sums of both sides stay exact).
            shift = drift * length
            cum = np.concatenate([[0.0], np.cumsum(0.5 * h * (f[1:] + f[:-1]))])
            inside = np.interp(shift, x, cum) - np.interp(-shift, x, cum)
            atom += float(inside)
            moved = np.where(x > 0, np.interp(x + shift, x, f, right=0.0),
                             np.interp(x - shift, x, f, left=0.0))
            zero = len(x) // 2
            moved[zero] = 0.5 * (np.interp(shift, x, f) + np.interp(-shift, x, f))
            f = moved
    if f is None:
        return VelocityLaw(np.array([0.0, 1.0]), np.zeros(2), 1.0 if point == 0 else 0.0, point)
    return VelocityLaw(x, f, atom, math.nan)


def stop_time_sf(pieces, drift: float, t: float, v0: float = 0.0) -> float:
    """P(t_s > t), t_s = T + |X(T)| / c with T the last end (the fixed-step runs' stop)."""
    ps, drift, v0 = _check(pieces, drift, v0)
    end = ps[-1][0]
    if t < end:
        return 1.0
    law = velocity_law(ps, drift, end, v0)
    return law.speed_sf(drift * (t - end))


def distance_mean(pieces, drift: float, time: float, v0: float = 0.0) -> float:
    """E S(time) = (v0^2 + int_0^time sigma^2 ds - E X(time)^2) / (2c), for any schedule and
    start; after the stop, (v0^2 + int sigma^2) / (2c)."""
    ps, drift, v0 = _check(pieces, drift, v0)
    law = velocity_law(ps, drift, time, v0)
    return (v0 * v0 + noise_energy(ps, time) - law.moment(2)) / (2 * drift)
