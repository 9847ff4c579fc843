"""The paper's figures: simulated statistics with their error bars, the analytic curves and
the residuals where the paper's closed forms hold, densities against histograms.

Every function returns a :class:`matplotlib.figure.Figure` (drawn with the Agg canvas, never
through pyplot's global state, so it works without a display and in threads);
:func:`write_figures` writes them all (PNG, PDF or SVG). The moment figures are in the scene's
units (s, m, J for an SI scene) or, with ``units="scaled"``, the paper's scaled units (eq3,
eq8); the densities of the paper's scene are in scaled units.

Needs the ``plots`` extra: ``pip install crandall[plots]`` (matplotlib).
"""

from __future__ import annotations

import functools
import io
import json
import math
import os
from typing import Dict, List, Optional, Sequence

import numpy as np
from scipy.stats import beta

from . import analytic, distributions
from ._files import write_atomic
from .engine import velocity_samples
from .fragility import FragilityResult
from . import paper
from .paper import CURVES, Curve, curve, scaled_factors
from .quantities import quantity
from .model import ANALYTIC, holds
from .records import NewmarkResult
from .results import MIN_CARRIERS, Result
from .scene import Scene
from .spec import MAX_SEED, check_int
from .units import Scaling

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
    "paths",
    "newmark",
    "newmark_sweep",
    "fragility",
    "UNITS",
    "FORMATS",
]

#: Error bars are this many standard errors (a 95 % interval).
Z95 = 1.96
_SIM = dict(fmt="o", ms=4, color="C3", ecolor="C3", capsize=3, zorder=3)
_CURVE = dict(color="C0", lw=1.6, zorder=2)
#: A point whose standard error is not estimated because few paths carry it: hollow.
_FEW = dict(ls="none", marker="o", ms=5, mfc="none", mec="C3", mew=1.2, zorder=3)


def _figure(width: float = 6.4, height: float = 4.4):
    try:
        from matplotlib.figure import Figure
    except ImportError:  # pragma: no cover - depends on the environment
        raise ImportError("figures need matplotlib: pip install 'crandall[plots]'") from None
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    fig = Figure(figsize=(width, height), dpi=110, layout="constrained")
    FigureCanvasAgg(fig)
    # The figure is not pyplot's, so no backend registers a display for it and a notebook
    # would print its repr: it shows itself as a picture.
    fig._repr_png_ = functools.partial(_png, fig)
    return fig


def _png(fig) -> bytes:
    buffer = io.BytesIO()
    fig.savefig(buffer, format="png")
    return buffer.getvalue()


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
        ax.annotate("switch-off", (tau0, 1.0), xycoords=("data", "axes fraction"),
                    xytext=(3, -12), textcoords="offset points", fontsize=8, color="0.4")


#: The units a figure is drawn in: the scene's own (s, m, J for an SI scene; scaled for a
#: scaled one), or the paper's scaled units.
UNITS = ("scene", "scaled")
#: Output formats of write_figures.
FORMATS = ("png", "pdf", "svg")


def _check_units(units) -> str:
    if units not in UNITS:
        raise ValueError(f"units must be one of {', '.join(UNITS)}, got {units!r}")
    return units


def _has_closed_forms(result: Result) -> bool:
    """Whether the paper's closed forms describe this result's scene (and its scaled units
    exist)."""
    sc = result.scene
    return holds(sc, ANALYTIC) and (sc.units == "scaled" or sc.scaling is not None)


def _axes_converter(result: Result, units: str):
    """(to_x, to_y, x label, y suffix): scaled tau and a scaled statistic of ``kind ** power``
    to the figure's units, and the labels."""
    sc = result.scene
    s = None if sc.units == "scaled" else sc.scaling
    if units == "scaled" or s is None:
        if units == "scaled" and sc.units == "SI" and s is None:
            raise ValueError("units: this scene has no scaled units (mu = 0, h = 0, or scales "
                             "beyond doubles); draw it in units='scene'")
        return (lambda tau: tau), (lambda v, kind, power: v), r"scaled time $\tau$", ""
    return (s.to_t, lambda v, kind, power: s.to_si(v, kind, power), "time $t$ (s)", "SI")


