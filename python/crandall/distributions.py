"""Quantiles and exceedance probabilities, with confidence intervals, from binned counts.

The functions take a histogram as plain arrays: ``edges`` (strictly increasing, finite, at
least two), ``counts`` (one per bin, ``len(edges) - 1``), and the numbers of values below the
first edge (``under``, including -inf) and at or above the last (``over``, including +inf).
Bins are half-open, ``[edges[j], edges[j + 1])``, as in the core's histograms and in
boost-histogram. NaN values are not part of these counts (the core counts them apart).

The intervals are conservative: they hold the true value with at least the stated
probability, whatever the bins. Where the bins limit what the counts can say (a value is
known only to lie somewhere in its bin), the interval is widened to the whole bin, never
narrowed by interpolation. The method: docs/methods/histograms.md.
"""

from __future__ import annotations

import math
import numbers
from typing import NamedTuple

import numpy as np
from .errors import ParameterError

__all__ = ["Estimate", "quantile", "exceedance", "to_boost_histogram", "point_cells", "ATOM"]


class Estimate(NamedTuple):
    """A point estimate and a confidence interval ``[low, high]`` around it.

    Attributes
    ----------
    value : float
        The point estimate (interpolated within its bin; infinite if it lies beyond the
        histogram's edges, in the underflow or the overflow).
    low, high : float
        The confidence interval; may be infinite where the histogram's range limits it.
    resolution : float
        The most by which the bins can have widened the interval: for a quantile, the widths
        of the two bins that hold the bracketing order statistics (infinite for a flow cell);
        for an exceedance, the fraction of values in the bin that holds the level (the count
        it leaves undecided). Where it is a large part of ``high - low`` the bins, not the
        number of values, limit the interval: finer bins would narrow it.
    """

    value: float
    low: float
    high: float
    resolution: float = math.nan

    @property
    def bin_limited(self) -> bool:
        """Whether the bins account for at least half the interval's width (finer bins would
        narrow it noticeably; more values would not, by much)."""
        width = self.high - self.low
        return bool(self.resolution >= 0.5 * width) if math.isfinite(width) else bool(
            math.isinf(self.resolution))


def _count(value, name: str) -> int:
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, numbers.Integral):
        if isinstance(value, numbers.Real) and float(value).is_integer():
            value = int(value)
        else:
            raise ParameterError(name, f"{name} must be a non-negative integer count, got "
                                       f"{value!r}")
    if not 0 <= value <= np.iinfo(np.int64).max:
        raise ParameterError(name, f"{name} must be a non-negative integer count below 2^63, got "
                                   f"{value!r}")
    return int(value)


def _histogram(edges, counts, under, over):
    """Validated copies: edges (float64), cells [under, *counts, over] (int64), the total."""
    try:
        e = np.asarray(edges, dtype=np.float64)
    except (TypeError, ValueError):
        raise ParameterError("edges", "edges must be a 1-D sequence of numbers") from None
    if e.ndim != 1 or e.size < 2:
        raise ParameterError("edges", "edges must be 1-D with at least two entries, got shape "
                                      f"{e.shape}")
    if not np.all(np.isfinite(e)):
        raise ParameterError("edges", "edges must be finite")
    if not np.all(np.diff(e) > 0):
        raise ParameterError("edges", "edges must be strictly increasing")
    c = np.asarray(counts)
    if c.ndim != 1 or c.size != e.size - 1:
        raise ParameterError("counts", f"counts must be 1-D with len(edges) - 1 = {e.size - 1} "
                                       f"entries, got shape {c.shape}")
    if c.dtype.kind == "u":
        if c.size and c.max() > np.iinfo(np.int64).max:
            raise ParameterError("counts", "counts: a count exceeds 2^63 - 1")
        c = c.astype(np.int64)
    elif c.dtype.kind == "i":
        c = c.astype(np.int64)
    elif c.dtype.kind == "f":
        if not (np.all(np.isfinite(c)) and np.all(c == np.floor(c))) or (c.size and c.max() >= 2.0**63):
            raise ParameterError("counts", "counts must be non-negative integers")
        c = c.astype(np.int64)
    else:
        raise ParameterError("counts", "counts must be non-negative integers, got dtype "
                                       f"{c.dtype}")
    if np.any(c < 0):
        raise ParameterError("counts", "counts must be non-negative integers")
    cells = np.concatenate(([_count(under, "under")], c, [_count(over, "over")])).astype(np.int64)
    if float(cells.sum(dtype=np.float64)) < 2.0**62:
        total = int(cells.sum())  # far from int64's limit: exact
    else:
        total = sum(int(x) for x in cells)  # Python ints: no overflow in the check below
    if total > np.iinfo(np.int64).max:
        raise ParameterError("counts", "counts: the total exceeds 2^63 - 1")
    return e, cells, total


