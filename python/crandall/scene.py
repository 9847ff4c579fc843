"""What to simulate: the body, the excitation, the output times and the observables."""

from __future__ import annotations

import dataclasses
import json
import math
import os
from typing import Any, Dict, Iterable, Mapping, Optional, Sequence, Union

import numpy as np

from . import excitation as _excitation
from . import scene_file
from .bins import bins_to_plain, check_bins, check_distributions
from .errors import ParameterError
from .quantities import DEFAULT_OBSERVE, OBSERVABLES, STOP_QUANTITIES, quantity
from .scene_checks import (_envelope, _noise_pieces, _number, _observe, _scaling, _schedule,
                           _times, envelopes)
from .scene_file import MAX_RANGE_TIMES, RUN_SETTINGS
from .scene_file import SCALED_KEYS as _SCALED_KEYS
from .scene_file import SI_KEYS as _SI_KEYS
from .scene_file import COMMON_KEYS as _COMMON_KEYS

__all__ = ["Scene", "OBSERVABLES", "STOP_QUANTITIES", "RUN_SETTINGS", "MAX_RANGE_TIMES",
           "ParameterError"]


class Scene:
    """A body on a randomly shaken foundation, in physical (SI) units.

    The body's velocity V relative to the foundation obeys (paper eq1)
    ``dV = -mu g sign(V) dt + h dW`` for ``t < t0`` and ``dV = -mu g sign(V) dt`` after,
    starting at rest (or at ``v0``); displacement ``U = u0 + int V dt``, distance
    ``S = int |V| dt``.

    Parameters
    ----------
    mu : float
        Coefficient of kinetic friction, >= 0 (0: a free Brownian body, which never stops).
    ky : float, optional
        Newmark's name for ``mu`` (give one of them): the yield acceleration of a one-way
        sliding block, in units of the scene's ``g``. Under white noise the one-way block's
        downslope displacement is this scene's distance S with ``mu = ky`` (docs/records.md);
        records give ky in standard gravity, so pass ``g=9.80665`` (the default g is 9.81) for
        the same ky g in m s^-2.
    h : float or sequence of float
        Intensity of the white-noise acceleration of the foundation, m s^-3/2, >= 0
        (0: the body stays at rest). A sequence, with ``t0`` a sequence of the same length:
        a piecewise intensity, ``h[i]`` acting on ``[t0[i-1], t0[i])`` (from 0 for i = 0), 0
        for a pause, no noise after the last ``t0`` (crandall.envelopes builds such schedules
        from smooth envelopes). The scene's scaled units and default step are those of the
        largest ``h[i]``.
    t0 : float or sequence of float
        Time the excitation is switched off, s, >= 0; ``math.inf`` for never. A sequence: the
        pieces' ends, > 0 and strictly increasing (finite). Pauses after the last shaken piece
        are the coast after the switch-off: the scene's ``t0`` attribute is the end of the last
        piece with ``h[i] > 0`` (0 if none, and for ``h = 0``), and a body that stops in a
        final pause is located there.
    envelope : crandall.envelopes.Envelope or dict, optional
        In place of ``h`` and ``t0``: a smooth intensity envelope (``envelopes.amin_ang``,
        ``jennings``, ``shinozuka_sato``, ``from_function``, or a named one's plain data
        ``{"kind": ..., its parameters, "pieces": n}``). The scene is simulated exactly on its
        pieces, and the error of the pieces against the envelope (estimated with twice the
        pieces) is in ``Result.bias`` for every statistic (docs/scenes.md), however few of
        its pieces are shaken (one, or none: ``Scene.effects`` keeps ``"envelope"``).
    excitation : crandall.excitation.Excitation or dict, optional
        What shakes the foundation (docs/excitation.md): white noise of intensity ``h`` (the
        default, the paper's model), or filtered white noise, ``crandall.KanaiTajimi(omega=,
        zeta=)`` or ``crandall.CloughPenzien(...)``, whose driving noise has the intensity
        ``h`` (or the envelope: it then modulates the driving noise). The filtered kinds may
        carry the intensity themselves (``KanaiTajimi(omega=, zeta=, h=)`` or ``S0=``), in
        place of the scene's ``h``. Plain data: ``{"kind": "kanai_tajimi", "omega": ...,
        "zeta": ...}``.
    mu_static : float, optional
        Coefficient of static friction, >= mu (default: mu). Under a filtered excitation a
        body at rest stays at rest while the ground's acceleration is at most mu_static g.
        White noise never lets a body rest before it ends, so it is refused there.
    g : float, default 9.81
        Acceleration of gravity, m s^-2, > 0.
    mass : float, default 1.0
        Mass of the body, kg, > 0 (scales the energies only).
    v0 : float, default 0.0
        Velocity of the body relative to the foundation at t = 0, m/s (any sign): a body
        already sliding when the shaking starts.
    u0 : float, default 0.0
        Displacement at t = 0, m: the displacement (and its peaks) are measured from where it
        is recorded, the body starting u0 away. The distance starts at 0.
    times : sequence of float
        Output times, s, strictly increasing, >= 0; may lie beyond t0 and the stop.
    observe : str or sequence of str
        Any of ``OBSERVABLES``: "velocity" (m/s), "displacement" (m), "distance" (m),
        "kinetic_energy" (J), "dissipated_energy" (J, friction loss mu m g S, eq4), "stop" (the
        stop time, s, and the stop values of the other observed quantities), "peaks" (the
        largest speed, "peak_speed", and with the displacement the largest |displacement|,
        "peak_displacement", up to every output time, and over the whole path with "stop").
        Default: all but "peaks" (and without "stop" when the body cannot stop: mu = 0 or t0
        infinite).
    distributions : bool or str or sequence of str, optional
        Ask for the distributions of quantities the scene holds (every one with True): the
        run then keeps a histogram of each at every output time (and at the stop), from which
        :meth:`Result.quantile`, :meth:`Result.exceedance` and :meth:`Result.histogram` come.
        Default None: none (nothing is binned, nothing costs).
    bins : int or mapping, optional
        The histograms' bins (docs/methods/histograms.md). Default: automatic log-linear edges
        from each quantity's scale, ``bins.DEFAULT_PER_OCTAVE`` (128) bins per octave, reaching
        50 scales from 0. An int: that many bins per octave (a power of two, 1 to 4096). A
        mapping from a quantity to an int (its bins per octave) or to a list of edges
        (strictly increasing, in the scene's units; values beyond them are counted in the
        underflow and overflow). The energies take the bins of the distance and the velocity.

    Use :meth:`Scene.scaled` for the paper's dimensionless units (eq3, eq8).

    Attributes
    ----------
    scaling : Scaling or None
        The scaled units of eq8 of this scene; None when mu = 0, h = 0, or when its scales are
        not finite, normal doubles (e.g. mu = 1e-300, h = 1: the friction is then negligible
        over any representable time, and the scene is simulated in SI units only;
        ``Result.moment`` and the analytic comparison are unavailable).

    Raises
    ------
    ValueError
        Naming the parameter: a non-number, NaN, a negative or infinite value, a friction
        deceleration mu g that overflows doubles, or bad ``times`` / ``observe``.
    """

    def __init__(
        self,
        *,
        mu: Optional[float] = None,
        h: Any = None,
        t0: Any = None,
        envelope: Any = None,
        g: float = 9.81,
        mass: float = 1.0,
        v0: float = 0.0,
        u0: float = 0.0,
        times: Iterable[float],
        observe: Optional[Sequence[str]] = None,
        distributions: Any = None,
        bins: Any = None,
        ky: Optional[float] = None,
        excitation: Any = None,
        mu_static: Optional[float] = None,
    ) -> None:
        if mu is not None and ky is not None:
            raise ParameterError("mu, ky", "mu, ky: give one of them (ky is Newmark's name for "
                                           "mu: the yield acceleration in units of g)")
        if mu is None and ky is None:
            raise ParameterError("mu", "mu: missing (or ky, Newmark's name for it)")
        mu = _number("ky", ky) if mu is None else _number("mu", mu)
        excitation = _excitation.from_dict(excitation)
        if excitation.h is not None:
            # The intensity given with the excitation is the scene's h (kept once: the plain
            # data hold it as h, the excitation without it).
            if h is not None or envelope is not None:
                raise ParameterError("h", "h: the excitation carries its intensity "
                                          f"(h = {excitation.h!r}); give it once")
            h = excitation.h
            excitation = dataclasses.replace(excitation, h=None)
        envelope = _envelope(envelope, h, t0)
        if envelope is not None:
            try:
                # Every output time a piece end (Envelope.at_times); bad times are refused
                # below, naming them.
                envelope = envelope.at_times(_times(times, math.inf, ("stop",)))
            except ParameterError:
                pass
            h, t0 = envelope.h, envelope.t0
        elif h is None or t0 is None:
            raise ParameterError("h" if h is None else "t0",
                                 f"{'h' if h is None else 't0'}: missing (give h and t0, or "
                                 "envelope=)")
        hs, ends, piecewise = _schedule(h, t0, "h", "t0")
        # The reference intensity of a piecewise scene (its scaled units, its default step):
        # the largest of its pieces.
        h, t0 = max(hs), ends[-1]
        g = _number("g", g, positive=True)
        mass = _number("mass", mass, positive=True)
        if mu_static is not None:
            mu_static = _number("mu_static", mu_static)
            if mu_static < mu:
                raise ParameterError("mu_static", f"mu_static must be >= mu = {mu!r} (static "
                                     f"friction is at least the kinetic), got {mu_static!r}")
            if mu_static != mu and not excitation.effects:
                raise ParameterError("mu_static", "mu_static: under white noise a body at rest "
                                     "leaves rest at once, so static friction has no effect; "
                                     "it applies with a filtered excitation (excitation=)")
        if not math.isfinite(mu * g):
            raise ParameterError("mu, g", f"mu, g: the friction deceleration mu g = {mu!r} * "
                                          f"{g!r} overflows doubles")
        self._setup(
            units="SI",
            drift=mu * g,
            noise=h,
            t0=t0,
            times=times,
            observe=observe,
            mass=mass,
            params=dict(({"mu": mu, "envelope": envelope.to_dict(), "g": g, "mass": mass}
                         if envelope is not None else
                         {"mu": mu, "h": list(hs) if piecewise else h,
                          "t0": list(ends) if piecewise else t0, "g": g, "mass": mass}),
                        # Only a scene that sets them lists them (the plain data, files and
                        # checkpoints of white-noise scenes stay as they were).
                        **({"excitation": excitation.to_dict()} if excitation.effects else {}),
                        **({"mu_static": mu_static}
                           if mu_static is not None and mu_static != mu else {})),
            scaling=_scaling(mu, h, g),
            pieces=tuple(zip(ends, hs)) if piecewise else None,
            distributions=distributions,
            bins=bins,
            v0=v0,
            u0=u0,
            envelope=envelope,
            excitation=excitation,
            static_drift=(mu_static if mu_static is not None else mu) * g,
        )

    @classmethod
    def scaled(
        cls,
        *,
        tau0: float,
        times: Iterable[float],
        v0: float = 0.0,
        u0: float = 0.0,
        h: Any = None,
        observe: Optional[Sequence[str]] = None,
        distributions: Any = None,
        bins: Any = None,
    ) -> "Scene":
        """A scene in the paper's scaled units (eq3): dU1 = -2 sign(U1) dtau + sqrt(2) dW.

        Times are scaled times tau; velocity is U1, displacement U2, distance U3; kinetic
        energy is U1^2/2 and dissipated energy 2 U3 (both per unit mass, in units of the squared
        velocity scale, so that the energy law eq7 reads E[dissipated energy at stop] = tau0).

        Parameters
        ----------
        tau0 : float
            Scaled switch-off time, >= 0, or ``math.inf``.
        v0, u0 : float, default 0.0
            The initial scaled velocity U1(0) and displacement U2(0).
        h : sequence of float, optional
            A piecewise intensity: with ``tau0`` a sequence of the pieces' ends, ``h[i]`` is
            piece i's intensity relative to the scaled unit (the noise is sqrt(2) h[i]; 1 is
            the paper's intensity, 0 a pause). Default: 1 until ``tau0``.
        times, observe, distributions, bins
            As for :class:`Scene`, in scaled units.
        """
        self = cls.__new__(cls)
        if h is None and not isinstance(tau0, (list, tuple, np.ndarray)):
            hs, ends, piecewise = (1.0,), (_number("tau0", tau0, allow_inf=True),), False
        elif not isinstance(h, (list, tuple, np.ndarray)):
            raise ParameterError("h", "h: in scaled units one intensity is the unit itself; give "
                                      "h only as a sequence, with tau0 the pieces' ends")
        else:
            hs, ends, piecewise = _schedule(1.0 if h is None else h, tau0, "h", "tau0")
        tau0 = ends[-1]
        self._setup(
            units="scaled",
            drift=2.0,
            noise=math.sqrt(2.0),
            t0=tau0,
            times=times,
            observe=observe,
            mass=1.0,
            params={"tau0": list(ends), "h": list(hs)} if piecewise else {"tau0": tau0},
            scaling=None,
            pieces=tuple((e, math.sqrt(2.0) * x) for e, x in zip(ends, hs)) if piecewise else None,
            distributions=distributions,
            bins=bins,
            v0=v0,
            u0=u0,
        )
        return self

    def _setup(self, *, units, drift, noise, t0, times, observe, mass, params, scaling,
               distributions=None, bins=None, v0=0.0, u0=0.0, pieces=None, envelope=None,
               excitation=None, static_drift=None):
        v0 = _number("v0", v0, signed=True)
        u0 = _number("u0", u0, signed=True)
        # Only a scene that starts away from rest at the origin lists its start (the plain
        # data, and so the checkpoints and files, of other scenes stay as they were).
        params = dict(params)
        if v0 != 0.0:
            params["v0"] = v0
        if u0 != 0.0:
            params["u0"] = u0
        #: A piecewise intensity: ((end, noise), ...) in the scene's units (noise in the core's
        #: sense: h, or sqrt(2) times the relative intensity in scaled units); None: ``noise``
        #: until ``t0``.
        if pieces is not None:
            noise = max(n for _, n in pieces) if units == "SI" else noise
            pieces, t0 = _noise_pieces(pieces, noise)
        elif noise == 0:
            # One intensity of 0 is the schedule h = [0]: no noise ever, so the noise ends at
            # 0 and the body coasts from its start (the stop located where its speed runs
            # out, not at the given t0); the plain data keep the t0 given.
            t0 = 0.0
        self.pieces = pieces
        #: The smooth envelope (crandall.envelopes.Envelope) the pieces stand for, or None:
        #: its piece error is estimated by halving the pieces (Result.bias). Kept whatever its
        #: pieces came to: an envelope left with one shaken piece (run as the one-intensity
        #: scene) or none is still approximated by its pieces, not the paper's scene.
        self.envelope = envelope
        #: What shakes the foundation (crandall.excitation): white noise of the scene's
        #: intensity (the paper's), or a filter of it.
        self.excitation = excitation if excitation is not None else _excitation.WhiteNoise()
        #: The static friction deceleration mu_static g (>= drift): a body at rest under a
        #: filtered excitation stays at rest while |a_g| <= static_drift.
        self.static_drift = float(drift if static_drift is None else static_drift)
        # Without friction a body that moves never stops; one at rest with no noise has
        # stopped.
        silent = noise == 0 and (pieces is None or all(n == 0 for _, n in pieces))
        can_stop = math.isfinite(t0) and (drift > 0 or (silent and v0 == 0.0))
        if observe is None:
            observe = (DEFAULT_OBSERVE if can_stop
                       else tuple(n for n in DEFAULT_OBSERVE if n != "stop"))
        observe = _observe(observe)
        if "stop" in observe and not math.isfinite(t0):
            name = "t0" if units == "SI" else "tau0"
            raise ParameterError("observe", f"observe: 'stop' needs a finite {name}: the "
                                            "excitation never ends")
        if "stop" in observe and not can_stop:
            raise ParameterError("observe", "observe: 'stop' needs mu > 0: without friction the "
                                            "body never stops")
        #: The state at t = 0: velocity and displacement, in the scene's units.
        self.v0 = float(v0)
        self.u0 = float(u0)
        self.units = units
        self.drift = float(drift)
        self.noise = float(noise)
        self.t0 = float(t0)
        self.times = _times(times, t0, observe)
        self.times.setflags(write=False)
        self.observe = observe
        self.mass = float(mass)
        self.params = dict(params)
        self.scaling = scaling
        #: The quantities whose distributions the run keeps (table order; empty: none).
        self.distributions = check_distributions(distributions, observe)
        #: (bins per octave of the automatic edges, per-quantity settings), checked.
        self.bin_settings = check_bins(bins, self.distributions, self.t0)
        #: Run settings (paths, seed, method, dt) read from a scene file; empty otherwise.
        #: ``crandall run`` uses them unless its options override them.
        self.run_settings: Dict[str, Any] = {}

    # -- files and dictionaries -----------------------------------------------------------

    def to_dict(self) -> Dict[str, Any]:
        """The scene as plain data (JSON-able; ``inf`` for a switch-off that never comes).

        ``Scene.from_dict(scene.to_dict())`` rebuilds an equal scene; results and checkpoints
        store a scene this way.
        """
        out: Dict[str, Any] = {"units": self.units}
        out.update(self.params)
        out["times"] = [float(t) for t in self.times]
        out["observe"] = list(self.observe)
        # Only when asked: the dictionaries (and checkpoint identities) of scenes without
        # distributions stay as they were.
        if self.distributions:
            out["distributions"] = list(self.distributions)
            plain = self.bins
            if plain is not None:
                out["bins"] = plain
        return out

    @property
    def effects(self) -> frozenset:
        """The effects this scene holds beyond the paper's (a body at rest at the origin, one
        constant intensity until t0): ``"initial_state"`` when it starts with a velocity or a
        displacement, ``"piecewise_intensity"`` when it is shaken by pieces of different
        intensities (or pauses between them), ``"envelope"`` when it is given as a smooth
        envelope (``Scene(envelope=...)``, however few pieces remain shaken),
        ``"filtered_excitation"`` when the ground acceleration is a filter of the noise
        (``Scene(excitation=KanaiTajimi(...))``), with ``"ring_down"`` when its filter rings
        on after t0 (``ring_down=True``), ``"static_friction"`` when ``mu_static`` exceeds
        ``mu``. Each identity or closed form that crandall uses lists the effects it
        still holds under (:mod:`crandall.model`) and is used only for scenes whose effects it
        supports."""
        out = set()
        if self.v0 != 0.0 or self.u0 != 0.0:
            out.add("initial_state")
        if self.pieces is not None:
            out.add("piecewise_intensity")
        if self.envelope is not None:
            out.add("envelope")
        out |= self.excitation.effects
        if self.static_drift > self.drift:
            out.add("static_friction")
        return frozenset(out)

    def with_intensity(self, *, envelope=None, h=None, t0=None,
                       distributions: bool = True) -> "Scene":
        """The same scene (friction, excitation, start, times, observables) shaken by another
        intensity: an envelope, or ``h`` and ``t0`` (a schedule). The one place the envelope's
        refinements and the bias estimate's schedules are made, so that every field of the
        scene reaches them. ``distributions=False`` leaves out the distributions and bins."""
        if self.units != "SI":
            raise ValueError("with_intensity: a physical (SI) scene only")
        p = {k: v for k, v in self.params.items() if k not in ("h", "t0", "envelope")}
        if envelope is not None:
            p["envelope"] = envelope
        else:
            p["h"], p["t0"] = h, t0
        extra = ({"distributions": self.distributions, "bins": self.bins}
                 if distributions else {})
        return type(self)(**p, times=self.times, observe=self.observe, **extra)

    @property
    def bins(self):
        """The scene's ``bins`` as plain data: None (automatic, the default resolution), an
        int (bins per octave) or a dict of quantity names to ints or lists of edges."""
        return bins_to_plain(*self.bin_settings)

    @classmethod
    def from_dict(cls, data: Dict[str, Any]) -> "Scene":
        """Rebuild a scene from :meth:`to_dict`'s output.

        Raises
        ------
        ValueError
            If ``data`` is not a mapping, ``units`` is not "SI" or "scaled", a key is missing
            or unknown, or a value is bad (the message names the key).
        """
        if not isinstance(data, Mapping):
            raise ParameterError("data", "data must be a dict (Scene.to_dict()), got "
                                         f"{type(data).__name__}")
        data = dict(data)
        units = data.pop("units", None)
        if units == "SI":
            keys, required = _SI_KEYS + _COMMON_KEYS, (
                ("mu", "envelope", "times") if "envelope" in data else ("mu", "h", "t0", "times"))
        elif units == "scaled":
            keys, required = _SCALED_KEYS + _COMMON_KEYS, ("tau0", "times")
        else:
            raise ParameterError("units", f"units must be 'SI' or 'scaled', got {units!r}")
        for k in data:
            if k not in keys:
                raise ParameterError(k, f"{k}: unknown key for units = {units!r}; allowed: "
                                        f"{', '.join(keys)}")
        for k in required:
            if k not in data:
                raise ParameterError(k, f"{k}: missing (units = {units!r} needs "
                                        f"{', '.join(required)})")
        return cls(**data) if units == "SI" else cls.scaled(**data)

    @classmethod
    def from_toml(cls, path: Union[str, "os.PathLike[str]"]) -> "Scene":
        """Read a scene from a TOML file.

        The file has a ``[scene]`` table and an optional ``[run]`` table::

            title = "A 100 kg crate on a truck bed"   # optional, free text
            [scene]
            units = "SI"             # or "scaled" (the paper's units, eq3)
            mu = 0.3                 # SI: mu, h, t0, and optionally g, mass
            h = 1.0
            t0 = 2.0                 # inf (TOML's infinity) for never
            mass = 100.0
            times = [0.5, 1.0, 2.0]  # or a range {start, stop, num} or {start, stop, step}
            observe = ["velocity", "distance", "stop"]   # optional; default all but "peaks"
            distributions = ["distance_at_stop"]   # optional; true for every quantity
            bins = 64                # optional: bins per octave, or a table
                                     # {distance_at_stop = [0.0, 0.5, 1.0, 2.0]}
            [run]                    # optional: defaults for simulate / crandall run
            paths = 100_000
            seed = 1
            method = "exact"
            dt = 0.001

        An SI scene may give ``h`` and ``t0`` as lists (a piecewise intensity), or instead an
        envelope table, ``envelope = { kind = "amin_ang", h = 0.6, t1 = 2.0, t2 = 8.0,
        c = 0.4, pieces = 16 }`` (kinds and parameters: ``crandall.envelopes.KINDS``).
        A scaled scene has ``tau0`` instead of ``mu, h, t0, g, mass``. A range includes its
        ``stop``: ``{start = 0.5, stop = 2.0, num = 4}`` is 0.5, 1.0, 1.5, 2.0, as is
        ``{start = 0.5, stop = 2.0, step = 0.5}``.

        Parameters
        ----------
        path : str or os.PathLike
            The TOML file, or the name of a scene shipped with crandall (``"crate"``,
            ``"cabinet_amin_ang"``, ...: :meth:`Scene.shipped` lists them), used when no file
            of that name exists here.

        Returns
        -------
        Scene
            With :attr:`run_settings` holding the ``[run]`` table (keys among ``RUN_SETTINGS``).

        Raises
        ------
        ValueError
            If the file cannot be read or parsed, or a key is missing, unknown or has a bad
            value: the message names the file, the key and what is wrong.
        """
        parsed = scene_file.read(scene_file.locate(path))
        try:
            scene = cls(**parsed.kwargs) if parsed.units == "SI" else cls.scaled(**parsed.kwargs)
        except ValueError as exc:
            raise parsed.error_of(exc) from None
        scene.run_settings = parsed.run_settings()
        return scene

    @staticmethod
    def shipped() -> Dict[str, str]:
        """The scenes shipped with crandall: name -> title, for :meth:`from_toml` (and
        ``crandall run NAME``)."""
        return {name: scene_file.title(path) for name, path in scene_file.shipped().items()}

    @property
    def time_name(self) -> str:
        return "t" if self.units == "SI" else "tau"

    def units_of(self, name: str) -> str:
        """Units of an observable or stop quantity in this scene ("" in scaled units)."""
        if self.units == "scaled":
            return ""
        return quantity(name).si_unit

    def __eq__(self, other) -> bool:
        """Scenes are equal when their plain data (:meth:`to_dict`) are: the same model,
        times, observables, distributions and bins (not the run settings of a file)."""
        if not isinstance(other, Scene):
            return NotImplemented
        return self.to_dict() == other.to_dict()

    def __hash__(self) -> int:
        return hash(json.dumps(self.to_dict(), sort_keys=True))

    def __repr__(self) -> str:
        args = ", ".join(f"{k}={v!r}" for k, v in self.params.items())
        ctor = "Scene" if self.units == "SI" else "Scene.scaled"
        extra = ""
        if self.distributions:
            extra = f", distributions={list(self.distributions)!r}"
            if self.bins is not None:
                extra += f", bins={self.bins!r}"
        return (f"{ctor}({args}, times=<{self.times.size} times>, "
                f"observe={list(self.observe)!r}{extra})")
