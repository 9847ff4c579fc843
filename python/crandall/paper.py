"""The paper's setting (Berezin & Zayats) and the comparison of a result with the analytic layer.

``python -m crandall`` (``make run``) simulates :func:`default_scene` and prints
:func:`comparison`: simulated values beside the analytic ones, the stop-time statistics and
the energy law eq7.
"""

from __future__ import annotations

import math

import numpy as np

from . import analytic
from .results import Result
from .scene import Scene

__all__ = ["default_scene", "DEFAULT_PATHS", "comparison", "scaled_factors"]

#: Paths of the main job.
DEFAULT_PATHS = 1_000_000
#: Scaled switch-off time of the paper's figures.
PAPER_TAU0 = 5.0


def default_scene() -> Scene:
    """Scaled units, tau0 = 5, output times up to past the stop, every observable."""
    times = [0.1, 0.25, 0.5, 1.0, 2.0, 3.0, 4.0, 5.0, 5.25, 5.5, 6.0, 7.0, 8.0]
    return Scene.scaled(tau0=PAPER_TAU0, times=times)


def scaled_factors(result: Result):
    """A result's times in the paper's scaled units, and the factors to scale its quantities.

    Returns (tau, tau0, velocity factor, length factor, time factor): multiply a velocity by
    the first factor to get U1, a displacement or distance by the second to get U2 or U3, a
    time by the third to get tau (all 1 for a scaled scene). Physical scenes need mu > 0 and
    h > 0 (eq8); otherwise ValueError.
    """
    sc = result.scene
    if sc.units == "scaled":
        return sc.times, sc.t0, 1.0, 1.0, 1.0
    if sc.scaling is None:
        raise ValueError("scene: the analytic layer needs mu > 0 and h > 0 (eq8)")
    s = sc.scaling
    return s.to_tau(sc.times), s.to_tau(sc.t0), 1 / s.velocity_scale, 1 / s.length_scale, 1 / s.time_scale


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
    difference in standard errors (z). Variances of displacement and distance have analytic
    values only while the noise is on (tau <= tau0). The simulated numbers carry the method's
    bias (bench/bias.py) on top of the statistical error.
    """
    tau, tau0, fv, fl, ft = scaled_factors(result)
    obs = result.scene.observe
    lines = [f"paths={result.paths}  seed={result.seed}  method={result.method}  "
             f"dt={result.dt:.4g}  (scaled units; z = (simulated - analytic) / stderr)"]
    head = f"{'tau':>6}"
    cols = []
    if "distance" in obs:
        cols.append(("E U3", "distance", "mean", fl, lambda t: analytic.distance_mean(t, tau0)))
    if "velocity" in obs:
        cols.append(("Var U1", "velocity", "var", fv, lambda t: analytic.velocity_var(t, tau0)))
    if "displacement" in obs:
        cols.append(("Var U2", "displacement", "var", fl,
                     lambda t: analytic.displacement_var(t, tau0) if t <= tau0 else None))
    if "distance" in obs:
        cols.append(("Var U3", "distance", "var", fl,
                     lambda t: analytic.distance_var(t, tau0) if t <= tau0 else None))
    for label, *_ in cols:
        head += f" | {label + ' sim':>10} {'±se':>9} {'analytic':>10} {'z':>6}"
    lines.append(head)
    stats = {}
    for label, name, kind, f, _ in cols:
        if kind == "mean":
            stats[label] = (result.mean(name) * f, result.stderr(name) * f)
        else:
            stats[label] = (result.var(name) * f * f, result.var_stderr(name) * f * f)
    for i, t in enumerate(np.atleast_1d(tau)):
        row = f"{t:>6.3g}"
        for label, _, _, _, ref in cols:
            sim, se = stats[label]
            r = ref(float(t))
            row += " | " + _cell(sim[i], se[i], None if r is None else float(r))
        lines.append(row)
    if "stop" in obs:
        lines.append("")
        lines.append("At the stop (tau_s = tau0 + |U1(tau0)| / 2, eq14):")
        ts, ts_se = result.mean("stop_time") * ft, result.stderr("stop_time") * ft
        lines.append(f"  E tau_s        {_cell(ts, ts_se, float(analytic.stop_time_mean(tau0)))}")
        vs, vs_se = result.var("stop_time") * ft**2, result.var_stderr("stop_time") * ft**2
        lines.append(f"  Var tau_s      {_cell(vs, vs_se, float(analytic.stop_time_var(tau0)))}")
        if "displacement" in obs:
            v = result.var("displacement_at_stop") * fl**2
            se = result.var_stderr("displacement_at_stop") * fl**2
            lines.append(f"  Var U2(tau_s)  {_cell(v, se, float(analytic.displacement_at_stop_var(tau0)))}")
        if "distance" in obs:
            v = result.var("distance_at_stop") * fl**2
            se = result.var_stderr("distance_at_stop") * fl**2
            lines.append(f"  Var U3(tau_s)  {_cell(v, se, float(analytic.distance_at_stop_var(tau0)))}")
            m = result.mean("distance_at_stop") * fl
            se = result.stderr("distance_at_stop") * fl
            lines.append("")
            lines.append("Energy law (eq7): mean friction loss = foundation's mean kinetic energy at t0,")
            lines.append("i.e. E[U3(tau_s)] = tau0 / 2:")
            lines.append(f"  E U3(tau_s)    {_cell(m, se, tau0 / 2)}")
    return "\n".join(lines)