def _nonempty(edges, counts, under, over):
    e, cells, total = _histogram(edges, counts, under, over)
    if total == 0:
        raise ParameterError("counts", "counts: the histogram is empty (no value in counts, under "
                                       "or over)")
    return e, cells, total


def _confidence(confidence) -> float:
    if not isinstance(confidence, numbers.Real) or not 0.0 < float(confidence) < 1.0:
        raise ParameterError("confidence", "confidence must be a number strictly between 0 and "
                                           f"1, got {confidence!r}")
    return float(confidence)


def _cell_bounds(e: np.ndarray):
    """Lower and upper ends of every cell [under, bins..., over]."""
    lower = np.concatenate(([-math.inf], e))
    upper = np.concatenate((e, [math.inf]))
    return lower, upper


#: The least positive double, 2^-1074: the automatic edges put it just above 0, so that the
#: bin [0, ATOM) holds exact zeros only (the atom at 0 of a stopped body's velocity, of a
#: scene without excitation, ...).
ATOM = float(np.nextafter(0.0, 1.0))


def point_cells(edges) -> np.ndarray:
    """Which bins ``[a, b)`` hold one value only, ``a`` itself (``b`` is the next double after
    ``a``): an atom, known exactly, which no interpolation within the bin may spread."""
    e = np.asarray(edges, dtype=np.float64)
    return e[1:] == np.nextafter(e[:-1], np.inf)


def _is_point(lower, upper, i: int) -> bool:
    return bool(math.isfinite(lower[i]) and upper[i] == np.nextafter(lower[i], np.inf))


def _order_statistic_ranks(n: int, q: float, alpha: float):
    """Ranks l <= u with P(X_(l) <= xi_q <= X_(u)) >= 1 - alpha, equal tails.

    With B the number of values <= xi_q (binomial(n, q) for a continuous law, stochastically
    larger otherwise) X_(l) > xi_q iff B < l, so l is the largest rank with P(B < l) <= alpha/2;
    likewise X_(u) < xi_q needs at least u values < xi_q, so u is the least rank with
    P(B >= u) <= alpha/2. Rank 0 stands for -inf and rank n + 1 for +inf.
    """
    from scipy.special import bdtr, bdtrc, bdtrik

    if q == 0.0:
        return 0, 1
    if q == 1.0:
        return n, n + 1
    half = alpha / 2

    def below(k):  # P(B < k) = P(B <= k - 1)
        return 0.0 if k <= 0 else float(bdtr(k - 1, n, q))

    def at_least(k):  # P(B >= k) = P(B > k - 1)
        return 1.0 if k <= 0 else float(bdtrc(k - 1, n, q))

    def guess(y):
        # bdtrik solves bdtr(k, n, q) = y for a real k: a start a step or two from the answer;
        # the loops below decide by the binomial tails themselves.
        k = bdtrik(y, n, q)
        return min(max(int(k), 0), n) if math.isfinite(k) else int(n * q)

    lo = guess(half)
    while lo > 0 and below(lo) > half:
        lo -= 1
    while lo < n and below(lo + 1) <= half:
        lo += 1
    hi = guess(1 - half) + 1
    while hi > 1 and at_least(hi - 1) <= half:
        hi -= 1
    while hi <= n and at_least(hi) > half:
        hi += 1
    return lo, hi


