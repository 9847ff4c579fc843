"""The paper's figures: analytic curves with simulated points, densities against histograms.

Every function returns a :class:`matplotlib.figure.Figure` (drawn with the Agg canvas, never
through pyplot's global state, so it works without a display and in threads);
:func:`write_figures` writes them all as PNG. Figures are in the paper's scaled units (eq3,
eq8): a physical scene's statistics are converted (it needs mu > 0 and h > 0).

Needs the ``plots`` extra: ``pip install crandall[plots]`` (matplotlib).
"""

from __future__ import annotations

import math
import os
from typing import Dict, List, Optional, Sequence

import numpy as np
from scipy.stats import beta

from . import analytic, distributions
from .engine import velocity_samples
from .paper import CURVES, Curve, curve, scaled_factors
from .quantities import quantity
from .model import ANALYTIC, holds
from .results import Result
from .spec import MAX_SEED, check_int

__all__ = [
    "distance_mean",
    "velocity_var",
    "displacement_var",
    "distance_var",
    "velocity_density",
    "stop_time_density",
    "distribution",
    "STOP_DISTRIBUTIONS",
    "figures",
    "write_figures",
]

#: Error bars are this many standard errors (a 95 % interval).
Z95 = 1.96
_SIM = dict(fmt="o", ms=4, color="C3", ecolor="C3", capsize=3, zorder=3)
_CURVE = dict(color="C0", lw=1.6, zorder=2)


def _figure(width: float = 6.4, height: float = 4.4):
    try:
        from matplotlib.figure import Figure
    except ImportError:  # pragma: no cover - depends on the environment
        raise ImportError("figures need matplotlib: pip install 'crandall[plots]'") from None
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    fig = Figure(figsize=(width, height), dpi=110, layout="constrained")
    FigureCanvasAgg(fig)
    return fig


def _curve_grid(tau, tau0):
    top = float(np.max(tau)) if np.size(tau) else 1.0
    if math.isfinite(tau0):
        top = max(top, tau0)
    top *= 1.04
    if not (math.isfinite(tau0) and 0.0 < tau0 < top):
        return np.linspace(0.0, top, 400)
    # After the switch-off the variances of displacement and distance cost 10-25 ms a point
    # (quadratures, docs/analytic.md) and the curves are smooth there: fewer points.
    return np.concatenate([np.linspace(0.0, tau0, 360), np.linspace(tau0, top, 41)[1:]])


def _switch_off_line(ax, tau0, right):
    if math.isfinite(tau0) and tau0 <= right:
        ax.axvline(tau0, color="0.6", ls=":", lw=1)
        ax.annotate(r"switch-off $\tau_0$", (tau0, 1.0), xycoords=("data", "axes fraction"),
                    xytext=(3, -12), textcoords="offset points", fontsize=8, color="0.4")


def _moment_figure(result: Result, c: Curve):
    if not isinstance(result, Result):
        raise ValueError(f"result must be a crandall.Result, got {type(result).__name__}")
    if c.quantity not in result.names:
        raise ValueError(f"result: {c.quantity!r} was not observed in this scene")
    tau, tau0, *_ = scaled_factors(result)
    sim, se = c.simulated_scaled(result)
    fig = _figure()
    ax = fig.add_subplot()
    grid = _curve_grid(tau, tau0)
    ax.plot(grid, c.analytic(grid, tau0), label="analytic", **_CURVE)
    ax.errorbar(tau, sim, yerr=Z95 * se, label=f"simulated, ±{Z95} stderr ({result.paths:,} paths)",
                **_SIM)
    right = max(grid[-1], float(np.max(tau)) if np.size(tau) else 0.0)
    _switch_off_line(ax, tau0, right)
    ax.set_xlim(0, right * 1.02)
    ax.set_ylim(bottom=0)
    ax.set_xlabel(r"scaled time $\tau$")
    ax.set_ylabel(c.ylabel)
    where = "" if result.scene.units == "scaled" else " (SI scene in scaled units, eq8)"
    ax.set_title(c.title + where, fontsize=10)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8, loc="best")
    return fig


def distance_mean(result: Result):
    """Figure 2 of the paper: the mean scaled distance E U3(tau), eq10r, with the simulation.

    Parameters
    ----------
    result : Result
        A run observing the distance (scaled, or physical with mu > 0 and h > 0).

    Returns
    -------
    matplotlib.figure.Figure
    """
    return _moment_figure(result, curve("distance_mean"))


def velocity_var(result: Result):
    """Figure 3: the variance of the scaled velocity Var U1(tau), eq10s, with the simulation.

    Parameters
    ----------
    result : Result
        A run observing the velocity.

    Returns
    -------
    matplotlib.figure.Figure
    """
    return _moment_figure(result, curve("velocity_var"))