def _schedule_strip(ax, sc, right: float, to_x) -> None:
    """The intensity over time of a scene, a step plot (a piecewise scene); ``to_x`` takes the
    scene's times to the figure's."""
    pieces = tuple((to_x(e), n) for e, n in (sc.pieces if sc.pieces is not None
                                              else ((sc.t0, sc.noise),)))
    xs, ys, start = [], [], 0.0
    for end, noise in pieces:
        e = min(end, right) if math.isfinite(end) else right
        xs += [start, e]
        ys += [noise, noise]
        start = end
        if start >= right:
            break
    if start < right:
        xs += [start, right]
        ys += [0.0, 0.0]
    ax.fill_between(xs, ys, step=None, color="0.75", lw=0)
    ax.plot(xs, ys, color="0.35", lw=1, label="pieces")
    env = getattr(sc, "envelope", None)
    if env is not None and env.function is not None:  # (read back from a file: pieces only)
        # The smooth envelope the pieces stand for (an SI scene's times).
        t = np.linspace(0.0, env.t0[-1], 400)
        ax.plot([to_x(x) for x in t], [float(env.function(float(x))) for x in t], color="C0",
                lw=1.2, label=f"envelope ({env.kind}, {env.pieces} pieces)")
        ax.legend(fontsize=7, loc="upper right", frameon=False)
    ax.set_ylabel("noise" if sc.units == "scaled" else "h", fontsize=8)
    ax.set_ylim(bottom=0)
    ax.tick_params(labelsize=7, labelbottom=False)


