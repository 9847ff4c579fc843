"""How many pieces a smooth envelope is run with: refined until the error of the pieces,
as estimated, is below the run's statistical error (``simulate(paths=)``) or half its
target (``simulate(error=)``, ``rel_error=``).

An envelope's scene is simulated exactly on its pieces; the error of the pieces against the
envelope is estimated by halving every piece (crandall.bias: the same paths on both
schedules). A run whose error bars are far below that error would report a precision it does
not have (issue: on the cabinet scene, 16 pieces erred by 0.0017 in a velocity variance of
0.0005 reported to +-4e-6). So before the run, a pilot of the coupled runs (at most
``PILOT_PATHS`` paths, the stream of the run's own bias estimate) estimates the piece error of
every statistic the run reports, and the envelope's pieces are multiplied by the power of two
its first order asks for, until every *resolved* piece error is at most the target. A piece
error the pilot does not resolve (its estimate is a bound: the difference is within 2
standard errors) does not ask for more pieces (more pieces cannot lower a bound set by the
pilot's paths); it is part of the result's bias like every other bound, so the total error
the result reports (``Result.error``, the figures' bars) includes it. At most ``MAX_FACTOR``
times the pieces given; past that the run goes on and warns.

The choice is a pure function of the scene, the run's paths (or target) and its seed, so a
run resumed from its checkpoint, or a Dask task, finds the same pieces.
"""

from __future__ import annotations

import math
import time
import warnings
from typing import Callable, Dict, Optional, Sequence, Tuple

import numpy as np

from . import bias
from .errors import ParameterError
from .model import ENVELOPE
from .quantities import quantity
from .results import StatisticsWarning
from .spec import RunSpec

__all__ = ["choose", "stderr_target", "accuracy_target", "with_pieces", "PILOT_PATHS",
           "MAX_FACTOR"]

#: Paths of the pilot (per schedule), at most the run's own: those of the bias estimate's
#: piece error, so that a run's estimate reuses its pilot's table.
PILOT_PATHS = bias.PIECE_PATHS
#: Paths of the pilot while the pieces are still far from enough.
SCOUT_PATHS = 1024
#: Most times the pieces given that a run refines them to.
MAX_FACTOR = 1024

#: A statistic's target in the core's units: (name, stat, slot, its pilot value, the pilot's
#: per-path values, its largest size over the slots) -> the largest piece error allowed.
Target = Callable[[str, str, int, float, np.ndarray, float], float]


def with_pieces(scene, pieces: int):
    """The scene on its envelope with ``pieces`` pieces (everything else the same)."""
    if pieces == scene.envelope.pieces:
        return scene
    env = scene.envelope
    return scene.with_intensity(envelope=type(env)(env.kind, env.params, pieces, env.function,
                                                   env.breaks, max(pieces, env.pieces),
                                                   _warn=False))


def stderr_target(paths: int) -> Target:
    """A run of ``paths`` paths: the piece error at most its statistic's standard error,
    predicted from the pilot's per-path values."""
    def target(name, stat, slot, value, x, size):
        n = len(x)
        c = x - x.mean()
        m2 = float(np.mean(c * c))
        if stat == "mean":
            return math.sqrt(m2 / paths)
        m4 = float(np.mean(c ** 4))
        return math.sqrt(max(m4 - m2 * m2, 0.0) / paths) * math.sqrt(n / max(n - 1, 1))
    return target


def _value(stat: str, x: np.ndarray) -> float:
    """The statistic of per-path values ``x``."""
    return float(np.mean(x)) if stat == "mean" else float(np.var(x, ddof=1))


def _scale(stat: str, value: float, x: np.ndarray) -> float:
    """A statistic's size as a relative target measures it (crandall.adaptive's tolerance):
    its absolute value, for a mean at least the quantity's spread."""
    return max(abs(value), float(np.std(x))) if stat == "mean" else abs(value)


def accuracy_target(scene, eps: Optional[float], rel: Optional[float],
                    floor: float = 0.0) -> Target:
    """A run to an accuracy: the piece error at most half the statistic's target (in the
    core's units, as crandall.adaptive measures it: a mean that is 0 by symmetry against
    the quantity's spread, and never less than ``floor`` times the statistic's largest size
    over the output times, adaptive.REL_FLOOR), so that the levels have the rest."""
    def target(name, stat, slot, value, x, size):
        if eps is not None:
            f = abs(quantity(name).factor(scene))
            if f == 0.0:
                return math.inf
            return 0.5 * eps / (f if stat == "mean" else f * f)
        return 0.5 * rel * max(_scale(stat, value, x), floor * size)
    return target


