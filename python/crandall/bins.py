"""Which distributions a scene asks for, and the bins of their histograms.

A scene may ask for the distribution of any quantity it holds (``Scene(distributions=...)``):
the core then counts, per output time and at the stop, every path's value in a histogram with
fixed bins (docs/methods/histograms.md). This module checks the scene's ``distributions`` and
``bins`` and works out every histogram axis the core records: by default the automatic
log-linear edges from the quantity's scale (from the analytic layer, in the scene's units),
or the edges the user gave.

The core bins five variables per slot (``quantities.HISTOGRAM_VARIABLES``); the other
quantities are functions of them: the dissipated energy is ``m mu g`` times the distance (the
distance's edges times that factor), the kinetic energy ``m V^2 / 2`` is the velocity's
histogram folded at 0 (the automatic velocity edges are exact mirrors, so the fold is bin to
bin), and the stop time is the core's time from the switch-off plus t0.

Pure Python: the core's ``BinEdges`` are built from :func:`axes` by ``crandall.engine``.
"""

from __future__ import annotations

import math
import numbers
from dataclasses import dataclass
from typing import Any, Dict, List, Mapping, NamedTuple, Optional, Tuple

import numpy as np

from ._lazy import lazy_module
from .errors import ParameterError
from .model import MOVING_AT_SWITCH_OFF, holds
from .quantities import (DISPLACEMENT, DISTANCE, HISTOGRAM_VARIABLES, PEAK_DISPLACEMENT,
                         PEAK_SPEED, VELOCITY, find, names_for, quantity)

# The analytic layer (scipy) gives the automatic scales: loaded when a scene first needs them.
analytic = lazy_module("crandall.analytic")

__all__ = ["DEFAULT_PER_OCTAVE", "MAX_PER_OCTAVE", "REACH", "BULK_BINS", "Axis", "axes",
           "axis_name", "check_distributions", "check_bins", "bins_to_plain",
           "primary_of", "VARIABLE_COUNT", "Histograms", "check_histograms", "recorded"]

#: Bins per octave of the automatic edges unless the scene says otherwise: the bin is between
#: 1/256 and 1/128 of the value beyond the scale. With 32, the intervals of the paper scene's
#: stop quantiles at 10^6 paths were at least half bin width (``Estimate.bin_limited``) from
#: the median to the 99.9 % quantile; with 128 they are 2 to 4 times narrower, at no
#: measurable cost (the lookup is the same arithmetic; the counts of a slot, 8 to 16 kB, stay
#: in cache) (docs/distributions.md).
DEFAULT_PER_OCTAVE = 128
#: Most bins per octave a scene may ask for (a power of two).
MAX_PER_OCTAVE = 1 << 12
#: The automatic edges reach this many scales from 0: beyond any feasible number of paths
#: for the exponential tails of this problem (P(U1 > 50 sd) ~ e^-70).
REACH = 50.0
#: A one-sided automatic axis whose values lie far from 0 (the distance at long times, whose
#: spread relative to its mean falls like tau^-1/2) gets at least this many bins per standard
#: deviation at its mean: its bins per octave are raised to the power of two that gives that.
BULK_BINS = 8
#: Histogram variables per slot.
VARIABLE_COUNT = len(HISTOGRAM_VARIABLES)
# Smallest and largest scale the core's automatic edges take (it needs >= 2^-900).
_TINY, _HUGE = 2.0 ** -800, 2.0 ** 800

# The quantity that names each histogram variable, over time and at the stop; the other
# quantities (the energies) are functions of these.
_PRIMARY_TIME = ("velocity", "displacement", "distance", "peak_speed", "peak_displacement")
_PRIMARY_STOP = ("stop_time", "displacement_at_stop", "distance_at_stop", "peak_speed_at_stop",
                 "peak_displacement_at_stop")
_SYMMETRIC = (True, True, False, False, False)
_SYMMETRIC_STOP = (False, True, False, False, False)


