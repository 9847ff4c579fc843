"""The discretisation bias of a fixed-step run's statistics (``Result.bias``), estimated on
coupled grids (docs/methods/adaptive.md, "Fixed-step runs").

A fixed-step run keeps the moments of its (extrapolated) estimator only. Its bias is
estimated by a separate run of the same scene (as many paths as the run, at most BIAS_PATHS)
in which every path is integrated on three exactly coupled grids (docs/methods/richardson.md:
the same exact path, so differences between grids have a small variance), chosen so that the
run's own grid is one of them: the run's step counts, per segment, times 2^r, with r = 2 for
"exact" (grids h/4, h/2, h: the run's grid is the coarsest), r = 1 for "richardson2" (h/2, h,
2h: the run's two grids are the coarser ones) and r = 0 for "richardson" (h, 2h, 4h: the
run's grids). The step counts of the run are whole numbers of its method's group (1, 2 or 4)
per segment, and refining them by 2^r keeps every point of the run's grid, so no other grid
than the run's is ever measured in its place:

- "exact" (trapezoid on the grid h): E[P_h] minus the three-grid Richardson extrapolation
  from (h/4, h/2, h), which assumes a bias c1 h^1.5 + c2 h^2 and so removes the run's leading
  terms;
- "richardson2": its combination of (h, 2h) minus the three-grid extrapolation from
  (h/2, h, 2h): an estimate of richardson2's own bias;
- "richardson": the difference between richardson2 and richardson on the run's grids, which
  estimates richardson2's bias and so bounds the bias of richardson, whose leading term
  richardson2 keeps;
- statistics exact in law at any step (every moment of the velocity, the kinetic energy, the
  stop time): 0;
- "euler" and "refine", and the peaks under white noise (maxima over the grid, whose
  shortfall bench/peaks.py measures): not estimated (NaN). Under a filtered excitation the
  coupled grids record each path's peaks on every grid (the running maxima over each grid's
  points and event points), and their bias is estimated as the other statistics' (the
  measured order below; docs/filtered.md, "Peaks").

Where the difference is not resolved (below 2 standard errors) the estimate is its bound,
|difference| + 2 standard errors. The separate run draws its own paths (a stream of its own,
derived from the seed), so the estimate is reproducible and independent of the run's paths.

A scene given as a smooth envelope (``Scene(envelope=...)``) adds the error of its pieces to
every statistic's bias, the ones exact in law for the pieces too: the same coupled run (the
same paths, paired by index) on the envelope with twice the pieces, compared on the finest
coupled grid (the two schedules' grid biases nearly cancel there). The piece error is first
order in the piece length (on Amin & Ang's envelope the differences between n and 2n pieces
fall by 2.2 to 2.9 per halving), so the error of n pieces is estimated as twice the
difference (twice its bound where it is not resolved); grid and piece errors add. The
variance at the stop of the distance (and the energy) takes its difference through Ito's
isometry (crandall.model.ISOMETRY): Var S(t_s) = E int sigma^2 V^2 dt / c^2 on either schedule,
so the difference is one of means of an integral the coupled runs then record, far less spread
than the squares' (docs/scenes.md).
"""

from __future__ import annotations

import collections
import dataclasses
import functools
import json
import math
from typing import Dict, Optional, Tuple

import numpy as np

from . import _core
from . import engine, results
from ._resources import available_memory
from .driver import Estimator, Progress, Task, drive
from .errors import ParameterError
from .methods import GRIDS, METHODS, SKELETON
from .model import (ENVELOPE, FILTERED_EXCITATION, GRID_ORDERS, exact_in_law, holds,
                    isometry_applies)
from .quantities import VELOCITY, core_flags, quantity
from .spec import RunSpec
from .streams import bias_key

__all__ = ["estimate", "piece_errors", "BIAS_PATHS", "PIECE_ORDER_FACTOR"]

