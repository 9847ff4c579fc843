"""Shaking that builds up and decays: smooth intensity envelopes as piecewise schedules.

crandall simulates a piecewise-constant intensity exactly (``Scene(h=[...], t0=[...])``). A
smooth envelope h(t) is replaced by pieces whose intensity keeps the mean of h^2 over each
piece, h_i^2 = (1 / (t_i - t_{i-1})) int h(t)^2 dt, so the energy the noise feeds in
(int h^2 dt / 2 per unit mass, the mean friction loss at the stop) is the envelope's on every
piece. Within a piece the intensity is constant where the envelope is not: that replacement,
not the simulation, is what is approximate, and a scene given the envelope
(``Scene(envelope=...)``) estimates its error with twice the pieces (``Result.bias``).

Each function returns an :class:`Envelope`: give it to ``crandall.Scene(envelope=..., ...)``,
which then also reports the error of the pieces (``Result.bias``: the difference from a run
with twice the pieces), or unpack it, ``h, t0 = envelopes.amin_ang(...)``, for the lists of a
piecewise scene ``crandall.Scene(h=h, t0=t0, ...)`` (the pieces alone: no piece error).

The envelopes (t in s, h the intensity of the strong phase in m s^-3/2):

- :func:`amin_ang`: Amin & Ang (1968), a variance envelope: h(t)^2 = h^2 I(t), I = (t / t1)^2
  while it builds up, 1 in the strong phase [t1, t2), exp(-c (t - t2)) as it decays.
- :func:`jennings`: Jennings, Housner & Tsai (1968), an amplitude envelope: h(t) = h e(t),
  e = (t / t1)^2, 1 on [t1, t2), exp(-c (t - t2)).
- :func:`shinozuka_sato`: Shinozuka & Sato (1967), an amplitude envelope: h(t) = h (exp(-a t)
  - exp(-b t)) / max, b > a > 0, 1 at its peak.
- :func:`from_function`: any h(t).

And :func:`intensity_from_psd`, the intensity of white noise from the power spectral density
of the ground acceleration.
"""

from __future__ import annotations

import copy
import math
import numbers
import warnings
from typing import Any, Callable, Dict, List, Mapping, Optional, Sequence, Tuple

import numpy as np
from scipy import integrate

from .errors import ParameterError

__all__ = ["Envelope", "EnvelopeWarning", "MAX_PIECES", "from_function", "amin_ang", "jennings",
           "shinozuka_sato", "intensity_from_psd", "KINDS"]

Schedule = Tuple[List[float], List[float]]


class EnvelopeWarning(UserWarning):
    """A function envelope whose pieces may have missed part of it: h(t) was 0 at every
    point sampled, or positive at a point of a piece whose quadrature saw 0."""


def _positive(name: str, value, *, zero: bool = False) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise ParameterError(name, f"{name} must be a number, got {value!r}")
    value = float(value)
    if not math.isfinite(value) or value < 0 or (value == 0 and not zero):
        raise ParameterError(name, f"{name} must be finite and {'>= 0' if zero else '> 0'}, "
                                   f"got {value!r}")
    return value


#: Most pieces an envelope may be given (its piece-error estimate runs twice as many).
MAX_PIECES = 100_000


def _ends(end: float, pieces: int, breaks: Sequence[float] = (),
          limit: int = MAX_PIECES) -> List[float]:
    if isinstance(pieces, bool) or not isinstance(pieces, (int, np.integer)) or pieces < 1:
        raise ParameterError("pieces", f"pieces must be an integer >= 1, got {pieces!r}")
    if pieces > limit:
        raise ParameterError("pieces", f"pieces must be <= {limit}, got {pieces!r}")
    return _merge(end, np.linspace(0.0, end, int(pieces) + 1)[1:].tolist(), breaks)