def _moment_figure(result: Result, c: Curve, units: str = "scene"):
    if not isinstance(result, Result):
        raise ValueError(f"result must be a crandall.Result, got {type(result).__name__}")
    if c.quantity not in result.names:
        raise ValueError(f"result: {c.quantity!r} was not observed in this scene")
    _check_units(units)
    sc = result.scene
    kind = quantity(c.quantity).kind
    power = 1 if c.statistic == "mean" else 2
    closed = _has_closed_forms(result)
    with result._table():
        # The figure marks what is not a number (a hollow point, below) instead of warning.
        sim, se = c.simulated(result)
        # The bars: the total error (standard error and bias together) wherever the bias is
        # known (an envelope's pieces, a grid's bias); the standard error where it is not
        # (NaN: euler, refine, peaks) or not estimated yet (Result.bias_pending: a figure
        # never runs paths; the command line estimates it first).
        total = (np.full(np.shape(se), np.nan) if result.bias_pending
                 else np.asarray(result._error(c.quantity, c.statistic, False), dtype=float))
    with_bias = np.isfinite(total) & (total > np.asarray(se, dtype=float))
    bars = np.where(np.isfinite(total), total, np.asarray(se, dtype=float))
    times = np.asarray(result.times, dtype=float)
    if units == "scaled":
        sim, se, bars = (paper.to_scaled(result, x, kind, power) for x in (sim, se, bars))
        times = np.asarray(scaled_factors(result)[0] if closed else (
            times if sc.units == "scaled" else sc.scaling.to_tau(times)), dtype=float)
    to_x, to_y, xlabel, _ = _axes_converter(result, units)
    strip = sc.pieces is not None or sc.envelope is not None
    rows = [1] * strip + [3] + [1] * closed
    fig = _figure(6.4, 4.4 + 0.9 * (len(rows) - 1))
    axes = fig.subplots(len(rows), 1, sharex=True, gridspec_kw={"height_ratios": rows})
    axes = np.atleast_1d(axes)
    ax = axes[1 if strip else 0]
    right = float(np.max(times)) if times.size else 1.0
    if closed:
        tau, tau0, *_ = scaled_factors(result)
        grid = _curve_grid(tau, tau0)
        ax.plot(to_x(grid), to_y(c.analytic(grid, tau0), kind, power), label="analytic",
                **_CURVE)
        right = max(right, float(to_x(grid[-1])))
        _switch_off_line(ax, to_x(tau0), right)
    elif math.isfinite(sc.t0):
        t0 = sc.t0 if units == "scene" or sc.units == "scaled" else sc.scaling.to_tau(sc.t0)
        _switch_off_line(ax, t0, right)
    # Points whose standard error few paths would decide (Result.carriers) have none: drawn
    # hollow, without a bar, and left out of the residuals.
    few = np.asarray(result._few(c.quantity, c.statistic), dtype=bool)
    sim, se = np.asarray(sim, dtype=float), np.asarray(se, dtype=float)
    what = "total error (stderr and bias)" if with_bias.any() else "stderr"
    ax.errorbar(times[~few], sim[~few], yerr=Z95 * np.asarray(bars, dtype=float)[~few],
                label=f"simulated, ±{Z95} {what} ({result.paths:,} paths)", **_SIM)
    if few.any():
        ax.plot(times[few], sim[few], **_FEW,
                label=f"few paths carry this (< {MIN_CARRIERS}): no error bar")
    ax.set_xlim(0, right * 1.02)
    ax.set_ylim(bottom=0)
    unit = "" if (units == "scaled" or sc.units == "scaled") else sc.units_of(c.quantity)
    name = ("mean " if c.statistic == "mean" else "variance of ") + c.quantity
    scaled = units == "scaled" or sc.units == "scaled"
    ax.set_ylabel(c.ylabel if scaled
                  else f"{name} (({unit})$^2$)" if power == 2 else f"{name} ({unit})")
    title = c.title if scaled else f"{name[0].upper()}{name[1:]}"
    ax.set_title(title + ("" if closed else " (no closed form for this scene)"), fontsize=10)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8, loc="best")
    if strip:
        scene_to_x = (sc.scaling.to_tau if units == "scaled" and sc.units == "SI"
                      else (lambda t: t))
        _schedule_strip(axes[0], result.scene, right * 1.02, scene_to_x)
    if closed:
        # The residual: z = (simulated - analytic) / stderr at each output time, with the
        # +-2 band a correct error bar keeps about 95 % of the points in.
        tau, tau0, *_ = scaled_factors(result)
        ref = to_y(np.asarray(c.analytic(tau, tau0), dtype=float), kind, power)
        with np.errstate(divide="ignore", invalid="ignore"):
            z = np.where(few, np.nan, (sim - ref) / se)
        rax = axes[-1]
        rax.axhline(0, color="0.5", lw=0.8)
        for y in (-2, 2):
            rax.axhline(y, color="0.6", ls="--", lw=0.8)
        rax.plot(times, z, "o", ms=3, color="C3")
        for t in times[few]:
            # No z where there is no error to divide by: a mark at the time, not a point.
            rax.axvline(t, color="0.45", ls=":", lw=0.8)
            rax.annotate("no z", (t, 1.0), xycoords=("data", "axes fraction"),
                         xytext=(0, -8), textcoords="offset points", ha="center",
                         fontsize=6, color="0.45")
        rax.set_ylabel("z", fontsize=8)
        finite = np.abs(z[np.isfinite(z)])
        top = max(3.0, float(finite.max()) * 1.15) if finite.size else 3.0
        rax.set_ylim(-top, top)
        rax.grid(alpha=0.3)
        rax.set_xlabel(xlabel)
    else:
        ax.set_xlabel(xlabel)
    return fig


def distance_mean(result: Result, units: str = "scene"):
    """Figure 2 of the paper: the mean scaled distance E U3(tau), eq10r, with the simulation.

    Parameters
    ----------
    result : Result
        A run observing the distance (scaled, or physical with mu > 0 and h > 0).

    Returns
    -------
    matplotlib.figure.Figure
    """
    return _moment_figure(result, curve("distance_mean"), units)


def velocity_var(result: Result, units: str = "scene"):
    """Figure 3: the variance of the scaled velocity Var U1(tau), eq10s, with the simulation.

    Parameters
    ----------
    result : Result
        A run observing the velocity.

    Returns
    -------
    matplotlib.figure.Figure
    """
    return _moment_figure(result, curve("velocity_var"), units)


def displacement_var(result: Result, units: str = "scene"):
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
    return _moment_figure(result, curve("displacement_var"), units)


def distance_var(result: Result, units: str = "scene"):
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
    return _moment_figure(result, curve("distance_var"), units)


