"""Rare outcomes: tail probabilities P(Q > level) down to 1e-12 with an honest relative error.

Plain Monte Carlo needs about 100 / p paths for a 10 % relative error at probability p. Two
estimators reach small p at a cost that grows like log(1/p) instead (docs/methods/tails.md):

- **splitting** (adaptive multilevel splitting, Cérou & Guyader 2007, in the generalised form
  of Bréhier, Gazeau, Goudenège, Lelièvre & Rousset 2016, unbiased for any number of
  particles): particles are paths on a fixed grid, each with a score; at each iteration the
  particles whose path maximum of the score is lowest are killed and replaced by copies of
  survivors, continued with fresh noise from the first grid point where the survivor's score
  passed the killed level. The paths are the exact skeleton of the velocity (the core's exact
  step), so splitting adds no step bias of its own.
- **importance sampling**: paths simulated under a changed friction over a final window,
  weighted by the exact likelihood ratio of the two laws of the velocity's grid values (the
  closed-form transition density of the sign-drift diffusion, any step length).

Every quantity is a function of the grid values of the velocity (displacement and distance are
the trapezoid rule on the grid, the exact method's integrals): the probabilities are those of
a fixed-step exact run at the same ``dt``; velocity and stop time have no step bias at all.
"""

from __future__ import annotations

import functools
import hashlib
import json
import math
import os
import time as _time
import warnings
from dataclasses import dataclass, field
from typing import Any, Dict, List, NamedTuple, Optional, Sequence, Union

import numpy as np

from . import _core, _render
from . import streams as _streams
from ._lazy import lazy_module
from ._resources import available_memory
from .checkpoint import json_state, read_json_state
from .driver import Estimator, Progress, Task, check_client, drive
from .driver import threads as resolve_threads
from .errors import ParameterError
from .model import TAIL_MODEL
from .results import StatisticsWarning
from .scene import Scene
from .spec import (MAX_SEED, as_seed, check_int, check_positive, check_scene, default_dt,
                   draw_seed, is_real)

__all__ = ["tail", "TailResult", "TAIL_QUANTITIES", "TAIL_METHODS"]

_schedule = lazy_module("crandall.analytic.schedule")

TAIL_METHODS = ("splitting", "importance")
#: A replica's path streams: replica r uses streams r * 2^40 + 0, 1, ...
_REPLICA_STREAMS = 1 << 40
#: The most samples (replicas or batches) of one run: their streams' first numbers fit in int64.
_MAX_SAMPLES = 1 << 23
#: Thresholds of an importance-sampling run's degeneracy (docs/methods/tails.md): fewer
#: effective samples among the paths past a level, or a single path carrying more of its weight.
MIN_EFFECTIVE_SAMPLES = 30.0
MAX_WEIGHT_SHARE = 0.1
#: The fewest grid steps with noise that splitting runs on (see tail()).
MIN_SPLITTING_STEPS = 50
#: How many more samples than the pilot's variance asks for the run takes.
SAFETY = 1.3
#: ... or, if larger, as many as the 99 % upper confidence bound of the pilot's variance asks:
#: its variance times (n - 1) / chi2_0.01(n - 1) (2.49 for a pilot of 20 replicas). Splitting
#: replicas are skewed (the distance at 1e-9, normalised score: relative spread 0.58, skewness
#: 1.6), so their sample variance is low more often than a normal sample's: with the 90 % bound,
#: 17 % of runs end above the target relative error there, with the 99 % one 3.9 %
#: (bench/tails_pilot.py). The normal quantile of the bound; chi2 by Wilson & Hilferty's cube
#: (plain float arithmetic, the same on every machine).
UPPER_Z = 2.3263478740408408


def variance_upper_factor(n: int) -> float:
    """(n - 1) / chi2_0.01(n - 1): the 99 % upper confidence bound of a variance estimated from
    n samples, over the estimate (normal samples; Wilson-Hilferty's approximation of the
    chi-square quantile: above it for few degrees of freedom (1.5 times at 3, 1.02 at 9),
    within 0.5 % from 19 on; infinite below 3)."""
    k = n - 1
    if k < 1:
        return math.inf
    c = 2.0 / (9.0 * k)
    cube = 1.0 - c - UPPER_Z * math.sqrt(c)
    return math.inf if cube <= 0 else 1.0 / cube ** 3
#: The smallest target relative error: the samples a target asks for are about a sample's
#: relative variance over rel_error^2, and max_samples is at most 10^12.
MIN_REL_ERROR = 1e-6
#: Largest Pareto shape of the weights' tail (:func:`pareto_shape`) for a reliable estimate.
MAX_PARETO_SHAPE = 0.7


@dataclass(frozen=True)
class _Quantity:
    name: str
    unit: str  # SI unit ("" in scaled scenes)
    at_stop: bool  # needs the stop: the horizon is the end of the excitation
    velocity_only: bool  # a function of the velocity alone (no step bias)
    peak: bool  # the quantity is the path maximum of its score
    text: str


#: The quantities a tail run estimates, with their units in an SI scene.
TAIL_QUANTITIES: Dict[str, _Quantity] = {q.name: q for q in (
    _Quantity("stop_time", "s", True, True, False, "stop time t_s"),
    _Quantity("velocity", "m/s", False, True, False, "velocity V(t) (signed)"),
    _Quantity("speed", "m/s", False, True, False, "speed |V(t)|"),
    _Quantity("distance_at_stop", "m", True, False, False, "distance travelled S(t_s)"),
    _Quantity("dissipated_energy_at_stop", "J", True, False, False,
              "energy dissipated by friction, m mu g S(t_s)"),
    _Quantity("displacement_at_stop", "m", True, False, False, "displacement U(t_s) (signed)"),
    _Quantity("residual_displacement", "m", True, False, False,
              "residual displacement |U(t_s)| (magnitude)"),
    _Quantity("peak_displacement_at_stop", "m", True, False, True,
              "peak displacement max |U| over the grid and the coast"),
    _Quantity("peak_speed_at_stop", "m/s", True, True, True, "peak speed max |V| over the grid"),
)}