def primary_of(name: str) -> str:
    """The quantity whose histogram axis ``name``'s distribution comes from (itself, or the
    distance for the dissipated energy, the velocity for the kinetic energy)."""
    q = quantity(name)
    if name == "stop_time":
        return name
    return (_PRIMARY_STOP if q.at_stop else _PRIMARY_TIME)[q.histogram_variable]


def axis_name(at_stop: bool, variable: int) -> str:
    """The quantity that names histogram variable ``variable`` over time or at the stop."""
    return (_PRIMARY_STOP if at_stop else _PRIMARY_TIME)[variable]


def _names(value, parameter: str):
    if isinstance(value, str):
        return [value]
    if isinstance(value, (bytes, bytearray, Mapping)):
        raise ParameterError(parameter, f"{parameter} must be True, None or a list of "
                                        f"quantity names, got {value!r}")
    try:
        names = list(value)
    except TypeError:
        raise ParameterError(parameter, f"{parameter} must be True, None or a list of "
                                        f"quantity names, got {value!r}") from None
    for n in names:
        if not isinstance(n, str):
            raise ParameterError(parameter, f"{parameter}: names must be strings, got {n!r}")
    return names


def check_distributions(value, observe) -> Tuple[str, ...]:
    """The quantities a scene observing ``observe`` asks the distributions of.

    ``None`` or ``False``: none; ``True``: every quantity the scene holds; a name or a list
    of names: those (each must be a quantity the scene holds). Returned in table order.
    """
    held = names_for(observe)
    if value is None or value is False:
        return ()
    if value is True:
        return held
    if isinstance(value, (bool, np.bool_)):
        return held if bool(value) else ()
    names = _names(value, "distributions")
    for n in names:
        if n not in held:
            raise ParameterError("distributions", f"distributions: {n!r} is not a quantity this "
                                                  f"scene holds; choose from {', '.join(held)}")
    return tuple(n for n in held if n in names)


def _recorded(distributions) -> Dict[Tuple[bool, int], List[str]]:
    """The recorded histogram axes, (at_stop, variable) -> the asked quantities on it."""
    out: Dict[Tuple[bool, int], List[str]] = {}
    for n in distributions:
        q = quantity(n)
        out.setdefault((q.at_stop, q.histogram_variable), []).append(n)
    return out


def _per_octave(value, where: str) -> int:
    if (isinstance(value, (bool, np.bool_)) or not isinstance(value, numbers.Integral)
            or not 1 <= int(value) <= MAX_PER_OCTAVE or int(value) & (int(value) - 1)):
        raise ParameterError("bins", f"{where} must be a power of two from 1 to "
                                     f"{MAX_PER_OCTAVE} (bins per octave), got {value!r}")
    return int(value)


#: The most bins one histogram axis may have (the core's MAX_HISTOGRAM_BINS, which
#: tests/test_result_distributions.py holds it to): refused when the scene is made.
MAX_BINS = 1 << 22


def _edges(value, where: str) -> Tuple[float, ...]:
    if isinstance(value, (str, bytes)):
        raise ParameterError("bins", f"{where} must be a list of edges, got {value!r}")
    try:
        items = list(value)
    except TypeError:
        raise ParameterError("bins", f"{where} must be a power of two (bins per octave) or a "
                                     f"list of edges, got {value!r}") from None
    for x in items:
        if isinstance(x, (bool, np.bool_)) or not isinstance(x, numbers.Real):
            raise ParameterError("bins", f"{where}: edges must be real numbers, got {x!r}")
    e = np.asarray(items, dtype=float)
    if e.ndim != 1 or e.size < 2:
        raise ParameterError("bins", f"{where} needs at least two edges, got {len(items)}")
    if not np.isfinite(e).all():
        raise ParameterError("bins", f"{where}: edges must be finite")
    if not (np.diff(e) > 0).all():
        raise ParameterError("bins", f"{where}: edges must be strictly increasing")
    if e.size - 1 > MAX_BINS:
        raise ParameterError("bins", f"{where}: {e.size - 1} bins, more than the {MAX_BINS} "
                                     "one histogram may have")
    return tuple(float(x) for x in e)