def paths(data):
    """Sample paths (:func:`crandall.paths`) against time: velocity, displacement and
    distance, one thin line per path, each path's stop marked; for a piecewise scene (pauses,
    an envelope's pieces) the intensity above.

    Parameters
    ----------
    data : xarray.Dataset
        What :func:`crandall.paths` returns.

    Returns
    -------
    matplotlib.figure.Figure
    """
    needed = ("velocity", "displacement", "distance", "stop_time")
    if not all(hasattr(data, "data_vars") and k in data.data_vars for k in needed) \
            or "scene" not in getattr(data, "attrs", {}):
        raise ValueError("data must be what crandall.paths returns (an xarray.Dataset of "
                         "velocity, displacement, distance and stop_time)")
    sc = Scene.from_dict(json.loads(data.attrs["scene"]))
    t = np.asarray(data["time"].values, dtype=float)
    strip = int(sc.pieces is not None or sc.envelope is not None)
    rows = [1] * strip + [2, 2, 2]
    fig = _figure(width=6.4, height=1.3 * strip + 5.6)
    axes = fig.subplots(len(rows), 1, sharex=True, gridspec_kw={"height_ratios": rows})
    stops = np.asarray(data["stop_time"].values, dtype=float)
    time_label = "time (s)" if sc.units == "SI" else r"scaled time $\tau$"
    for ax, name in zip(axes[strip:], needed[:3]):
        values = np.asarray(data[name].values, dtype=float)
        for i, row in enumerate(values):
            line, = ax.plot(t, row, lw=0.8, alpha=0.8)
            if np.isfinite(stops[i]) and t[0] <= stops[i] <= t[-1]:
                ax.plot([stops[i]], [np.interp(stops[i], t, row)], "o", ms=3,
                        color=line.get_color())
        unit = data[name].attrs.get("units", "1")
        ax.set_ylabel(name + ("" if unit == "1" else f" ({unit})"), fontsize=8)
        ax.grid(alpha=0.3)
    if strip:
        _schedule_strip(axes[0], sc, float(t[-1]), lambda x: x)
    axes[-1].set_xlabel(time_label)
    axes[strip].set_title(f"{values.shape[0]} sample paths (dots: the stops), seed "
                          f"{data.attrs.get('seed', '?')}", fontsize=10)
    return fig


def _check_samples(paths, seed):
    return check_int("paths", paths, 100), check_int("seed", seed, 0, MAX_SEED)


def velocity_density(times: Sequence[float] = (0.25, 1.0, 5.0), *, paths: int = 200_000,
                     seed: int = 0, scaling: Optional[Scaling] = None):
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
    scaling : crandall.Scaling, optional
        An SI scene's scales: the panels are then drawn in m/s and s (the same samples and
        curves, converted).

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
    v = 1.0 if scaling is None else scaling.scale("velocity")
    for i, (ax, tau) in enumerate(zip(axes, taus)):
        y = velocity_samples(tau, paths, seed + i)
        # Four standard deviations: all but the far tail (Var U1 <= 1/2 at every tau).
        half = max(4.0 * math.sqrt(float(analytic.velocity_var(tau))), 0.05)
        ax.hist(y * v, bins=np.linspace(-half, half, 61) * v, density=True,
                histtype="stepfilled", color="C1", alpha=0.35, label=f"{paths:,} samples")
        grid = np.linspace(-half, half, 801)
        ax.plot(grid * v, analytic.velocity_pdf(grid, tau) / v, label="analytic", **_CURVE)
        ax.set_xlim(-half * v, half * v)
        if scaling is None:
            ax.set_title(rf"$\tau$ = {tau:g}", fontsize=10)
            ax.set_xlabel(r"scaled velocity $U_1$")
        else:
            ax.set_title(f"t = {scaling.to_si(tau, 'time'):.4g} s", fontsize=10)
            ax.set_xlabel("velocity [m/s]")
        ax.grid(alpha=0.3)
    axes[0].set_ylabel("density" + ("" if scaling is None else " [s/m]"))
    axes[0].legend(fontsize=7, loc="upper left")
    fig.suptitle(f"Density of the {'scaled ' if scaling is None else ''}velocity from rest "
                 "(noise on)", fontsize=10)
    return fig