#: Paths of the coupled run: the run's own number, at most this (so that the estimate never
#: costs more than about 1/16 of a run of a million paths, nor more than the run itself).
BIAS_PATHS = 65536
#: ... and at most this many bytes of per-path values (scenes with many output times).
BIAS_BYTES = 256 << 20
#: Paths per batch of the coupled run (the progress bar's and Ctrl-C's unit).
BATCH_PATHS = 8192
#: The coupled run's method: its grids (h, 2h, 4h of the refined grid) are the coupled grids,
#: its weights the better estimator every difference is taken against.
COUPLED_METHOD = "richardson"
#: Per method, the refinement of the coupled run over the run's grid (2^r times its steps),
#: so that the run's grids are the coarsest of the coupled grids: the run's grid is the
#: coarsest ("exact", r = 2), its two grids the coarser ones ("richardson2", r = 1) or its
#: three grids all of them ("richardson", r = 0). Read from the core's table
#: (crandall.methods): every method whose steps are the exact skeleton's (SKELETON: its
#: integrals are the trapezoid rule on its grids, which the coupled grids reproduce) with at
#: most the coupled run's grids, r = the coupled run's grids minus its own. The others
#: ("euler", "refine") have no coupled refinement: their bias is not estimated.
REFINEMENT = {m: GRIDS[COUPLED_METHOD] - GRIDS[m] for m in METHODS
              if SKELETON[m] and GRIDS[m] <= GRIDS[COUPLED_METHOD]}


#: The error of n pieces over the difference between n and 2n pieces (first order).
PIECE_ORDER_FACTOR = 2.0


def _sum(values: np.ndarray, threads: int) -> float:
    return float(_core.sum_products(values[:, None], [1], threads)[0])


