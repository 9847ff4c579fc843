"""The simulation methods the engine offers, the default one, and the default step."""

from typing import NamedTuple

from . import _core

__all__ = ["METHODS", "GRIDS", "SKELETON", "ORDERS", "MethodRow", "TABLE",
           "MIN_EVENT_DEPTH", "MAX_EVENT_DEPTH",
           "EXTRAPOLATING_METHODS", "DEFAULT_METHOD", "DEFAULT_DT_TAU", "DEFAULT_MIN_STEPS",
           "DEFAULT_STEPS_FREE", "DEFAULT_DT_FILTER", "DEFAULT_DT_TAU_FILTER"]


class MethodRow(NamedTuple):
    """A row of the core's methods' table (plan.hpp, ``kMethodTable``)."""

    #: The name ``simulate(method=...)`` takes.
    name: str
    #: Coupled grids it integrates on (steps h, 2h, 4h, ...; 1 without extrapolation).
    grids: int
    #: Whether its steps are the exact skeleton's (and its integrals the trapezoid rule on its
    #: grids, which the bias estimate's coupled grids reproduce).
    skeleton: bool
    #: The exponent p of the leading term c dt^p of its moments' bias; NaN where not known.
    order: float


#: The core's methods' table, one row per method in the core's order. The core decides it
#: (plan.hpp; _core.METHOD_TABLE): every name, grid count and order here is read from it.
TABLE = tuple(MethodRow(*row) for row in _core.METHOD_TABLE)

#: Method names accepted by ``simulate(method=...)``:
#: "exact": velocity exact in law for any step; displacement and distance by the trapezoid
#: rule on the exact skeleton. "euler": Euler-Maruyama (weak order 1), for comparison.
#: "richardson": the exact skeleton with trapezoid integrals on the grid and on every 2nd and
#: every 4th point of it (the same path), every moment extrapolated to step 0 assuming a bias
#: c1 h^1.5 + c2 h^2 (docs/methods/richardson.md). "richardson2": the same on two grids (h, 2h),
#: assuming c h^1.5. "refine": the exact skeleton, with steps that start within 2 standard
#: deviations of 0 taken as 8 exact substeps (docs/methods/refine.md).
#: The core decides the list ("exact", "euler", "richardson", "richardson2", "refine").
METHODS = tuple(row.name for row in TABLE)

#: Grids each method integrates on (the core's Richardson levels): the fine one, and for the
#: extrapolating methods every 2nd (and 4th) point of it. Sizes the accumulators in memory.
#: Decided in the core (plan.hpp, grids()); read from it here.
GRIDS = {row.name: row.grids for row in TABLE}

#: Whether a method's steps are the exact skeleton's (the core's table): the methods whose bias
#: the coupled grids estimate (crandall.bias.REFINEMENT).
SKELETON = {row.name: row.skeleton for row in TABLE}

#: Each method's order, the exponent p of the leading term c dt^p of the bias of the moments it
#: reports (the time integrals'; the velocity's and the stop's are exact in law with every
#: method but "euler"), as the core's table states it (plan.hpp, with where each comes from):
#: "exact" 1.5 (the trapezoid rule's leading exponent on the skeleton; a run to an accuracy's
#: levels assume it, crandall.adaptive), "euler" 1, "richardson2" 2 (h^1.5 removed); NaN, not
#: known, for "richardson" (its second moments keep a term of unknown exponent,
#: docs/methods/richardson.md) and "refine" (no order stated or derived, docs/methods/refine.md).
ORDERS = {row.name: float(row.order) for row in TABLE}

#: Methods whose accumulators are a signed combination of several grids (Richardson
#: extrapolation): their even central sums may be negative for a handful of paths.
EXTRAPOLATING_METHODS = tuple(m for m in METHODS if GRIDS[m] > 1)