class _Problem:
    """A scene, a quantity and the grid its paths are simulated on, with the quantity's score."""

    def __init__(self, scene: Scene, quantity: str, time: Optional[float], dt: Optional[float],
                 breaks: Sequence[float] = (), coarse: bool = False):
        # tail() and its Dask task (sample) both start here
        check_scene(scene, TAIL_MODEL, "crandall.tail")
        if not isinstance(quantity, str) or quantity not in TAIL_QUANTITIES:
            raise ParameterError("quantity", f"quantity must be one of {', '.join(TAIL_QUANTITIES)}; got {quantity!r}")
        self.scene, self.q = scene, TAIL_QUANTITIES[quantity]
        c = scene.drift
        pieces = list(scene.pieces) if scene.pieces is not None else [(scene.t0, scene.noise)]
        end = pieces[-1][0]
        if self.q.at_stop:
            if time is not None:
                raise ParameterError("time", f"time: {quantity} is a quantity at the stop; it takes no output time")
            if not (math.isfinite(end) and c > 0):
                raise ParameterError("quantity", f"quantity: {quantity} needs the stop, which needs mu > 0 and a finite t0")
            horizon = end
        else:
            if time is None:
                raise ParameterError("time", f"time: {quantity} is a quantity at an output time; give time=")
            if not is_real(time):
                raise ParameterError("time", f"time must be a number, got {time!r}")
            time = float(time)
            if not (math.isfinite(time) and time >= 0):
                raise ParameterError("time", f"time must be finite and >= 0, got {time}")
            horizon = min(time, end)
        self.time = time
        self.horizon = horizon
        self.coast = (time - horizon) if time is not None else 0.0  # noiseless time after the grid
        dt = check_positive("dt", default_dt(scene) if dt is None else dt)
        self.dt = dt
        self.args = (scene, quantity, time, dt)
        # The intervals between the pieces' ends and the extra breaks; coarse: one exact step
        # each (the velocity's law does not depend on the grid).
        cuts = sorted({0.0, horizon} | {e for e, _ in pieces if 0 < e < horizon}
                      | {x for x in breaks if 0 < x < horizon})
        intervals = []
        for a, b in zip(cuts[:-1], cuts[1:]):
            sigma = next(n for e, n in pieces if e >= b)
            intervals.append((a, b, sigma))
        lengths, noises, starts = [], [], []
        for a, b, sigma in intervals:
            if b > a:
                n = 1 if (sigma == 0 or coarse) else max(1, math.ceil((b - a) / dt - 1e-9))
                if n > 10_000_000:
                    raise ParameterError("dt", f"dt: {n} steps over one piece of the excitation; the paths would not fit")
                edges = a + (b - a) * np.arange(n + 1) / n
                lengths.extend(np.diff(edges))
                noises.extend([sigma] * n)
                starts.extend(edges[:-1])
        self.lengths = np.asarray(lengths, dtype=np.float64)
        self.noises = np.asarray(noises, dtype=np.float64)
        self.drifts = np.full(len(lengths), c, dtype=np.float64)
        self.step_starts = np.asarray(starts, dtype=np.float64)
        # The expected drift of the distance still to come: S + V^2/(2c) grows at the constant
        # rate sigma^2/(2c) while the noise acts (docs/methods/tails.md), so adding what is still
        # to come makes the distance's score its conditional mean.
        if c > 0:
            per_step = self.noises ** 2 * self.lengths / (2 * c)
            self.remaining = np.concatenate([np.cumsum(per_step[::-1])[::-1], [0.0]])
        else:
            self.remaining = np.zeros(len(lengths) + 1)
        self._normal = None  # the splitting score's normalisation (_normaliser), built on demand

    def _normaliser(self):
        """What the normalised splitting score needs, per grid point (docs/methods/tails.md,
        "The score splitting ranks by, for one level"): the point's time, the cumulative sums of sigma^2 dt, sigma^2 dt r and
        sigma^2 dt r^2 over the steps before it (r: a step's midpoint), and the variance the
        rest of the excitation adds at the stationary speed, sum of sigma^6 dt / (2 c^4) over
        the steps after it; and each point's step length."""
        if self._normal is None:
            # Overflow to inf (an intensity far outside a physical range) is what
            # normalisable() looks for.
            with np.errstate(over="ignore", invalid="ignore"):
                c = self.scene.drift
                points = np.concatenate([[0.0], np.cumsum(self.lengths)])
                w = self.noises ** 2 * self.lengths
                mid = self.step_starts + self.lengths / 2
                cum = [np.concatenate([[0.0], np.cumsum(w * mid ** k)]) for k in range(3)]
                stat = self.noises ** 6 * self.lengths / (2 * c ** 4)
                stationary = np.concatenate([np.cumsum(stat[::-1])[::-1], [0.0]])
                step = np.concatenate([self.lengths, self.lengths[-1:]])
                self._normal = (points, cum, stationary, step)
        return self._normal

    #: The quantities whose splitting score is normalised by the spread still to come (when a
    #: run asks for one level): the distance and energy at the stop and the displacement where
    #: the body would stop, whose martingale parts all grow at the rate sigma^2 V^2 / c^2.
    NORMALISED = ("distance_at_stop", "dissipated_energy_at_stop", "displacement_at_stop",
                  "residual_displacement")

    def first_random_point(self) -> int:
        """The first grid point that differs between paths: the end of the first noisy step."""
        return int(np.argmax(self.noises > 0)) + 1

    def split_score(self, states: np.ndarray, top: Optional[float], uncoast: bool = False):
        """(the score splitting ranks paths by, the quantity's score), both of shape
        states.shape[:2]. With ``top`` (a run of one level, for the NORMALISED quantities) the
        first is (m - top) / sd, m the quantity's score (its conditional mean, or where the body
        would stop now) and sd^2 an estimate of the variance still to come: sigma^2 (|V| / c -
        r)^2 integrated while the speed would decay to zero, plus the stationary speed's share
        of the rest. At the last point sd is a floor eps, so the score there is (Q - top) / eps
        and Q > top is a score above 0 (split_threshold). Otherwise both are m, or with
        ``uncoast`` (:meth:`coasts_to_rest`) the first is :meth:`uncoasted`."""
        m = self.score(states)
        if top is None:
            return (self.uncoasted(states) if uncoast else m), m
        points, cum, stationary, step = self._normaliser()
        c = self.scene.drift
        q = np.abs(states[..., 0]) / c
        end = points + q  # when the speed would reach zero without noise
        # The grid point at or after it, counted in the steps of the point's own piece (the
        # pieces' steps differ a little; a score needs no more than that).
        ahead = np.ceil(np.minimum(q / step, self.steps)).astype(np.int64)
        e = np.minimum(np.arange(self.steps + 1) + ahead, self.steps)
        var = (end * end * (cum[0][e] - cum[0]) - 2 * end * (cum[1][e] - cum[1])
               + (cum[2][e] - cum[2]))
        np.maximum(var, 0.0, out=var)
        var += stationary
        var[..., -1] = 0.0
        var += self.floor2()
        return (m - top) / (self._scale() * np.sqrt(var)), m

    def _scale(self) -> float:
        """The quantity's unit over the distance's (the energy: m mu g)."""
        return self.scene.mass * self.scene.drift if self.q.name == "dissipated_energy_at_stop" else 1.0

    def normalisable(self, schedule: bool = True) -> bool:
        """Whether split_score's normalisation serves: a NORMALISED quantity, one intensity
        (unless ``schedule`` is False: bench/tails_score.py measures the others), its
        sums finite and its floor eps^2 positive (an intensity far outside a physical range can
        overflow sigma^6 or underflow it to 0; such a run keeps the plain score)."""
        if self.q.name not in self.NORMALISED or (schedule and not self.one_intensity()):
            return False
        points, cum, stationary, step = self._normaliser()
        f = self.floor2()
        return (math.isfinite(f) and f > 0 and all(np.all(np.isfinite(x)) for x in cum)
                and bool(np.all(np.isfinite(stationary))))

    def one_intensity(self) -> bool:
        """Whether the noise acts with one intensity over one stretch of time (calm before or
        after it allowed): the scenes where the normalised score is measured to help. On a
        build-up, two pieces or an envelope it was as often worse as better (1/0.6 to 1/1.24
        times the plain score's work between 1e-3 and 1e-5), and across a lull followed by more
        shaking (a pause, an aftershock) far worse (25 to 50 times the work): its spread to
        come shrinks faster than the quantity's true tail there, the score drops for every
        path, and the path maxima stop measuring progress (docs/methods/tails.md)."""
        noisy = np.flatnonzero(self.noises > 0)
        if len(noisy) == 0:
            return False
        stretch = self.noises[noisy[0]:noisy[-1] + 1]
        return bool(np.all(stretch == stretch[0]))

    def floor2(self) -> float:
        """eps^2 of split_score: a millionth of the stationary variance to come at the start."""
        return 1e-6 * float(self._normaliser()[2][0])

    def split_threshold(self, level: float, top: float) -> float:
        """The normalised score's value at the last point for Q = level (0 for level = top)."""
        return (level - top) / (self._scale() * np.sqrt(0.0 + self.floor2()))

    @property
    def noisy_steps(self) -> int:
        return int(np.count_nonzero(self.noises > 0))

    @property
    def noisy_time(self) -> float:
        return float(np.sum(self.lengths[self.noises > 0]))

    @property
    def steps(self) -> int:
        return len(self.lengths)

    def start_states(self, n: int) -> np.ndarray:
        states = np.empty((n, self.steps + 1, 3))
        states[:, 0] = (self.scene.v0, self.scene.u0, 0.0)
        return states

    def coasts_to_rest(self, levels: np.ndarray) -> bool:
        """Whether splitting ranks the paths by :meth:`uncoasted`: the velocity and the speed
        after the switch-off, at levels >= 0 (where Q > L if and only if the unclipped value
        exceeds L, so that a path past the level is always ranked past it)."""
        return (self.q.name in ("velocity", "speed") and self.coast > 0
                and bool(np.min(levels) >= 0))

    def uncoasted(self, states: np.ndarray) -> np.ndarray:
        """The velocity (speed) at the output time without the clip at rest: v - c coast
        (|v| - c coast). The coasted quantity is 0 for every path whose speed at the end of the
        grid is below c coast, long after the switch-off almost all of them: as a splitting
        score it would tie them all at 0 (extinction at the first iteration). This one ranks
        them, and above 0 it is the quantity."""
        v = states[..., 0]
        shift = self.scene.drift * self.coast
        return (np.abs(v) if self.q.name == "speed" else v) - shift

    def _coasted(self, v):
        """The velocity at the output time from the velocity at the end of the grid."""
        if self.coast == 0.0:
            return v
        c = self.scene.drift
        return np.sign(v) * np.maximum(np.abs(v) - c * self.coast, 0.0)

    def score(self, states: np.ndarray) -> np.ndarray:
        """The score at every grid point, shape states.shape[:2]; its last point (or, for the
        peaks, its maximum over the path) is the quantity."""
        v, u, s = states[..., 0], states[..., 1], states[..., 2]
        c = self.scene.drift
        name = self.q.name
        if name == "stop_time":
            return self.horizon + np.abs(v) / c
        if name == "velocity":
            return self._coasted(v)
        if name == "speed":
            return np.abs(self._coasted(v))
        if name in ("distance_at_stop", "dissipated_energy_at_stop"):
            out = s + v * v / (2 * c) + self.remaining
            return out * (self.scene.mass * c) if name == "dissipated_energy_at_stop" else out
        ahead = u + v * np.abs(v) / (2 * c)  # the displacement where the body would stop now
        if name == "displacement_at_stop":
            return ahead
        if name == "residual_displacement":
            return np.abs(ahead)
        if name == "peak_displacement_at_stop":
            out = np.abs(u)
            out[..., -1] = np.maximum(out[..., -1], np.abs(ahead[..., -1]))
            return out
        return np.abs(v)  # peak_speed_at_stop: the speed only falls after the last piece

    def value(self, score: np.ndarray) -> np.ndarray:
        return score.max(axis=-1) if self.q.peak else score[..., -1]

    def coarse_for(self, window: float) -> "_Problem":
        """The same problem on the coarsest grid with a break at horizon - window: one exact
        step per piece and part (velocity quantities only, which are exact on any grid)."""
        return _Problem(*self.args, breaks=(self.horizon - window,), coarse=True)

    def describe(self) -> Dict[str, Any]:
        return {"quantity": self.q.name, "time": self.time, "dt": self.dt, "steps": self.steps}


def _extend(problem: _Problem, states, rows, starts, streams, key, threads, law=None,
            touched=None):
    law = law or _Law(problem.drifts)
    _core.extend_paths(states, np.asarray(rows, dtype=np.int64), np.asarray(starts, dtype=np.int64),
                       np.asarray(streams, dtype=np.uint64), problem.lengths, problem.noises,
                       law.drifts, key, threads, touched, law.slow,
                       None if law.slow is None else problem.drifts)


# -- splitting ------------------------------------------------------------------------------


def _normalised_top(problem: _Problem, levels: np.ndarray, schedule: bool = True) -> Optional[float]:
    """The level splitting's score is normalised towards: the one level of a run of one level
    of a NORMALISED quantity under one intensity (None: the plain score). ``schedule=False``
    drops the schedule's condition (bench/tails_score.py)."""
    return float(levels[0]) if len(levels) == 1 and problem.normalisable(schedule) else None


def _splitting_replica(problem: _Problem, levels: np.ndarray, particles: int, kill: int,
                       key: int, replica: int, threads: int, max_iterations: int,
                       normalise: Optional[bool] = None, deadline: Optional[float] = None):
    """One run of adaptive multilevel splitting: an unbiased estimate of P(Q > L) for each L.

    The estimate for L is taken at the first iteration whose kill level z (the kill-th smallest
    path maximum of the score) reaches L: prod(1 - K_j / n) times the fraction of the particles
    with Q > L, K_j the number killed at iteration j (every particle at or below z, so ties are
    killed together: Bréhier et al. 2016). If every particle sits at z the estimate is 0.

    A run of one level of a NORMALISED quantity under one intensity ranks the paths by the
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
    """
    n = particles
    rng = np.random.default_rng([key, replica, 1])
    base = replica * _REPLICA_STREAMS
    states = problem.start_states(n)
    _extend(problem, states, np.arange(n), np.zeros(n), base + np.arange(n), key, threads)
    branches = n
    steps = n * problem.steps
    top = None if normalise is False else _normalised_top(problem, levels, normalise is None)
    first = problem.first_random_point() if top is not None else 0
    thresholds = (np.array([problem.split_threshold(float(x), top) for x in levels])
                  if top is not None else levels)
    uncoast = top is None and problem.coasts_to_rest(levels)
    score, plain = problem.split_score(states, top, uncoast)
    level = score[:, first:].max(axis=1)
    value = problem.value(plain)
    order = np.argsort(levels, kind="stable")
    estimates = np.full(len(levels), np.nan)
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
            estimates[order[done]] = math.exp(log_weight) * np.mean(value > levels[order[done]])
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
        log_weight += math.log1p(-len(killed) / n)
        survivors = np.flatnonzero(level > z)
        parents = survivors[rng.integers(len(survivors), size=len(killed))]
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


# -- importance sampling --------------------------------------------------------------------


def log_transition_density(x, x0, t, c, sigma):
    """The sign-drift diffusion's log transition density (crandall.analytic.schedule, loaded on
    first use: ``import crandall`` stays free of scipy)."""
    return _schedule.log_transition_density(x, x0, t, c, sigma)


