"""The paper's setting (Berezin & Zayats) and the comparison of a result with the analytic layer.

``python -m crandall`` (``make run``) simulates :func:`default_scene` and prints
:func:`comparison`: simulated values beside the analytic ones, the stop-time statistics and
the energy law eq7.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from . import analytic
from .errors import ParameterError
from .quantities import quantity
from .model import ANALYTIC, holds
from .results import Result
from .scene import Scene

__all__ = ["default_scene", "DEFAULT_PATHS", "comparison", "scaled_factors", "to_scaled",
           "Curve", "CURVES", "curve"]

#: Paths of the main job.
DEFAULT_PATHS = 1_000_000
#: Scaled switch-off time of the paper's figures.
PAPER_TAU0 = 5.0


def default_scene() -> Scene:
    """Scaled units, tau0 = 5, output times up to past the stop, every observable but the
    peaks, and the distributions of every quantity (they cost about 4 to 6 % more time:
    bench/distribution_cost.py)."""
    times = [0.1, 0.25, 0.5, 1.0, 2.0, 3.0, 4.0, 5.0, 5.25, 5.5, 6.0, 7.0, 8.0]
    return Scene.scaled(tau0=PAPER_TAU0, times=times, distributions=True)


def _scaling(result: Result):
    """The scene's Scaling (None for a scaled scene); ValueError if it has no scaled units."""
    sc = result.scene
    if sc.units == "scaled":
        return None
    if sc.scaling is None:
        raise ParameterError("scene", "scene: the analytic layer needs mu > 0 and h > 0 (eq8)")
    return sc.scaling


def to_scaled(result: Result, value, kind: str, power: int = 1):
    """A value of ``kind ** power`` from a result's units to the paper's scaled units (eq8).

    Unchanged for a scaled scene; for a physical one, :meth:`crandall.Scaling.to_scaled`.
    ValueError if the scene has no scaled units (mu = 0 or h = 0).
    """
    s = _scaling(result)
    return value if s is None else s.to_scaled(value, kind, power)


def scaled_factors(result: Result):
    """A result's times in the paper's scaled units, and the factors to scale its quantities.

    Returns (tau, tau0, velocity factor, length factor, time factor): multiply a velocity by
    the first factor to get U1, a displacement or distance by the second to get U2 or U3, a
    time by the third to get tau (all 1 for a scaled scene). Physical scenes need mu > 0 and
    h > 0 (eq8); otherwise ValueError. :func:`to_scaled` converts a value directly.
    """
    sc = result.scene
    if not holds(sc, ANALYTIC):
        raise ParameterError("result", f"result: the paper's closed forms do not hold for a scene with "
                         f"{', '.join(sorted(sc.effects))}")
    s = _scaling(result)
    if s is None:
        return sc.times, sc.t0, 1.0, 1.0, 1.0
    return (s.to_tau(sc.times), s.to_tau(sc.t0), s.to_scaled(1.0, "velocity"),
            s.to_scaled(1.0, "length"), s.to_scaled(1.0, "time"))


@dataclass(frozen=True)
class Curve:
    """One of the paper's curves: an analytic function of tau, the simulated statistic it
    predicts, and the domain where the closed form is known.

    Attributes
    ----------
    name : str
        The analytic function in :mod:`crandall.analytic` (``distance_mean``), also the key
        of the curve in the bench results.
    quantity : str
        The simulated quantity (``distance``).
    statistic : str
        "mean" or "var".
    label : str
        Its short label in tables ("E U3").
    figure : str
        The paper's figure, as the file stem ``crandall run`` writes (``fig2_distance_mean``).
    ylabel, title : str
        The figure's axis label and title.
    """

    name: str
    quantity: str
    statistic: str
    label: str
    figure: str
    ylabel: str
    title: str

    def analytic(self, tau, tau0=math.inf):
        """The analytic value at scaled time(s) tau for switch-off tau0."""
        return getattr(analytic, self.name)(tau, tau0)

    def simulated(self, result: Result):
        """(value, standard error) of the statistic over the result's times, its units."""
        if self.statistic == "mean":
            return result.mean(self.quantity), result.stderr(self.quantity)
        return result.var(self.quantity), result.var_stderr(self.quantity)

    def simulated_scaled(self, result: Result):
        """:meth:`simulated` in the paper's scaled units."""
        kind = quantity(self.quantity).kind
        power = 1 if self.statistic == "mean" else 2
        return tuple(to_scaled(result, x, kind, power) for x in self.simulated(result))