def check_bins(value, distributions, t0: float):
    """The scene's ``bins`` checked: (bins per octave of the automatic edges, per-quantity
    settings), the settings keyed by the quantity that names a histogram axis, each a power
    of two (its bins per octave) or a tuple of edges in the scene's units.

    ``None``: automatic edges with ``DEFAULT_PER_OCTAVE``; an int: automatic edges with that
    many bins per octave; a mapping: per quantity, an int or a list of edges (the others
    automatic). A quantity's entry must name a recorded axis (a quantity asked for, or, for
    the energies, the distance or the velocity they come from).
    """
    if value is None:
        return DEFAULT_PER_OCTAVE, {}
    if not distributions:
        raise ParameterError("bins", "bins: the scene asks for no distributions; give "
                                     "distributions as well")
    if not isinstance(value, Mapping):
        if isinstance(value, numbers.Integral) and not isinstance(value, (bool, np.bool_)):
            return _per_octave(value, "bins"), {}
        raise ParameterError("bins", "bins must be None, a power of two (bins per octave) or a "
                                     f"mapping of quantity names to those or to edges, got "
                                     f"{value!r}")
    recorded = _recorded(distributions)
    allowed = {axis_name(s, v): (s, v) for s, v in recorded}
    settings: Dict[str, Any] = {}
    for name, spec in value.items():
        if name not in allowed:
            known = find(name) if isinstance(name, str) else None
            hint = ""
            if known is not None and primary_of(name) != name:
                hint = (f" ({name}'s distribution comes from {primary_of(name)}'s histogram: "
                        f"give bins for {primary_of(name)!r})")
            raise ParameterError("bins", f"bins: {name!r} names no histogram of this scene"
                                         f"{hint}; choose from {', '.join(allowed) or 'none'}")
        where = f"bins[{name!r}]"
        if isinstance(spec, numbers.Integral) and not isinstance(spec, (bool, np.bool_)):
            settings[name] = _per_octave(spec, where)
            continue
        edges = _edges(spec, where)
        if name == "stop_time":
            core = np.asarray(edges) - t0
            if not (np.diff(core) > 0).all():
                raise ParameterError("bins", f"{where}: the edges minus t0 = {t0!r} (the core "
                                             "counts the time from the switch-off) are not "
                                             "strictly increasing in doubles; give edges further "
                                             "apart")
        if name == "velocity" and "kinetic_energy" in recorded.get((False, VELOCITY), []):
            e = np.asarray(edges)
            if not np.array_equal(e, -e[::-1]):
                raise ParameterError("bins", f"{where}: the kinetic energy's distribution folds "
                                             "the velocity's at 0, which needs edges symmetric "
                                             "about 0 (e == -e[::-1])")
        settings[name] = edges
    return DEFAULT_PER_OCTAVE, settings


def bins_to_plain(per_octave: int, settings: Mapping[str, Any]):
    """The scene's ``bins`` as plain data (``Scene.to_dict``): None for the default, an int,
    or a dict of ints and lists."""
    if not settings:
        return None if per_octave == DEFAULT_PER_OCTAVE else per_octave
    out: Dict[str, Any] = {k: (v if isinstance(v, int) else list(v)) for k, v in settings.items()}
    return out


@dataclass(frozen=True)
class Axis:
    """One recorded histogram axis, in the core's units (the scene's; the stop time from the
    switch-off).

    Attributes
    ----------
    index : int
        Its place in the core's list of axes: ``slot * VARIABLE_COUNT + variable``.
    slot : int
        The output time's index, or the number of output times for the stop.
    variable : int
        Index into ``quantities.HISTOGRAM_VARIABLES``.
    name : str
        The quantity that names it (``axis_name``).
    edges : tuple of float or None
        User-given edges (core units); None for automatic ones.
    scale, per_octave, symmetric
        The automatic edges' parameters (``BinEdges.log_linear(scale, per_octave, REACH,
        symmetric)``); ignored with user edges.
    """

    index: int
    slot: int
    variable: int
    name: str
    edges: Optional[Tuple[float, ...]]
    scale: float
    per_octave: int
    symmetric: bool