def displacement_var(result: Result):
    """Figure 4: the variance of the scaled displacement Var U2(tau), eq10t, with the simulation.

    The analytic curve is drawn while the noise is on (tau <= tau0), where it is known in
    closed form; simulated points are drawn at every output time.

    Parameters
    ----------
    result : Result
        A run observing the displacement.

    Returns
    -------
    matplotlib.figure.Figure
    """
    return _moment_figure(result, curve("displacement_var"))


def distance_var(result: Result):
    """Figure 5: the variance of the scaled distance Var U3(tau), eq10u (corrected).

    The analytic curve is drawn while the noise is on (tau <= tau0).

    Parameters
    ----------
    result : Result
        A run observing the distance.

    Returns
    -------
    matplotlib.figure.Figure
    """
    return _moment_figure(result, curve("distance_var"))


def _check_samples(paths, seed):
    return check_int("paths", paths, 100), check_int("seed", seed, 0, MAX_SEED)


def velocity_density(times: Sequence[float] = (0.25, 1.0, 5.0), *, paths: int = 200_000,
                     seed: int = 0):
    """The density of the scaled velocity U1(tau) at a few times against histograms.

    The analytic density is the paper's f(y, tau) (:func:`crandall.analytic.velocity_pdf`,
    noise on, from rest); the histograms are of ``paths`` samples of U1(tau), each drawn by one
    exact step from 0 to tau (exact in law).

    Parameters
    ----------
    times : sequence of float
        Scaled times tau > 0 (at most 6).
    paths : int
        Samples per time, >= 100.
    seed : int
        Seed of the samples.

    Returns
    -------
    matplotlib.figure.Figure
    """
    paths, seed = _check_samples(paths, seed)
    try:
        taus = [float(t) for t in times]
    except (TypeError, ValueError):
        raise ValueError(f"times must be a sequence of numbers, got {times!r}") from None
    if not taus or len(taus) > 6 or not all(math.isfinite(t) and t > 0 for t in taus):
        raise ValueError(f"times must hold 1 to 6 finite scaled times > 0, got {times!r}")
    fig = _figure(width=3.2 * len(taus) + 0.6, height=3.8)
    axes = fig.subplots(1, len(taus), squeeze=False)[0]
    for i, (ax, tau) in enumerate(zip(axes, taus)):
        y = velocity_samples(tau, paths, seed + i)
        # Four standard deviations: all but the far tail (Var U1 <= 1/2 at every tau).
        half = max(4.0 * math.sqrt(float(analytic.velocity_var(tau))), 0.05)
        ax.hist(y, bins=np.linspace(-half, half, 61), density=True, histtype="stepfilled",
                color="C1", alpha=0.35, label=f"{paths:,} samples")
        grid = np.linspace(-half, half, 801)
        ax.plot(grid, analytic.velocity_pdf(grid, tau), label="analytic f(y, τ)", **_CURVE)
        ax.set_xlim(-half, half)
        ax.set_title(rf"$\tau$ = {tau:g}", fontsize=10)
        ax.set_xlabel(r"scaled velocity $U_1$")
        ax.grid(alpha=0.3)
    axes[0].set_ylabel("density")
    axes[0].legend(fontsize=7, loc="upper left")
    fig.suptitle("Density of the scaled velocity from rest (noise on)", fontsize=10)
    return fig


def stop_time_density(tau0: float = 5.0, *, paths: int = 200_000, seed: int = 0):
    """The density of the stop time tau_s = tau0 + |U1(tau0)|/2 (eq14) against a histogram.

    Parameters
    ----------
    tau0 : float
        Scaled switch-off time, finite and > 0.
    paths : int
        Samples, >= 100; each U1(tau0) drawn by one exact step from rest.
    seed : int
        Seed of the samples.

    Returns
    -------
    matplotlib.figure.Figure
    """
    paths, seed = _check_samples(paths, seed)
    if isinstance(tau0, bool) or not isinstance(tau0, (int, float, np.integer, np.floating)) \
            or not math.isfinite(tau0) or tau0 <= 0:
        raise ValueError(f"tau0 must be finite and > 0, got {tau0!r}")
    tau0 = float(tau0)
    stops = tau0 + np.abs(velocity_samples(tau0, paths, seed)) / 2
    mean, sd = float(analytic.stop_time_mean(tau0)), math.sqrt(float(analytic.stop_time_var(tau0)))
    right = mean + 5 * sd
    fig = _figure()
    ax = fig.add_subplot()
    ax.hist(stops, bins=np.linspace(tau0, right, 61), density=True, histtype="stepfilled",
            alpha=0.3, color="C1", label=f"{paths:,} samples")
    grid = np.linspace(tau0, right, 600)
    ax.plot(grid, analytic.stop_time_pdf(grid, tau0), color="C0", lw=1.6,
            label="analytic (eq14)")
    ax.axvline(mean, color="0.4", ls="--", lw=1, label=rf"mean {mean:.4g}")
    ax.set_xlim(tau0 - 0.05 * (right - tau0), right)
    ax.set_xlabel(r"scaled stop time $\tau_s$")
    ax.set_ylabel("density")
    ax.set_title(rf"Density of the stop time, $\tau_0$ = {tau0:g}", fontsize=10)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    return fig


