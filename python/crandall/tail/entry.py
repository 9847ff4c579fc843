"""``crandall.tail``: the arguments checked, the method, grid and proposal chosen, the run driven."""

from __future__ import annotations

import json
import math
import os
import time as _time
import warnings
from typing import Any, Dict, Optional, Sequence, Union

import numpy as np

from .. import _core
from .. import streams as _streams
from ..driver import check_client, drive
from ..driver import threads as resolve_threads
from ..errors import ParameterError
from ..model import EXACT_STEP, TAIL_MODEL, holds
from ..results import StatisticsWarning
from ..scene import Scene
from ..spec import MAX_SEED, as_seed, check_int, draw_seed, is_real
from .importance import _choose_proposal, _TOP_WEIGHTS, pareto_shape, SIGN_PILOT
from .problem import _extend, _grid_for, _Problem
from .result import _stats, StatisticsFailure, TailResult
from .run import _check_memory, _TailRun
from .splitting import _normalised_top

TAIL_METHODS = ("splitting", "importance")
#: The most samples (replicas or batches) of one run: their streams' first numbers fit in int64.
_MAX_SAMPLES = 1 << 23
#: Thresholds of an importance-sampling run's degeneracy (docs/methods/tails.md): fewer
#: effective samples among the paths past a level, or a single path carrying more of its weight.
MIN_EFFECTIVE_SAMPLES = 30.0
MAX_WEIGHT_SHARE = 0.1
#: The fewest grid steps with noise that splitting runs on (see tail()).
MIN_SPLITTING_STEPS = 50
#: The smallest target relative error: the samples a target asks for are about a sample's
#: relative variance over rel_error^2, and max_samples is at most 10^12.
MIN_REL_ERROR = 1e-6
#: Largest Pareto shape of the weights' tail (:func:`pareto_shape`) for a reliable estimate.
MAX_PARETO_SHAPE = 0.7


#: Path-steps of the measurement of the core's rate (_rate): a few milliseconds (a tail run
#: at 1e-9 takes about a second, of which the measurement took 4 % at 2^18).
_RATE_STEPS = 1 << 16


def _rate(problem: _Problem, key: int, threads: int) -> float:
    """Path-steps per second of the core's exact step on this problem's grid, measured on a
    few paths over the grid's last steps (their numbers are discarded): what a run's least
    cost is estimated from before it starts. The faster of two measurements (a loaded
    machine's pause makes one slower, and a lower bound of the cost must not grow by it)."""
    if problem.filtered:
        # The filtered walk's steps (each with its event search) from a start state at the
        # point m steps before the end; far fewer of them: a step costs about 14 exact steps
        # (docs/methods/tails.md, "Filtered excitations").
        m = max(1, min(problem.steps, _RATE_STEPS // 512))
        k = max(1, _RATE_STEPS // 32 // m)
        states = problem.start_states(k)
        states[:, problem.steps - m] = states[:, 0]
        best = math.inf
        for _ in range(2):
            t = _time.perf_counter()
            _extend(problem, states, np.arange(k), np.full(k, problem.steps - m),
                    np.arange(k), key ^ 0x5A5A, threads)
            best = min(best, _time.perf_counter() - t)
        return k * m / max(best, 1e-9)
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
        # rule, and is refused. Under a filtered excitation no quantity is exact on any grid
        # (its events are located on substeps of the grid's steps): a dt given is refused.
        if (problem.q.velocity_only and holds(scene, EXACT_STEP)) or dt is None:
            problem = _Problem(scene, quantity, time, problem.noisy_time / MIN_SPLITTING_STEPS)
        else:
            raise ParameterError("dt", f"dt: splitting needs at least {MIN_SPLITTING_STEPS} "
                                 f"steps while the noise acts; dt = {problem.dt:g} gives "
                                 f"{problem.noisy_steps}")
    if method not in TAIL_METHODS:
        raise ParameterError("method", f"method must be one of {', '.join(TAIL_METHODS)}; got {method!r}")
    if method == "importance" and not holds(scene, TAIL_MODEL):
        # Its weights are the sign-drift velocity's transition density.
        missing = ", ".join(sorted(frozenset(scene.effects) - TAIL_MODEL.supports))
        raise ParameterError("method", f"method: importance sampling is not available for a "
                             f"scene with {missing} ({TAIL_MODEL.what} does not hold there); "
                             f"use method='splitting'")
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
    unit = "" if scene.units == "scaled" else problem.q.si_unit
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
        # The displacement's proposals (its score re-draws the signs) hit less often in their
        # pilot (a few per cent at 1e-9): more pilot paths, so that the best of them shows its
        # 20 hits.
        pilot = max(SIGN_PILOT if problem.tail_score.signs is not None else 256, particles)
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
                   path_bytes=problem.path_bytes,
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