def choose(scene, names: Sequence[str], *, paths: int, seed: int, threads: int,
           target: Target, step_length: float, stats: Optional[set] = None,
           dt: Optional[float] = None, method: str = "richardson",
           max_seconds: float = math.inf,
           event_depth: Optional[int] = None) -> Tuple[object, Optional[Dict]]:
    """The scene with the pieces its run needs, and what the choice found (None when the
    scene has no envelope to refine): ``pieces`` given and chosen, ``worst``, the largest
    resolved piece error over its target on the chosen pieces, and ``table``, the chosen
    pieces' errors per (name, stat) (crandall.bias.piece_table). ``stats``: the (name, stat)
    pairs that count (all of ``names``' means and variances if None); ``step_length``: the
    run's step (pieces are not refined below it on average); ``dt``, ``method``,
    ``event_depth``: the run's (the pilot's coupled grids are its bias estimate's, and search
    a filtered excitation's events as deep as the run does). ``max_seconds``: a pilot still
    refining after that long is a ParameterError naming it (a run to an accuracy's bound)."""
    env = scene.envelope
    if (ENVELOPE not in scene.effects or env is None or env.function is None or paths < 2
            or not env.refine):
        return scene, None
    # At most MAX_FACTOR times the pieces, and pieces no shorter on average than the run's
    # step (shorter ones would add steps: the cost of the run would grow with its pieces).
    most = MAX_FACTOR
    while most > 1 and env.params["end"] / (env.pieces * most) < step_length:
        most //= 2
    factor, worst, before, taken = 1, math.inf, math.inf, 1
    current = scene
    stalled = False
    # A rough pilot while the pieces are far from enough, the full one to confirm.
    pilot = min(paths, SCOUT_PATHS)
    started = time.perf_counter()
    while True:
        spent = time.perf_counter() - started
        if spent > max_seconds:
            raise ParameterError(
                "max_seconds", f"max_seconds: choosing the envelope's pieces took {spent:.3g} "
                f"s (now {env.pieces * factor} pieces), beyond max_seconds={max_seconds!r}; "
                "raise max_seconds, ask for a larger target, or keep the pieces given "
                "(envelope.fixed())")
        current = with_pieces(scene, env.pieces * factor)
        spec = RunSpec.create(current, paths=pilot, seed=seed, dt=dt,
                              method=bias.piece_method(scene, method), event_depth=event_depth)
        try:
            table, values = bias.piece_table_kept(spec, names, threads)
        except ValueError as exc:
            if "2^53 steps" not in str(exc):
                raise
            # The finer schedules' grids do not fit (a horizon of 1e18 s): the pieces stay
            # as they were; the run's own grid decides whether it can run at all.
            return scene, None
        worst, which = 0.0, ""
        # Per statistic its largest size over the slots (a relative target's floor).
        sizes = {}
        for (name, stat), (errors, _) in table.items():
            if name in values:
                sizes[(name, stat)] = max(
                    (_scale(stat, _value(stat, values[name][:, k]), values[name][:, k])
                     for k in range(len(errors))), default=0.0)
        for (name, stat), (errors, bounds) in table.items():
            if stats is not None and (name, stat) not in stats:
                continue
            for slot, (e, bound) in enumerate(zip(errors, bounds)):
                if bound or not e > 0:
                    continue
                x = values[name][:, slot]
                allowed = target(name, stat, slot, _value(stat, x), x, sizes[(name, stat)])
                ratio = e / allowed if allowed > 0 else math.inf
                if ratio > worst:
                    at = ("" if quantity(name).at_stop
                          else f" at {scene.times[slot]:g}")
                    worst, which = ratio, f"the {stat} of {name}{at}"
        if worst <= 1.0 and pilot < min(paths, PILOT_PATHS):
            pilot = min(paths, PILOT_PATHS)
            continue
        if worst <= 1.0 or factor >= most:
            break
        if taken >= 8 and worst > before / 2:
            # Eight times the pieces or more did not halve it (a statistic whose standard
            # error shrinks with the pieces, as the coast after an envelope that ends at 0):
            # stop here.
            stalled = True
            break
        before = worst
        step = 2 ** max(1, math.ceil(math.log2(worst))) if math.isfinite(worst) else MAX_FACTOR
        taken = min(factor * step, most) // factor
        factor *= taken
    if worst > 1.0:
        why = ("more pieces did not lower it" if stalled else
               f"{MAX_FACTOR} times the {env.pieces} given" if most == MAX_FACTOR else
               f"pieces no shorter than the run's step, {step_length:.3g}")
        warnings.warn(f"envelope: with {env.pieces * factor} pieces ({why}) the error of the "
                      f"pieces in {which} is still {worst:.3g} times what the run asks (in "
                      "Result.bias, part of every error reported); give the envelope more "
                      "pieces, or a smaller dt", StatisticsWarning, stacklevel=4)
    return current, {"pieces_given": env.pieces, "pieces": env.pieces * factor,
                     "worst": worst, "table": table}