def quantile(edges, counts, under, over, q, confidence=0.95) -> Estimate:
    """The q-quantile of the binned values, with an order-statistic confidence interval.

    Parameters
    ----------
    edges : array_like of float
        Bin edges, strictly increasing and finite, at least two.
    counts : array_like of int
        Values in each bin ``[edges[j], edges[j + 1])``.
    under, over : int
        Values below ``edges[0]`` and at or above ``edges[-1]``.
    q : float
        The probability, ``0 <= q <= 1``.
    confidence : float, optional
        The interval's coverage, strictly between 0 and 1 (default 0.95).

    Returns
    -------
    Estimate
        ``value``: the sample quantile interpolated linearly within its bin (the point where
        the cumulative count reaches ``q * total``, bins taken as uniformly filled; in a point
        bin, see :func:`point_cells`, its one value exactly); ``-inf``
        or ``+inf`` when it lies in the underflow or the overflow, where the bins cannot place
        it. ``q = 0`` gives the lower edge of the lowest non-empty bin, ``q = 1`` the upper
        edge of the highest.
        ``resolution``: the widths of the two bins that widened the interval (see
        :class:`Estimate`).
        ``low``, ``high``: a distribution-free interval for the population quantile
        ``inf{x : P(X <= x) >= q}``: the order statistics ``X_(l) <= X_(u)`` chosen from the
        binomial law of the number of values below the quantile (equal tails, each at most
        ``(1 - confidence) / 2``, so coverage is at least ``confidence`` for any law), then
        widened to the lower edge of ``X_(l)``'s bin and the upper edge of ``X_(u)``'s bin.
        That widening is where the histogram limits the interval (it is the bin width at
        each end); ``-inf`` or ``+inf`` where an order statistic is beyond the edges, or
        beyond the sample (``q = 0`` has no lower bound, ``q = 1`` no upper).

    Raises
    ------
    ValueError
        Bad edges, counts, under, over, q or confidence; an empty histogram (``counts``).
    """
    e, cells, n = _nonempty(edges, counts, under, over)
    if not isinstance(q, numbers.Real) or not 0.0 <= float(q) <= 1.0:
        raise ParameterError("q", f"q must be a number in [0, 1], got {q!r}")
    q = float(q)
    alpha = 1.0 - _confidence(confidence)
    lower, upper = _cell_bounds(e)
    cum = np.cumsum(cells)
    last = len(cells) - 1

    def cell_of_rank(k: int) -> int:
        """The cell holding the k-th smallest value (1 <= k <= n)."""
        return int(np.searchsorted(cum, k, side="left"))

    r = q * n
    if r <= 0.0:
        i = cell_of_rank(1)
        value = lower[i]
    else:
        # The first cell whose cumulative count reaches q n, i.e. the cell of X_(ceil(q n)).
        i = min(int(np.searchsorted(cum, r, side="left")), last)
        if i == 0:
            value = -math.inf
        elif i == last:
            value = math.inf
        elif _is_point(lower, upper, i):
            value = lower[i]  # every value in the bin is its lower edge: no interpolation
        else:
            before = float(cum[i] - cells[i])
            frac = min(max((r - before) / float(cells[i]), 0.0), 1.0)
            value = min(max(lower[i] + frac * (upper[i] - lower[i]), lower[i]), upper[i])
    lo_rank, hi_rank = _order_statistic_ranks(n, q, alpha)
    resolution = 0.0
    low, high = -math.inf, math.inf
    # An order statistic in a point bin is known exactly: no widening there.
    if lo_rank != 0:
        c = cell_of_rank(lo_rank)
        low = float(lower[c])
        if not _is_point(lower, upper, c):
            resolution += float(upper[c] - lower[c])
    if hi_rank != n + 1:
        c = cell_of_rank(hi_rank)
        if _is_point(lower, upper, c):
            high = float(lower[c])
        else:
            high = float(upper[c])
            resolution += float(upper[c] - lower[c])
    return Estimate(float(value), low, high, resolution)


def _clopper_pearson(k_low: int, k_high: int, n: int, alpha: float):
    """Lower bound at k_low and upper bound at k_high of n: the beta quantiles that solve
    P(B >= k_low | p) = alpha/2 and P(B <= k_high | p) = alpha/2."""
    from scipy.special import betaincinv

    low = 0.0 if k_low == 0 else float(betaincinv(k_low, n - k_low + 1, alpha / 2))
    high = 1.0 if k_high == n else float(betaincinv(k_high + 1, n - k_high, 1 - alpha / 2))
    return low, high


