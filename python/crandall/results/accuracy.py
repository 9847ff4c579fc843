"""``AccuracyResult``: a run to a requested accuracy's estimates as a ``Result``."""

from __future__ import annotations

import math
from typing import Dict, List, Optional, Tuple

import numpy as np

from .. import _core, _dataset
from ..model import FILTERED_EXCITATION, FILTERED_LEVELS, LEVELS
from ..quantities import names_for, quantity
from ..scene import Scene
from ..errors import ParameterError
from .common import Stat
from .result import Result


class AccuracyResult(Result):
    """Statistics of a run to a requested accuracy (``crandall.simulate(scene, error=...)``).

    A :class:`Result`: the same statistics (``mean``, ``var``, ``std``, ``stderr``,
    ``var_stderr``), accuracy (``bias``, ``error``, ``interval``, ``exact``), tables
    (``to_pandas``, ``to_xarray``, the same layout), files (``save``, ``crandall.load``,
    bitwise) and figures. Every statistic (the mean and the variance of each quantity at each
    output time, and at the stop) comes from the multilevel estimator with its standard
    error, its estimated discretisation bias and the total error sqrt(stderr^2 + bias^2),
    which the run brought below the target. ``stderr(name, "var")`` is the standard error of
    the variance (as ``var_stderr``). A statistic the run was not asked for (``statistics=``)
    raises ValueError naming ``stat``; in tables it is NaN.

    It holds no per-path accumulators: no histograms (a scene that asks for distributions is
    refused by ``simulate(error=...)``), no mixed moments (:meth:`moment`).

    Attributes
    ----------
    error_target, rel_error_target : float or None
        The target the run met (one of them).
    model : str
        The multilevel model the run rested on: ``"levels"`` (white noise) or
        ``"filtered_levels"`` (a filtered excitation; docs/methods/adaptive.md).
    levels : list of dict
        Per level: ``level``, ``paths``, ``steps_per_path``, ``dt`` (its step).
    paths : int
        Paths over all levels.
    dt : float
        The finest level's step.
    """

    kind = "accuracy"
    method = "mlmc"

    def __init__(self, *, scene: Scene, seed: int, error_target: Optional[float],
                 rel_error_target: Optional[float],
                 estimates: Dict[Tuple[str, str], np.ndarray],
                 exact: Dict[Tuple[str, str], bool], levels: List[dict], path_steps: int,
                 rounds: int, wall_time: Optional[float] = None,
                 random_stream: Optional[int] = None) -> None:
        self.scene = scene
        self.seed = int(seed)
        self.error_target = None if error_target is None else float(error_target)
        self.rel_error_target = None if rel_error_target is None else float(rel_error_target)
        self.random_stream = int(_core.RANDOM_STREAM if random_stream is None else random_stream)
        self._estimates = {k: np.asarray(v, dtype=np.float64) for k, v in estimates.items()}
        self._exact = dict(exact)
        self.levels = [dict(lv) for lv in levels]
        self.paths = int(sum(lv["paths"] for lv in self.levels))
        self.dt = float(self.levels[-1]["dt"]) if self.levels else math.nan
        self.min_steps = 0
        self.steps_per_path = int(self.levels[-1]["steps_per_path"]) if self.levels else 0
        self._path_steps = int(path_steps)
        self._rounds = int(rounds)
        self._wall_time = None if wall_time is None else float(wall_time)
        self._histograms = None
        self._warned: set = set()

    # -- what the run holds --------------------------------------------------------------

    @property
    def spec(self):
        raise ValueError("spec: a run to an accuracy has no fixed-step specification; its "
                         "target, seed and scene are error_target, rel_error_target, seed "
                         "and scene")

    @property
    def model(self) -> str:
        """The name of the multilevel model the run rested on (crandall.model):
        ``"filtered_levels"`` for a filtered excitation (levels on the filtered core's coupled
        grids, the bias from the measured order), else ``"levels"`` (the white-noise
        skeleton's levels, control variates and identities)."""
        # As adaptive.levels.levels_model chooses it (the results load without the estimator).
        return (FILTERED_LEVELS if FILTERED_EXCITATION in self.scene.effects else LEVELS).name

    @property
    def accumulators(self):
        raise ValueError("accumulators: a run to an accuracy keeps its estimates, not "
                         "per-path accumulators")

    @property
    def names(self) -> tuple:
        """The quantities with at least one statistic in this result."""
        return tuple(n for n in names_for(self.scene.observe)
                     if any((n, s) in self._estimates for s in ("mean", "var")))

    def stats_of(self, name: str) -> tuple:
        """The statistics ("mean", "var") the run estimated for a quantity."""
        return tuple(s for s in ("mean", "var") if (name, s) in self._estimates)

    @property
    def cost(self) -> dict:
        """What the answer cost: ``wall_time`` (s), ``path_steps``, ``paths`` per level,
        ``rounds``."""
        return {"wall_time": self._wall_time, "path_steps": self._path_steps,
                "paths": [lv["paths"] for lv in self.levels], "rounds": self._rounds}

    def _get(self, name: str, stat: str, field: int, missing_nan: bool = False):
        if stat not in ("mean", "var"):
            raise ParameterError("stat", f"stat must be 'mean' or 'var', got {stat!r}")
        if name not in self.names:
            raise ParameterError("name", f"name: {name!r} is not in this result; it holds "
                                         f"{', '.join(self.names)}")
        q = quantity(name)
        if (name, stat) not in self._estimates:
            if missing_nan:
                out = np.full(1 if q.at_stop else self.times.size, math.nan)
                return float(out[0]) if q.at_stop else out
            raise ParameterError("stat", f"stat: the {stat} of {name} was not asked for (the "
                                         "run's statistics= named "
                                         f"{', '.join(self.stats_of(name))} of it)")
        f = q.factor(self.scene)
        scale = f if stat == "mean" else f * f
        vals = self._estimates[(name, stat)][:, field] * scale
        if field == 0 and stat == "mean" and q.offset is not None:
            vals = vals + q.offset(self.scene)
        return float(vals[0]) if q.at_stop else vals

    # -- statistics -----------------------------------------------------------------------

    def mean(self, name: str) -> Stat:
        """The estimated mean of a quantity."""
        return self._get(name, "mean", 0)

    def var(self, name: str) -> Stat:
        """The estimated variance of a quantity."""
        return self._get(name, "var", 0)

    def std(self, name: str) -> Stat:
        """The square root of the estimated variance (0 where the estimate is below 0)."""
        return np.sqrt(np.maximum(self.var(name), 0.0))

    def stderr(self, name: str, stat: str = "mean") -> Stat:
        """The standard error of a statistic (statistical error only); of the mean unless
        ``stat="var"``."""
        return self._get(name, stat, 1)

    def var_stderr(self, name: str) -> Stat:
        """The standard error of the variance."""
        return self._get(name, "var", 1)

    def _bias(self, name: str, stat: str, warn: bool):
        return self._get(name, stat, 2, missing_nan=not warn)

    def bias(self, name: str, stat: str = "mean") -> Stat:
        """The estimated magnitude of the discretisation bias of a statistic: 0 exactly for
        the statistics exact in law (see :meth:`exact`), otherwise Giles' estimate from the
        finest levels."""
        return self._bias(name, stat, True)

    def bias_is_bound(self, name: str, stat: str = "mean") -> bool:
        """False: the levels' bias is an estimate, never a bound."""
        self._get(name, stat, 2)
        return False

    def _error(self, name: str, stat: str, warn: bool):
        return np.hypot(self._get(name, stat, 1, missing_nan=not warn),
                        self._get(name, stat, 2, missing_nan=not warn))

    def exact(self, name: str, stat: str = "mean") -> bool:
        """Whether the statistic is exact (its bias is 0, not estimated): exact in law at any
        step, or given by an identity (the mean distance through Ito's formula)."""
        self._get(name, stat, 0)
        return self._exact[(name, stat)]

    def moment(self, j: int, k: int, l: int) -> np.ndarray:  # noqa: E741 - the paper's index
        raise ValueError("moment: a run to an accuracy estimates means and variances only; "
                         "run mixed moments with paths=")

    def carriers(self, name: str) -> Stat:
        raise ValueError("carriers: a run to an accuracy keeps its levels' estimates, not the "
                         "central sums the carrying paths are counted from; run with paths=")

    def _few(self, name: str, stat: str) -> np.ndarray:
        # Its standard errors come from the levels' estimates (crandall.adaptive).
        return np.zeros(1 if quantity(name).at_stop else self.times.size, dtype=bool)

    def table(self, name: str) -> np.ndarray:
        """The tables' row(s) of a quantity: (mean, var, std, stderr, var_stderr, bias_mean,
        error_mean, bias_var, error_var), NaN for a statistic not estimated; shape (times, 9),
        or (9,) at the stop."""
        m = [self._get(name, "mean", k, True) for k in (0, 1, 2)]
        v = [self._get(name, "var", k, True) for k in (0, 1, 2)]
        cols = [m[0], v[0], np.sqrt(np.maximum(v[0], 0.0)), m[1], v[1],
                m[2], np.hypot(m[1], m[2]), v[2], np.hypot(v[1], v[2])]
        return np.stack([np.asarray(c, dtype=float) for c in cols], axis=-1)

    # -- presentation ---------------------------------------------------------------------

    def target_text(self) -> str:
        return (f"error <= {self.error_target:g}" if self.error_target is not None
                else f"rel_error <= {self.rel_error_target:g}")

    # -- its statistics table (rendered as every result's: results/tables.py) --------------

    _layout = "statistic_rows"

    def _statistics_rows(self, rows, name: str, pending: bool) -> None:
        """A quantity's rows from the levels' estimates (NaN for a statistic not asked
        for)."""
        q = quantity(name)
        times = [math.nan] if q.at_stop else self.times
        m = [self._get(name, "mean", k, True) for k in (0, 1, 2)]
        v = [self._get(name, "var", k, True) for k in (0, 1, 2)]
        std = np.sqrt(np.maximum(v[0], 0.0))
        for stat, (value, stderr, bias) in (("mean", m), ("var", v)):
            rows.add(name, self.scene.units_of(name), q.long_name_in(self.scene.units), times,
                     stat, value=value, std=std, stderr=stderr, bias=bias,
                     error=np.hypot(stderr, bias), estimated=(name, stat) in self._estimates,
                     exact=self._exact.get((name, stat), False), bound=False, few=False)

    def _run_lines(self, pending: bool) -> tuple:
        wall = self._wall_time
        return (f"  {self.target_text()}  seed={self.seed}  method=mlmc  "
                + ("" if self.model == "levels" else f"model={self.model}  ")
                + f"levels={len(self.levels)}  paths per level={self.cost['paths']}  "
                f"path-steps={self._path_steps:.3g}"
                + ("" if wall is None else f"  time={wall:.3g} s"),)

    def _run_brief(self) -> str:
        return (f"{self.target_text()}, seed {self.seed}, multilevel"
                + ("" if self.model == "levels" else f" ({self.model})")
                + f": {len(self.levels)} levels, paths per level {self.cost['paths']}")

    def _table_notes(self) -> tuple:
        # No note on a stop time set by the scene (Result._scene_note reads the fixed-step
        # moments); no standard error is marked (_few), so there is no note on them either.
        return ()

    def _file_contents(self) -> tuple:
        return _dataset.accuracy_contents(self)

    @property
    def bias_pending(self) -> bool:
        """False: the levels' biases are part of the run."""
        return False

    def estimate_bias(self) -> "AccuracyResult":
        """Nothing to do: the levels' biases are part of the run."""
        return self

    def __repr__(self) -> str:
        return (f"<crandall.Result {self.scene!r} {self.target_text()} seed={self.seed} "
                f"method='mlmc' paths={self.paths}>")