def _pow2_at_least(x: float) -> int:
    """The least power of two >= x (capped at MAX_PER_OCTAVE; 1 for x <= 1 or NaN)."""
    if not x > 1:
        return 1
    if x >= MAX_PER_OCTAVE:
        return MAX_PER_OCTAVE
    return 1 << math.ceil(math.log2(x))


def _scaled_scales(tau: float, tau0: float):
    """Scales of the five variables at scaled time tau (noise off after tau0), scaled units:
    (velocity sd, displacement sd, distance mean, distance sd); the law at the stop for
    tau = inf. Within a factor of about 2 of the truth is all the automatic edges need."""
    on = min(tau, tau0)
    v_sd = math.sqrt(max(float(analytic.velocity_var(on)), 0.0))
    if tau <= tau0:
        x_sd = math.sqrt(max(float(analytic.displacement_var(tau)), 0.0))
        d_mean = float(analytic.distance_mean(tau))
        d_sd = math.sqrt(max(float(analytic.distance_var(tau)), 0.0))
    else:
        # Between the switch-off and the stop the spreads grow from their values at tau0 to
        # those at the stop (closed forms; the coast's own cost 10 ms a point).
        x_sd = math.sqrt(float(analytic.displacement_at_stop_var(tau0)))
        d_mean = (float(analytic.distance_at_stop_mean(tau0)) if math.isinf(tau)
                  else float(analytic.distance_mean(tau, tau0)))
        d_sd = math.sqrt(float(analytic.distance_at_stop_var(tau0)))
    return v_sd, x_sd, d_mean, d_sd


def _brownian_scales(t: float, t0: float, h: float):
    """The same scales without friction (mu = 0, or scales beyond doubles): a Brownian
    velocity h W while the noise is on, constant after (scene units)."""
    on = min(t, t0)
    # Products, not powers: they overflow to inf (then the unit scale is used), where ``**``
    # raises.
    v_sd = h * math.sqrt(on)
    coast = max(t - on, 0.0)
    x_sd = h * on * math.sqrt(on) / math.sqrt(3.0) + v_sd * coast
    d_mean = math.sqrt(2.0 / math.pi) * (2.0 / 3.0 * h * on * math.sqrt(on) + v_sd * coast)
    return v_sd, x_sd, d_mean, x_sd


def _slot_scales(scene, t: float) -> Tuple[float, float, float, float, float]:
    """(velocity, displacement, distance mean, distance sd, stop time) scales at time t
    (``inf``: the stop) in the scene's units; 0 where the quantity is 0."""
    s = scene.scaling
    if scene.units == "scaled" or s is not None:
        to_tau = (lambda x: x) if scene.units == "scaled" else s.to_tau
        tau0 = to_tau(scene.t0) if math.isfinite(scene.t0) else math.inf
        tau = math.inf if math.isinf(t) else to_tau(t)
        v, x, dm, dsd = _scaled_scales(tau, tau0)
        stop = float(analytic.velocity_abs_mean(tau0)) / 2 if math.isfinite(tau0) else 0.0
        if scene.units == "SI":
            v, stop = s.to_si(v, "velocity"), s.to_si(stop, "time")
            x, dm, dsd = (s.to_si(y, "length") for y in (x, dm, dsd))
        return v, x, dm, dsd, stop
    if math.isinf(t):
        t = scene.t0 if math.isfinite(scene.t0) else 0.0
    v, x, dm, dsd = _brownian_scales(t, scene.t0, scene.noise)
    return v, x, dm, dsd, 0.0