def stop_time_density(tau0: float = 5.0, *, paths: int = 200_000, seed: int = 0,
                      scaling: Optional[Scaling] = None):
    """The density of the stop time tau_s = tau0 + |U1(tau0)|/2 (eq14) against a histogram.

    Parameters
    ----------
    tau0 : float
        Scaled switch-off time, finite and > 0.
    paths : int
        Samples, >= 100; each U1(tau0) drawn by one exact step from rest.
    seed : int
        Seed of the samples.
    scaling : crandall.Scaling, optional
        An SI scene's scales: the panel is then drawn in seconds.

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
    t = 1.0 if scaling is None else scaling.scale("time")
    fig = _figure()
    ax = fig.add_subplot()
    ax.hist(stops * t, bins=np.linspace(tau0, right, 61) * t, density=True,
            histtype="stepfilled", alpha=0.3, color="C1", label=f"{paths:,} samples")
    grid = np.linspace(tau0, right, 600)
    ax.plot(grid * t, analytic.stop_time_pdf(grid, tau0) / t, color="C0", lw=1.6,
            label="analytic (eq14)")
    ax.axvline(mean * t, color="0.4", ls="--", lw=1, label=rf"mean {mean * t:.4g}")
    ax.set_xlim((tau0 - 0.05 * (right - tau0)) * t, right * t)
    if scaling is None:
        ax.set_xlabel(r"scaled stop time $\tau_s$")
        ax.set_ylabel("density")
        ax.set_title(rf"Density of the stop time, $\tau_0$ = {tau0:g}", fontsize=10)
    else:
        ax.set_xlabel("stop time [s]")
        ax.set_ylabel("density [1/s]")
        ax.set_title(f"Density of the stop time, t0 = {tau0 * t:.4g} s", fontsize=10)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    return fig


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


def figures(result: Result, *, paths: int = 200_000, units: str = "scene") -> Dict[str, object]:
    """Every figure that suits a result, by file stem.

    Figures 2-5 for the observed quantities, in the scene's units (``units="scene"``: seconds,
    metres and joules for an SI scene) or the paper's scaled units (``units="scaled"``), with
    the analytic curve and a residual panel (z of the simulated points against it) where the
    paper's closed forms hold for the scene, and the intensity over time above them for a
    piecewise scene. A point whose standard error fewer than ``crandall.results.MIN_CARRIERS``
    paths would decide (:meth:`crandall.Result.carriers`: the velocity's variance long after the
    switch-off, when almost every path is at rest) is drawn hollow, without an error bar, and
    has no residual ("no z"). Where the closed forms hold, also the velocity density at up to three of
    the scene's output times while the noise is on (or 0.25, 1, 5 if none) and the stop-time
    density (scaled units): from the run's own histograms when it holds the distributions
    (``Scene(distributions=...)``, with their exceedance curves, :func:`distribution`),
    otherwise from ``paths`` samples of a separate sampler seeded by the result's seed. The
    stop quantities of ``STOP_DISTRIBUTIONS`` whose distributions the run holds
    (``NAME_distribution``), for any scene.

    Parameters
    ----------
    result : Result
        Any result (a run to an accuracy too).
    paths : int
        Samples per density.
    units : str
        "scene" (default) or "scaled" (needs mu > 0 and h > 0 in an SI scene).

    Returns
    -------
    dict of str to matplotlib.figure.Figure
        Keys among ``fig2_distance_mean``, ``fig3_velocity_var``, ``fig4_displacement_var``,
        ``fig5_distance_var``, ``velocity_density``, ``stop_time_density``, and
        ``NAME_distribution`` for the stop quantities.
    """
    _check_units(units)
    names = result.names
    out = {c.figure: _moment_figure(result, c, units) for c in CURVES if c.quantity in names}
    held = result.distributions
    if _has_closed_forms(result):
        tau, tau0, *_ = scaled_factors(result)
        seed = result.seed
        # An SI scene's panels in seconds and metres unless scaled units are asked for.
        si = (result.scene.scaling if units == "scene" and result.scene.units == "SI"
              else None)
        on = sorted({float(t) for t in np.atleast_1d(tau) if 0 < t <= tau0})
        if len(on) > 3:
            # The first, the last and the one nearest their geometric mean: the law changes
            # fast at first and is nearly stationary after tau ~ 2.
            mid = min(on[1:-1], key=lambda t: abs(math.log(t / math.sqrt(on[0] * on[-1]))))
            on = [on[0], mid, on[-1]]
        if "velocity" in held and on:
            # The run's own histograms at those times (the scene's times, in its units).
            shown = [float(t) for t, s in zip(result.times, np.atleast_1d(tau)) if float(s) in on]
            out["velocity_density"] = distribution(result, "velocity", shown)
        else:
            out["velocity_density"] = velocity_density(on or (0.25, 1.0, 5.0), paths=paths,
                                                       seed=seed, scaling=si)
        if "stop" in result.scene.observe and tau0 > 0:
            if "stop_time" in held:
                out["stop_time_density"] = distribution(result, "stop_time")
            else:
                out["stop_time_density"] = stop_time_density(tau0, paths=paths, seed=seed,
                                                             scaling=si)
    elif "stop_time" in held:
        out["stop_time_density"] = distribution(result, "stop_time")
    for name in STOP_DISTRIBUTIONS[1:]:
        if name in held:
            out[f"{name}_distribution"] = distribution(result, name)
    return out


def write_figures(result: Result, folder, *, paths: int = 200_000, units: str = "scene",
                  dpi: int = 150, format: str = "png") -> List[str]:
    """Write :func:`figures` into ``folder`` (created if missing).

    Parameters
    ----------
    result : Result
        Any result.
    folder : str or os.PathLike
        Output folder; files are named after the keys of :func:`figures`.
    paths : int
        Samples per density.
    units : str
        "scene" or "scaled", as :func:`figures`.
    dpi : int
        Resolution of raster figures (png), 50 to 1200.
    format : str
        One of ``FORMATS``: "png", "pdf" or "svg".

    Returns
    -------
    list of str
        The files written.
    """
    dpi = check_int("dpi", dpi, 50, 1200)
    if format not in FORMATS:
        raise ValueError(f"format must be one of {', '.join(FORMATS)}, got {format!r}")
    os.makedirs(folder, exist_ok=True)
    written = []
    for stem, fig in figures(result, paths=paths, units=units).items():
        path = os.path.join(folder, f"{stem}.{format}")
        # Replaced atomically, as results and checkpoints are: a full disk leaves no torn
        # figure and its error names the file.
        write_atomic(path, lambda f, fig=fig: fig.savefig(f, dpi=dpi, format=format))
        written.append(path)
    return written


def newmark(result: NewmarkResult):
    """A Newmark block on one record, as pySLAMMER draws it: the ground acceleration (g) with
    the yields, the sliding velocity (m/s) and the sliding displacement (m) against time, the
    slides shaded; the title names the record, the yields, the PGA and the method.

    Parameters
    ----------
    result : NewmarkResult
        One case of :func:`crandall.newmark` (one record, one yield, one polarity).

    Returns
    -------
    matplotlib.figure.Figure
    """
    if not isinstance(result, NewmarkResult) or result.dims:
        raise ValueError("result must be one case of crandall.newmark (one record, one yield "
                         "and one polarity); a sweep keeps no histories: plots.newmark_sweep")
    t = result.time
    fig = _figure(width=7.0, height=6.2)
    axes = fig.subplots(3, 1, sharex=True)
    rec = result.records[0]
    axes[0].plot(t, result.acceleration, color="C0", lw=0.6, label="ground acceleration")
    ys = result.yields
    if result.mode == "one-way":
        levels = [(ys["ky"][0], "ky")]
    elif result.mode == "flat":
        levels = [(ys["mu_static"][0], "mu_static"), (-ys["mu_static"][0], None)]
    else:
        levels = [(ys["kd"][0], "kd"), (-ys["ku"][0], "-ku")]
    for value, label in levels:
        if math.isfinite(value):
            axes[0].axhline(value, color="k", lw=0.8, ls="--", label=label)
    axes[0].set_ylabel("acceleration (g)")
    axes[0].legend(loc="upper right", fontsize=8)
    axes[1].plot(t, result.velocity, color="k", lw=0.9)
    axes[1].set_ylabel("sliding velocity (m/s)")
    axes[2].plot(t, result.sliding_displacement, color="k", lw=1.2)
    axes[2].set_ylabel("sliding displacement (m)")
    axes[2].set_xlabel("time (s)")
    for onset, stop, _, _ in result.events:
        for ax in axes[1:]:
            ax.axvspan(onset, stop, color="C1", alpha=0.15, lw=0)
    for ax in axes:
        ax.grid(alpha=0.3)
    axes[0].set_xlim(t[0], t[-1])
    sense = "downslope" if result.mode != "flat" else "relative to the foundation"
    fig.suptitle(f"{rec['name']}: {result.label}, PGA {rec['pga']:.3g} g, "
                 f"{result.polarities[0]} polarity\n{result.method} method: {sense} "
                 f"{result.displacement:.4g} m, {result.slips} slides", fontsize=10)
    return fig


def newmark_sweep(result: NewmarkResult):
    """A sweep of one-way or incline yields: the displacement at the record's end against the
    yield (log scale), a line per record (and polarity: normal solid, inverse dashed).

    Parameters
    ----------
    result : NewmarkResult
        :func:`crandall.newmark` with an array of yields.

    Returns
    -------
    matplotlib.figure.Figure
    """
    if not isinstance(result, NewmarkResult) or "yield" not in result.dims:
        raise ValueError("result must be a sweep of crandall.newmark over an array of yields")
    name = {"one-way": "ky", "flat": "mu", "incline": "kd"}[result.mode]
    x = result.yields[name]
    fig = _figure(width=7.0, height=4.8)
    ax = fig.subplots()
    for i, rec in enumerate(result.records):
        for p, pol in enumerate(result.polarities):
            y = np.abs(result.table[i, :, p, 0])
            ok = y > 0
            ax.plot(x[ok], y[ok], ls="-" if pol == "normal" else "--", lw=1.0,
                    color=f"C{i % 10}", label=rec["name"] if p == 0 else None)
    ax.set_yscale("log")
    ax.set_xlabel(f"{name} (g)")
    ax.set_ylabel("|displacement| at the record's end (m)")
    ax.grid(alpha=0.3, which="both")
    if len(result.records) <= 20:
        ax.legend(fontsize=6, ncol=2, loc="lower left")
    ax.set_title(f"{result.method} method, {len(result.records)} records x {x.size} yields x "
                 f"{len(result.polarities)} polarities (solid normal, dashed inverse)",
                 fontsize=9)
    return fig


_MARKERS = "osD^v<>p"


def _fragility_curves(ax, result: FragilityResult, *, records: bool = False) -> None:
    """Draw ``result``'s curves on ``ax``: per threshold (and value of ``by``) its estimates
    with their 95 % band (log probability; unreliable points hollow) and its lognormal fit
    dashed. One axis: a colour per threshold; two: a colour per value of ``by``, a marker per
    threshold. A record suite (``records``): squares on dotted lines, a lighter band,
    labels that say so (the colours match the stochastic curves' thresholds)."""
    sections = result.sections()
    fits = result.fit_lognormal()
    fits = fits if result.by is not None else [fits]
    unit = f" {result.units}" if result.units else ""
    for j, (sec, fit) in enumerate(zip(sections, fits)):
        x = sec.values
        fine = np.geomspace(x[0], x[-1], 200)
        at = "" if result.by is None else f"{result._by_label} = {result.by_values[j]:.3g}, "
        for k, d in enumerate(sec.thresholds):
            color = f"C{(j if result.by is not None else k) % 10}"
            marker = "s" if records else (_MARKERS[k % len(_MARKERS)] if result.by else "o")
            p = sec.probability[:, k]
            ok = sec.reliable[:, k] & (p > 0)
            ax.fill_between(x, np.maximum(sec.low[:, k], 1e-300), sec.high[:, k], color=color,
                            alpha=0.1 if records else 0.2, lw=0,
                            hatch="//" if records else None)
            name = f"{'records: ' if records else ''}{at}> {d:.3g}{unit}"
            ax.plot(x[ok], p[ok], marker=marker, ls=":" if records else "-", color=color,
                    ms=4, mfc="none" if records else color, label=name)
            bad = ~sec.reliable[:, k] & (p > 0)
            if bad.any():
                ax.plot(x[bad], p[bad], ls="none", marker=marker, ms=5, mfc="none", mec=color)
            if np.isfinite(fit.median[k]):
                ax.plot(fine, fit.probability(fine, k), "-." if records else "--", color=color,
                        lw=1.0, label=f"  lognormal: median {fit.median[k]:.3g}, "
                                      f"beta {fit.beta[k]:.2f}")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel(result.axis_label)


def fragility(result: FragilityResult, hazard=None, use: str = "fit",
              records: Optional[FragilityResult] = None):
    """Fragility curves: P(Q > threshold) against the grid's intensity (or mu), a line per
    threshold with its 95 % band (log probability; unreliable points hollow), the lognormal
    fit (:meth:`FragilityResult.fit_lognormal`) dashed; a grid over intensity and mu: a
    colour per mu, a marker per threshold. With ``hazard`` (a hazard curve ``(im, rate)`` of
    the intensity) a second panel: the annual rate of exceeding each threshold
    (:meth:`FragilityResult.hazard`, through the fit or, ``use="estimates"``, the grid's
    estimates) with its 95 % interval.

    ``records``: a record suite's fragility (:func:`crandall.record_fragility`) drawn on the
    same panel, squares on dotted lines, the colour of each threshold as the stochastic
    curves' (of each yield as their mu's over two axes): on the same x axis when both are
    over a friction or yield (mu and ky in g are one number: docs/records.md), else on an x
    axis of its own along the top (the records' PGA against the model's h).

    Returns
    -------
    matplotlib.figure.Figure
    """
    if not isinstance(result, FragilityResult):
        raise ValueError(f"result must be a crandall.FragilityResult, got {type(result).__name__}")
    if records is not None and not isinstance(records, FragilityResult):
        raise ValueError(f"records must be a crandall.RecordFragilityResult, got "
                         f"{type(records).__name__}")
    fig = _figure(width=6.4 if hazard is None else 11.0)
    axes = fig.subplots(1, 1 if hazard is None else 2, squeeze=False)[0]
    ax = axes[0]
    _fragility_curves(ax, result)
    ax.set_ylabel(f"P({result.quantity} > threshold)")
    ax.grid(alpha=0.3, which="both")
    handles, labels = ax.get_legend_handles_labels()
    if records is not None:
        friction = ("mu", "ky", "kd")
        same = result.axis == records.axis or (result.axis in friction
                                               and records.axis in friction)
        rax = ax if same else ax.twiny()
        _fragility_curves(rax, records, records=True)
        if not same:
            rax.set_xlabel(f"records: {records.axis_label}")
            more = rax.get_legend_handles_labels()
            handles, labels = handles + more[0], labels + more[1]
        else:
            ax.set_xlabel(f"{result.axis_label}; records: {records.axis_label}")
            handles, labels = ax.get_legend_handles_labels()
    ax.legend(handles, labels, fontsize=6 if records is not None or result.by else 7)
    if hazard is not None:
        hz = result.hazard(hazard, use=use)
        hz = hz if result.by is not None else [hz]
        ax2 = axes[1]
        for j, h in enumerate(hz):
            ok = np.isfinite(h.rate)
            style = dict(_SIM, color=f"C{j % 10}", ecolor=f"C{j % 10}")
            label = None if result.by is None else f"{result._by_label} = {result.by_values[j]:.3g}"
            ax2.errorbar(h.thresholds[ok], h.rate[ok],
                         yerr=[h.rate[ok] - h.low[ok], h.high[ok] - h.rate[ok]], label=label,
                         **style)
            ax2.plot(h.thresholds[ok], h.rate[ok], **dict(_CURVE, color=f"C{j % 10}"))
        ax2.set_xscale("log")
        ax2.set_yscale("log")
        ax2.set_xlabel(f"threshold{f' [{result.units}]' if result.units else ''}")
        ax2.set_ylabel("annual rate of exceedance"
                       + (" (lognormal fit)" if use == "fit" else " (grid estimates)"))
        ax2.grid(alpha=0.3, which="both")
        if result.by is not None:
            ax2.legend(fontsize=7)
    return fig