def _merge(end: float, generated: Sequence[float], given: Sequence[float]) -> List[float]:
    """The piece ends: ``given`` (the envelope's corners, so no piece straddles a change of
    form; output times; a coarser schedule's ends) exactly, and the ``generated`` ones that
    are not within 1e-12 end of a given one (an equal division's point one rounding away from
    a corner would leave a piece of 1e-16 s), and ``end``."""
    fixed = sorted({float(b) for b in given if 0.0 < b < end} | {float(end)})
    tol = 1e-12 * end
    pos = np.searchsorted(fixed, generated)
    keep: List[float] = []
    for g, i in sorted(zip(generated, pos)):
        if ((i == len(fixed) or fixed[i] - g > tol) and (i == 0 or g - fixed[i - 1] > tol)
                and (not keep or g - keep[-1] > tol)):
            keep.append(float(g))
    return sorted(set(fixed) | set(keep))


def _intensity(h: Callable[[float], float], t: float) -> float:
    """h(t), checked: a real number (not a bool), finite and >= 0; ParameterError naming h
    and t otherwise. (A float takes the short way: the quadrature calls this for every point
    of every piece.)"""
    v = h(t)
    if type(v) is not float:
        if isinstance(v, np.ndarray) and v.ndim == 0:
            v = v[()]
        if isinstance(v, (bool, np.bool_)) or not isinstance(v, numbers.Real):
            kind = ("None" if v is None else "a bool" if isinstance(v, (bool, np.bool_)) else
                    "a complex number" if isinstance(v, numbers.Complex) else
                    f"a {type(v).__name__}")
            raise ParameterError("h", f"h({t:g}) = {v!r}: an intensity is a real number, "
                                      f"finite and >= 0 (h returned {kind})")
        v = float(v)
    if not 0.0 <= v < math.inf:  # NaN fails too
        raise ParameterError("h", f"h({t:g}) = {v!r}: an intensity is finite and >= 0")
    return v


#: Points of [0, end] where h is checked before the quadrature (and compared with its pieces).
CHECK_POINTS = 17


def _function_schedule(h: Callable[[float], float], end: float, pieces: int = 32,
                       breaks: Sequence[float] = (), limit: int = MAX_PIECES,
                       warn: bool = True, extra: Sequence[float] = ()) -> Schedule:
    """The schedule of an intensity function h(t) >= 0 on [0, end]: ``pieces`` equal pieces
    (and a piece end at each of ``breaks``, where h changes form), each with the root mean
    square of h over it. Raises ParameterError for a bad argument or an h that is not a
    real number, negative or not finite at a point it is evaluated at. With ``warn``, warns
    (:class:`EnvelopeWarning`) where the pieces may have missed part of h: h sampled 0
    everywhere, or positive at a checked point of a piece whose quadrature saw 0."""
    end = _positive("end", end)
    if not callable(h):
        raise ParameterError("h", f"h must be a function of t, got {h!r}")
    ends = _ends(end, pieces, breaks, limit)
    if extra:  # further cuts of a refined schedule (Envelope.refined)
        given = set(breaks)
        ends = _merge(end, list(extra) + ends, [e for e in ends if e in given])
    # h is known only where it is evaluated: CHECK_POINTS evenly spaced points, then on each
    # piece the points of an adaptive Gauss-Kronrod rule (21 at first, more where its error
    # estimate asks). Every value is checked as it comes, so a bad value anywhere seen is
    # refused; a feature between all of those points (a narrow pulse) is not seen.
    checked = [(t, _intensity(h, t)) for t in np.linspace(0.0, end, CHECK_POINTS).tolist()]
    count = [0]

    def square(t: float) -> float:
        count[0] += 1
        v = _intensity(h, t)
        return v * v  # inf where it overflows (refused below), not an OverflowError

    out, start = [], 0.0
    for e in ends:
        value, _ = integrate.quad(square, start, e, limit=200)
        if not math.isfinite(value) or value < 0:
            raise ParameterError("h", f"h: its square does not integrate to a finite value "
                                      f">= 0 on [{start:g}, {e:g}]")
        out.append(math.sqrt(value / (e - start)))
        start = e
    advice = ("give the start and end of what it misses as breaks= (each becomes a piece "
              "end), or more pieces")
    if not warn:
        return out, ends
    if not any(out) and not any(v for _, v in checked):
        warnings.warn(f"h: the envelope is 0: h(t) was 0 at every one of the "
                      f"{count[0] + CHECK_POINTS} points it was sampled at on [0, {end:g}], "
                      f"and a pulse between them is not seen; if h is not 0, {advice}",
                      EnvelopeWarning, stacklevel=4)
    # A checked point inside a piece (not on its ends, where h may step) where h > 0 and the
    # piece came out 0: the quadrature stepped over what the point saw.
    bounds = set(ends) | {0.0}
    for t, v in checked:
        if v > 0 and t not in bounds:
            i = int(np.searchsorted(ends, t))  # ends[i - 1] < t < ends[i]
            if out[i] == 0:
                lo = ends[i - 1] if i else 0.0
                warnings.warn(f"h: h({t:g}) = {v!r} but its piece [{lo:g}, {ends[i]:g}] has "
                              f"intensity 0: the quadrature's points there all missed it (a "
                              f"narrow pulse); {advice}", EnvelopeWarning, stacklevel=4)
                break
    return out, ends


