"""What a tail run returns (``TailResult``), the statistics of its samples, and the error it
raises when no estimate can be made (``StatisticsFailure``)."""

from __future__ import annotations

import json
import os
from dataclasses import dataclass, field
from typing import Any, Dict, Union

import numpy as np

from .. import _frames, _render
from .._files import write_atomic
from ..results import render_text
from ..results.table import Table
from ..errors import ParameterError

#: The netCDF attribute that marks a saved tail result (crandall.load reads it back).
FILE_ATTR = "crandall_tail"


@dataclass
class TailResult:
    """Tail probabilities P(Q > level) of one quantity, with their errors and diagnostics.

    Attributes
    ----------
    quantity, levels, units
        The quantity, its levels (ascending, in the scene's units) and the unit.
    probability, stderr, rel_error : ndarray
        The estimate at each level, its standard error and stderr / probability.
    method : str
        "splitting" or "importance".
    samples : int
        Independent replicas (splitting) or paths (importance sampling) in the estimate.
    seconds, steps : float, int
        Wall time and exact steps simulated (the cost).
    diagnostics : dict
        Splitting: iterations per replica, particles, and the score ("normalised" towards the
        one level, or "plain"; docs/methods/tails.md). Importance sampling: the proposal, and
        per level the effective sample size of the paths past it and the largest weight share.
    reliable : ndarray of bool
        False where the diagnostics show a degenerate estimate (importance sampling with too few
        effective samples or one dominant weight; a level no replica reached; a level every
        replica's every particle exceeded, ``all_replicas_one``, where P is only known to be
        within about 3 / (replicas x particles) of 1): its number is not a clean estimate.
    spec : dict
        What was run (scene, quantity, time, dt, method, seed, ...).
    """

    quantity: str
    levels: np.ndarray
    units: str
    probability: np.ndarray
    stderr: np.ndarray
    rel_error: np.ndarray
    method: str
    samples: int
    seconds: float
    steps: int
    diagnostics: Dict[str, Any]
    reliable: np.ndarray
    spec: Dict[str, Any] = field(default_factory=dict)

    def interval(self, level: float = 0.95):
        """The two-sided confidence interval (lower, upper) of each probability at ``level``,
        normal on the mean of the independent samples, clipped at 0; a deterministic answer
        (no noise before the quantity is read: one sample, no error) is its own interval."""
        from scipy.stats import norm, t as student

        if not (0 < level < 1):
            raise ParameterError("level", f"level must be in (0, 1), got {level}")
        if self.diagnostics.get("deterministic"):
            return self.probability.copy(), self.probability.copy()
        q = (student.ppf(0.5 + level / 2, self.samples - 1) if self.samples < 200
             else norm.ppf(0.5 + level / 2))
        return (np.maximum(self.probability - q * self.stderr, 0.0),
                self.probability + q * self.stderr)

    def _statistics_table(self) -> Table:
        """The result's table, which its summary, HTML and pandas table render: per level the
        probability, its standard error, relative error, 95 % interval, and whether it is
        reliable."""
        lo, hi = self.interval()
        what = "replicas" if self.method == "splitting" else "paths"
        n = len(self.levels)
        columns = {"level": np.asarray(self.levels), "units": np.array([self.units] * n,
                                                                       dtype=object),
                   "probability": np.asarray(self.probability),
                   "stderr": np.asarray(self.stderr), "rel_error": np.asarray(self.rel_error),
                   "lower": lo, "upper": hi, "reliable": np.asarray(self.reliable)}
        head = f"P({self.quantity} > level), {self.method}"
        return Table("levels", "crandall tail",
                     (f"{head}, {self.samples} {what}, {self.seconds:.1f} s, "
                      f"{self.steps:.3g} steps",),
                     (f"{head}, {self.samples:,} {what}, {self.seconds:.1f} s",), columns)

    def to_pandas(self):
        """One row per level: probability, stderr, rel_error, the 95 % interval, reliable."""
        return _frames.levels_pandas(self._statistics_table())

    def __str__(self) -> str:
        return render_text.text(self._statistics_table())

    def summary(self) -> str:
        """The table of :meth:`__str__` (as every crandall result has)."""
        return str(self)

    def _repr_html_(self) -> str:
        """The table of :meth:`__str__` as HTML (Jupyter shows it for a tail result)."""
        return _render.html_table(self._statistics_table())

    def to_xarray(self):
        """An xarray Dataset over ``level``: probability, stderr, rel_error, reliable; the
        quantity, units, method, samples, cost, diagnostics and spec (JSON) as attributes."""
        attrs = {FILE_ATTR: 1, "quantity": self.quantity, "units": self.units,
                 "method": self.method, "samples": int(self.samples),
                 "seconds": float(self.seconds), "steps": int(self.steps),
                 "diagnostics": json.dumps(self.diagnostics, default=_plain),
                 "spec": json.dumps(self.spec, default=_plain)}
        return _frames.levels_xarray(self._statistics_table(), attrs)

    def save(self, path: Union[str, "os.PathLike[str]"]) -> None:
        """Write a netCDF file (netCDF-3 by SciPy, as crandall's other results), replaced
        atomically; :func:`crandall.load` reads it back with every number bitwise the same."""
        ds = self.to_xarray()
        encoding = {name: {"_FillValue": None} for name in list(ds.coords) + list(ds.data_vars)}
        data = bytes(ds.to_netcdf(engine="scipy", format="NETCDF3_64BIT", encoding=encoding))
        write_atomic(path, lambda f: f.write(data))

    @classmethod
    def _from_dataset(cls, ds) -> "TailResult":
        """The result a Dataset of :meth:`to_xarray` holds."""
        a = ds.attrs
        return cls(quantity=str(a["quantity"]), levels=ds["level"].values.copy(),
                   units=str(a["units"]), probability=ds["probability"].values.copy(),
                   stderr=ds["stderr"].values.copy(), rel_error=ds["rel_error"].values.copy(),
                   method=str(a["method"]), samples=int(a["samples"]),
                   seconds=float(a["seconds"]), steps=int(a["steps"]),
                   diagnostics=json.loads(str(a["diagnostics"])),
                   reliable=ds["reliable"].values.astype(bool),
                   spec=json.loads(str(a["spec"])))

    def plot(self, ax=None, reference=None, label=None):
        """The exceedance curve with its 95 % band (log probability). ``reference``: a
        fixed-step :class:`crandall.Result` with the quantity's distribution, whose plain Monte
        Carlo exceedance is drawn where it is informative (p above 100 / paths)."""
        import matplotlib.pyplot as plt

        if ax is None:
            _, ax = plt.subplots(figsize=(6, 4))
        lo, hi = self.interval()
        ok = self.probability > 0
        ax.fill_between(self.levels[ok], np.maximum(lo[ok], 1e-300), hi[ok], alpha=0.3,
                        label="95 % interval")
        ax.plot(self.levels[ok], self.probability[ok], "o-", ms=3, label=label or self.method)
        if reference is not None:
            name = "stop_time" if self.quantity == "stop_time" else self.quantity
            grid = np.linspace(self.levels[0], self.levels[-1], 200)
            p = np.array([reference.exceedance(name, float(x)).value for x in grid])
            floor = 100.0 / reference.paths
            keep = p >= floor
            ax.plot(grid[keep], p[keep], "k--", label=f"plain Monte Carlo ({reference.paths:.0e} paths)")
        ax.set_yscale("log")
        unit = f" [{self.units}]" if self.units else ""
        ax.set_xlabel(f"level{unit}")
        ax.set_ylabel(f"P({self.quantity} > level)")
        ax.legend()
        return ax