class _CoupledRun(Estimator):
    """The coupled run's per-path values as the driver's estimator: batches of BATCH_PATHS
    paths written into one array (each path's values depend on its index only, so the batches
    give the bits of one call). Run on request, here only: it keeps no checkpoint."""

    name = "bias"

    def __init__(self, spec, paths: int, threads: int, quadratic: bool = False,
                 one_grid: bool = False) -> None:
        # The run's own options (every field of its spec), on coupled grids that include the
        # run's grid, with a stream of its own; with ``quadratic`` also the isometry's integral
        # int sigma^2 V^2 dt, in a slot after the stop's (it changes no other value).
        scene = spec.scene
        o = engine.plan_options(spec, histograms=False)
        # One grid, the run's (the envelope's piece error compares schedules on one grid);
        # else the three coupled grids of the grid's bias.
        o.method = "exact" if one_grid else COUPLED_METHOD
        o.refinement = 0 if one_grid else REFINEMENT[spec.method]
        o.seed = bias_key(spec.seed)
        o.quadratic_variation = quadratic
        # At most BIAS_BYTES of per-path values (3 grids x 3 variables per output slot; a
        # filtered excitation's peaks take as many slots again).
        slots = len(scene.times) + (1 if "stop" in scene.observe else 0) + (1 if quadratic else 0)
        if _peaks_recorded(scene):
            slots += len(scene.times) + (1 if "stop" in scene.observe else 0)
        n = int(min(paths, BIAS_PATHS, max(2, BIAS_BYTES // (8 * 9 * slots))))
        o.paths = n
        self.plan = _core.Plan(o)
        self.threads = threads
        self.one_grid = one_grid
        self.n = n
        # The values' layout (a stop slot may hold more than one), from one path.
        self.shape = (n,) + _core.run_samples(self.plan, 0, 1, 1).shape[1:]
        self.samples = None
        self.done = 0

    def check_memory(self) -> None:
        need = 8 * math.prod(self.shape) + self.threads * (16 << 20)
        have = available_memory()
        if need > have:
            raise ParameterError("times", f"times: the bias estimate's {self.n} coupled paths need about "
                             f"{need / 2**20:.0f} MiB, more than the {have / 2**20:.0f} MiB "
                             "this process may still allocate; give fewer times or threads")

    def rounds(self):
        self.samples = np.empty(self.shape)
        yield [Task(None, (), functools.partial(self._batch, first, min(BATCH_PATHS,
                                                                        self.n - first)),
                    min(BATCH_PATHS, self.n - first))
               for first in range(0, self.n, BATCH_PATHS)]

    def _batch(self, first: int, count: int):
        return _core.run_samples(self.plan, first, count, self.threads, False,
                                 self.samples[first:first + count])

    def merge(self, task, output) -> None:
        self.done += task.size

    def progress(self) -> Progress:
        # The piece error's one-grid runs (before a run: its pilot) say what they are.
        return Progress(self.done, self.n,
                        "envelope pieces' error" if self.one_grid else "bias estimate")

    def result(self) -> np.ndarray:
        return self.samples


def _samples(spec, paths: int, threads: int, quadratic: bool = False,
             one_grid: bool = False) -> np.ndarray:
    """The coupled run's per-path values, (paths, slots, 3 grids, 3 variables); with
    ``one_grid`` on the run's grid alone, (paths, slots, 1, 3 variables)."""
    return drive(_CoupledRun(spec, paths, threads, quadratic, one_grid))[0]


def _isometry_names(scene, names) -> set:
    """The quantities of ``names`` whose piece error of the variance is taken through Ito's
    isometry (crandall.model.ISOMETRY): the coupled runs then record int sigma^2 V^2 dt, which
    the core does with the stop and an integral observed and no peaks."""
    flags = core_flags(scene.observe)
    if not (flags["stop"] and (flags["displacement"] or flags["distance"])
            and not flags.get("peaks")):
        return set()
    return {n for n in names if isometry_applies(quantity(n), scene)}


def _peaks_recorded(scene) -> bool:
    """Whether the coupled grids record each path's peaks (in the slots after the stop's): the
    filtered core does when the scene observes them (Options::sample_slots); the white-noise
    kernel does not."""
    return FILTERED_EXCITATION in scene.effects and bool(core_flags(scene.observe).get("peaks"))


def _grid_estimated(name: str, scene) -> bool:
    """Whether the coupled grids estimate the grid bias of ``name``: every statistic not
    exact in law, the peaks only where the grids record them."""
    return not exact_in_law(name, scene) and (not quantity(name).peak or _peaks_recorded(scene))


def needs_run_for(result) -> bool:
    """Whether :func:`estimate` runs paths of its own for this result: coupled grids for a
    statistic not exact in law (white noise's peaks have none), or an envelope's pieces."""
    coupled = result.paths >= 2 and result.method in REFINEMENT
    return coupled and (ENVELOPE in result.scene.effects or any(
        _grid_estimated(n, result.scene) for n in result.names))


def estimate(result, threads: int = 1) -> Dict[Tuple[str, str], Tuple[np.ndarray, bool]]:
    """Per (name, stat): the estimated |bias| (array over the output times, or one value at
    the stop) and whether it is a bound (the difference was not resolved)."""
    method = result.method
    out: Dict[Tuple[str, str], Tuple[np.ndarray, bool]] = {}
    names = result.names
    envelope = ENVELOPE in result.scene.effects
    needs_run = needs_run_for(result)
    # The run's own grids (the envelope's piece error has coupled runs of its own).
    grid_needed = any(_grid_estimated(n, result.scene) for n in names)
    samples = (_samples(result.spec, result.paths, threads)
               if needs_run and grid_needed else None)
    if envelope and result.scene.envelope.function is None:
        # A function envelope read back from plain data: its pieces without the function, so
        # the error of the pieces is unknown (NaN in every statistic's bias; Result.bias says
        # why).
        unknown = {(n, s): (np.full(1 if quantity(n).at_stop else len(result.times), math.nan),
                            False) for n in names for s in ("mean", "var")}
        pieces = unknown
    else:
        pieces = (_piece_errors(result.spec, result.names, threads, result.paths)
                  if needs_run and envelope else {})
    a, b = _estimators(method)
    # Without the white-noise skeleton's expansion (model.GRID_ORDERS: a filtered excitation)
    # the bias of the run's grid h is e(h) = |P_h - P_h/2| r / (r - 1), with r the measured
    # ratio of the differences (h, h/2) and (h/2, h/4) (_order_factor: 2, first order, where
    # r is not resolved, up to MAX_ORDER_FACTOR where no convergence is seen).
    measured = method == "exact" and not holds(result.scene, GRID_ORDERS)
    n_times = len(result.times)
    # The peaks' slots follow the output times' and the stop's (Options::sample_slots).
    peak_base = n_times + (1 if "stop" in result.scene.observe else 0)
    for name in names:
        q = quantity(name)
        slots = [n_times] if q.at_stop else list(range(n_times))
        f = q.factor(result.scene)
        for stat in ("mean", "var"):
            scale = abs(f) if stat == "mean" else f * f
            if exact_in_law(name, result.scene):
                out[(name, stat)] = _plus(np.zeros(len(slots)), False, pieces.get((name, stat)),
                                          scale)
                continue
            if samples is None or not _grid_estimated(name, result.scene):
                # White noise's peaks: their shortfall is measured by bench/peaks.py
                # (docs/distributions.md), not estimated per run: the white-noise kernel's
                # coupled grids hold no running maxima.
                out[(name, stat)] = (np.full(len(slots), math.nan), False)
                continue
            values, bounds = [], []
            for slot in slots:
                v = samples[:, peak_base + slot if q.peak else slot, :, q.variable]
                v = np.abs(v) if q.magnitude else v ** q.power
                v = v - _sum(v[:, 0], threads) / len(v)  # centred: the combinations sum to 1
                if measured:
                    d, se = _difference(v, _GRID_H, _GRID_H2, stat, threads)
                    d2, se2 = _difference(v, _GRID_H2, _GRID_H4, stat, threads)
                    factor = _order_factor(d, se, d2, se2)
                else:
                    d, se = _difference(v, a, b, stat, threads)
                    factor = 1.0
                resolved = abs(d) > 2 * se
                mag = factor * (abs(d) if resolved else abs(d) + 2 * se)
                values.append(mag * scale)
                bounds.append(not resolved)
            out[(name, stat)] = _plus(np.array(values), any(bounds), pieces.get((name, stat)),
                                      scale)
    return out


def _estimators(method: str):
    """The weights (finest coupled grid first) of the run's estimator on the coupled grids and
    of a better one, or (None, None) for a method with no coupled refinement. The run's
    estimator is its own weights on the coarsest of the coupled grids (REFINEMENT), the better
    one the coupled run's method on all of them: for "exact" (0, 0, 1) against richardson,
    for "richardson2" (0, w2) against richardson. The coupled run's method itself is compared
    from the method of one grid fewer on the finest grids (richardson2's (w2, 0)), which
    estimates that method's bias and so bounds its own."""
    r = REFINEMENT.get(method)
    if r is None:
        return None, None
    better = np.array(_core.richardson_weights(COUPLED_METHOD))
    if r > 0:
        return np.concatenate([np.zeros(r), _core.richardson_weights(method)]), better
    lower = next(m for m, rm in REFINEMENT.items() if rm == 1)
    return np.concatenate([_core.richardson_weights(lower), [0.0]]), better


#: The coupled grids' estimates (finest first): the run's grid h, h/2 and h/4 alone.
_GRID_H = np.array([0.0, 0.0, 1.0])
_GRID_H2 = np.array([0.0, 1.0, 0.0])
_GRID_H4 = np.array([1.0, 0.0, 0.0])


def _plus(values: np.ndarray, bound: bool, piece: Optional[Tuple[np.ndarray, bool]],
          factor: float):
    """The grid's bias estimate plus the envelope's piece error (if any; in the core's
    units, times ``factor`` in the quantity's)."""
    if piece is None:
        return values, bound
    return values + piece[0] * factor, bound or piece[1]


def _refined(scene):
    """The scene on its envelope with twice the pieces (everything else the same)."""
    return scene.with_intensity(envelope=scene.envelope.refined(2), distributions=False)


def piece_errors(scene, names, *, seed: int, paths: int = BIAS_PATHS,
                 threads: int = 1) -> Dict[Tuple[str, str], Tuple[np.ndarray, bool]]:
    """Per (name, stat) of ``names``: the estimated error of simulating the envelope of
    ``scene`` by its pieces, in the core's units (multiply by the quantity's factor, squared
    for "var"; an array over the output times, or one value at the stop) and
    whether it is a bound; NaN for white noise's peaks; {} for a scene without an envelope. The coupled
    run on the default grid (its finest grid: the default step), on both schedules (see the
    module's docstring), with at most ``paths`` paths; for runs to an accuracy, whose own
    bias is the grid's."""
    if ENVELOPE not in scene.effects or paths < 2:
        return {}
    spec = RunSpec.create(scene, paths=min(paths, BIAS_PATHS), seed=seed,
                          method=piece_method(scene))
    return _piece_errors(spec, names, threads)


def piece_method(scene, method: str = "richardson") -> str:
    """The method of the coupled runs that estimate a scene's piece error: ``method`` if it
    has a refinement (REFINEMENT), else the coupled run's; the exact one, on its coupled grids,
    for a filtered excitation (the white-noise methods do not step it)."""
    if FILTERED_EXCITATION in scene.effects:
        return "exact"
    return method if method in REFINEMENT else COUPLED_METHOD


def _coarse_on_fine(scene, fine):
    """The scene's pieces cut at the ends of ``fine`` (its refinement): each fine piece with
    the intensity of the scene's piece that holds it. The law of the scene's pieces on the
    grid of the fine schedule, so that both draw the same random numbers at the same times:
    paired by index on different grids, the paths of the two schedules part within a piece
    (per-path differences as spread as the values themselves, 0.025 against 0.023 in the
    cabinet scene's velocity at 1 s), on one grid they differ only by the intensities."""
    coarse_ends = np.asarray(scene.envelope.t0)
    fine_ends = list(fine.envelope.t0)
    holder = np.searchsorted(coarse_ends, fine_ends, side="left")
    h = [float(scene.envelope.h[i]) for i in holder]
    return scene.with_intensity(h=h, t0=fine_ends, distributions=False)


def _order_factor(d1: float, se1: float, d2: float, se2: float) -> float:
    """e(n) / |d1| from the differences d1 = m(n) - m(2n) and d2 = m(2n) - m(4n): r/(r-1)
    with r = |d1| / |d2| the measured ratio where d2 is resolved (PIECE_ORDER_FACTOR, first
    order, where it is not), PIECE_ORDER_FACTOR (r = 2) at least, and
    MAX_ORDER_FACTOR where r is near 1 or below (no convergence seen: the pieces are far from
    the envelope's time scales, where more pieces are the answer, not a factor)."""
    if not abs(d2) > 2 * se2:
        return PIECE_ORDER_FACTOR  # no second difference seen: first order assumed
    r = abs(d1) / abs(d2)
    if r >= PIECE_ORDER_FACTOR:
        return PIECE_ORDER_FACTOR
    return min(r / (r - 1.0), MAX_ORDER_FACTOR) if r > 1.0 else MAX_ORDER_FACTOR


#: The largest e(n) / |m(n) - m(2n)| the piece error is given (convergence not seen).
MAX_ORDER_FACTOR = 11.0


def piece_table(spec, names, threads: int, paths: Optional[int] = None):
    """Per (name, stat) of ``names``: the estimated error of the envelope's pieces at each
    slot (core units; NaN for white noise's peaks) and whether each is a bound; and per name the
    scene's per-path values (paths, slots). The coupled run (``spec``'s options, on coupled
    grids, at most ``paths`` or ``spec.paths`` paths) on three nested schedules laid on the
    finest one's grid: the scene's pieces (n), each halved (2n) and halved again (4n). The
    error of n pieces is |m(n) - m(2n)| times the factor the ratio of the two differences
    gives (:func:`_order_factor`: 2 where the pieces are halving their error, more before)."""
    scene = spec.scene
    n_times = len(scene.times)
    quadratic = bool(_isometry_names(scene, names))
    isometry = _isometry_names(scene, names) if quadratic else set()
    middle = _refined(scene)
    finest = _refined(middle)
    count = spec.paths if paths is None else paths
    runs = [_samples(dataclasses.replace(spec, scene=s), count, threads, quadratic,
                     one_grid=True)
            for s in (_coarse_on_fine(scene, finest), _coarse_on_fine(middle, finest), finest)]
    n = len(runs[0])
    out: Dict[Tuple[str, str], Tuple[np.ndarray, np.ndarray]] = {}
    values: Dict[str, np.ndarray] = {}

    def moments(x: np.ndarray) -> np.ndarray:
        return np.abs(x) if q.magnitude else x ** q.power

    def difference(a: np.ndarray, b: np.ndarray, stat: str, name: str, k: int, i: int):
        if stat == "mean":
            phi = a - b
        elif name in isometry:
            # Var S(t_s) = E int sigma^2 V^2 dt / c^2 on either schedule: the difference of
            # the variances is a difference of means, of per-path values far less spread
            # than the squares' (docs/methods/adaptive.md).
            c2 = scene.drift * scene.drift
            phi = (runs[i][:, n_times + 1, 0, VELOCITY]
                   - runs[i + 1][:, n_times + 1, 0, VELOCITY]) / c2
        else:
            ca = a - _sum(a, threads) / n
            cb = b - _sum(b, threads) / n
            phi = ca * ca - cb * cb
        d = _sum(phi, threads) / n
        return d, math.sqrt(_sum((phi - d) ** 2, threads) / max(n - 1, 1) / n)

    peak_base = n_times + (1 if "stop" in scene.observe else 0)  # (Options::sample_slots)
    for name in names:
        q = quantity(name)
        slots = [n_times] if q.at_stop else list(range(n_times))
        if q.peak and not _peaks_recorded(scene):
            for stat in ("mean", "var"):
                out[(name, stat)] = (np.full(len(slots), math.nan),
                                     np.zeros(len(slots), dtype=bool))
            continue
        columns = [peak_base + k for k in slots] if q.peak else slots
        x = [moments(r[:, columns, 0, q.variable]) for r in runs]
        values[name] = x[0]
        for stat in ("mean", "var"):
            errors, bounds = [], []
            for k in range(len(slots)):
                d1, se1 = difference(x[0][:, k], x[1][:, k], stat, name, k, 0)
                d2, se2 = difference(x[1][:, k], x[2][:, k], stat, name, k, 1)
                resolved = abs(d1) > 2 * se1
                if resolved:
                    errors.append(_order_factor(d1, se1, d2, se2) * abs(d1))
                else:
                    errors.append(PIECE_ORDER_FACTOR * (abs(d1) + 2 * se1))
                bounds.append(not resolved)
            out[(name, stat)] = (np.array(errors), np.array(bounds))
    return out, values


#: The piece errors of the last runs' pilots (crandall.pieces), so that the bias estimate of
#: a run on the pieces its pilot chose reuses the pilot's table (the same paths: the same
#: numbers) instead of running it again. Keyed by the spec's plain data and the names.
_TABLES: "collections.OrderedDict" = collections.OrderedDict()
_TABLES_KEPT = 8


def _table_key(spec, names, paths) -> str:
    return json.dumps([spec.to_dict(), sorted(names), paths], sort_keys=True)


def piece_table_kept(spec, names, threads: int, paths: Optional[int] = None):
    """:func:`piece_table`, from the kept tables when this spec's was computed already."""
    count = min(spec.paths if paths is None else paths, PIECE_PATHS)
    spec = dataclasses.replace(spec, paths=count)
    key = _table_key(spec, names, count)
    if key not in _TABLES:
        _TABLES[key] = piece_table(spec, names, threads, count)
        while len(_TABLES) > _TABLES_KEPT:
            _TABLES.popitem(last=False)
    return _TABLES[key]


#: Paths of the piece error's coupled runs (three schedules, the finest with four times the
#: pieces): as many as the pilot that chose the pieces (crandall.pieces.PILOT_PATHS).
PIECE_PATHS = 4096


def _piece_errors(spec, names, threads: int, paths: Optional[int] = None):
    """:func:`piece_table` as (errors, whether any is a bound) per (name, stat)."""
    table, _ = piece_table_kept(spec, names, threads, paths)
    return {k: (v, bool(b.any())) for k, (v, b) in table.items()}


def _difference(v: np.ndarray, a: np.ndarray, b: np.ndarray, stat: str, threads: int):
    """The difference between the combinations a and b of the grids' estimates of a mean or
    a variance, and its standard error (delta method on the per-path values)."""
    n = len(v)

    def dot(x, y) -> float:  # in Python floats: the same bits on every machine
        return sum(float(p) * float(q) for p, q in zip(x, y))

    m1 = [_sum(v[:, g], threads) / n for g in range(3)]
    if stat == "mean":
        phi = sum(v[:, g] * (a[g] - b[g]) for g in range(3))
        d = dot(m1, a - b)
    else:
        m2 = [_sum(v[:, g] * v[:, g], threads) / n for g in range(3)]
        ma, mb = dot(a, m1), dot(b, m1)
        d = dot(a - b, m2) - ma * ma + mb * mb
        phi = sum(v[:, g] * v[:, g] * (a[g] - b[g]) - 2 * ma * a[g] * v[:, g]
                  + 2 * mb * b[g] * v[:, g] for g in range(3))
    mean = _sum(phi, threads) / n
    var = _sum((phi - mean) ** 2, threads) / max(n - 1, 1)
    return d, math.sqrt(var / n)


# Results ask this module for their bias through the hook (results never import an engine).
results.set_bias_estimator(estimate, needs_run_for)