def _three_phase(name: str, h, t1, t2, c, end, pieces, amplitude: bool) -> "Envelope":
    h = _positive("h", h, zero=True)
    t1, t2 = _positive("t1", t1), _positive("t2", t2)
    c = _positive("c", c)
    if t2 < t1:
        raise ParameterError("t2", f"t2 must be >= t1 (the strong phase [t1, t2)), got t1={t1!r}, "
                                   f"t2={t2!r}")
    end = _positive("end", end) if end is not None else t2 + math.log(1e4) / c
    if end <= t1:
        raise ParameterError("end", f"end must be after t1 = {t1!r}, got {end!r}")

    def shape(t: float) -> float:
        if t < t1:
            return (t / t1) ** 2
        if t < t2:
            return 1.0
        return math.exp(-c * (t - t2))

    params = {"h": h, "t1": t1, "t2": t2, "c": c, "end": end}
    if amplitude:
        return Envelope(name, params, pieces, lambda t: h * shape(t), (t1, t2))
    return Envelope(name, params, pieces, lambda t: h * math.sqrt(shape(t)), (t1, t2))


def amin_ang(h: float, t1: float, t2: float, c: float, end: Optional[float] = None,
             pieces: int = 32) -> "Envelope":
    """Amin & Ang's variance envelope: h(t)^2 = h^2 (t / t1)^2 on [0, t1), h^2 on [t1, t2),
    h^2 exp(-c (t - t2)) after, cut at ``end`` (default: where the variance is 1e-4 of the
    strong phase's, t2 + ln(1e4) / c)."""
    return _three_phase("amin_ang", h, t1, t2, c, end, pieces, amplitude=False)


def jennings(h: float, t1: float, t2: float, c: float, end: Optional[float] = None,
             pieces: int = 32) -> "Envelope":
    """Jennings, Housner & Tsai's amplitude envelope: h(t) = h (t / t1)^2 on [0, t1), h on
    [t1, t2), h exp(-c (t - t2)) after, cut at ``end`` (default t2 + ln(1e4) / c, where the
    amplitude is 1e-4 of the strong phase's)."""
    return _three_phase("jennings", h, t1, t2, c, end, pieces, amplitude=True)


def shinozuka_sato(h: float, a: float, b: float, end: Optional[float] = None,
                   pieces: int = 32) -> "Envelope":
    """Shinozuka & Sato's amplitude envelope: h(t) = h (exp(-a t) - exp(-b t)) / peak, b > a > 0,
    1 at its peak t* = ln(b / a) / (b - a); cut at ``end`` (default: where it has fallen to 1e-4
    of its peak, about t* + ln(1e4) / a)."""
    h = _positive("h", h, zero=True)
    a, b = _positive("a", a), _positive("b", b)
    if not b > a:
        raise ParameterError("b", f"b must be > a, got a={a!r}, b={b!r}")
    peak_t = math.log(b / a) / (b - a)
    peak = math.exp(-a * peak_t) - math.exp(-b * peak_t)
    end = _positive("end", end) if end is not None else peak_t + math.log(1e4) / a
    return Envelope("shinozuka_sato", {"h": h, "a": a, "b": b, "end": end}, pieces,
                    lambda t: h * (math.exp(-a * t) - math.exp(-b * t)) / peak, (peak_t,))