#: The paper's four curves (Figs. 2-5), in the order tables and figures show them.
CURVES = (
    Curve("distance_mean", "distance", "mean", "E U3", "fig2_distance_mean",
          r"$E\,U_3$", "Mean scaled distance travelled (Fig. 2)"),
    Curve("velocity_var", "velocity", "var", "Var U1", "fig3_velocity_var",
          r"Var $U_1$", "Variance of the scaled velocity (Fig. 3)"),
    Curve("displacement_var", "displacement", "var", "Var U2", "fig4_displacement_var",
          r"Var $U_2$", "Variance of the scaled displacement (Fig. 4)"),
    Curve("distance_var", "distance", "var", "Var U3", "fig5_distance_var",
          r"Var $U_3$", "Variance of the scaled distance (Fig. 5)"),
)


def curve(name: str) -> Curve:
    """The curve of ``CURVES`` called ``name`` (KeyError if none)."""
    for c in CURVES:
        if c.name == name:
            return c
    raise KeyError(name)


def _num(x, spec: str) -> str:
    # NaN: not estimable from this run (e.g. a variance of 1 path), shown as "n/a".
    width = spec.split(".")[0].lstrip(">+")
    return f"{'n/a':>{width}}" if np.isnan(x) else format(x, spec)


def _cell(sim, se, ref):
    if ref is None or not np.isfinite(ref):
        return f"{_num(sim, '>10.5f')} ±{_num(se, '8.5f')} {'':>10} {'':>6}"
    z = (sim - ref) / se if se > 0 else (0.0 if se == 0 else math.nan)
    return f"{_num(sim, '>10.5f')} ±{_num(se, '8.5f')} {ref:>10.5f} {_num(z, '>+6.1f')}"


def comparison(result: Result) -> str:
    """Simulated statistics beside the analytic layer, in scaled units.

    Columns per quantity: simulated value, its standard error, the analytic value and the
    difference in standard errors (z), at every output time, before and after the switch-off.
    The simulated numbers carry the method's
    bias (bench/bias.py) on top of the statistical error.
    """
    tau, tau0, *_ = scaled_factors(result)
    names = result.names
    lines = [f"paths={result.paths}  seed={result.seed}  method={result.method}  "
             f"dt={result.dt:.4g}  (scaled units; z = (simulated - analytic) / stderr)"]
    head = f"{'tau':>6}"
    cols = [c for c in CURVES if c.quantity in names]
    for c in cols:
        head += f" | {c.label + ' sim':>10} {'±se':>9} {'analytic':>10} {'z':>6}"
    lines.append(head)
    stats = {c.name: c.simulated_scaled(result) for c in cols}
    for i, t in enumerate(np.atleast_1d(tau)):
        row = f"{t:>6.3g}"
        for c in cols:
            sim, se = stats[c.name]
            ref = float(c.analytic(float(t), tau0))
            row += " | " + _cell(sim[i], se[i], ref)
        lines.append(row)

    def at_stop(name, statistic):
        kind = quantity(name).kind
        if statistic == "mean":
            return to_scaled(result, result.mean(name), kind), to_scaled(
                result, result.stderr(name), kind)
        return (to_scaled(result, result.var(name), kind, 2),
                to_scaled(result, result.var_stderr(name), kind, 2))

    if "stop_time" in names:
        lines.append("")
        lines.append("At the stop (tau_s = tau0 + |U1(tau0)| / 2, eq14):")
        lines.append(f"  E tau_s        "
                     f"{_cell(*at_stop('stop_time', 'mean'), float(analytic.stop_time_mean(tau0)))}")
        lines.append(f"  Var tau_s      "
                     f"{_cell(*at_stop('stop_time', 'var'), float(analytic.stop_time_var(tau0)))}")
        if "displacement_at_stop" in names:
            ref = float(analytic.displacement_at_stop_var(tau0))
            lines.append(f"  Var U2(tau_s)  {_cell(*at_stop('displacement_at_stop', 'var'), ref)}")
        if "distance_at_stop" in names:
            ref = float(analytic.distance_at_stop_var(tau0))
            lines.append(f"  Var U3(tau_s)  {_cell(*at_stop('distance_at_stop', 'var'), ref)}")
            lines.append("")
            lines.append("Energy law (eq7): mean friction loss = foundation's mean kinetic energy at t0,")
            lines.append("i.e. E[U3(tau_s)] = tau0 / 2:")
            lines.append(f"  E U3(tau_s)    {_cell(*at_stop('distance_at_stop', 'mean'), tau0 / 2)}")
    return "\n".join(lines)
