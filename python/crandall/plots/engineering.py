"""Figures of the engineering layer: Newmark's block on a record and its sweeps, and
fragility curves with their hazard."""

from __future__ import annotations

import math
from typing import Optional

import numpy as np

from ..fragility import FragilityResult
from ..records import NewmarkResult
from ..errors import ParameterError
from .common import _CURVE, _SIM, _figure


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
        raise ParameterError("result", "result must be one case of crandall.newmark (one record, "
                                       "one yield and one polarity); a sweep keeps no histories: "
                                       "plots.newmark_sweep")
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
        raise ParameterError("result", "result must be a sweep of crandall.newmark over an array "
                                       "of yields")
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
        raise ParameterError("result", "result must be a crandall.FragilityResult, got "
                                       f"{type(result).__name__}")
    if records is not None and not isinstance(records, FragilityResult):
        raise ParameterError("records", f"records must be a crandall.RecordFragilityResult, got "
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