def from_function(h: Callable[[float], float], end: float, pieces: int = 32,
                  breaks: Sequence[float] = ()) -> "Envelope":
    """The envelope of an intensity function h(t) >= 0 on [0, end]: ``pieces`` equal pieces
    (and a piece end at each of ``breaks``, where h changes form), each with the root mean
    square of h over it. A function is not plain data: a scene saved with it keeps its pieces
    only.

    h is known only where it is evaluated: at 17 evenly spaced points of [0, end], then on
    each piece at the points of an adaptive Gauss-Kronrod quadrature (21 at first, more where
    its error estimate asks). A feature of h narrower than the spacing of those points (a
    pulse of a millisecond in a piece of a second) can fall between all of them and be
    missed: give its start and end in ``breaks`` (each becomes a piece end, so the feature
    fills pieces of its own), or more pieces. Where h was 0 at every point evaluated, or is
    positive at one of the 17 points in a piece that came out 0, an :class:`EnvelopeWarning`
    says so. A scene given the envelope (``Scene(envelope=...)``) stays an envelope scene
    however few of its pieces are shaken (one, or none): its piece error is estimated and
    nothing of it is reported exact.

    Raises ParameterError (a ValueError) naming ``h`` for an h that is not a function, or
    that returns at a point it is evaluated at anything but a real number (None, a complex
    number, a string, a bool), NaN, an infinity or a negative value; naming ``end``,
    ``pieces`` for a bad argument."""
    if not callable(h):
        raise ParameterError("h", f"h must be a function of t, got {h!r}")
    return Envelope("function", {"end": end}, pieces, h, tuple(breaks))


