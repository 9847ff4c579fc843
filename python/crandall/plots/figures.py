"""A run's whole set of figures (:func:`figures`) and their files (:func:`write_figures`)."""

from __future__ import annotations

import math
import os
from typing import Dict, List

import numpy as np

from .._files import write_atomic
from ..paper import CURVES, scaled_factors
from ..results import Result
from ..spec import check_int
from ..errors import ParameterError
from .common import FORMATS, _check_units, _has_closed_forms
from .histograms import STOP_DISTRIBUTIONS, distribution
from .moments import _moment_figure
from .samples import stop_time_density, velocity_density


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
        raise ParameterError("format", f"format must be one of {', '.join(FORMATS)}, got "
                                       f"{format!r}")
    os.makedirs(folder, exist_ok=True)
    written = []
    for stem, fig in figures(result, paths=paths, units=units).items():
        path = os.path.join(folder, f"{stem}.{format}")
        # Replaced atomically, as results and checkpoints are: a full disk leaves no torn
        # figure and its error names the file.
        write_atomic(path, lambda f, fig=fig: fig.savefig(f, dpi=dpi, format=format))
        written.append(path)
    return written