def _log_weights(problem: _Problem, states: np.ndarray, drifts: np.ndarray) -> np.ndarray:
    """log of dP/dQ for each path: the sum over the steps where the proposal's drift differs
    of log p_c - log p_c' of the step's velocities (exact: the grid values are a Markov chain
    under either law, and every quantity is a function of them)."""
    out = np.zeros(states.shape[0])
    changed = np.flatnonzero(drifts != problem.drifts)
    c = problem.scene.drift
    for k in changed:
        x0, x1 = states[:, k, 0], states[:, k + 1, 0]
        t, sigma = problem.lengths[k], problem.noises[k]
        out += (log_transition_density(x1, x0, t, c, sigma)
                - log_transition_density(x1, x0, t, drifts[k], sigma))
    return out


class _Law(NamedTuple):
    """A proposal's law on a grid: per step the drift, and (or None) the speed below which a
    step keeps the scene's friction; ``full`` (or None) the drifts of a defensive component
    over every noisy step that draws DEFENSIVE of the paths (see _proposal)."""

    drifts: np.ndarray
    slow: Optional[np.ndarray] = None
    full: Optional[np.ndarray] = None


def _proposal(problem: _Problem, window: float, drift: float, slow: float = 0.0,
              full: Optional[float] = None) -> _Law:
    """The proposal's law: ``drift`` on the noisy steps that start in the last ``window`` of
    the horizon, the scene's friction elsewhere; with ``slow`` > 0 only while the speed at the
    step's start is at least ``slow`` times the piece's mean stationary speed sigma^2 / (2 c)
    (below it the scene's friction: the weight then does not see the time spent near 0).

    With ``full`` (a drift) and a window that leaves noisy steps before it, a defensive
    mixture: DEFENSIVE of the paths have the friction ``full`` on every noisy step. A window's
    proposal leaves the velocity at the window's start under the scene's law, and its weight
    grows with that velocity about as fast as the velocity's density falls, so paths that
    start the window already fast weigh up to 1 / P times more than the others (the stop time
    at tau0 = 20 past 25, P = 2e-9, window 5, drift -c: a relative variance per path of order
    1e8 by quadrature, where pilots of a few hundred paths saw tens). The whole horizon's
    likelihood ratio on the coarse grid, its pieces tilted (_tilted), falls with the final
    speed, so paths past the level weigh about what one at the level does at most, and the
    mixture's weights at most that over DEFENSIVE (docs/methods/tails.md)."""
    d = problem.drifts.copy()
    noisy = problem.noises > 0
    inside = (problem.step_starts >= problem.horizon - window - 1e-12 * problem.horizon) & noisy
    d[inside] = _tilted(problem, inside, drift)
    whole = None
    if full is not None and np.any(noisy & ~inside):
        whole = problem.drifts.copy()
        whole[noisy] = _tilted(problem, noisy, full)
    if slow <= 0.0:
        return _Law(d, None, whole)
    if whole is not None:
        raise ValueError("full: a speed-dependent proposal has no defensive full-horizon component")
    return _Law(d, np.where(inside, slow * problem.noises ** 2 / (2 * problem.scene.drift), 0.0))


def _tilted(problem: _Problem, steps: np.ndarray, drift: float) -> np.ndarray:
    """The drifts of the ``steps`` of a proposal with ``drift`` on the loudest of them. For the
    velocity quantities a step of noise sigma gets c - (c - drift) sigma^2 / sigma_max^2: the
    friction lowered by theta sigma^2 for one theta, the exponential tilt of |V| (the law of the
    path weighted by exp(theta |V(T)|)), whose likelihood ratio's free part
    exp(-theta (|x'| - |x|)) telescopes across pieces, so the whole horizon's weight falls with
    the final speed under any schedule. One drift for every piece does not: with the pieces'
    noise falling (v0 = 6, scaled intensities 1.5 then 0.7 over 4 each, P = 1e-8), a path fast
    at the end of the loud piece weighs more the faster it was. Under one intensity this is
    ``drift`` itself; the other quantities keep ``drift`` on every step."""
    noise = problem.noises[steps]
    if not _coarse(problem) or len(noise) == 0:
        return np.full(len(noise), drift)
    c, top = problem.scene.drift, np.max(noise)
    return np.where(noise == top, drift, c - (c - drift) * (noise / top) ** 2)


def _importance_batch(problem, law, levels, paths, key, first, threads):
    """Per path and level: the path's weight if it passes the level, else 0."""
    states = problem.start_states(paths)
    rows = np.arange(paths)
    if problem.q.name in SIGN_QUANTITIES:
        # A defensive mixture (Hesterberg 1995): the first DEFENSIVE of the paths under the
        # scene's own law, the others under the proposal; each weighed against the mixture,
        # which bounds the speeds' part of the weight by 1 / DEFENSIVE.
        own = int(round(DEFENSIVE * paths)) if np.any(law.drifts != problem.drifts) else 0
        touched = np.zeros((paths, problem.steps), dtype=np.uint8)
        for part, part_law in ((rows[:own], _Law(problem.drifts)), (rows[own:], law)):
            if len(part):
                _extend(problem, states, part, np.zeros(len(part)), first + part, key, threads,
                        law=part_law, touched=touched)
        value, logw = _resigned(problem, states, touched, levels, key, first)
        log_pq = _log_weights_touched(problem, states, touched, law)
        if own:
            log_pq = -np.logaddexp(math.log(DEFENSIVE), math.log1p(-DEFENSIVE) - log_pq)
        logw = logw + log_pq
    else:
        if law.slow is not None:
            raise ValueError("slow: a speed-dependent proposal needs the touches' weights")
        # With a full-horizon component: its DEFENSIVE of the paths first, each path weighed
        # against the mixture (a deterministic mixture, Owen & Zhou 2000: unbiased with the
        # components' shares fixed).
        own = int(round(DEFENSIVE * paths)) if law.full is not None else 0
        for part, drifts in ((rows[:own], law.full), (rows[own:], law.drifts)):
            if len(part):
                _extend(problem, states, part, np.zeros(len(part)), first + part, key, threads,
                        law=_Law(drifts))
        value = problem.value(problem.score(states))
        logw = _log_weights(problem, states, law.drifts)
        if own:
            logw = -np.logaddexp(math.log(DEFENSIVE) - _log_weights(problem, states, law.full),
                                 math.log1p(-DEFENSIVE) - logw)
    hits = value[:, None] > levels[None, :]
    return np.where(hits, np.exp(logw)[:, None], 0.0)


# -- importance sampling of the displacement: the signs re-drawn ----------------------------

#: The quantities whose importance sampling re-draws the signs of the velocity's excursions
#: (a friction change alone pushes the distance, not the displacement, one way).
SIGN_QUANTITIES = ("displacement_at_stop", "residual_displacement")
#: The share of their paths simulated under the scene's own law, and of their signs drawn as
#: fair coins (defensive mixtures); for the velocity quantities, of the paths under the
#: full-horizon component of a window's proposal (_proposal). On the stop time at tau0 = 20
#: past 25 (by quadrature) the mixture of window 10, drift -c/2 with drift 0 over the horizon
#: has a relative variance per path of 14 with a share of 0.1, 18 with 0.3, where either alone
#: has 91 and 29.
DEFENSIVE = 0.1
#: Their proposals' speed thresholds, in units of the stationary mean speed sigma^2 / (2 c).
SLOW_FACTORS = (0.0, 1.0)
#: Tilts are solved for in t = theta max_j B_j, in [0, _MAX_TILT] (tanh(40) is 1 in doubles).
_MAX_TILT = 40.0


def _log_weights_touched(problem: _Problem, states: np.ndarray, touched: np.ndarray,
                         law: _Law) -> np.ndarray:
    """log dP/dQ of the speeds |V| on the grid and the steps' touches of 0 (a Markov chain
    under either law, the signs left out: they are re-drawn, _resigned), over the steps where
    the proposal's drift differs. A step from |x| = a to |x'| = y that did not touch 0 has the
    density of a Brownian motion with drift -c killed at 0, whose ratio between two drifts
    is exp(-(c - c') (y - a) / sigma^2 - (c^2 - c'^2) t / (2 sigma^2)); one that touched has
    twice the density of reaching the opposite sign, p(-y | a) (docs/methods/tails.md). With
    a speed-dependent proposal, only the steps that started at or above its threshold."""
    out = np.zeros(states.shape[0])
    changed = np.flatnonzero(law.drifts != problem.drifts)
    c = problem.scene.drift
    for k in changed:
        a, y = np.abs(states[:, k, 0]), np.abs(states[:, k + 1, 0])
        t, sigma, d = problem.lengths[k], problem.noises[k], law.drifts[k]
        s2 = sigma * sigma
        hit = touched[:, k] != 0
        free = -(c - d) * (y - a) / s2 - (c * c - d * d) * t / (2 * s2)
        if hit.any():
            free[hit] = (log_transition_density(-y[hit], a[hit], t, c, sigma)
                         - log_transition_density(-y[hit], a[hit], t, d, sigma))
        if law.slow is not None:
            free[a < law.slow[k]] = 0.0  # the scene's own law there
        out += free
    return out


def _log_cosh(x: np.ndarray) -> np.ndarray:
    ax = np.abs(x)
    return ax + np.log1p(np.exp(-2.0 * ax)) - math.log(2.0)


def _tilt(fixed: np.ndarray, parts: np.ndarray, top: np.ndarray, target: float,
          sign: float) -> np.ndarray:
    """Per path the tilt theta >= 0 at which the mean of fixed + sign sum_j s_j B_j under the
    tilted coins (P(s_j = sign) = (1 + tanh(theta B_j)) / 2) is the target; 0 if it already is,
    the largest tilt if no signs reach it. By bisection in t = theta max_j B_j."""
    lo, hi = np.zeros(len(fixed)), np.full(len(fixed), _MAX_TILT)
    scale = np.where(top > 0, top, 1.0)
    for _ in range(64):
        mid = 0.5 * (lo + hi)
        mean = fixed + sign * np.sum(parts * np.tanh(mid[:, None] * parts / scale[:, None]), axis=1)
        short = sign * mean < sign * target
        lo, hi = np.where(short, mid, lo), np.where(short, hi, mid)
    theta = hi / scale
    return np.where(sign * fixed >= sign * target, 0.0, theta)