class Envelope:
    """A smooth intensity envelope and the pieces it is simulated with.

    ``kind``: one of :data:`KINDS` ("amin_ang", "jennings", "shinozuka_sato") or "function";
    ``params``: its arguments (``h``, ``t1``, ``t2``, ``c``, ``end``; or ``h``, ``a``, ``b``,
    ``end``); ``pieces``: the number of equal pieces (the envelope's corners are piece ends
    too). ``h`` and ``t0``: the schedule (lists), computed once. Unpacks as ``h, t0``.
    :meth:`refined` gives the same envelope with more pieces (the piece error's estimate
    runs twice the pieces); :meth:`to_dict` its plain data (not for a function)."""

    def __init__(self, kind: str, params: Mapping[str, Any], pieces: int,
                 function: Optional[Callable[[float], float]], breaks: Sequence[float] = (),
                 _limit: int = MAX_PIECES, _warn: bool = True,
                 _schedule: Optional[Schedule] = None, _extra: Sequence[float] = ()) -> None:
        self.kind = kind
        self.params = dict(params)
        #: h(t); None for a function envelope read back from plain data (its pieces only).
        self.function = function
        self.breaks = tuple(float(b) for b in breaks)
        if _schedule is not None:
            self.h, self.t0 = _schedule
        else:
            # Checks end, pieces and the function's values; warns where a function's pieces
            # may have missed part of it (a named envelope's form is known: h = 0 is all of
            # it).
            self.h, self.t0 = _function_schedule(function, self.params["end"], pieces,
                                                 self.breaks, _limit,
                                                 warn=_warn and kind not in KINDS,
                                                 extra=_extra)
        self.pieces = int(pieces)
        self.params["end"] = float(self.t0[-1])
        #: Whether a run may refine the pieces until their error is within its own
        #: (crandall.pieces); False after :meth:`fixed`: the run keeps these pieces.
        self.refine = True

    def fixed(self) -> "Envelope":
        """The same envelope, run on exactly these pieces (their error still estimated and
        reported, never reduced by the run)."""
        out = copy.copy(self)
        out.refine = False
        return out

    def __iter__(self):
        return iter((self.h, self.t0))

    def refined(self, factor: int = 2) -> "Envelope":
        """The same envelope with ``factor`` times the pieces."""
        if isinstance(factor, bool) or not isinstance(factor, (int, np.integer)) or factor < 1:
            raise ParameterError("factor", f"factor must be an integer >= 1, got {factor!r}")
        if self.function is None:
            raise ParameterError("envelope", "envelope: this function envelope came back from "
                                             "plain data (a saved result, a checkpoint), which "
                                             "keep its pieces, not its function: it cannot be "
                                             "refined, so its piece error is unknown; give "
                                             "envelopes.from_function(...) again")
        # Beyond MAX_PIECES only by refining (the piece error of an envelope given the most).
        pieces = self.pieces * int(factor)
        # Every piece cut into ``factor`` equal ones, whatever made its ends (an equal
        # division, a corner, an output time): the schedules are nested, so their difference
        # is the error of these pieces, not of the ones that happen to be split. Its plain
        # data (kind, pieces) do not rebuild it: it is the estimate's schedule, never a run's.
        starts = (0.0,) + tuple(self.t0[:-1])
        cuts = [a + (b - a) * k / factor for a, b in zip(starts, self.t0)
                for k in range(1, int(factor))]
        # Not warned again: the piece error's run refines the envelope the user was warned of.
        return Envelope(self.kind, self.params, pieces, self.function,
                        self.breaks + tuple(self.t0[:-1]), max(MAX_PIECES, pieces),
                        _warn=False, _extra=cuts)

    def at_times(self, times: Sequence[float]) -> "Envelope":
        """The same envelope with a piece end at each of ``times`` inside (0, end) too (a
        scene's output times: there the pieces have fed in exactly the envelope's noise
        energy, int_0^t h^2 ds, so what is left of the piece error at an output time is the
        timing of that energy within the pieces, which halves at least as fast as the piece
        length, where a piece straddling an output time errs by a share of its whole energy:
        0.023 m against 8e-5 m in the mean distance at 1 s of the cabinet scene, 16 pieces).
        Itself when every such time is a piece end already, or for a function envelope read
        back from plain data (its pieces are all it has)."""
        end = self.params["end"]
        ends = set(self.t0)
        extra = sorted({float(t) for t in times if 0.0 < float(t) < end} - ends)
        if not extra or self.function is None:
            return self
        out = Envelope(self.kind, self.params, self.pieces, self.function,
                       self.breaks + tuple(extra), max(MAX_PIECES, self.pieces), _warn=False)
        out.refine = self.refine
        return out

    @property
    def serializable(self) -> bool:
        """Whether :meth:`to_dict` describes it whole (a named envelope; a function's plain
        data keep its pieces, not the function)."""
        return self.kind in KINDS

    def to_dict(self) -> Dict[str, Any]:
        """The envelope as plain data: ``kind``, its parameters and ``pieces``; for a function
        (kind "function") its pieces too, ``h`` and ``t0``: read back, it is an envelope whose
        piece error is unknown (:meth:`refined` needs the function), never the plain schedule
        of its pieces."""
        fixed = {} if self.refine else {"refine": False}
        if not self.serializable:
            return {"kind": self.kind, **self.params, "pieces": self.pieces,
                    "h": list(self.h), "t0": list(self.t0), **fixed}
        return {"kind": self.kind, **self.params, "pieces": self.pieces, **fixed}

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> "Envelope":
        """Rebuild a named envelope from :meth:`to_dict`'s output (errors name the key)."""
        if not isinstance(data, Mapping):
            raise ParameterError("envelope", "envelope must be a table (kind, its parameters, "
                                             f"pieces), got {data!r}")
        data = dict(data)
        kind = data.pop("kind", None)
        refine = data.pop("refine", True)
        if not isinstance(refine, bool):
            raise ParameterError("envelope.refine", "envelope.refine must be true or false, got "
                                                    f"{refine!r}")
        out = cls._from_pieces(data) if kind == "function" else cls._named(kind, data)
        return out if refine else out.fixed()

    @classmethod
    def _named(cls, kind, data: Dict[str, Any]) -> "Envelope":
        if kind not in KINDS:
            raise ParameterError("envelope.kind", "envelope.kind must be one of "
                                                  f"{', '.join(KINDS)}, got {kind!r}")
        build, keys = KINDS[kind]
        unknown = sorted(set(data) - set(keys) - {"pieces"})
        if unknown:
            raise ParameterError(
                f"envelope.{unknown[0]}", f"envelope.{unknown[0]}: unknown key for kind {kind!r}; "
                f"allowed: {', '.join(keys + ('pieces', 'refine'))}")
        missing = [k for k in keys if k not in data and k != "end"]
        if missing:
            raise ParameterError(
                f"envelope.{missing[0]}", f"envelope.{missing[0]}: missing (kind {kind!r} needs "
                f"{', '.join(k for k in keys if k != 'end')})")
        return build(**data)

    @classmethod
    def _from_pieces(cls, data: Dict[str, Any]) -> "Envelope":
        """A function envelope's plain data read back: its pieces, no function."""
        unknown = sorted(set(data) - {"end", "pieces", "h", "t0"})
        if unknown:
            raise ParameterError(f"envelope.{unknown[0]}", f"envelope.{unknown[0]}: unknown key "
                                                           "for kind 'function'; allowed: end, "
                                                           "pieces, h, t0, refine")
        for key in ("pieces", "h", "t0"):
            if key not in data:
                raise ParameterError(f"envelope.{key}", f"envelope.{key}: missing (kind "
                                                        "'function' needs pieces, h, t0)")
        h, t0 = data["h"], data["t0"]
        if not (isinstance(h, (list, tuple)) and isinstance(t0, (list, tuple)) and h
                and len(h) == len(t0)):
            raise ParameterError("envelope.h, envelope.t0", "envelope.h, envelope.t0: a function "
                                                            "envelope's pieces must be two lists "
                                                            "of one length")
        values = []
        for key, seq in (("h", h), ("t0", t0)):
            for i, v in enumerate(seq):
                if isinstance(v, bool) or not isinstance(v, (int, float)) \
                        or not math.isfinite(v) or v < 0:
                    raise ParameterError(f"envelope.{key}", f"envelope.{key}[{i}] must be a "
                                                            f"finite number >= 0, got {v!r}")
            values.append(tuple(float(v) for v in seq))
        if not all(b > a for a, b in zip((0.0,) + values[1][:-1], values[1])):
            raise ParameterError("envelope.t0", "envelope.t0: the pieces' ends must be > 0 and "
                                                "strictly increasing")
        pieces = data["pieces"]
        if isinstance(pieces, bool) or not isinstance(pieces, int) or pieces < 1:
            raise ParameterError("envelope.pieces", "envelope.pieces must be an integer >= 1, "
                                                    f"got {pieces!r}")
        return cls("function", {"end": values[1][-1]}, pieces, None,
                   _schedule=(list(values[0]), list(values[1])))

    def __eq__(self, other) -> bool:
        if not isinstance(other, Envelope):
            return NotImplemented
        if self.serializable and other.serializable:
            return self.to_dict() == other.to_dict()
        return self is other

    def __hash__(self) -> int:
        return hash((self.kind, tuple(sorted(self.params.items())), self.pieces, self.refine))

    def __repr__(self) -> str:
        args = ", ".join(f"{k}={v!r}" for k, v in self.params.items())
        fixed = "" if self.refine else ", refine=False"
        return f"Envelope({self.kind!r}, {args}, pieces={self.pieces}{fixed})"


