"""What every result shares: the warning of unreliable statistics, the per-time statistic type, the
read-only accumulators, the moments' layout and the formatting of numbers in tables."""

from __future__ import annotations

import math
import statistics as _statistics
from typing import NamedTuple, Optional, Union

import numpy as np

from .. import _core, _render, distributions
from ..bins import Histograms


class StatisticsWarning(UserWarning):
    """A statistic could not be estimated from this run and is returned as NaN.

    Raised (as a warning) by :meth:`Result.var`, :meth:`Result.std`, :meth:`Result.stderr` and
    :meth:`Result.var_stderr` when they return NaN: a variance from fewer than 2 paths; a
    standard error of a variance whose fourth-moment term is negative (an extrapolated method
    at a step far too long for it) or overflows doubles; or a standard error that rests on the
    fourth moment (of a variance, of the kinetic energy's mean) where fewer than
    :data:`MIN_CARRIERS` paths carry the spread (:meth:`Result.carriers`).
    """


#: The fewest paths that must carry a quantity's spread (:meth:`Result.carriers`) for the
#: standard errors that rest on its fourth moment (a variance's; the kinetic energy's mean's)
#: to be reported. Fewer, and the few paths far from the mean decide the fourth moment: the
#: interval +- 1.96 standard errors of a variance covered 77-91 % of the law's value with 5
#: to 30 carrying paths and 49-75 % with fewer than 2, for sparse, normal and Laplace samples
#: alike, and 17 % on the simulated velocity after the switch-off where fewer than 2 carried
#: it, with z down to -78 870 (bench/few_carriers.py, docs/accumulators.md); from 30 on,
#: 90-96 %. 30 carrying
#: paths need about 100 paths of a normal quantity, a few hundred of a heavier-tailed one.
MIN_CARRIERS = 30

#: Exponents (velocity, displacement, distance) of the accumulators' moments, in their order.
MONOMIALS = tuple(tuple(e) for e in _core.monomial_exponents())
_EXPONENTS = list(MONOMIALS)
_INDEX = {e: i for i, e in enumerate(_EXPONENTS)}


def _sqrt(x: float) -> float:
    return math.sqrt(x) if x >= 0 else math.nan  # NaN (n/a) stays NaN


def _fmt(x: float, spec: str, few: bool = False) -> str:
    width = "".join(c for c in spec.split(".")[0] if c.isdigit())
    # few: a standard error not estimated because few paths carry the spread (FEW_MARK).
    text = FEW_MARK if few else "n/a" if math.isnan(x) else format(x, spec)
    return f"{text:>{width}}" if width else text


FEW_MARK = _render.FEW_MARK


def _shaken_before(scene, until: float) -> bool:
    """Whether the noise has acted before ``until``: model.noise_energy(scene, until) > 0,
    asked without squaring the intensity (which overflows for h near 1e300)."""
    if scene.pieces is None:
        return scene.noise > 0 and until > 0
    start = 0.0
    for end, noise in scene.pieces:
        if noise > 0 and until > start:
            return True
        start = end
    return False


def _e(v: int, power: int) -> int:
    exps = [0, 0, 0]
    exps[v] = power
    return _INDEX[tuple(exps)]


def _times_text(times) -> str:
    shown = ", ".join(f"{t:g}" for t in times[:8])
    return shown + (f", ... ({len(times)} times)" if len(times) > 8 else "")


def _fold(edges: np.ndarray, cells: np.ndarray, base: str = "velocity",
          folded_name: str = "kinetic energy"):
    """A symmetric axis folded at 0: the histogram of |x| (edges >= 0; cells [under = 0,
    bins..., over, NaN]). Bin [a, b) of x goes to the bin of |x| starting at a (a >= 0), at
    -b (b <= 0), or at 0 (a < 0 < b); both flows go to the overflow. ``base`` and
    ``folded_name`` name the two in the error of an axis that is not symmetric."""
    refuse = (f"name: the {base}'s bins are not symmetric about 0, so the {folded_name}'s "
              "distribution cannot be folded from them")
    atom = edges.size > 2 and edges[edges.size // 2] == distributions.ATOM
    if atom:
        # The atom edge just above 0 has no mirror below: the rest is symmetric.
        rest = np.delete(edges, edges.size // 2)
        if not np.array_equal(rest, -rest[::-1]):
            raise ValueError(refuse)
    elif not np.array_equal(edges, -edges[::-1]):
        raise ValueError(refuse)
    pos = edges[edges >= 0]
    if pos[0] != 0.0:
        pos = np.concatenate(([0.0], pos))
    n = edges.size - 1
    a, b = edges[:-1], edges[1:]
    start = np.where(a >= 0, a, np.where(b <= 0, -b, 0.0))
    if atom:
        # [-w, 0) folds onto (0, w]: beside the atom [0, ATOM) of exact zeros, not into it.
        start = np.where((a < 0) & (start == 0.0), distributions.ATOM, start)
    target = np.searchsorted(pos, start, side="left")
    folded = np.zeros(pos.size + 2, dtype=np.uint64)
    np.add.at(folded, 1 + target, np.asarray(cells[1:n + 1], dtype=np.uint64))
    folded[-2] = np.uint64(cells[0]) + np.uint64(cells[n + 1])
    folded[-1] = cells[n + 2]
    return pos, folded


#: A statistic: an array over the output times, or a float for a quantity at the stop.
Stat = Union[float, np.ndarray]


def z_of(level: float) -> float:
    """The two-sided standard normal quantile of a coverage ``level``."""
    return _statistics.NormalDist().inv_cdf(0.5 + 0.5 * float(level))


class Accumulators(NamedTuple):
    """The merged accumulators a result's statistics come from (``Result.accumulators``).

    Each is a ``crandall._core.Moments``: ``counts``, ``means`` (of velocity, displacement,
    distance) and ``central`` sums per slot, exactly as the run merged them; saving them
    (``crandall.io``) is what makes a loaded result bitwise the saved one. Read them only:
    the result's statistics are computed from the same objects.
    """

    #: One slot per output time.
    times: object
    #: One slot: the stop (time after the switch-off, and the integrals there); None when the
    #: scene does not observe "stop".
    stop: Optional[object]
    #: The peaks (max |U1|, max |U2|, 0) per output time; None unless the scene observes
    #: "peaks".
    peaks: Optional[object] = None
    #: The peaks over the whole path (one slot); None unless the scene observes "peaks" and
    #: "stop".
    stop_peaks: Optional[object] = None
    #: The histograms (``crandall.bins.Histograms``: axis indices, edges, uint64 counts);
    #: None unless the scene asks for distributions.
    histograms: Optional[Histograms] = None
    #: The moments of (V^2, 0, 0) per output time, from which the kinetic energy's variance
    #: gets its standard error (it needs E V^8); None unless the scene observes
    #: "kinetic_energy" (and in results saved before crandall kept them).
    energy: Optional[object] = None
