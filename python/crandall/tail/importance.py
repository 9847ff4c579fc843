"""Importance sampling: the proposals (a changed friction over a final window, the signs of the
velocity's excursions re-drawn), their exact likelihood ratios, the proposal's pilot and the
weights' diagnostics (docs/methods/tails.md)."""

from __future__ import annotations

import math
from typing import List, Optional

import numpy as np

from ..model import TAIL_MODEL, require
from . import detmath as dm
from .problem import _coarse, _extend, _grid_for, _Law, _Problem, log_transition_density


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
    # The weights are the sign-drift velocity's transition density: refused, naming the
    # scene, where it does not hold (also in a Dask task, which starts here).
    require(problem.scene, TAIL_MODEL, "importance sampling (crandall.tail)")
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
    if problem.tail_score.signs is not None:
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
            log_pq = -dm.logaddexp(_LOG_DEFENSIVE, _LOG_OTHERS - log_pq)
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
            logw = -dm.logaddexp(_LOG_DEFENSIVE - _log_weights(problem, states, law.full),
                                 _LOG_OTHERS - logw)
    hits = value[:, None] > levels[None, :]
    return np.where(hits, dm.exp(logw)[:, None], 0.0)


# -- importance sampling of the displacement: the signs re-drawn ----------------------------

# The quantities whose importance sampling re-draws the signs of the velocity's excursions (a
# friction change alone pushes the distance, not the displacement, one way) are those whose
# tail score declares ``signs`` (problem.SCORES: the displacement at the stop and its
# magnitude); the constants below are theirs.
#: The share of their paths simulated under the scene's own law, and of their signs drawn as
#: fair coins (defensive mixtures); for the velocity quantities, of the paths under the
#: full-horizon component of a window's proposal (_proposal). On the stop time at tau0 = 20
#: past 25 (by quadrature) the mixture of window 10, drift -c/2 with drift 0 over the horizon
#: has a relative variance per path of 14 with a share of 0.1, 18 with 0.3, where either alone
#: has 91 and 29.
DEFENSIVE = 0.1
#: log DEFENSIVE and log(1 - DEFENSIVE), with the same bits on every CPU (detmath.py).
_LOG_DEFENSIVE = dm.scalar(dm.log, DEFENSIVE)
_LOG_OTHERS = dm.scalar(dm.log1p, -DEFENSIVE)
#: Their proposals' speed thresholds, in units of the stationary mean speed sigma^2 / (2 c).
SLOW_FACTORS = (0.0, 1.0)
#: Their proposals' frictions, in units of c (see _choose_proposal).
SIGN_DRIFTS = (1.0, 0.5, 0.0, -0.25, -0.5)
#: Their proposal pilot's least paths per proposal (the others': 256): their proposals hit
#: less often in it (a few per cent at 1e-9), so that the best of them shows its 20 hits.
SIGN_PILOT = 1024
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
    return dm.log_cosh(x)


def _tilt(fixed: np.ndarray, parts: np.ndarray, top: np.ndarray, target: float,
          sign: float) -> np.ndarray:
    """Per path the tilt theta >= 0 at which the mean of fixed + sign sum_j s_j B_j under the
    tilted coins (P(s_j = sign) = (1 + tanh(theta B_j)) / 2) is the target; 0 if it already is,
    the largest tilt if no signs reach it. By bisection in t = theta max_j B_j."""
    lo, hi = np.zeros(len(fixed)), np.full(len(fixed), _MAX_TILT)
    scale = np.where(top > 0, top, 1.0)
    for _ in range(64):
        mid = 0.5 * (lo + hi)
        mean = fixed + sign * np.sum(parts * dm.tanh(mid[:, None] * parts / scale[:, None]), axis=1)
        short = sign * mean < sign * target
        lo, hi = np.where(short, mid, lo), np.where(short, hi, mid)
    theta = hi / scale
    return np.where(sign * fixed >= sign * target, 0.0, theta)


def _resigned(problem: _Problem, states: np.ndarray, touched: np.ndarray,
              levels: np.ndarray, key: int, first: int):
    """The displacement's quantity with the excursions' signs re-drawn, and log dP/dQ of the
    signs (``levels`` in the quantity's units; the value too: the score times the row's
    factor).

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
    magnitude = problem.tail_score.signs == "magnitude"
    parts = [(np.zeros(n), 1.0)]
    for level in problem.in_score_units(np.asarray(levels, dtype=float)):
        parts.append((_tilt(fixed, free, top, level, 1.0), 1.0))
        if magnitude:
            parts.append((_tilt(fixed, free, top, -level, -1.0), -1.0))
    # The fair coin takes DEFENSIVE of the paths, the tilts share the rest equally.
    share = np.array([DEFENSIVE] + [(1.0 - DEFENSIVE) / (len(parts) - 1)] * (len(parts) - 1))
    which = np.minimum(np.searchsorted(np.cumsum(share), pick, side="right"), len(parts) - 1)
    theta = np.zeros(n)
    towards = np.ones(n)
    for i, (th, d) in enumerate(parts):
        theta = np.where(which == i, th, theta)
        towards = np.where(which == i, d, towards)
    p = 0.5 * (1.0 + dm.tanh(theta[:, None] * free))
    signs = np.where(draws < p, 1.0, -1.0) * towards[:, None]
    total = np.sum(signs * free, axis=1)
    log_q = np.stack([dm.scalar(dm.log, w) + d * th * total
                      - np.sum(_log_cosh(th[:, None] * free), axis=1)
                      for w, (th, d) in zip(share, parts)])
    log_q = dm.logaddexp_reduce(log_q)
    value = fixed + total
    if magnitude:
        value = np.abs(value)
    return problem._times_factor(value), -log_q


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


def _ld_windows(problem: _Problem, top: float) -> List[float]:
    """Windows from the large-deviation path of the velocity quantities (the tail scores that
    declare ``ld_speed``): |V| climbs to a level a at the rate c of the reversed friction over
    its last a / c (the time reversal of the relaxation), so the proposal reverses the
    friction over that window."""
    c, speed = problem.scene.drift, problem.tail_score.ld_speed
    if speed is None:
        return []
    a = speed(problem, problem.in_score_units(top))
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
    signs = problem.tail_score.signs is not None
    if signs:
        # The signs are tilted already; the speeds need a lower friction, at most half
        # reversed: on the paper's scene (dt = 0.05, 20000 paths per proposal) a friction of
        # -c/2 over the whole horizon had the smallest relative variance per path at 5e-7 and
        # 1e-9 (62 and 79, Pareto shapes 0.55 and 0.42), a reversed -c a heavy tail at 5e-7
        # (shape 0.90).
        drifts = [c * f for f in SIGN_DRIFTS]
    # The displacement's proposals may also change the friction only while the body slides
    # faster than the stationary mean speed (SLOW_FACTORS; 0: whatever its speed).
    slows = SLOW_FACTORS if signs else (0.0,)
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
    k = np.mean(dm.log1p(-theta[:, None] * x[None, :]), axis=1)
    loglik = n * (dm.log(-theta / k) - k - 1.0)
    weight = 1.0 / dm.exp(loglik[None, :] - loglik[:, None]).sum(axis=1)
    keep = weight >= 10 * np.finfo(float).eps
    theta_hat = np.sum(theta[keep] * weight[keep]) / np.sum(weight[keep])
    k_hat = np.mean(dm.log1p(-theta_hat * x))
    # The prior: shrink towards 0.5 as if 10 observations sat there.
    return float((n * k_hat + 10 * 0.5) / (n + 10))
