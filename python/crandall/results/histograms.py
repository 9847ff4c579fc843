"""A result's distributions: histograms, quantiles and exceedances from its counts."""

from __future__ import annotations

import math
import numbers
from typing import Any, Optional

import numpy as np

from .. import distributions
from ..quantities import quantity
from ..errors import ParameterError
from .common import _fold, _times_text


class _Distributions:
    """A result's distributions (``Scene(distributions=...)``): the histograms, quantiles and
    exceedances from the run's own counts, with their intervals. A part of :class:`Result`."""

    # -- distributions ------------------------------------------------------------------

    @property
    def distributions(self) -> tuple:
        """The quantities whose distributions this result holds (``Scene(distributions=...)``)."""
        return tuple(self.scene.distributions) if self._histograms is not None else ()

    def _slot(self, name: str, q, time) -> int:
        if q.at_stop:
            if time is not None:
                raise ParameterError("time", f"time: {name} is a value at the stop, with one "
                                             f"distribution; give no time (got time={time!r})")
            return self.times.size
        if time is None:
            raise ParameterError("time", f"time: {name} has a distribution at every output time; "
                                         f"give time, one of {_times_text(self.times)}")
        if isinstance(time, (bool, np.bool_)) or not isinstance(time, numbers.Real) \
                or not math.isfinite(float(time)):
            # Not finite: inf would pass the rounding test below (inf - t <= 1e-12 inf).
            raise ParameterError("time", f"time: {time!r} is not an output time of this result; "
                                         f"give one of {_times_text(self.times)}")
        t = float(time)
        hit = np.flatnonzero(self.times == t)
        if not hit.size:
            # A time typed again differs from the stored one by a rounding at most.
            hit = np.flatnonzero(np.abs(self.times - t) <= 1e-12 * np.maximum(np.abs(self.times), abs(t)))
        if not hit.size:
            raise ParameterError("time", f"time: {time!r} is not an output time of this result; "
                                         f"give one of {_times_text(self.times)}")
        return int(hit[0])

    def _binned(self, name: str, time):
        """(edges, cells, offset, shown edges) of a quantity's distribution: edges and cells
        [under, bins..., over, NaN] in the quantity's units less ``offset`` (the stop time's
        t0), and the edges to show (the user's, when given)."""
        if not isinstance(name, str) or name not in self.names:
            raise ParameterError("name", f"name: {name!r} is not in this result; it holds "
                                         f"{', '.join(self.names)}")
        if name not in self.distributions:
            asked = ", ".join(self.distributions) or "none"
            raise ParameterError("name", "name: the scene did not ask for the distribution of "
                                         f"{name!r} (its distributions: {asked}); give Scene(..., "
                                         "distributions=[...]) and run it again")
        q = quantity(name)
        slot = self._slot(name, q, time)
        found = self._histograms.find(slot, q.histogram_variable)
        if found is None:  # pragma: no cover - the scene's axes are all recorded
            raise ParameterError("name", f"name: no histogram of {name!r} at this slot")
        edges, cells = np.asarray(found[0], dtype=np.float64), np.asarray(found[1])
        atom = edges == distributions.ATOM
        if q.power == 2:
            edges, cells = _fold(edges, cells)
            atom = edges == distributions.ATOM
            edges = edges * edges
        elif q.magnitude:
            edges, cells = _fold(edges, cells, "displacement at the stop", name.replace("_", " "))
            atom = edges == distributions.ATOM
        f = self._factor(name)
        if f == 0.0:
            raise ParameterError("name", f"name: {name} is 0 on every path of this scene (its "
                                         "factor is 0: no friction, mu = 0), so it has no "
                                         "distribution to bin")
        if f != 1.0:
            edges = edges * f
        # The atom bin [0, ATOM) holds exact zeros, whatever the units: its upper edge stays
        # the least positive double (squared or scaled, it would underflow onto 0).
        edges[atom] = distributions.ATOM
        if not (np.diff(edges) > 0).all():
            raise ParameterError("name", f"name: {name}'s bin edges are not distinct in doubles "
                                         f"once converted to its units (factor {f!r}); choose "
                                         "units nearer 1")
        offset = q.offset(self.scene) if q.offset is not None else 0.0
        shown = edges + offset if offset else edges
        user = self.scene.bin_settings[1].get(name)
        if isinstance(user, tuple) and len(user) == len(edges):
            shown = np.asarray(user, dtype=np.float64)
        if cells[-1]:
            self._warn_nan(name, "the distribution", [math.nan],
                           f"{int(cells[-1])} paths gave NaN (left out of quantiles and "
                           "exceedances)", 3)
        return edges, cells, offset, shown

    def histogram(self, name: str, time: Optional[float] = None) -> Any:
        """The run's histogram of a quantity as a ``boost_histogram.Histogram``.

        Needs the ``hist`` extra (``pip install 'crandall[hist]'``) and a scene that asked for
        the distribution (``Scene(..., distributions=[name])``).

        Parameters
        ----------
        name : str
            A quantity in :attr:`distributions`.
        time : float, optional
            For a quantity over time, one of the output times :attr:`times`; none for a
            quantity at the stop.

        Returns
        -------
        boost_histogram.Histogram
            One ``Variable`` axis on the bins' edges in the quantity's units, with underflow
            and overflow; ``Int64`` counts, every path counted once (a NaN value, which no
            sane run gives, is left out: it warns). The kinetic energy's bins are the
            velocity's folded at 0, the dissipated energy's the distance's times m mu g.
            The automatic bins have an atom bin ``[0, 2^-1074)`` that holds exact zeros only
            (a stopped or unshaken body; its density is not a number to plot, its count is the
            probability of exactly 0); for the stop time, shown from t0, it joins the bin
            above it (t0 + 2^-1074 is t0 in doubles).
            With "richardson" or "richardson2" the histograms are of the finest grid's paths
            (counts cannot be extrapolated).

        Raises
        ------
        ValueError
            ``name`` not held or its distribution not asked for; ``time`` missing, given for a
            stop quantity, or not an output time.
        ImportError
            boost-histogram is not installed.
        """
        shown, cells, label = self.histogram_counts(name, time)
        return distributions.to_boost_histogram(shown, cells[1:-1], int(cells[0]),
                                                int(cells[-1]), label)

    def histogram_counts(self, name: str, time: Optional[float] = None):
        """The run's histogram of a quantity as plain arrays (what :meth:`histogram` gives as
        a ``boost_histogram.Histogram``, which the figures do without).

        Returns
        -------
        edges : numpy.ndarray
            The bins' edges in the quantity's units (as :meth:`histogram`'s axis).
        counts : numpy.ndarray
            Paths per cell: the underflow, one per bin, the overflow (``len(edges) + 1``).
        label : str
            The quantity, its unit and the time.
        """
        edges, cells, offset, shown = self._binned(name, time)
        atom = np.flatnonzero(edges == distributions.ATOM)
        if offset and atom.size and shown[atom[0]] == shown[atom[0] - 1]:
            # t0 + 2^-1074 is t0: the atom bin of the stop time cannot be shown apart once t0
            # is added, so it joins the bin above it here (quantiles and exceedances, taken
            # from the switch-off, keep it apart).
            j = int(atom[0])
            cells = np.array(cells, copy=True)
            cells[j + 1] += cells[j]
            cells = np.delete(cells, j)
            shown = np.delete(shown, j)
        if not (np.diff(shown) > 0).all():
            # The core bins the stop time from the switch-off; edges far finer than t0's
            # rounding collide once t0 is added back. Quantiles and exceedances are computed
            # from the switch-off and are not affected.
            raise ParameterError("name", f"name: {name}'s bin edges plus t0 = {self.scene.t0!r} "
                                         "are not distinct in doubles; use quantile or "
                                         "exceedance, or give coarser bins")
        unit = self.scene.units_of(name)
        label = name + (f" [{unit}]" if unit else "") + (
            "" if time is None else f" at {self.scene.time_name} = {float(time):g}")
        return shown, np.asarray(cells[:-1]), label

    def quantile(self, name: str, q: float, time=None,
                 confidence: float = 0.95) -> distributions.Estimate:
        """The q-quantile of a quantity from the run's histogram, with a confidence interval.

        Parameters
        ----------
        name : str
            A quantity in :attr:`distributions`.
        q : float
            The probability, strictly between 0 and 1 (0.99: the value 99 % of paths stay at
            or below).
        time : float, optional
            One of :attr:`times` for a quantity over time; none for one at the stop.
        confidence : float
            The interval's coverage, strictly between 0 and 1 (default 0.95).

        Returns
        -------
        crandall.distributions.Estimate
            ``value``: the sample quantile, interpolated within its bin. ``low``, ``high``: a
            distribution-free interval for the law's quantile, coverage at least
            ``confidence`` for any law: the order statistics bracketing the quantile
            (binomial ranks), widened to the edges of the bins that hold them. The bin width
            limits the interval at each end by at most one bin (1/128 to 1/256 of the value
            with the default bins beyond the quantity's scale); once the sampling interval
            is a few bins wide it is the paths, not the bins, that limit it
            (docs/methods/histograms.md, "Intervals"). Infinite where the quantile lies
            beyond the bins (user edges that do not reach it). In the quantity's units.
            ``resolution``: the widths of the two bins at the interval's ends, the most the
            bins can have widened it; ``bin_limited``: whether that is at least half the
            interval (then finer ``bins`` would narrow it; more paths, not much).

        Raises
        ------
        ValueError
            As :meth:`histogram`, and ``q`` or ``confidence`` outside (0, 1).
        """
        if isinstance(q, (bool, np.bool_)) or not isinstance(q, numbers.Real) \
                or not 0.0 < float(q) < 1.0:
            raise ParameterError("q", f"q must be a number strictly between 0 and 1, got {q!r}")
        edges, cells, offset, _ = self._binned(name, time)
        est = distributions.quantile(edges, cells[1:-2], int(cells[0]), int(cells[-2]),
                                     float(q), confidence)
        if not offset:
            return est
        return est._replace(value=est.value + offset, low=est.low + offset,
                            high=est.high + offset)

    def exceedance(self, name: str, level: float, time=None,
                   confidence: float = 0.95) -> distributions.Estimate:
        """P(quantity > level) from the run's histogram, with a confidence interval.

        Parameters
        ----------
        name : str
            A quantity in :attr:`distributions`.
        level : float
            The threshold, in the quantity's units (not NaN).
        time : float, optional
            One of :attr:`times` for a quantity over time; none for one at the stop.
        confidence : float
            The interval's coverage, strictly between 0 and 1 (default 0.95).

        Returns
        -------
        crandall.distributions.Estimate
            ``value``: the fraction of paths above ``level`` (the bin holding the level
            counted in proportion to its part above it). ``low``, ``high``: Clopper-Pearson
            bounds, coverage at least ``confidence``, taken at the fewest and the most paths
            that can be above the level given the bins: the bin holding the level is where
            the histogram limits the interval (a level on an edge still leaves that bin
            undecided). ``resolution``: the fraction of paths in that bin; ``bin_limited``:
            whether it is at least half the interval's width.

        Raises
        ------
        ValueError
            As :meth:`histogram`, and a bad ``level`` or ``confidence``.
        """
        if isinstance(level, (bool, np.bool_)) or not isinstance(level, numbers.Real) \
                or math.isnan(float(level)):
            raise ParameterError("level", f"level must be a number (not NaN), got {level!r}")
        edges, cells, offset, _ = self._binned(name, time)
        return distributions.exceedance(edges, cells[1:-2], int(cells[0]), int(cells[-2]),
                                        float(level) - offset, confidence)