def _resigned(problem: _Problem, states: np.ndarray, touched: np.ndarray,
              levels: np.ndarray, key: int, first: int):
    """The displacement's quantity with the excursions' signs re-drawn, and log dP/dQ of the
    signs.

    Under the scene's law the sign after each touch of 0 is a fair coin, independent of the
    speeds. So the displacement at the stop is U = U_fixed + sum_j s_j B_j: B_j the distance
    the path covers between touch j and the next (trapezoid halves of a touching step go to
    the two sides; the coast after the grid to the last), U_fixed the start's u0 plus the part
    before the first touch (its sign the start velocity's), s_j fair signs. Given the speeds,
    the signs are drawn from a mixture of fair coins (a DEFENSIVE share) and, per level in
    equal shares, the coins tilted towards it (exponential tilting of a sum of independent
    signs: P(s_j = +1) = (1 + tanh(theta B_j)) / 2, theta solving E U = level; for |U| also
    towards -level); the weight is the exact ratio of the fair coins' law to the mixture's (at
    most 1 / DEFENSIVE)."""
    fixed, free = _excursions(problem, states, touched)
    n = len(fixed)
    top = free.max(axis=1) if free.shape[1] else np.zeros(n)
    rng = np.random.Generator(np.random.PCG64(np.random.SeedSequence([key, first, 1 << 40])))
    pick, draws = rng.random(n), rng.random(free.shape)
    # The components: (theta per path, direction); the fair coin first.
    parts = [(np.zeros(n), 1.0)]
    for level in np.asarray(levels, dtype=float):
        parts.append((_tilt(fixed, free, top, level, 1.0), 1.0))
        if problem.q.name == "residual_displacement":
            parts.append((_tilt(fixed, free, top, -level, -1.0), -1.0))
    # The fair coin takes DEFENSIVE of the paths, the tilts share the rest equally.
    share = np.array([DEFENSIVE] + [(1.0 - DEFENSIVE) / (len(parts) - 1)] * (len(parts) - 1))
    which = np.minimum(np.searchsorted(np.cumsum(share), pick, side="right"), len(parts) - 1)
    theta = np.zeros(n)
    towards = np.ones(n)
    for i, (th, d) in enumerate(parts):
        theta = np.where(which == i, th, theta)
        towards = np.where(which == i, d, towards)
    p = 0.5 * (1.0 + np.tanh(theta[:, None] * free))
    signs = np.where(draws < p, 1.0, -1.0) * towards[:, None]
    total = np.sum(signs * free, axis=1)
    log_q = np.stack([math.log(w) + d * th * total - np.sum(_log_cosh(th[:, None] * free), axis=1)
                      for w, (th, d) in zip(share, parts)])
    log_q = np.logaddexp.reduce(log_q, axis=0)
    value = fixed + total
    if problem.q.name == "residual_displacement":
        value = np.abs(value)
    return value, -log_q


def _excursions(problem: _Problem, states: np.ndarray, touched: np.ndarray):
    """The displacement at the stop as fixed + sum_j s_j B_j (see _resigned): per path the
    fixed part (u0 and the stretch before the first touch, with the start velocity's sign) and
    the B_j >= 0 of the stretches after each touch (rows padded with 0)."""
    v, s = states[:, :, 0], states[:, :, 2]
    n, points = v.shape
    speed = np.abs(v)
    seg = np.zeros((n, points), dtype=np.int64)
    np.cumsum(touched, axis=1, out=seg[:, 1:])
    # Per step, what it adds to the distance on each side of a touch.
    hit = touched != 0
    h = problem.lengths[None, :]
    before = np.where(hit, 0.5 * h * speed[:, :-1], s[:, 1:] - s[:, :-1])
    after = np.where(hit, 0.5 * h * speed[:, 1:], 0.0)
    width = int(seg[:, -1].max()) + 1
    parts = np.zeros((n, width))
    row = np.repeat(np.arange(n), points - 1)
    np.add.at(parts, (row, seg[:, :-1].ravel()), before.ravel())
    np.add.at(parts, (row, seg[:, 1:].ravel()), after.ravel())
    parts[np.arange(n), seg[:, -1]] += speed[:, -1] ** 2 / (2 * problem.scene.drift)
    fixed = problem.scene.u0 + np.sign(problem.scene.v0) * parts[:, 0]
    return fixed, parts[:, 1:]


def _coarse(problem: _Problem) -> bool:
    """Whether importance sampling runs on the coarsest grid (the velocity quantities)."""
    return problem.q.velocity_only and not problem.q.peak


def _grid_for(problem: _Problem, window: float) -> _Problem:
    """The grid importance sampling runs on: the coarsest one for the velocity quantities (the
    likelihood ratio of fewer grid values has a lighter tail: it no longer sees the time the
    path spends near 0), the problem's own otherwise."""
    if _coarse(problem):
        return problem.coarse_for(window)
    return problem


def _ld_windows(problem: _Problem, top: float) -> List[float]:
    """Windows from the large-deviation path of the velocity quantities: |V| climbs to a level
    a at the rate c of the reversed friction over its last a / c (the time reversal of the
    relaxation), so the proposal reverses the friction over that window."""
    c, name = problem.scene.drift, problem.q.name
    if name == "stop_time":
        a = (top - problem.horizon) * c
    elif name in ("speed", "velocity", "peak_speed_at_stop"):
        a = abs(top) + c * problem.coast
    else:
        return []
    if not (c > 0 and a > 0):
        return []
    return [min(problem.horizon, a / c)]


#: The pilot paths per proposal of the velocity quantities, which run on a few grid steps (one
#: per piece and window). On the stop time at tau0 = 20 past 25 (100 seeds) pilots of 1024
#: paths chose window 5, drift -c in 19 runs (its mixture's relative variance per path is 50 by
#: quadrature; 13 of the 19 runs were flagged, their weights' tail heavy), pilots of 4096 in
#: none: always window 10, drift -c/2 (14), all 100 runs reliable.
_COARSE_PILOT = 4096


def _choose_proposal(problem, levels, key, threads, pilot, budget=None):
    """The proposal (window, drift) with the smallest estimated relative variance per path at
    the rarest level, over a grid of windows and drifts (and the large-deviation window of the
    velocity quantities), from pilot paths of their own stream (left out of the estimate, so
    the choice does not bias it). ``budget(done, total)``, called before each proposal's
    paths, may refuse to go on (max_seconds)."""
    c = problem.scene.drift
    top = float(np.max(levels))
    windows = sorted({problem.horizon * f for f in (1 / 16, 1 / 8, 1 / 4, 1 / 2, 1.0)}
                     | set(_ld_windows(problem, top)))
    drifts = [c * f for f in (1.0, 0.5, 0.0, -0.5, -1.0, -1.5, -2.0)]
    if problem.q.name in SIGN_QUANTITIES:
        # The signs are tilted already; the speeds need a lower friction, at most half
        # reversed: on the paper's scene (dt = 0.05, 20000 paths per proposal) a friction of
        # -c/2 over the whole horizon had the smallest relative variance per path at 5e-7 and
        # 1e-9 (62 and 79, Pareto shapes 0.55 and 0.42), a reversed -c a heavy tail at 5e-7
        # (shape 0.90).
        drifts = [c * f for f in (1.0, 0.5, 0.0, -0.25, -0.5)]
    # The displacement's proposals may also change the friction only while the body slides
    # faster than the stationary mean speed (SLOW_FACTORS; 0: whatever its speed).
    slows = SLOW_FACTORS if problem.q.name in SIGN_QUANTITIES else (0.0,)
    # The velocity quantities' windows shorter than the horizon draw DEFENSIVE of their paths
    # with the friction over the whole horizon that did best on its own (_proposal: their
    # weights are bounded then). The whole horizon's proposals are tried first, to know it.
    mixed = _coarse(problem)
    if mixed:
        pilot = max(pilot, _COARSE_PILOT)
    full = None
    best, tried = None, []
    stream = 1 << 62
    # How many proposals the pilot tries (for budget's estimate of the time left).
    total = sum(1 for _ in windows for d in drifts for f in slows
                if not (f > 0 and d == c) and not (f == 0 and d < 0 and len(slows) > 1))
    done = 0
    for w in sorted(windows, key=lambda w: w != problem.horizon):
        grid = _grid_for(problem, w)
        if mixed and w != problem.horizon and full is None:
            # No whole-horizon proposal had 20 pilot paths past the level: the one with the
            # most still bounds the weights.
            full = max((t for t in tried if t["window"] == problem.horizon),
                       key=lambda t: t["hits"])["drift"]
        for d in drifts:
            for f in slows:
                if f > 0 and d == c:
                    continue  # no change of law: the same proposal as f = 0
                if f == 0 and d < 0 and len(slows) > 1:
                    # A reversed friction down to 0 weighs every touch of 0: on the crate's
                    # fine grid (867 steps, 20000 paths at 1.3e-9) -c/2 had a relative
                    # variance per path of 3400 and a Pareto shape of 0.91 that way, 103 and
                    # 0.51 above the mean speed; a pilot of 1024 paths does not see the tail.
                    continue
                if budget is not None:
                    budget(done, total)
                done += 1
                prop = _proposal(grid, w, d, f, full if w != problem.horizon else None)
                contrib = _importance_batch(grid, prop, np.array([top]), pilot, key, stream,
                                            threads)[:, 0]
                stream += pilot
                hits = int(np.count_nonzero(contrib))
                mean = contrib.mean()
                rel = contrib.var() / mean ** 2 if mean > 0 else math.inf
                used = None if prop.full is None else full
                tried.append({"window": w, "drift": d, "slow": f, "full": used, "hits": hits,
                              "relative_variance": rel})
                if hits >= 20 and (best is None or rel < best[4]):
                    best = (w, d, f, used, rel)
        if mixed and w == problem.horizon and best is not None:
            full = best[1]
    return best, tried


#: Weights kept per level and batch for the Pareto diagnostic (the largest).
_TOP_WEIGHTS = 512


def pareto_shape(largest: np.ndarray) -> float:
    """The shape k of a generalised Pareto law fitted to the excesses of the largest weights
    over the next one (the tail of the weights' law), by the empirical-Bayes estimate of Zhang
    & Stephens (2009) with the weakly informative prior of Pareto-smoothed importance sampling
    (Vehtari, Simpson, Gelman, Yao & Gabry). k > 0.7: the weights' variance is infinite or the
    estimate is pre-asymptotic, so the reported standard error is not to be trusted; k < 0.5:
    finite variance. ``largest``: the M + 1 largest weights (any order), M >= 5."""
    w = np.sort(np.asarray(largest, dtype=float))
    x = w[1:] - w[0]
    n = len(x)
    if n < 5 or x[-1] <= 0:
        return math.nan
    grid = 30 + int(math.sqrt(n))
    # Candidate values of theta = -k / sigma, spread by the quartile and the maximum.
    theta = 1.0 / x[-1] + (1.0 - np.sqrt(grid / (np.arange(1, grid + 1) - 0.5))) / (3.0 * x[max(int(n / 4 + 0.5) - 1, 0)])
    k = np.mean(np.log1p(-theta[:, None] * x[None, :]), axis=1)
    loglik = n * (np.log(-theta / k) - k - 1.0)
    with np.errstate(over="ignore"):
        weight = 1.0 / np.exp(loglik[None, :] - loglik[:, None]).sum(axis=1)
    keep = weight >= 10 * np.finfo(float).eps
    theta_hat = np.sum(theta[keep] * weight[keep]) / np.sum(weight[keep])
    k_hat = np.mean(np.log1p(-theta_hat * x))
    # The prior: shrink towards 0.5 as if 10 observations sat there.
    return float((n * k_hat + 10 * 0.5) / (n + 10))


