"""Runs to a requested accuracy: multilevel Monte Carlo on the exactly coupled grids.

``crandall.simulate(scene, error=EPS)`` lands here. The method, its measurements and its
error estimates are in docs/methods/adaptive.md; in short:

- Level 0 simulates paths on a coarse base grid; level l >= 1 simulates other paths on the
  grid refined 2^l times and forms, on each path, the difference between the statistic's
  per-path value on that grid and on every second point of it (the grid of level l - 1, on the
  same exact path: the coupling is perfect, no extra random numbers). The telescoping sum of
  the level means estimates the statistic on the finest grid; its discretisation bias is
  estimated from the finest level's mean.
- The variance of the distance at the stop (and of the dissipated energy there) is the mean of
  int_0^t0 sigma^2 V^2 dt / c^2 (Ito's isometry, crandall.model.ISOMETRY): a per-path value with
  far less spread than (S(t_s) - E S(t_s))^2, still an integral on the grid, so its levels
  and bias are estimated as for any other.
- Statistics exact in law at any step (every moment of the velocity, the kinetic energy, the
  stop time) need level 0 only, and their bias is exactly 0. So does the mean distance (and
  the mean dissipated energy), through the identity
  E S(t) = (sigma^2 min(t, t0) - E X(t)^2) / (2 c) that Ito's formula gives for a body
  starting at rest (c the friction deceleration, sigma the noise intensity).
- Samples are allocated across levels as Giles' multilevel Monte Carlo prescribes, from level
  variances and costs (steps per path) estimated on the run, in rounds. Every decision is a
  function of the merged sums at a round's end, and every path's numbers are a function of
  (seed, level, path index): the result is bitwise the same for any thread count.

A filtered excitation (crandall.model.FILTERED_LEVELS) runs on the filtered core's coupled
grids with none of the white-noise identities or control variates above: every statistic on
the levels, its bias from the measured ratio of the two finest level means (first order where
it is not resolved; docs/methods/adaptive.md, "A filtered excitation");
``levels.levels_model`` chooses the model by the scene's effects.

The package's modules: ``levels`` (the levels' grids, batches and sums), ``features`` (the
control variates), ``schedule`` (estimates, bias, tolerance, the rounds, the checkpoint's
state), ``estimator`` (``_Engine``, the driver's estimator, and its Dask task ``batch_task``)
and ``entry`` (``simulate_to_error``). The names below are the package's public face and the
ones other modules, tests and benchmarks reach as ``crandall.adaptive.<name>``. A setting is
read where its module uses it, so a test or benchmark changes it there
(``crandall.adaptive.schedule.MAX_LEVELS``, ``.estimator.USE_CONTROLS``,
``.features.CONTROL_SLOTS``, ``.entry.CHECKPOINT_SECONDS``).
"""

from .. import _core  # noqa: F401  (tests replace the core's functions through it)
from .entry import CHECKPOINT_SECONDS, simulate_to_error
from .estimator import BATCH_BYTES, USE_CONTROLS, _Engine, _result, batch_task
from .features import CONTROL_SLOTS
from .levels import (BASE_DT_FACTOR, BASE_MIN_STEPS, BATCH_PATHS, MAX_SECONDS, PILOT_PATHS, STATS,
                     Z95, _check_statistics, _Level, _moments, _solve_many, _targets)
from .schedule import MAX_LEVEL_PATHS, MAX_LEVELS, REL_FLOOR, _checksum

__all__ = ["simulate_to_error", "BASE_DT_FACTOR", "BASE_MIN_STEPS",
           "BATCH_PATHS", "PILOT_PATHS", "MAX_LEVELS", "STATS"]