#: The stop quantities whose distributions ``crandall run`` draws (and prints the quantiles
#: of) when the run holds them: the file stem of each figure is ``NAME_distribution``.
STOP_DISTRIBUTIONS = ("stop_time", "displacement_at_stop", "distance_at_stop",
                      "dissipated_energy_at_stop")


def _binned(result: Result, name: str, time):
    """Edges, counts per bin, flows and total of the run's histogram of ``name``."""
    h = result.histogram(name, time)
    edges = np.asarray(h.axes[0].edges, dtype=float)
    cells = np.asarray(h.view(flow=True), dtype=float)
    return edges, cells[1:-1], cells[0], cells[-1], float(cells.sum())


def _shown_range(counts):
    """The bins from the first to the last non-empty one (the automatic edges reach 50
    scales; the figure shows where the paths are)."""
    filled = np.flatnonzero(counts)
    if not filled.size:
        return 0, len(counts)
    return int(filled[0]), int(filled[-1]) + 1


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
        raise ValueError(f"result must be a crandall.Result, got {type(result).__name__}")
    q = quantity(name) if name in result.names else None
    if q is None or name not in result.distributions:
        raise ValueError(f"name: the result holds no distribution of {name!r}")
    if q.at_stop:
        if times is not None:
            raise ValueError(f"times: {name} is at the stop; give no times")
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


def figures(result: Result, *, paths: int = 200_000) -> Dict[str, object]:
    """Every figure that suits a result, by file stem.

    Figures 2-5 for the observed quantities; the velocity density at up to three of the
    scene's output times while the noise is on (or 0.25, 1, 5 if none); the stop-time density
    when the scene stops. When the run holds the distributions (``Scene(distributions=...)``)
    the densities are its own histograms, with their exceedance curves (:func:`distribution`),
    and so are those of the stop quantities of ``STOP_DISTRIBUTIONS`` it holds
    (``NAME_distribution``); otherwise the densities use ``paths`` samples of a separate
    sampler seeded by the result's seed.

    Parameters
    ----------
    result : Result
        Scaled, or physical with mu > 0 and h > 0.
    paths : int
        Samples per density.

    Returns
    -------
    dict of str to matplotlib.figure.Figure
        Keys among ``fig2_distance_mean``, ``fig3_velocity_var``, ``fig4_displacement_var``,
        ``fig5_distance_var``, ``velocity_density``, ``stop_time_density``, and
        ``NAME_distribution`` for the stop quantities.
    """
    tau, tau0, *_ = scaled_factors(result)  # raises ValueError for scenes without scaled units
    names = result.names
    out = {c.figure: _moment_figure(result, c) for c in CURVES if c.quantity in names}
    seed = result.seed
    on = sorted({float(t) for t in np.atleast_1d(tau) if 0 < t <= tau0})
    if len(on) > 3:
        # The first, the last and the one nearest their geometric mean: the law changes fast at
        # first and is nearly stationary after tau ~ 2.
        mid = min(on[1:-1], key=lambda t: abs(math.log(t / math.sqrt(on[0] * on[-1]))))
        on = [on[0], mid, on[-1]]
    held = result.distributions
    if "velocity" in held and on:
        # The run's own histograms at those times (the scene's times, in its units).
        shown = [float(t) for t, s in zip(result.times, np.atleast_1d(tau)) if float(s) in on]
        out["velocity_density"] = distribution(result, "velocity", shown)
    else:
        out["velocity_density"] = velocity_density(on or (0.25, 1.0, 5.0), paths=paths,
                                                   seed=seed)
    if "stop" in result.scene.observe and tau0 > 0:
        if "stop_time" in held:
            out["stop_time_density"] = distribution(result, "stop_time")
        else:
            out["stop_time_density"] = stop_time_density(tau0, paths=paths, seed=seed)
    for name in STOP_DISTRIBUTIONS[1:]:
        if name in held:
            out[f"{name}_distribution"] = distribution(result, name)
    return out


def write_figures(result: Result, folder, *, paths: int = 200_000) -> List[str]:
    """Write :func:`figures` as PNG files into ``folder`` (created if missing).

    Parameters
    ----------
    result : Result
        Scaled, or physical with mu > 0 and h > 0.
    folder : str or os.PathLike
        Output folder; files are named after the keys of :func:`figures` (``*.png``).
    paths : int
        Samples per density.

    Returns
    -------
    list of str
        The files written.
    """
    os.makedirs(folder, exist_ok=True)
    written = []
    for stem, fig in figures(result, paths=paths).items():
        path = os.path.join(folder, stem + ".png")
        fig.savefig(path)
        written.append(path)
    return written