def sample(job: Dict[str, Any], index: int, threads: int = 0,
           deadline: Optional[float] = None,
           random_stream: Optional[int] = None) -> Dict[str, Any]:
    """Sample ``index`` of a tail run described by ``job`` (plain data: the scene's dict, the
    quantity, time, grid step, levels, particles, key and, for importance sampling, the
    proposal): a splitting replica, or a batch of ``particles`` weighted paths. A pure function
    of (job, index): the Dask task of a tail run. A replica still running at ``deadline`` (a
    ``time.time()``, the run's max_seconds) stops between its iterations and returns only
    ``timed_out`` and how far it got (no sample: the run leaves it out). ``random_stream``:
    the client's, given to a Dask task (:func:`crandall.streams.check_random_stream`)."""
    if random_stream is not None:
        _streams.check_random_stream(random_stream)
    problem = _Problem(Scene.from_dict(job["scene"]), job["quantity"], job["time"], job["dt"])
    lv = np.asarray(job["levels"], dtype=float)
    n, key = job["particles"], job["key"]
    if job["proposal"] is None:
        # A guard against a run that does not progress.
        est, info = _splitting_replica(problem, lv, n, max(1, n // 10), key, index, threads,
                                       _max_iterations(n), deadline=deadline)
        if info.get("timed_out"):
            return {"timed_out": True, "iterations": info["iterations"],
                    "log_weight": info["log_weight"]}
        return {"estimates": est.tolist(), "iterations": info["iterations"],
                "steps": info["steps"], "extinct": info["extinct"]}
    window, drift, slow, full = job["proposal"]
    grid = _grid_for(problem, window)
    contrib = _importance_batch(grid, _proposal(grid, window, drift, slow, full), lv, n, key,
                                index * _REPLICA_STREAMS, threads)
    return {"paths": n, "steps": n * grid.steps,
            "sum": contrib.sum(axis=0).tolist(),
            "sum2": (contrib ** 2).sum(axis=0).tolist(),
            "hits": np.count_nonzero(contrib, axis=0).tolist(),
            "top": [np.sort(col[col > 0])[-_TOP_WEIGHTS:].tolist() for col in contrib.T]}


# -- the result -----------------------------------------------------------------------------


@dataclass
class TailResult:
    """Tail probabilities P(Q > level) of one quantity, with their errors and diagnostics.

    Attributes
    ----------
    quantity, levels, units
        The quantity, its levels (ascending, in the scene's units) and the unit.
    probability, stderr, rel_error : ndarray
        The estimate at each level, its standard error and stderr / probability.
    method : str
        "splitting" or "importance".
    samples : int
        Independent replicas (splitting) or paths (importance sampling) in the estimate.
    seconds, steps : float, int
        Wall time and exact steps simulated (the cost).
    diagnostics : dict
        Splitting: iterations per replica, particles, and the score ("normalised" towards the
        one level, or "plain"; docs/methods/tails.md). Importance sampling: the proposal, and
        per level the effective sample size of the paths past it and the largest weight share.
    reliable : ndarray of bool
        False where the diagnostics show a degenerate estimate (importance sampling with too few
        effective samples or one dominant weight; a level no replica reached; a level every
        replica's every particle exceeded, ``all_replicas_one``, where P is only known to be
        within about 3 / (replicas x particles) of 1): its number is not a clean estimate.
    spec : dict
        What was run (scene, quantity, time, dt, method, seed, ...).
    """

    quantity: str
    levels: np.ndarray
    units: str
    probability: np.ndarray
    stderr: np.ndarray
    rel_error: np.ndarray
    method: str
    samples: int
    seconds: float
    steps: int
    diagnostics: Dict[str, Any]
    reliable: np.ndarray
    spec: Dict[str, Any] = field(default_factory=dict)

    def interval(self, level: float = 0.95):
        """The two-sided confidence interval (lower, upper) of each probability at ``level``,
        normal on the mean of the independent samples, clipped at 0; a deterministic answer
        (no noise before the quantity is read: one sample, no error) is its own interval."""
        from scipy.stats import norm, t as student

        if not (0 < level < 1):
            raise ParameterError("level", f"level must be in (0, 1), got {level}")
        if self.diagnostics.get("deterministic"):
            return self.probability.copy(), self.probability.copy()
        q = (student.ppf(0.5 + level / 2, self.samples - 1) if self.samples < 200
             else norm.ppf(0.5 + level / 2))
        return (np.maximum(self.probability - q * self.stderr, 0.0),
                self.probability + q * self.stderr)

    def to_pandas(self):
        """One row per level: probability, stderr, rel_error, the 95 % interval, reliable."""
        import pandas as pd

        lo, hi = self.interval()
        return pd.DataFrame({"level": self.levels, "units": self.units,
                             "probability": self.probability, "stderr": self.stderr,
                             "rel_error": self.rel_error, "lower_95": lo, "upper_95": hi,
                             "reliable": self.reliable})

    def __str__(self) -> str:
        lo, hi = self.interval()
        unit = f" [{self.units}]" if self.units else ""
        lines = [f"P({self.quantity} > level), {self.method}, {self.samples} "
                 f"{'replicas' if self.method == 'splitting' else 'paths'}, "
                 f"{self.seconds:.1f} s, {self.steps:.3g} steps",
                 f"{'level' + unit:>16} {'probability':>12} {'stderr':>10} {'rel.err':>8} "
                 f"{'95% interval':>25}"]
        for i, lv in enumerate(self.levels):
            flag = "" if self.reliable[i] else "  UNRELIABLE (see diagnostics)"
            lines.append(f"{lv:16.6g} {self.probability[i]:12.4g} {self.stderr[i]:10.3g} "
                         f"{self.rel_error[i]:8.3f} [{lo[i]:.3g}, {hi[i]:.3g}]{flag}")
        return "\n".join(lines)

    def _repr_html_(self) -> str:
        """The table of :meth:`__str__` as HTML (Jupyter shows it for a tail result)."""
        return _render.tail_html(self)

    def plot(self, ax=None, reference=None, label=None):
        """The exceedance curve with its 95 % band (log probability). ``reference``: a
        fixed-step :class:`crandall.Result` with the quantity's distribution, whose plain Monte
        Carlo exceedance is drawn where it is informative (p above 100 / paths)."""
        import matplotlib.pyplot as plt

        if ax is None:
            _, ax = plt.subplots(figsize=(6, 4))
        lo, hi = self.interval()
        ok = self.probability > 0
        ax.fill_between(self.levels[ok], np.maximum(lo[ok], 1e-300), hi[ok], alpha=0.3,
                        label="95 % interval")
        ax.plot(self.levels[ok], self.probability[ok], "o-", ms=3, label=label or self.method)
        if reference is not None:
            name = "stop_time" if self.quantity == "stop_time" else self.quantity
            grid = np.linspace(self.levels[0], self.levels[-1], 200)
            p = np.array([reference.exceedance(name, float(x)).value for x in grid])
            floor = 100.0 / reference.paths
            keep = p >= floor
            ax.plot(grid[keep], p[keep], "k--", label=f"plain Monte Carlo ({reference.paths:.0e} paths)")
        ax.set_yscale("log")
        unit = f" [{self.units}]" if self.units else ""
        ax.set_xlabel(f"level{unit}")
        ax.set_ylabel(f"P({self.quantity} > level)")
        ax.legend()
        return ax


# -- the run: the driver's estimator -------------------------------------------------------


def _stats(chosen, splitting: bool, levels: int):
    """(samples, mean, stderr, per-sample variance) of the estimate from the samples
    ``chosen``."""
    if splitting:
        arr = np.array([c["estimates"] for c in chosen])
        n = len(arr)
        var = arr.var(axis=0, ddof=1) if n > 1 else np.full(levels, np.inf)
        return n, arr.mean(axis=0), np.sqrt(var / n), var
    n = sum(c["paths"] for c in chosen)
    s1 = np.sum([c["sum"] for c in chosen], axis=0)
    s2 = np.sum([c["sum2"] for c in chosen], axis=0)
    mean = s1 / n
    var = np.maximum(s2 / n - mean ** 2, 0.0) * n / max(n - 1, 1)
    return n, mean, np.sqrt(var / n), var


def _canonical(data) -> bytes:
    """Plain data as canonical JSON (keys sorted; floats as Python writes them, which read
    back exactly), one line: what the checkpoint's checksum is computed over."""
    return json.dumps(data, sort_keys=True, separators=(",", ":")).encode("utf-8") + b"\n"


def _digest(spec: Dict[str, Any], samples: Sequence[Dict[str, Any]]):
    """The SHA-256 of a tail run's spec followed by its samples (hashlib's object: a run
    updates it with each sample it merges, so that a checkpoint costs no second pass)."""
    digest = hashlib.sha256(_canonical(spec))
    for s in samples:
        digest.update(_canonical(s))
    return digest


def _max_iterations(particles: int) -> int:
    """The iterations after which a splitting replica gives up: 200 n log(1/p) / n for
    log(1/p) up to about 12000, never reached by a run that progresses."""
    return 200 * particles * 60


def _check_samples(samples: Sequence[Dict[str, Any]], job: Dict[str, Any], most: int) -> None:
    """Check a checkpoint's samples against what the run ``job`` can have written: at most
    ``most`` of them, each with its fields, of the right types, lengths and ranges, and
    consistent with each other. A ValueError whose text starts with the field
    ("samples[3].estimates: ...")."""
    if len(samples) > most:
        raise ValueError(f"samples: {len(samples)} of them, more than the {most} this run can "
                         "take")
    levels, n = len(job["levels"]), job["particles"]
    problem = _Problem(Scene.from_dict(job["scene"]), job["quantity"], job["time"], job["dt"])
    splitting = job["proposal"] is None
    steps = problem.steps if splitting else _grid_for(problem, job["proposal"][0]).steps

    def integer(i, key, lo, hi=None):
        v = samples[i].get(key)
        if isinstance(v, bool) or not isinstance(v, int) or v < lo or (hi is not None and v > hi):
            raise ValueError(f"samples[{i}].{key}: {v!r} is not a whole number in "
                             f"[{lo}, {'...' if hi is None else hi}]")
        return v

    def per_level(i, key, lo, hi=math.inf):
        v = samples[i].get(key)
        if (not isinstance(v, list) or len(v) != levels
                or not all(isinstance(x, (int, float)) and not isinstance(x, bool) for x in v)):
            raise ValueError(f"samples[{i}].{key}: not a list of numbers, one per level "
                             f"({levels})")
        a = np.array(v, dtype=float)
        if not (np.all(np.isfinite(a)) and np.all(a >= lo) and np.all(a <= hi)):
            raise ValueError(f"samples[{i}].{key}: {v} holds a number that is not finite or "
                             f"not in [{lo:g}, {hi:g}]")
        return a

    for i in range(len(samples)):
        if splitting:
            est = per_level(i, "estimates", 0.0, 1.0)
            iterations = integer(i, "iterations", 0, _max_iterations(n))
            # A replica's steps: its n paths whole, then at most n - 1 continued per iteration.
            integer(i, "steps", n * steps, n * steps + iterations * (n - 1) * steps)
            # The last level's estimate is taken at the last iteration (or is 0): at most the
            # weight, each iteration having killed at least a tenth of the particles (compared
            # in logarithms, within the rounding of a sum of as many logarithms, below 1e-6).
            kill = max(1, n // 10)
            if est[-1] > 0 and math.log(est[-1]) > iterations * math.log1p(-kill / n) + 1e-6:
                raise ValueError(f"samples[{i}].estimates: {float(est[-1])!r} at the last "
                                 f"level, above the weight {iterations} iterations leave")
            continue
        integer(i, "paths", n, n)
        integer(i, "steps", n * steps, n * steps)
        s1, s2 = per_level(i, "sum", 0.0), per_level(i, "sum2", 0.0)
        hits = samples[i].get("hits")
        if (not isinstance(hits, list) or len(hits) != levels
                or not all(isinstance(h, int) and not isinstance(h, bool) and 0 <= h <= n
                           for h in hits)):
            raise ValueError(f"samples[{i}].hits: not a list of whole numbers in [0, {n}], one "
                             f"per level ({levels})")
        top = samples[i].get("top")
        if not isinstance(top, list) or len(top) != levels:
            raise ValueError(f"samples[{i}].top: not a list of lists, one per level ({levels})")
        for j in range(levels):
            t = top[j]
            if (not isinstance(t, list) or len(t) != min(hits[j], _TOP_WEIGHTS)
                    or not all(isinstance(x, (int, float)) and not isinstance(x, bool) for x in t)):
                raise ValueError(f"samples[{i}].top[{j}]: not the {min(hits[j], _TOP_WEIGHTS)} "
                                 "largest weights past the level")
            t = np.array(t, dtype=float)
            if not (np.all(np.isfinite(t)) and np.all(t > 0) and np.all(np.diff(t) >= 0)):
                raise ValueError(f"samples[{i}].top[{j}]: not positive finite weights in "
                                 "ascending order")
            # Sums of `hits` weights, each at most the largest, which they hold: exact bounds
            # but for the rounding of a sum of at most n terms (below n 2^-53, well within
            # 1e-6). The squares' bounds are taken in units of the largest weight, and only
            # where its square is a normal double (a subnormal one has lost its digits).
            m = t[-1]
            if hits[j] and not (m <= s1[j] <= hits[j] * m * (1 + 1e-6) and m * m <= s2[j] and (
                    m < 1e-100 or (s2[j] / m <= s1[j] * (1 + 1e-6)
                                   and (s1[j] / m) ** 2 <= hits[j] * (s2[j] / m / m) * (1 + 1e-6)))):
                raise ValueError(f"samples[{i}].sum: {float(s1[j])!r} (sum2 {float(s2[j])!r}) at "
                                 f"level {j} cannot be the sum of {hits[j]} weights up to "
                                 f"{float(t[-1])!r}")
            if not hits[j] and (s1[j] or s2[j]):
                raise ValueError(f"samples[{i}].sum: {float(s1[j])!r} at level {j}, where no path "
                                 "hit")
        # The paths past a level are among those past any lower one.
        if np.any(np.diff(hits) > 0) or np.any(np.diff(s1) > 0) or np.any(np.diff(s2) > 0):
            raise ValueError(f"samples[{i}].hits: the hits or sums grow with the level")


class _TailRun(Estimator):
    """A tail run's samples (splitting replicas or batches of weighted paths) as the driver's
    estimator: each sample a pure function of the job and its index, run here or as a Dask
    task; the checkpoint holds the finished samples.

    Two stages, so that when to stop never depends on the estimate itself (stopping when the
    running error first looks small enough would favour runs whose rare large contributions
    have not come yet, a bias towards small probabilities): a pilot of ``min_samples`` samples,
    left out of the estimate, gives the variance per sample, hence the number of samples the
    target needs; then exactly that many (or fewer when max_samples or max_seconds ends the
    run: a cut that does not depend on their values either).
    """

    name = "tail"

    def __init__(self, job, spec, *, threads, task_threads, per_sample, path_bytes,
                 min_samples, max_samples, rel_error, max_seconds, started, rate=None,
                 steps=0, advice="give a larger max_seconds"):
        self.job, self.spec, self.threads = job, spec, threads
        self.task_threads = task_threads
        self.splitting = job["proposal"] is None
        self.levels = len(job["levels"])
        self.max_samples, self.rel_error = max_samples, rel_error
        self.max_seconds, self.started = max_seconds, started
        self.per_sample = per_sample
        self.path_bytes = path_bytes
        self.pilot_n = -(-min_samples // per_sample)
        #: What the pilot's variance is estimated from: replicas, or weighted paths.
        self.pilot_samples = self.pilot_n * per_sample
        self.min_samples = min_samples
        self.samples: List[Dict[str, Any]] = []
        #: The checksum of the spec and the samples merged so far (the checkpoint's).
        self.digest = _digest(spec, [])
        self.target_n: Optional[int] = None
        self.wanted = 0
        self.stopped_early = False
        #: The run's max_seconds as a time.time() (Dask workers compare their clocks with
        #: it): a replica still running then stops between its iterations.
        self.deadline = _time.time() + max_seconds - (_time.perf_counter() - started)
        #: Path-steps per second measured before the run (_rate) and the steps of a
        #: sample's grid: a sample's least cost, its first paths' steps, is estimated from
        #: them before any sample has run.
        self.rate, self.steps = rate, steps
        #: What would help when max_seconds does not suffice (tail()'s words for the case).
        self.advice = advice
        #: The output of a sample stopped by the deadline (no sample: left out).
        self.cut: Optional[Dict[str, Any]] = None
        #: Wall seconds and samples of the batches run in this call (the measured rate).
        self.ran = [0.0, 0]

    def identity(self):
        return self.spec

    def check_memory(self):
        _check_memory(self.job["particles"], self.path_bytes, self.threads, "particles",
                      f"particles: {self.job['particles']} paths", "give fewer particles or a "
                      "larger dt")

    def state(self):
        return json_state({"samples": self.samples, "checksum": self.digest.hexdigest()})

    def restore(self, arrays, path):
        """Carry on from a checkpoint's samples (its identity already matched this run's).

        Every sample is checked against what this run can have written (types, lengths,
        ranges, and the fields' consistency with each other), naming the field; then the
        checksum, which the run wrote over its spec and the samples, refuses any edit the
        ranges let through (an estimate scaled within [0, 1], another run's samples)."""
        where = f"checkpoint: {path}"
        st = read_json_state(path, arrays, "a tail run")
        samples = st.get("samples")
        if not isinstance(samples, list) or not all(isinstance(x, dict) for x in samples):
            raise ValueError(f"{where} is not a checkpoint of a tail run (field state: samples "
                             "is not a list of tables)")
        try:
            _check_samples(samples, self.job, self.pilot_n + max(2, -(-self.max_samples
                                                                     // self.per_sample)))
        except ValueError as exc:
            raise ValueError(f"{where} is damaged (field {exc}); remove it to start "
                             "again") from None
        digest = _digest(self.spec, samples)
        if st.get("checksum") != digest.hexdigest():
            why = ("missing" if "checksum" not in st else
                   "it does not match the samples and this run's spec: they were edited or "
                   "damaged")
            raise ValueError(f"{where} is damaged (field checksum: {why}); remove it to start "
                             "again")
        self.samples, self.digest = samples, digest

    def _tasks(self, first: int, last: int):
        return [Task(sample, (self.job, i, self.task_threads, self.deadline,
                             _streams.RANDOM_STREAM),
                     functools.partial(sample, self.job, i, self.threads, self.deadline), 1)
                for i in range(first, last)]

    def _elapsed(self) -> float:
        return _time.perf_counter() - self.started

    def _expect(self, count: int) -> float:
        """The seconds ``count`` more samples are expected to take: at the wall time per
        sample of those run in this call; before any, at least their first paths' steps at the
        measured rate (a lower bound: a replica's iterations come on top)."""
        seconds, done = self.ran
        if done:
            return seconds / done * count
        if not self.rate:
            return 0.0
        parallel = 1 if self.workers is None else max(1, min(count, self.workers))
        paths = self.job["particles"] * -(-count // parallel)
        return paths * self.steps / self.rate

    def _timed(self, batch):
        """Yield a batch to the driver, timing it (the driver merges it before resuming)."""
        started = _time.perf_counter()
        yield batch
        self.ran[0] += _time.perf_counter() - started
        self.ran[1] += len(batch)

    def _out_of_time(self, what: str) -> ParameterError:
        # Pilot replicas that ended in an extinction (their particles tied below the level)
        # had no particle past it: a sign that the level is out of reach.
        dead = sum(1 for c in self.samples if c.get("extinct") is not None
                   and not np.any(np.asarray(c.get("estimates", [])) > 0))
        out = (f" ({dead} of the {len(self.samples)} replicas run ended with their particles "
               "tied below the levels: they may be beyond what the paths reach)" if dead else "")
        return ParameterError(
            "max_seconds", f"max_seconds: {what}, more than max_seconds={self.max_seconds:g} "
            f"allows ({self._elapsed():.3g} s spent){out}; {self.advice}")

    def _pilot_cut(self) -> ParameterError:
        """The error of a pilot replica stopped by the deadline: how far it got."""
        top = max(self.job["levels"])
        return ParameterError(
            "max_seconds", f"max_seconds: the pilot's replica {len(self.samples)} had not "
            f"reached level {top:g} when max_seconds={self.max_seconds:g} ran out "
            f"({self._elapsed():.3g} s spent, {self.cut['iterations']} iterations; its "
            f"particles had got as far as a probability of about "
            f"{math.exp(self.cut['log_weight']):.1e}): the level is beyond what the paths "
            f"reach in that time; {self.advice}")

    def rounds(self):
        # On a cluster a batch of as many samples as it has threads (at least 8); here one.
        # A batch is not started when the time per sample measured so far (before any: its
        # least cost at the measured rate) says it would end past max_seconds; a replica
        # running then stops (sample's deadline). A pilot that cannot finish is refused.
        width = 1 if self.workers is None else max(8, self.workers)
        what = "replicas" if self.splitting else "batches"
        while len(self.samples) < self.pilot_n:
            last = self.pilot_n if self.workers is not None else len(self.samples) + 1
            left = self.pilot_n - len(self.samples)
            expect = self._expect(left)
            if self._elapsed() + expect > self.max_seconds:
                raise self._out_of_time(
                    f"the pilot's {left} {'remaining ' if self.samples else ''}{what} would "
                    f"take {'about' if self.ran[1] else 'at least'} {expect:.3g} s more")
            yield from self._timed(self._tasks(len(self.samples), last))
            if self.cut is not None:
                raise self._pilot_cut()
        _, pmean, _, pvar = _stats(self.samples[:self.pilot_n], self.splitting, self.levels)
        with np.errstate(divide="ignore", invalid="ignore"):
            need = np.where(pmean > 0, pvar / (self.rel_error * pmean) ** 2, np.nan)
        if np.all(np.isnan(need)):
            low = self.job["levels"][0]
            if not self.splitting:
                raise StatisticsFailure(f"importance: no pilot sample reached level {low:g}; "
                                        "use method='splitting'")
            # Replicas that ended in an extinction: their particles' scores tied below the
            # level, which more particles do not untie.
            reached = [c.get("extinct") for c in self.samples[:self.pilot_n]]
            reached = [x for x in reached if x is not None]
            how = (f"in {'every one' if len(reached) == self.pilot_n else len(reached)} the "
                   f"particles' scores stopped rising below it, all tied (they got as far as "
                   f"a probability of about {math.exp(min(reached)):.1e}): " if reached else "")
            raise StatisticsFailure(
                f"splitting: no pilot replica reached level {low:g}: {how}the level is "
                "beyond what the paths reach; give a smaller level, or try "
                "method='importance'")
        # The pilot's variance is itself noisy (and low more often than high for skewed
        # samples): SAFETY more, or up to the variance's 90 % upper confidence bound, and never
        # fewer than the pilot.
        self.wanted = int(min(self.max_samples,
                              max(self.min_samples, math.ceil(
                                  max(SAFETY, variance_upper_factor(self.pilot_samples))
                                  * np.nanmax(need)))))
        self.target_n = self.pilot_n + max(2, -(-self.wanted // self.per_sample))
        while len(self.samples) < self.target_n:
            batch = self._tasks(len(self.samples), min(self.target_n, len(self.samples) + width))
            if self._elapsed() + self._expect(len(batch)) > self.max_seconds:
                self.stopped_early = True
                return
            yield from self._timed(batch)
            if self.cut is not None:
                self.stopped_early = True
                return

    def merge(self, task, output):
        # A sample stopped by the deadline is no sample, nor is any after it in its batch
        # (the samples are kept in the order of their indices).
        if self.cut is not None or output.get("timed_out"):
            self.cut = self.cut or output
            return
        self.samples.append(output)
        self.digest.update(_canonical(output))

    def progress(self):
        if self.target_n is None:
            return Progress(len(self.samples), None, "pilot")
        return Progress(len(self.samples), self.target_n)

    def result(self):
        return self.samples


def _check_memory(paths: int, path_bytes: int, threads: int, name: str, what: str,
                  advice: str) -> None:
    """Refuse, before they are allocated, ``paths`` paths stored whole on a grid of
    ``path_bytes`` each (velocity, displacement, distance at every point), with room for a
    splitting step's copies and scores or importance sampling's touches and excursions (4 x),
    and a stack per thread, that would not fit in what this process may still allocate."""
    need = 4 * paths * path_bytes + threads * (16 << 20)
    have = available_memory()
    if need > have:
        raise ParameterError(
            name, f"{what} of {path_bytes // 24} grid points need about {need / 2**20:.0f} MiB, "
            f"more than the {have / 2**20:.0f} MiB this process may still allocate; {advice}")


#: Path-steps of the measurement of the core's rate (_rate): tens of milliseconds.
_RATE_STEPS = 1 << 18


def _rate(problem: _Problem, key: int, threads: int) -> float:
    """Path-steps per second of the core's exact step on this problem's grid, measured on a
    few paths over the grid's last steps (their numbers are discarded): what a run's least
    cost is estimated from before it starts. The faster of two measurements (a loaded
    machine's pause makes one slower, and a lower bound of the cost must not grow by it)."""
    m = max(1, min(problem.steps, _RATE_STEPS // 16))
    k = max(1, _RATE_STEPS // m)
    part = slice(problem.steps - m, problem.steps)
    states = np.zeros((k, m + 1, 3))
    states[:, 0, 0] = problem.scene.v0
    best = math.inf
    for _ in range(2):
        t = _time.perf_counter()
        _core.extend_paths(states, np.arange(k, dtype=np.int64), np.zeros(k, dtype=np.int64),
                           np.arange(k, dtype=np.uint64) + np.uint64(3 << 61),
                           problem.lengths[part], problem.noises[part], problem.drifts[part],
                           key, threads)
        best = min(best, _time.perf_counter() - t)
    return k * m / max(best, 1e-9)


def _levels(levels) -> np.ndarray:
    # Element by element: NumPy would take "1" as 1.0 and True as 1.0 silently.
    if isinstance(levels, np.ndarray):
        items = levels.ravel().tolist()
    elif isinstance(levels, (str, bytes)):
        items = [levels]
    else:
        try:
            items = levels = list(levels)  # also takes a generator once
        except TypeError:
            items = [levels]
    bad = next((x for x in items if not (is_real(x) or isinstance(x, (list, tuple, np.ndarray)))),
               None)
    if bad is not None:
        raise ParameterError("levels", f"levels must be a number or a sequence of numbers, got "
                                       f"{bad!r}")
    try:
        arr = np.atleast_1d(np.asarray(levels, dtype=float))
    except (TypeError, ValueError):
        raise ParameterError("levels", "levels must be a number or a sequence of numbers") from None
    if arr.ndim != 1 or arr.size == 0:
        raise ParameterError("levels", "levels must be a number or a non-empty sequence of numbers")
    if not np.all(np.isfinite(arr)):
        raise ParameterError("levels", f"levels must be finite, got {arr.tolist()}")
    if np.any(np.diff(arr) <= 0):
        raise ParameterError("levels", f"levels must be strictly increasing, got {arr.tolist()}")
    return arr


def _advice(problem: _Problem, splitting: bool, dt_given: bool,
            samples: Optional[str] = "") -> str:
    """What makes a tail run cheaper, for a message: only what is true for its case.
    ``samples``: the words for fewer samples (default: the run's pilot; None: none help)."""
    q = problem.q
    out = ["a smaller level"] if splitting else []
    coarse_is_own = not splitting and q.velocity_only and not q.peak  # runs on one step a part
    if not coarse_is_own and (not splitting or problem.noisy_steps > MIN_SPLITTING_STEPS):
        out.append(f"a larger dt (the {q.name}'s probabilities do not depend on it)"
                   if q.velocity_only else
                   f"a larger dt{' than the default' if not dt_given else ''} (a coarser "
                   f"trapezoid rule for the {q.name})")
    if samples == "":
        samples = "fewer particles or min_samples" if splitting else "fewer min_samples"
    if samples:
        out.append(samples)
    out.append("method='importance'" if splitting else "method='splitting'")
    return "give " + ", ".join(out) + " or a larger max_seconds"


def tail(scene: Scene, quantity: str, levels: Union[float, Sequence[float]], *,
         time: Optional[float] = None, rel_error: float = 0.1, method: str = "splitting",
         seed=None, dt: Optional[float] = None, particles: int = 200,
         min_samples: Optional[int] = None, max_samples: Optional[int] = None,
         max_seconds: float = 3600.0, threads: Optional[int] = None,
         progress: Optional[bool] = None, checkpoint: Optional[str] = None,
         client=None) -> TailResult:
    """Tail probabilities P(Q > level) of a quantity, to a relative error, down to about 1e-12.

    Parameters
    ----------
    scene : Scene
        Any scene: constant or piecewise intensity, any start (``v0``, ``u0``). A scene given
        as an envelope is run on its pieces: the probabilities are the pieces' (the piece
        error is not estimated for tails).
    quantity : str
        One of ``TAIL_QUANTITIES``: "stop_time", "velocity" and "speed" (signed and magnitude,
        at ``time``), "distance_at_stop", "dissipated_energy_at_stop", "displacement_at_stop"
        (signed), "residual_displacement" (|U(t_s)|), "peak_displacement_at_stop",
        "peak_speed_at_stop" (maxima over the grid points: below the continuous path's maxima
        by a discretisation error that falls like sqrt(dt)).
    levels : float or sequence of float
        Strictly increasing levels in the scene's units; one run estimates all of them (an
        exceedance curve).
    time : float, optional
        The output time of "velocity" and "speed" (the scene's time units).
    rel_error : float, default 0.1
        Target relative error (stderr / probability) at every level, in [1e-6, 1); samples
        are added until it is met, ``max_samples`` or ``max_seconds`` is reached (a
        StatisticsWarning then says what was reached).
    method : {"splitting", "importance"}
        Adaptive multilevel splitting (any quantity; the default) or importance sampling with
        an exact likelihood ratio (a lower or reversed friction over a final window, chosen
        from pilot paths).
    seed : int, numpy SeedSequence or Generator, optional
        The run's seed; the result is bitwise the same for any ``threads``.
    dt : float, optional
        Grid step (scene units). Default: the scene's default step (``crandall.default_dt``),
        for splitting refined to at least 50 steps while the noise acts (a short
        excitation).
        Velocity and stop time are exact on any grid (dt only changes the cost); displacement
        and distance are the trapezoid rule on it, as a fixed-step run with method "exact".
    particles : int, default 200
        Splitting: particles per replica (a tenth are killed per iteration). Importance
        sampling: paths per batch.
    min_samples, max_samples : int, optional
        The pilot's size, which sets how many samples the target needs (left out of the
        estimate), and the most samples the estimate may take: replicas (splitting; default 20
        and 100000; a pilot of at least 3) or paths (importance sampling; default 1000 and
        10^8).
    max_seconds : float, default 3600
        The run's time bound, pilots included. A pilot that would not finish in it is
        refused before it starts (its least cost at the core's speed measured on a few
        paths) or when the time per sample it shows says so; a replica still running at the
        bound stops (one in the pilot: refused, saying how far it got); the estimate's
        samples stop when the next would end past it (a StatisticsWarning says so). The
        refusals say what would help in the case at hand.
    threads : int, optional
        Threads of the core (default: all cores; with ``client``, threads per task, default 1).
    progress : bool, optional
        A progress bar (default: where a person watches).
    client : distributed.Client, optional
        Run the samples as Dask tasks on this cluster (bitwise the same result as a local
        run).
    checkpoint : str or path, optional
        A file of the finished samples (crandall's checkpoint format): a run with the same
        arguments resumes from it, and an interrupted run (Ctrl-C) loses only the replica or
        batch in progress. A file of another run (``rel_error``, ``min_samples`` and
        ``max_samples`` included) or estimator is refused, naming the arguments that differ;
        so is a damaged or edited one, naming the field (its samples are checked, and a
        checksum over them: docs/methods/tails.md).

    Returns
    -------
    TailResult
    """
    start = _time.perf_counter()
    problem = _Problem(scene, quantity, time, dt)
    lv = _levels(levels)
    if method == "splitting" and 0 < problem.noisy_steps < MIN_SPLITTING_STEPS:
        # Few grid points, few branch points: the replicas' estimates get a heavy tail (at
        # 5 steps over the paper's tau0 = 5 the relative spread of one replica at 1e-4 is 5,
        # against 1.0 at 50 steps), and their mean's interval stops covering. The velocity
        # quantities are exact on any grid, so theirs is refined; so is the default step of
        # the others (a short excitation); a coarser dt the user gave defines their trapezoid
        # rule, and is refused.
        if TAIL_QUANTITIES[quantity].velocity_only or dt is None:
            problem = _Problem(scene, quantity, time, problem.noisy_time / MIN_SPLITTING_STEPS)
        else:
            raise ParameterError("dt", f"dt: splitting needs at least {MIN_SPLITTING_STEPS} "
                                 f"steps while the noise acts; dt = {problem.dt:g} gives "
                                 f"{problem.noisy_steps}")
    if method not in TAIL_METHODS:
        raise ParameterError("method", f"method must be one of {', '.join(TAIL_METHODS)}; got {method!r}")
    if not (is_real(rel_error) and MIN_REL_ERROR <= rel_error < 1):
        raise ParameterError("rel_error", f"rel_error must be in [{MIN_REL_ERROR:g}, 1), got "
                                          f"{rel_error!r}")
    rel_error = float(rel_error)
    if not (isinstance(max_seconds, (int, float)) and max_seconds > 0):
        raise ParameterError("max_seconds", f"max_seconds must be > 0, got {max_seconds!r}")
    check_int("particles", particles, 10, 10_000_000)
    threads, task_threads = resolve_threads(threads)
    seed = as_seed(seed)
    if seed is None:
        seed = draw_seed()
    check_int("seed", seed, 0, MAX_SEED)
    splitting = method == "splitting"
    check_client(client)
    if checkpoint is not None and not isinstance(checkpoint, (str, os.PathLike)):
        raise ParameterError("checkpoint", f"checkpoint must be a path, got {checkpoint!r}")
    min_samples = check_int("min_samples", min_samples if min_samples is not None else (20 if splitting else 1000), 2, 10 ** 12)
    if splitting and min_samples < 3:
        # The pilot's variance bound (variance_upper_factor) is infinite below 3 samples.
        # Importance sampling's pilot is whole batches of particles >= 10 paths.
        raise ParameterError("min_samples", f"min_samples must be >= 3 for splitting (the "
                                            f"pilot's variance bound needs 3 replicas), got "
                                            f"{min_samples}")
    max_samples = check_int("max_samples", max_samples if max_samples is not None else (100_000 if splitting else 10 ** 8), min_samples, 10 ** 12)
    # Sample i continues its paths with the streams i * 2^40 + 0, 1, ... (signed 64-bit in the
    # core's call): at most 2^23 samples, pilot and second stage together.
    per = 1 if splitting else particles
    if -(-min_samples // per) + max(2, -(-max_samples // per)) > _MAX_SAMPLES - 1:
        what = "replicas" if splitting else f"batches of particles = {particles} paths"
        raise ParameterError("max_samples", f"max_samples: min_samples + max_samples come to more than "
                             f"{_MAX_SAMPLES - 1} {what} (their random streams are numbered in "
                             f"blocks of 2^40); give fewer" + ("" if splitting else " or more particles"))
    key = _streams.tail_key(seed)
    unit = "" if scene.units == "scaled" else TAIL_QUANTITIES[quantity].unit
    # What the samples are and how many the run takes (max_seconds is not: a run stopped by
    # it resumes with more time).
    spec = {"scene": scene.to_dict(), **problem.describe(), "levels": lv.tolist(),
            "method": method, "seed": seed, "particles": particles, "rel_error": rel_error,
            "min_samples": min_samples, "max_samples": max_samples}
    spec = json.loads(json.dumps(spec))  # the checkpoint's view of it (tuples become lists)
    if problem.noisy_steps == 0:
        # No noise before the horizon: the quantity is deterministic.
        states = problem.start_states(1)
        _extend(problem, states, [0], [0], [0], key, 1)
        value = float(problem.value(problem.score(states))[0])
        p = (value > lv).astype(float)
        z = np.zeros_like(p)
        return TailResult(quantity, lv, unit, p, z, z.copy(), method, 1, 0.0, 0,
                          {"deterministic": True}, np.ones(len(lv), bool), spec)
    diagnostics: Dict[str, Any] = {}
    window = drift = slow = 0.0
    full = None
    advice = _advice(problem, splitting, dt is not None)
    # The core's speed on this grid: the pilots' least cost is estimated from it before they
    # start (max_seconds bounds them too).
    rate = _rate(problem, key, threads)
    if splitting:
        diagnostics.update(particles=particles, killed_per_iteration=max(1, particles // 10),
                           score=("plain" if _normalised_top(problem, lv) is None
                                  else "normalised"))
    else:
        # The displacement's proposals hit less often in their pilot (a few per cent at 1e-9):
        # more pilot paths, so that the best of them shows its 20 hits.
        pilot = max(1024 if quantity in SIGN_QUANTITIES else 256, particles)
        # The proposal pilot's paths are allocated too: checked before it, as the run's are.
        grid = _grid_for(problem, problem.horizon)
        _check_memory(pilot, 8 * 3 * (grid.steps + 1), threads, "dt",
                      f"dt: importance sampling's proposal pilot, {pilot} paths",
                      "give a larger dt" + ("" if pilot > particles else " or fewer particles"))
        # Its paths are max(floor, particles): fewer particles help only above the floor.
        pilot_advice = _advice(problem, splitting, dt is not None,
                               "fewer particles" if pilot == particles else None)
        proposal_started = _time.perf_counter()

        def budget(done: int, total: int) -> None:
            # Before each proposal: the pilot's remaining proposals at the time per proposal
            # measured so far (before any: their paths' steps at the measured rate).
            spent = _time.perf_counter() - proposal_started
            expect = ((total - done) * spent / done if done
                      else total * pilot * grid.steps / rate)
            if _time.perf_counter() - start + expect > max_seconds:
                raise ParameterError(
                    "max_seconds", f"max_seconds: importance sampling's proposal pilot "
                    f"({total - done} {'more ' if done else ''}proposals of {pilot} paths) "
                    f"would take {'about' if done else 'at least'} {expect:.3g} s more, more "
                    f"than max_seconds={max_seconds:g} allows ({_time.perf_counter() - start:.3g} "
                    f"s spent); {pilot_advice}")

        best, tried = _choose_proposal(problem, lv, key, threads, pilot=pilot, budget=budget)
        diagnostics["proposals_tried"] = tried
        if best is None:
            raise StatisticsFailure(
                f"importance sampling: no proposal reached level {lv[-1]:g} in its pilot paths; "
                f"use method='splitting'")
        window, drift, slow, full, _ = best
        diagnostics["proposal"] = {"window": window, "drift": drift, "slow": slow,
                                   "full": full}

    # What a sample needs, as plain data: the sample is a pure function of it and its index,
    # run here or as a Dask task (bitwise the same).
    job = {"scene": scene.to_dict(), "quantity": quantity, "time": time, "dt": problem.dt,
           "levels": lv.tolist(), "particles": particles, "key": key,
           "proposal": None if splitting else (window, drift, slow, full)}

    run = _TailRun(job, spec, threads=threads, task_threads=task_threads,
                   per_sample=1 if splitting else particles,
                   path_bytes=8 * 3 * (problem.steps + 1),
                   min_samples=min_samples, max_samples=max_samples, rel_error=rel_error,
                   max_seconds=max_seconds, started=start, rate=rate, advice=advice,
                   steps=(problem if splitting else _grid_for(problem, window)).steps)
    drive(run, checkpoints=checkpoint, client=client, progress=progress)
    samples, pilot_n, wanted, stopped_early = (run.samples, run.pilot_n, run.wanted,
                                               run.stopped_early)
    diagnostics["pilot_samples"] = pilot_n * (1 if splitting else particles)
    used = samples[pilot_n:]
    if len(used) < 2:
        raise ParameterError(
            "max_seconds", f"max_seconds: {method} stopped by max_seconds={max_seconds:g} "
            f"after its pilot, before the estimate's samples ran (the pilot's took "
            f"{run.ran[0] / max(run.ran[1], 1):.3g} s each); {advice}")
    n, mean, se, _ = _stats(used, splitting, len(lv))
    with np.errstate(divide="ignore", invalid="ignore"):
        rel = np.where(mean > 0, se / mean, np.inf)
    reliable = mean > 0
    if splitting:
        arr = np.array([c["estimates"] for c in used])
        # A replica gives exactly 1 only when all its particles start above the level: if every
        # replica does, the spread between them (0) says nothing, and 1 - P is only known to be
        # below about 3 / (replicas x particles) (the rule of three, 95 %).
        ones = np.all(arr == 1.0, axis=0)
        diagnostics.update(replicas=n, iterations_mean=float(np.mean([c["iterations"] for c in used])),
                           zero_replicas=np.sum(arr == 0, axis=0).tolist(),
                           all_replicas_one=ones.tolist())
        reliable &= ~ones
    else:
        s1 = np.sum([c["sum"] for c in used], axis=0)
        s2 = np.sum([c["sum2"] for c in used], axis=0)
        hits = np.sum([c["hits"] for c in used], axis=0)
        shapes, shares = [], []
        for j in range(len(lv)):
            top = np.sort(np.concatenate([c["top"][j] for c in used]))
            shares.append(float(top[-1] / s1[j]) if s1[j] > 0 else 1.0)
            m = int(min(0.2 * hits[j], 3 * math.sqrt(hits[j]), _TOP_WEIGHTS - 1))
            shapes.append(pareto_shape(top[-(m + 1):]) if m >= 5 else math.nan)
        with np.errstate(divide="ignore", invalid="ignore"):
            ess = np.where(s2 > 0, s1 ** 2 / s2, 0.0)
        diagnostics.update(effective_samples=ess.tolist(), largest_weight_share=shares,
                           pareto_shape=shapes, hits=hits.tolist())
        reliable &= ((ess >= MIN_EFFECTIVE_SAMPLES) & (np.array(shares) <= MAX_WEIGHT_SHARE)
                     & (np.nan_to_num(np.array(shapes), nan=np.inf) < MAX_PARETO_SHAPE))
    total_steps = int(sum(c["steps"] for c in samples))
    result = TailResult(quantity, lv, unit, mean, se, rel, method, n,
                        _time.perf_counter() - start, total_steps, diagnostics, reliable, spec)
    if not np.all(reliable):
        bad = ", ".join(f"{x:g}" for x in lv[~reliable])
        warnings.warn(f"tail: the estimates at levels {bad} are not reliable (importance "
                      f"sampling degenerate, no sample reached the level, or every path "
                      f"exceeded it, so that P is only known to be near 1): see "
                      f"TailResult.diagnostics", StatisticsWarning, stacklevel=2)
    elif np.any(rel > rel_error):
        why = (f"max_seconds ({max_seconds:g} s)" if stopped_early else
               "max_samples" if wanted >= max_samples else "the pilot's variance estimate")
        warnings.warn(f"tail: relative error {float(np.max(rel)):.3g} above the target "
                      f"{rel_error:g}: the number of samples was limited by {why}",
                      StatisticsWarning, stacklevel=2)
    return result


class StatisticsFailure(RuntimeError):
    """An estimator found no usable answer (e.g. no importance-sampling proposal reached the
    level); the message says what to do instead."""
