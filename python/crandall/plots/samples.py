"""Figures drawn from paths: stored paths, the velocity density against its law and the stop
time's density, from samples the figure simulates itself."""

from __future__ import annotations

import json
import math
from typing import Optional, Sequence

import numpy as np

from .. import analytic
from ..engine import velocity_samples
from ..scene import Scene
from ..spec import MAX_SEED, check_int
from ..units import Scaling
from ..errors import ParameterError
from .common import _CURVE, _figure, _schedule_strip


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
        raise ParameterError("data", "data must be what crandall.paths returns (an xarray.Dataset "
                                     "of velocity, displacement, distance and stop_time)")
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
        raise ParameterError("times", "times must be a sequence of numbers, got "
                                      f"{times!r}") from None
    if not taus or len(taus) > 6 or not all(math.isfinite(t) and t > 0 for t in taus):
        raise ParameterError("times", "times must hold 1 to 6 finite scaled times > 0, got "
                                      f"{times!r}")
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
        raise ParameterError("tau0", f"tau0 must be finite and > 0, got {tau0!r}")
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