def _plain(x):
    """JSON for the NumPy numbers and arrays a tail's diagnostics hold."""
    if isinstance(x, np.ndarray):
        return x.tolist()
    if isinstance(x, np.generic):
        return x.item()
    raise TypeError(f"{type(x).__name__} is not JSON serialisable")


# -- the statistics of a run's samples ------------------------------------------------------


def _stats(chosen, splitting: bool, levels: int):
    """(samples, mean, stderr, per-sample variance) of the estimate from the samples
    ``chosen``."""
    if splitting:
        arr = np.array([c["estimates"] for c in chosen])
        n = len(arr)
        var = arr.var(axis=0, ddof=1) if n > 1 else np.full(levels, np.inf)
        return n, arr.mean(axis=0), np.sqrt(var / n), var
    n = sum(c["paths"] for c in chosen)
    s1 = np.sum([c["sum"] for c in chosen], axis=0)
    s2 = np.sum([c["sum2"] for c in chosen], axis=0)
    mean = s1 / n
    var = np.maximum(s2 / n - mean ** 2, 0.0) * n / max(n - 1, 1)
    return n, mean, np.sqrt(var / n), var


class StatisticsFailure(RuntimeError):
    """An estimator found no usable answer (e.g. no importance-sampling proposal reached the
    level); the message says what to do instead."""
