"""What the figures share: the Agg figure and its PNG bytes, the styles of simulated points
and curves, the units a figure is drawn in, the switch-off line and a schedule's strip."""

from __future__ import annotations

import functools
import io
import math

import numpy as np

from ..model import ANALYTIC, holds
from ..results import Result
from ..errors import ParameterError


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
        raise ParameterError("units", f"units must be one of {', '.join(UNITS)}, got {units!r}")
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
            raise ParameterError("units", "units: this scene has no scaled units (mu = 0, h = 0, "
                                          "or scales beyond doubles); draw it in units='scene'")
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
