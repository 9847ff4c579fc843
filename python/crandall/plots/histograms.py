"""Distributions from a run's histograms: the stop quantities' histograms against their
analytic laws, over the range that holds most of their mass."""

from __future__ import annotations

import math
from typing import Optional, Sequence

import numpy as np
from scipy.stats import beta

from .. import analytic, distributions
from ..quantities import quantity
from ..model import ANALYTIC, holds
from ..results import Result
from ..errors import ParameterError
from .common import _figure


#: The stop quantities whose distributions ``crandall run`` draws (and prints the quantiles
#: of) when the run holds them: the file stem of each figure is ``NAME_distribution``.
STOP_DISTRIBUTIONS = ("stop_time", "displacement_at_stop", "distance_at_stop",
                      "dissipated_energy_at_stop")


def _binned(result: Result, name: str, time):
    """Edges, counts per bin, flows and total of the run's histogram of ``name``."""
    edges, cells, _ = result.histogram_counts(name, time)
    cells = np.asarray(cells, dtype=float)
    return edges, cells[1:-1], cells[0], cells[-1], float(cells.sum())


#: The density panels show the bins that hold this much of the paths (the exceedance panel,
#: on a log scale, shows the tails).
SHOWN_MASS = 0.999


def _shown_range(counts, mass: float = SHOWN_MASS):
    """The bins from the one where the lowest (1 - mass) / 2 of the paths end to the one where
    the highest (1 - mass) / 2 begin (the automatic edges reach 50 scales, and a few paths far
    out would squeeze the bulk into a spike)."""
    counts = np.asarray(counts, dtype=float)
    total = counts.sum()
    if not total > 0:
        return 0, len(counts)
    cum = np.cumsum(counts)
    tail = 0.5 * (1.0 - mass) * total
    lo = int(np.searchsorted(cum, tail, side="right"))
    hi = int(np.searchsorted(cum, total - tail, side="left")) + 1
    lo = min(lo, int(np.flatnonzero(counts)[-1]))
    return lo, max(hi, lo + 1)


def _analytic_law(result: Result, name: str, time):
    """(pdf(x), sf(x)) of ``name`` in the result's units where the analytic layer has the
    law (the velocity while the noise is on, the stop time), else None."""
    sc = result.scene
    if (sc.units == "SI" and sc.scaling is None) or not holds(sc, ANALYTIC):
        return None
    s = None if sc.units == "scaled" else sc.scaling
    tau0 = sc.t0 if s is None else s.to_tau(sc.t0)
    if name == "velocity" and time is not None:
        tau = time if s is None else s.to_tau(time)
        if not (0 < tau <= tau0):
            return None
        vs = 1.0 if s is None else s.velocity_scale
        return (lambda x: analytic.velocity_pdf(x / vs, tau) / vs,
                lambda x: analytic.velocity_sf(x / vs, tau))
    if name == "stop_time" and math.isfinite(tau0) and tau0 > 0:
        ts = 1.0 if s is None else s.time_scale
        return (lambda x: analytic.stop_time_pdf(x / ts, tau0) / ts,
                lambda x: analytic.stop_time_sf(x / ts, tau0))
    return None


def distribution(result: Result, name: str, times: Optional[Sequence[float]] = None):
    """The density and the exceedance curve of a quantity, from the run's own histograms.

    Left: the density (counts per bin over paths times the bin's width), with the analytic
    density where the analytic layer has it (the velocity while the noise is on, the stop
    time). Right: P(quantity > x) on a log scale down to the last counted path, with the
    95 % Clopper-Pearson band of each edge's count (``Result.exceedance`` at the edges).

    Parameters
    ----------
    result : Result
        A run whose scene asked for the distribution of ``name``.
    name : str
        A quantity in ``result.distributions``.
    times : sequence of float, optional
        For a quantity over time, up to 3 output times (default: up to 3 of them); none for a
        stop quantity.

    Returns
    -------
    matplotlib.figure.Figure
    """
    if not isinstance(result, Result):
        raise ParameterError("result", "result must be a crandall.Result, got "
                                       f"{type(result).__name__}")
    q = quantity(name) if name in result.names else None
    if q is None or name not in result.distributions:
        raise ParameterError("name", f"name: the result holds no distribution of {name!r}")
    if q.at_stop:
        if times is not None:
            raise ParameterError("times", f"times: {name} is at the stop; give no times")
        slots = [None]
    else:
        slots = list(result.times if times is None else times)
        if len(slots) > 3:
            slots = [slots[0], slots[len(slots) // 2], slots[-1]]
    fig = _figure(width=10.0, height=4.0)
    dens, tail = fig.subplots(1, 2)
    unit = result.scene.units_of(name)
    label = q.long_name_in(result.scene.units) + (f" [{unit}]" if unit else "")
    for i, t in enumerate(slots):
        edges, counts, under, _, n = _binned(result, name, t)
        lo, hi = _shown_range(counts)
        e = edges[lo:hi + 1]
        width = np.diff(e)
        colour = f"C{i + 1}"
        tag = "" if t is None else f"{result.scene.time_name} = {t:g}"
        # An atom (the bin [0, 2^-1074) of exact zeros) has no density: left out of the
        # curve, its probability named in the legend.
        point = distributions.point_cells(e)
        density = np.where(point, np.nan, counts[lo:hi] / (n * np.where(point, 1.0, width)))
        atom = float(counts[lo:hi][point].sum()) / n
        dens.stairs(density, e, color=colour, lw=1.2,
                    label=(tag + ", " if tag else "") + f"run ({int(n):,} paths)"
                    + (f", P(= 0) = {atom:.3g}" if atom > 0 else ""))
        above = n - under - np.cumsum(np.concatenate(([0.0], counts)))
        keep = above[lo:hi + 1] > 0
        p_edge = above[lo:hi + 1][keep] / n
        tail.step(e[keep], p_edge, where="post", color=colour, lw=1.2,
                  label=(tag + ", " if tag else "") + "run")
        # 95 % Clopper-Pearson band of P(X >= edge) from the counts alone.
        k = above[lo:hi + 1][keep]
        low = np.where(k > 0, beta.ppf(0.025, k, n - k + 1), 0.0)
        high = np.where(k < n, beta.ppf(0.975, k + 1, n - k), 1.0)
        tail.fill_between(e[keep], low, high, step="post", color=colour, alpha=0.2, lw=0)
        law = _analytic_law(result, name, t)
        if law is not None:
            grid = np.linspace(e[0], e[-1], 600)
            pdf, sf = law
            dens.plot(grid, pdf(grid), color="k", lw=0.9, ls="--",
                      label="analytic" if i == 0 else None)
            with np.errstate(divide="ignore"):
                tail.plot(grid, sf(grid), color="k", lw=0.9, ls="--",
                          label="analytic" if i == 0 else None)
    dens.set_xlabel(label)
    dens.set_ylabel("density")
    tail.set_xlabel(label)
    tail.set_ylabel("P(value > x)")
    tail.set_yscale("log")
    for ax in (dens, tail):
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7)
    where = "" if name == "stop_time" else " at the stop" if q.at_stop else " over time"
    fig.suptitle(f"{q.long_name}{where}: density and exceedance from the run's histograms",
                 fontsize=10)
    return fig