def _with_start(scene, t: float, v_sd: float, x_sd: float, d_mean: float, stop: float):
    """The scales of a body that starts at v0, u0: at least the start's own (the speed |v0|,
    |u0| plus the distance it coasts, its coasting time), since the analytic layer's are those
    of a start at rest. NaN scales (beyond the analytic layer) stay NaN."""
    v0, c = abs(scene.v0), scene.drift
    horizon = scene.t0 if math.isinf(t) else t
    coast_time = v0 / c if c > 0 else math.inf
    travelled = v0 * min(horizon, coast_time) if math.isfinite(horizon) else (
        v0 * coast_time if math.isfinite(coast_time) else math.nan)

    def at_least(scale, floor):
        return scale if math.isnan(scale) or not math.isfinite(floor) else max(scale, floor)

    return (at_least(v_sd, v0), at_least(x_sd, abs(scene.u0) + travelled),
            at_least(d_mean, travelled), at_least(stop, coast_time))


def _usable(scale: float, fallback: float) -> float:
    if not (math.isfinite(scale) and scale > 0):
        scale = fallback
    if not (math.isfinite(scale) and scale > 0):
        scale = 1.0
    return min(max(scale, _TINY), _HUGE)


def recorded(scene) -> List[Tuple[int, int, int, str]]:
    """The histogram axes a scene's distributions record, in the core's order, without their
    bins: (index, slot, variable, name)."""
    dist = getattr(scene, "distributions", ())
    if not dist:
        return []
    kept = _recorded(dist)
    n = scene.times.size
    out = []
    for slot, at_stop in [(i, False) for i in range(n)] + [(n, True)]:
        for var in sorted(v for s, v in kept if s == at_stop):
            out.append((slot * VARIABLE_COUNT + var, slot, var, axis_name(at_stop, var)))
    return out


def axes(scene) -> List[Axis]:
    """Every histogram axis the scene's distributions need, in the core's order.

    The automatic scale of each: the velocity's standard deviation (at the switch-off once it
    is past: the peak speed never falls); the displacement's; the distance's mean, or its
    standard deviation if larger, with the bins per octave raised so that its standard
    deviation spans at least ``BULK_BINS`` bins at its mean; the peaks those of the velocity
    and the displacement; the stop time half the mean speed at the switch-off (its mean
    after the switch-off). A quantity identically 0 there (at t = 0, or without noise) gets
    the scene's unit scale: every value then falls in the bin at 0.
    """
    dist = getattr(scene, "distributions", ())
    if not dist:
        return []
    # Worked out once per scene (the memory check and the plan both need them; a scene's
    # times, observables and bins do not change once it is made).
    cached = getattr(scene, "_histogram_axes", None)
    if cached is not None:
        return list(cached)
    found = _axes(scene, dist)
    try:
        scene._histogram_axes = tuple(found)
    except AttributeError:  # pragma: no cover - a scene-like object that takes no attribute
        pass
    return found


def _axes(scene, dist) -> List[Axis]:
    per_octave, settings = scene.bin_settings
    recorded = _recorded(dist)
    times = [float(t) for t in scene.times]
    out = []
    slots = [(i, t, False) for i, t in enumerate(times)] + [(len(times), math.inf, True)]
    unit = _unit_scales(scene)
    for slot, t, at_stop in slots:
        wanted = sorted(v for s, v in recorded if s == at_stop)
        if not wanted:
            continue
        try:
            with np.errstate(all="ignore"):
                v_sd, x_sd, d_mean, d_sd, stop = _slot_scales(scene, t)
        except (OverflowError, ValueError, ZeroDivisionError):
            # Times or scales beyond what the analytic layer evaluates: the scales are only
            # hints (the edges need them within a factor of about 2), so the scene's units
            # stand in, and every value is still counted (under- and overflow included).
            v_sd = x_sd = d_mean = d_sd = stop = math.nan
        if scene.v0 != 0.0 or scene.u0 != 0.0:
            v_sd, x_sd, d_mean, stop = _with_start(scene, t, v_sd, x_sd, d_mean, stop)
        for var in wanted:
            name = axis_name(at_stop, var)
            given = settings.get(name)
            symmetric = (_SYMMETRIC_STOP if at_stop else _SYMMETRIC)[var]
            if name == "stop_time" and not holds(scene, MOVING_AT_SWITCH_OFF):
                # Kept from the switch-off: a body at rest for good before it is negative.
                symmetric = True
            m = given if isinstance(given, int) else per_octave
            if at_stop and var == VELOCITY:
                scale = _usable(stop, unit["time"])
            elif var in (VELOCITY, PEAK_SPEED):
                scale = _usable(v_sd, unit["velocity"])
            elif var in (DISPLACEMENT, PEAK_DISPLACEMENT):
                scale = _usable(x_sd, unit["length"])
            else:
                scale = _usable(max(d_mean, d_sd), unit["length"])
                if given is None and d_sd > 0 and d_mean > d_sd:
                    m = min(max(m, _pow2_at_least(BULK_BINS * d_mean / d_sd)), MAX_PER_OCTAVE)
            edges = None
            if isinstance(given, tuple):
                edges = tuple(float(x) for x in (np.asarray(given) - scene.t0)) \
                    if name == "stop_time" else given
            out.append(Axis(slot * VARIABLE_COUNT + var, slot, var, name, edges, scale, m,
                            symmetric))
    return out


