"""The moment figures: a mean or variance against time, simulated with its error bars beside
the paper's curve and the residuals where the closed forms hold."""

from __future__ import annotations

import math

import numpy as np

from .. import paper
from ..paper import Curve, curve, scaled_factors
from ..quantities import quantity
from ..results import MIN_CARRIERS, Result
from ..errors import ParameterError
from .common import (Z95, _CURVE, _FEW, _SIM, _axes_converter, _check_units, _curve_grid, _figure,
                     _has_closed_forms, _schedule_strip, _switch_off_line)


def _moment_figure(result: Result, c: Curve, units: str = "scene"):
    if not isinstance(result, Result):
        raise ParameterError("result", "result must be a crandall.Result, got "
                                       f"{type(result).__name__}")
    if c.quantity not in result.names:
        raise ParameterError("result", f"result: {c.quantity!r} was not observed in this scene")
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
