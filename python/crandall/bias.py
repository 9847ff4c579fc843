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
- "euler" and "refine", and the peaks (maxima over the grid, whose shortfall
  bench/peaks.py measures): not estimated (NaN).

Where the difference is not resolved (below 2 standard errors) the estimate is its bound,
|difference| + 2 standard errors. The separate run draws its own paths (a stream of its own,
derived from the seed), so the estimate is reproducible and independent of the run's paths.
"""

from __future__ import annotations

import math
from typing import Dict, Tuple

import numpy as np

from . import _core
from . import engine, results
from .model import exact_in_law
from .quantities import quantity
from .streams import bias_key

__all__ = ["estimate", "BIAS_PATHS"]

#: Paths of the coupled run: the run's own number, at most this (so that the estimate never
#: costs more than about 1/16 of a run of a million paths, nor more than the run itself).
BIAS_PATHS = 65536
#: ... and at most this many bytes of per-path values (scenes with many output times).
BIAS_BYTES = 256 << 20
#: Per method, the refinement of the coupled run over the run's grid (2^r times its steps),
#: so that the run's grid is the coarsest of the coupled grids ("exact"), the middle one
#: ("richardson2") or the finest ("richardson").
REFINEMENT = {"exact": 2, "richardson2": 1, "richardson": 0}


def _sum(values: np.ndarray, threads: int) -> float:
    return float(_core.sum_products(values[:, None], [1], threads)[0])


def _samples(result, threads: int) -> np.ndarray:
    # The run's own options (every field of its spec), on coupled grids that include the
    # run's grid, with a stream of its own.
    scene = result.scene
    o = engine.plan_options(result.spec, histograms=False)
    o.method = "richardson"
    o.refinement = REFINEMENT[result.method]
    o.seed = bias_key(result.seed)
    # At most BIAS_BYTES of per-path values (3 grids x 3 variables per output slot).
    per_path = 8 * 9 * (len(scene.times) + (1 if "stop" in scene.observe else 0))
    n = int(min(result.paths, BIAS_PATHS, max(2, BIAS_BYTES // per_path)))
    o.paths = n
    return _core.run_samples(_core.Plan(o), 0, n, threads)


def estimate(result, threads: int = 1) -> Dict[Tuple[str, str], Tuple[np.ndarray, bool]]:
    """Per (name, stat): the estimated |bias| (array over the output times, or one value at
    the stop) and whether it is a bound (the difference was not resolved)."""
    method = result.method
    out: Dict[Tuple[str, str], Tuple[np.ndarray, bool]] = {}
    names = result.names
    needs_run = result.paths >= 2 and method in ("exact", "richardson", "richardson2") and any(
        not exact_in_law(n, result.scene) and not quantity(n).peak for n in names)
    samples = _samples(result, threads) if needs_run else None
    w3 = np.array(_core.richardson_weights("richardson"))
    w2 = np.array(list(_core.richardson_weights("richardson2")))
    # a: the run's estimator on the coupled grids (finest first); b: a better one.
    if method == "exact":
        a, b = np.array([0.0, 0.0, 1.0]), w3
    elif method == "richardson2":
        a, b = np.concatenate([[0.0], w2]), w3
    else:
        a, b = np.concatenate([w2, [0.0]]), w3
    n_times = len(result.times)
    for name in names:
        q = quantity(name)
        slots = [n_times] if q.at_stop else list(range(n_times))
        f = q.factor(result.scene)
        for stat in ("mean", "var"):
            if exact_in_law(name, result.scene):
                out[(name, stat)] = (np.zeros(len(slots)), False)
                continue
            if samples is None or q.peak:
                # The peaks' shortfall is measured by bench/peaks.py (docs/distributions.md),
                # not estimated per run: the coupled grids' values hold no running maxima.
                out[(name, stat)] = (np.full(len(slots), math.nan), False)
                continue
            values, bounds = [], []
            for slot in slots:
                v = samples[:, slot, :, q.variable]
                v = np.abs(v) if q.magnitude else v ** q.power
                v = v - _sum(v[:, 0], threads) / len(v)  # centred: the combinations sum to 1
                d, se = _difference(v, a, b, stat, threads)
                resolved = abs(d) > 2 * se
                mag = abs(d) if resolved else abs(d) + 2 * se
                factor = f if stat == "mean" else f * f
                values.append(mag * abs(factor))
                bounds.append(not resolved)
            out[(name, stat)] = (np.array(values), any(bounds))
    return out


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
results.set_bias_estimator(estimate)