def exceedance(edges, counts, under, over, level, confidence=0.95) -> Estimate:
    """P(X > level) from the binned values, with a Clopper-Pearson confidence interval.

    Parameters
    ----------
    edges : array_like of float
        Bin edges, strictly increasing and finite, at least two.
    counts : array_like of int
        Values in each bin ``[edges[j], edges[j + 1])``.
    under, over : int
        Values below ``edges[0]`` and at or above ``edges[-1]``.
    level : float
        The threshold (not NaN; ``+inf`` gives exactly 0 exceedances).
    confidence : float, optional
        The interval's coverage, strictly between 0 and 1 (default 0.95).

    Returns
    -------
    Estimate
        ``value``: the fraction of values strictly above ``level``, counting the bin that
        contains ``level`` in proportion to the part of it above ``level`` (bins taken as
        uniformly filled); a point bin (see :func:`point_cells`: an atom, such as exact zeros
        in the automatic bin ``[0, ATOM)``) that holds ``level`` counts none, exactly. If ``level`` lies in the underflow or the overflow, which have no width to
        interpolate in, that cell counts half.
        ``resolution``: the fraction of values in the level's cell (see :class:`Estimate`).
        ``low``, ``high``: the number K of values above ``level`` is only known to lie between
        K_min (the cells wholly above the level) and K_max (those plus the cell holding it:
        a level on an edge ``edges[j]`` still leaves bin j's values equal to it undecided);
        the interval runs from the Clopper-Pearson lower bound at K_min to the upper bound at
        K_max, each at ``(1 - confidence) / 2``. Clopper-Pearson, not Wilson: its coverage is
        at least ``confidence`` for every probability and sample size, which matters in the
        tails (1e-3, 1e-4), where few values are counted and Wilson's interval covers less
        than it states (Brown, Cai & DasGupta, Statistical Science 16 (2001) 101-133); and a
        guarantee that holds for K_min and K_max holds for the unknown K between them.

    Raises
    ------
    ValueError
        Bad edges, counts, under, over, level or confidence; an empty histogram (``counts``).
    """
    e, cells, n = _nonempty(edges, counts, under, over)
    if not isinstance(level, numbers.Real) or math.isnan(float(level)):
        raise ParameterError("level", f"level must be a number (not NaN), got {level!r}")
    level = float(level)
    alpha = 1.0 - _confidence(confidence)
    if level == math.inf:
        low, high = _clopper_pearson(0, 0, n, alpha)
        return Estimate(0.0, low, high, 0.0)
    # The cell holding the level: the number of edges <= level (0 underflow, len(e) overflow).
    i = int(np.searchsorted(e, level, side="right"))
    above = int(cells[i + 1:].sum())
    inside = int(cells[i])
    lower, upper = _cell_bounds(e)
    if 0 < i < len(e) and _is_point(lower, upper, i):
        # A point bin holds the level itself only (an atom): none of it is above the level,
        # and the count above is known exactly.
        frac, inside = 0.0, 0
    elif 0 < i < len(e):
        frac = (upper[i] - level) / (upper[i] - lower[i])
    else:
        frac = 0.5
    value = (above + frac * inside) / n
    low, high = _clopper_pearson(above, above + inside, n, alpha)
    return Estimate(float(min(max(value, 0.0), 1.0)), low, high, inside / n)


def to_boost_histogram(edges, counts, under, over, label: str = ""):
    """The histogram as a ``boost_histogram.Histogram`` (needs the extra ``crandall[hist]``).

    Parameters
    ----------
    edges : array_like of float
        Bin edges, strictly increasing and finite, at least two.
    counts : array_like of int
        Values in each bin ``[edges[j], edges[j + 1])``.
    under, over : int
        Values below ``edges[0]`` and at or above ``edges[-1]``.
    label : str
        The axis label (the quantity, its units and time).

    Returns
    -------
    boost_histogram.Histogram
        One ``Variable`` axis on ``edges`` with underflow and overflow bins (the same
        half-open bins), ``Int64`` storage; ``h.view(flow=True)`` is ``[under, *counts, over]``.

    Raises
    ------
    ImportError
        boost-histogram is not installed.
    ValueError
        Bad edges, counts, under or over.
    """
    e, cells, _ = _histogram(edges, counts, under, over)
    try:
        import boost_histogram as bh
    except ImportError as exc:
        raise ImportError("to_boost_histogram needs boost-histogram: install the optional extra "
                          "with pip install 'crandall[hist]'") from exc
    h = bh.Histogram(bh.axis.Variable(e, underflow=True, overflow=True), storage=bh.storage.Int64())
    h.axes[0].label = str(label)
    h.view(flow=True)[...] = cells
    return h
