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

The package's modules: ``problem`` (the quantities, the grid, the scores, the paths continued),
``splitting`` (one replica), ``importance`` (proposals, weights, the proposal's pilot),
``run`` (the driver's estimator and its Dask task ``sample``), ``result`` (``TailResult``) and
``entry`` (``tail`` itself). The names below are the package's public face and the ones tests,
benchmarks and Dask tasks reach as ``crandall.tail.<name>`` (``crandall.tail`` in the package
is the function: ``importlib.import_module("crandall.tail")`` is this module). A name is looked
up where its module uses it, so a test replaces it there (``crandall.tail.run.sample``).
"""

from .entry import (MAX_PARETO_SHAPE, MIN_EFFECTIVE_SAMPLES, MIN_REL_ERROR, MIN_SPLITTING_STEPS,
                    TAIL_METHODS, _advice, _levels, tail)
from .importance import (DEFENSIVE, _choose_proposal, _excursions, _importance_batch, _proposal,
                         pareto_shape)
from .problem import (SCORES, TAIL_QUANTITIES, TailScore, _extend, _grid_for, _Problem,
                      log_transition_density)
from .result import StatisticsFailure, TailResult
from .run import _check_samples, _digest, _TailRun, sample, variance_upper_factor
from .splitting import _normalised_top, _splitting_replica

__all__ = ["tail", "TailResult", "TAIL_QUANTITIES", "TAIL_METHODS"]
