"""crandall: a body sliding with Coulomb friction on a white-noise-shaken foundation.

Exact-in-law simulation (C++ core) of Crandall's problem and the analytic results of
Berezin & Zayats (see ``crandall.analytic``).

>>> import crandall
>>> scene = crandall.Scene.scaled(tau0=5, times=[1, 5])
>>> result = crandall.simulate(scene, paths=10_000, seed=1)
>>> result.mean("distance").shape
(2,)
"""

from typing import TYPE_CHECKING

from ._version import __version__
from . import _openmp  # noqa: F401  (first: OpenMP's wait policy, read when the core loads)
from . import bias as _bias  # installs the results' bias estimator
from ._lazy import lazy_submodules as _lazy_submodules
from .io import load
from .records import NewmarkResult, Record, newmark
from .errors import ParameterError
from .excitation import CloughPenzien, KanaiTajimi, WhiteNoise
from .results import AccuracyResult, Result, StatisticsWarning
from .scene import OBSERVABLES, Scene
from .simulate import METHODS, default_dt, simulate, simulate_many
from .tail import StatisticsFailure, TailResult, tail
from .fragility import FragilityResult, fragility
from .suites import RecordFragilityResult, record_fragility
from .trajectories import paths
from .units import Scaling

__all__ = ["load", "Scene", "Result", "AccuracyResult", "simulate", "simulate_many", "default_dt",
           "Scaling", "OBSERVABLES", "METHODS", "ParameterError", "StatisticsWarning",
           "StatisticsFailure", "tail", "TailResult", "paths", "Record", "newmark",
           "NewmarkResult", "fragility", "FragilityResult", "record_fragility",
           "RecordFragilityResult", "KanaiTajimi", "CloughPenzien", "WhiteNoise"]

# The analytic layer and the envelopes need scipy: imported when first read
# (crandall.envelopes.amin_ang(...), crandall.analytic.physical(...)), not by `import crandall`.
# Type checkers see the modules themselves (and no __getattr__, which would let them accept
# any misspelt crandall.name).
if TYPE_CHECKING:
    from . import analytic, envelopes
else:
    __getattr__ = _lazy_submodules(__name__, ("analytic", "envelopes"))