#: The named envelopes: kind -> (function, its parameters).
KINDS: Dict[str, Tuple[Callable[..., Envelope], Tuple[str, ...]]] = {
    "amin_ang": (amin_ang, ("h", "t1", "t2", "c", "end")),
    "jennings": (jennings, ("h", "t1", "t2", "c", "end")),
    "shinozuka_sato": (shinozuka_sato, ("h", "a", "b", "end")),
}


def intensity_from_psd(psd: float, sided: str = "two") -> float:
    """The intensity h (m s^-3/2) of white-noise ground acceleration from its power spectral
    density in (m/s^2)^2 per rad/s.

    ``sided="two"``: S0 defined on -inf < omega < inf, the acceleration's autocorrelation
    2 pi S0 delta(tau), so h^2 = 2 pi S0. ``sided="one"``: G0 on omega >= 0 (G0 = 2 S0), so
    h^2 = pi G0. A density per Hz is 2 pi times the density per rad/s: divide it by 2 pi
    first.
    """
    psd = _positive("psd", psd, zero=True)
    # The square roots apart: 2 pi psd overflows for psd > 2.9e307, h never does (<= 3.4e154).
    if sided == "two":
        return math.sqrt(2.0 * math.pi) * math.sqrt(psd)
    if sided == "one":
        return math.sqrt(math.pi) * math.sqrt(psd)
    raise ParameterError("sided", f"sided must be 'one' or 'two', got {sided!r}")