#: The method ``simulate`` uses when none is given: "richardson", the cheapest for a given
#: accuracy in bench/work_precision.py (bench/results/work_precision.json): its bias in the
#: mean distance at tau = 5 is within 1e-3 for every step measured (|bias| <= 4.5e-4 +- 7e-5
#: up to dt = 0.8, where "exact" is off by 6.5e-2), and it needs the least time per path for
#: 1e-3 in the mean distance and in the variances of displacement and distance.
DEFAULT_METHOD = "richardson"

#: Default internal step in scaled time (tau), where time integrals are observed. Accuracy of
#: the default method at this step (paper's scene, tau0 = 5, outputs tau = 1 and 5; measured
#: by bench/work_precision.py against crandall.analytic): the mean distance's bias is below
#: 1e-3 at every step measured (dt <= 0.8); the velocity is exact in law (no bias at any step);
#: the variances of displacement and distance have biases of -7e-4 +- 8e-4 and
#: -1.2e-3 +- 5e-4 at dt = 0.1, and -6e-4 +- 1e-3 and -5e-4 +- 6e-4 at dt = 0.05, falling about
#: as dt^2 (docs/methods/richardson.md), so of order 1e-5 at this step. 0.025 would meet 1e-3
#: at a quarter of the cost; 0.01 is kept so that the default grid, and tests pinned to it,
#: stay as they were.
DEFAULT_DT_TAU = 0.01

#: A filtered excitation's default step: this many of the body's scaled time unit t*, and at
#: most DEFAULT_DT_FILTER of the filter's time scale 1 / omega. Its skeleton is exact at any
#: step and the events are located by bisection, so the step only sets how often the event
#: test looks: on Kanai-Tajimi at omega t* = 1 and 4 the mean distance at the stop is the same
#: at steps 0.02 s, 0.2 s and 1 s (t* = 2 s) to the statistical error of 30,000-60,000 paths
#: (docs/filtered.md), and the step 0.2 s costs a third of 0.02 s.
DEFAULT_DT_TAU_FILTER = 0.1
DEFAULT_DT_FILTER = 1.0

#: Without friction there is no natural time scale: the default step is the horizon over this.
DEFAULT_STEPS_FREE = 2000

#: The default grid is graded: before every output time and the switch-off t the step is at
#: most ``min(DEFAULT_DT_TAU, t / DEFAULT_MIN_STEPS)`` (``Options.min_steps`` of the core), so
#: each is reached in at least 64 steps whatever the scene's units, while a tiny first output
#: time does not force tiny steps on the rest of the path. The relative bias at a time T
#: reached in N steps is largest for small T, where it depends on N only, and is measured by
#: bench/resolution.py (bench/results/resolution.json; docs/methods/default-step.md): at
#: N = 64 the default method's worst is the variance of the distance, -1.4e-5 (exact figure in
#: the Brownian limit), about 1e-4 by the trend of N = 4, 8, 16 at T = 0.1 and 0.5 (the
#: Monte Carlo at N = 64 agrees within its 1.3e-3 standard error); "exact" reaches -5.9e-4
#: (mean distance, Brownian limit) to about -9e-4 (T = 0.5), so both stay within the 1e-3
#: documented above. N = 32 would do for "richardson" alone (-8e-5 in the Brownian limit) but
#: not for "exact" (-1.7e-3). An explicit ``dt`` gives a uniform grid (no grading).
DEFAULT_MIN_STEPS = 64

#: The range of a filtered excitation's ``event_depth`` (bisections of a step in which a stop or
#: an onset may happen; docs/filtered.md). At most the core's kMaxEventDepth (plan.hpp); at
#: least what every plan of a run needs: the bias estimate's coupled run walks the most grids
#: (``GRIDS``), and the core bisects its coarsest grid's steps at the finer grids'
#: points first, so it needs ``grids - 1`` bisections.
MIN_EVENT_DEPTH = max(GRIDS.values()) - 1
MAX_EVENT_DEPTH = 20
