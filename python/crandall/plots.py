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

from . import analytic
from .engine import velocity_samples
from .paper import CURVES, Curve, curve, scaled_factors
from .results import Result
from .spec import MAX_SEED, check_int

__all__ = [
    "distance_mean",
    "velocity_var",
    "displacement_var",
    "distance_var",
    "velocity_density",
    "stop_time_density",
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


def figures(result: Result, *, paths: int = 200_000) -> Dict[str, object]:
    """Every figure that suits a result, by file stem.

    Figures 2-5 for the observed quantities; the velocity density at up to three of the
    scene's output times while the noise is on (or 0.25, 1, 5 if none); the stop-time density
    when the scene stops. Densities use ``paths`` samples seeded by the result's seed.

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
        ``fig5_distance_var``, ``velocity_density``, ``stop_time_density``.
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
    out["velocity_density"] = velocity_density(on or (0.25, 1.0, 5.0), paths=paths, seed=seed)
    if "stop" in result.scene.observe and tau0 > 0:
        out["stop_time_density"] = stop_time_density(tau0, paths=paths, seed=seed)
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
