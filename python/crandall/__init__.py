"""crandall: a body sliding with Coulomb friction on a white-noise-shaken foundation.

Exact-in-law simulation (C++ core) of Crandall's problem and the analytic results of
Berezin & Zayats (see ``crandall.analytic``).

>>> import crandall
>>> scene = crandall.Scene.scaled(tau0=5, times=[1, 5])
>>> result = crandall.simulate(scene, paths=10_000, seed=1)
>>> result.mean("distance").shape
(2,)
"""

from ._version import __version__
from . import _openmp  # noqa: F401  (first: OpenMP's wait policy, read when the core loads)
from . import bias as _bias  # installs the results' bias estimator
from .io import load
from .results import Result, StatisticsWarning
from .scene import OBSERVABLES, Scene
from .simulate import METHODS, default_dt, simulate, simulate_many
from .tail import TailResult, tail
from .units import Scaling

__all__ = ["load", "Scene", "Result", "simulate", "simulate_many", "default_dt", "Scaling", "OBSERVABLES", "METHODS",
           "StatisticsWarning", "tail", "TailResult"]