def _unit_scales(scene) -> Dict[str, float]:
    """One scaled unit of each kind in the scene's units (1 where it has none)."""
    s = scene.scaling
    if scene.units == "SI" and s is not None:
        return {k: s.scale(k) for k in ("time", "velocity", "length")}
    return {"time": 1.0, "velocity": 1.0, "length": 1.0}


class Histograms(NamedTuple):
    """The histograms of a run: per recorded axis, its index (``slot * VARIABLE_COUNT +
    variable``), its edges (float64, the core's units) and its counts (uint64: underflow,
    one per bin, overflow, NaN). Merged by adding counts: exact, in any order."""

    index: Tuple[int, ...]
    edges: Tuple[np.ndarray, ...]
    counts: Tuple[np.ndarray, ...]

    def find(self, slot: int, variable: int):
        """(edges, counts) of an axis, or None if it is not recorded."""
        want = slot * VARIABLE_COUNT + variable
        for i, e, c in zip(self.index, self.edges, self.counts):
            if i == want:
                return e, c
        return None

    @property
    def nbytes(self) -> int:
        """Bytes of edges and counts: fixed by the axes, whatever the number of paths."""
        return int(sum(e.nbytes for e in self.edges) + sum(c.nbytes for c in self.counts))


def check_histograms(where: str, index, edges, counts, expected_index, paths=None) -> None:
    """Check stored histograms before trusting them (a ValueError naming ``where`` and the
    field): the recorded axes are the scene's, each axis has strictly increasing finite
    edges and ``len(edges) + 2`` non-negative integer counts, and (``paths`` given) every
    axis counts every path once."""
    index = [int(i) for i in index]
    if index != list(expected_index):
        raise ValueError(f"{where}: histogram_index is {index}, but the scene's distributions "
                         f"record the axes {list(expected_index)}")
    if len(edges) != len(index) or len(counts) != len(index):
        raise ValueError(f"{where}: histogram_edges and histogram_counts must have one entry "
                         f"per axis ({len(index)})")
    for i, e, c in zip(index, edges, counts):
        e = np.asarray(e)
        c = np.asarray(c)
        if e.ndim != 1 or e.size < 2 or e.dtype.kind != "f" or not np.isfinite(e).all() \
                or not (np.diff(e) > 0).all():
            raise ValueError(f"{where}: histogram_edges of axis {i} are not strictly "
                             "increasing finite numbers")
        if c.ndim != 1 or c.size != e.size + 2 or c.dtype.kind not in "iu" \
                or (c.dtype.kind == "i" and (c < 0).any()):
            raise ValueError(f"{where}: histogram_counts of axis {i} must be {e.size + 2} "
                             "counts >= 0 (underflow, one per bin, overflow, NaN)")
        if paths is not None and sum(int(x) for x in c) != paths:
            raise ValueError(f"{where}: histogram_counts of axis {i} add up to "
                             f"{sum(int(x) for x in c)}, expected the {paths} paths")
