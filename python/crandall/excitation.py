"""What shakes the foundation: a scene's excitation (docs/excitation.md).

A scene's ground acceleration a_g(t) is one of:

- :class:`WhiteNoise` (the default, the paper's): a_g = h(t) xi(t), white noise of intensity
  h(t) (the scene's ``h``, its pieces or its envelope). The body's velocity is then a
  diffusion, which never rests before the noise ends.
- :class:`KanaiTajimi`: white noise filtered by the ground's layer, an oscillator of natural
  frequency ``omega`` and damping ratio ``zeta``,
  ``x'' + 2 zeta omega x' + omega^2 x = -h(t) xi(t)``, ``a_g = -(2 zeta omega x' + omega^2 x)``.
- :class:`CloughPenzien`: the Kanai-Tajimi acceleration passed through a second oscillator
  (``omega_f``, ``zeta_f``) as a high-pass, ``y'' + 2 zeta_f omega_f y' + omega_f^2 y = a_KT``,
  ``a_g = y''``, which removes the Kanai-Tajimi spectrum's finite density at zero frequency
  (and so the ground's unbounded velocity and displacement variances).

A filtered excitation is a linear Gaussian system ``dz = A z dt + b h(t) dW``,
``a_g = c . z``, started at rest (z = 0); :meth:`Filtered.matrices` gives (A, b, c), which
the core steps exactly over any step (Van Loan's matrix exponential, docs/excitation.md).
In every case h(t) is the scene's intensity: ``Scene(h=, t0=)``, its pieces, or its
envelope, which then modulates the driving noise (the usual modulated filtered white noise),
not the filtered acceleration. After the switch-off the driving noise stops and a filter
rings down freely: the ground still moves, ever less.

An excitation names the model effects it adds (:attr:`Excitation.effects`, see
:mod:`crandall.model`): every identity that rests on white noise (the exact velocity step,
the Ito identity of the mean distance, the isometry, the closed forms, the scaling, the
tails' sign-drift model) declines a filtered scene, so no number is labelled exact or taken
from a white-noise formula for it. A filter that rings down after t0 (``ring_down=True``) adds
the effect ``ring_down``, which what rests on the shaking ending at t0 declines (a tail's
splitting).
"""

from __future__ import annotations

import math
import numbers
from dataclasses import dataclass
from typing import Any, Dict, FrozenSet, Optional, Tuple

import numpy as np

from .errors import ParameterError
from .model import FILTERED_EXCITATION as FILTERED
from .model import RING_DOWN

__all__ = ["Excitation", "WhiteNoise", "Filtered", "KanaiTajimi", "CloughPenzien",
           "FILTERED", "from_dict", "psd_intensity"]

def psd_intensity(S0: float) -> float:
    """The intensity h (m s^-3/2) of the driving white noise from its two-sided power
    spectral density S0, in (m/s^2)^2 per rad/s: h^2 = 2 pi S0 (the same conversion as
    :func:`crandall.envelopes.intensity_from_psd` with ``sided="two"``; the Kanai-Tajimi
    acceleration's density is then S0 |H(omega)|^2)."""
    if not _real(S0) or not (math.isfinite(S0) and S0 >= 0):
        raise ParameterError("S0", f"S0 must be finite and >= 0, got {S0!r}")
    return math.sqrt(2.0 * math.pi) * math.sqrt(S0)


def _real(value) -> bool:
    return isinstance(value, numbers.Real) and not isinstance(value, (bool, np.bool_))


def _positive(name: str, value, *, zero: bool = False) -> float:
    if not _real(value) or not math.isfinite(float(value)) or not (
            float(value) > 0 or (zero and float(value) == 0)):
        raise ParameterError(name, f"{name} must be finite and {'>= 0' if zero else '> 0'}, "
                                   f"got {value!r}")
    return float(value)


class Excitation:
    """What shakes the foundation (the base of every kind)."""

    #: The kind's name in plain data (``{"kind": ...}``) and in scene files.
    kind: str = ""

    @property
    def effects(self) -> FrozenSet[str]:
        """The model effects (crandall.model) the excitation adds to a scene."""
        return frozenset()

    @property
    def h(self) -> Optional[float]:
        """The driving intensity the excitation was given with (None: the scene's ``h``)."""
        return None

    def to_dict(self) -> Dict[str, Any]:
        raise NotImplementedError

    def core_options(self) -> Dict[str, Any]:
        """The core's options (``_core.Options`` fields) that this excitation sets."""
        return {}

    def time_scale(self) -> float:
        """The shortest time the excitation varies on (inf for white noise): the default step
        resolves it (crandall.spec.default_dt)."""
        return math.inf


@dataclass(frozen=True)
class WhiteNoise(Excitation):
    """White-noise ground acceleration of the scene's intensity h(t) (the paper's model)."""

    kind = "white"

    def to_dict(self) -> Dict[str, Any]:
        return {"kind": self.kind}


@dataclass(frozen=True)
class Filtered(Excitation):
    """A linear filter of white noise (the base of the filtered kinds)."""

    @property
    def effects(self) -> FrozenSet[str]:
        # The ring-down is an effect of its own: the estimators that rest on the shaking
        # ending at t0 (tails' splitting, model.TAIL_SPLITTING) refuse it through the model.
        return frozenset({FILTERED, RING_DOWN} if self.ring_down else {FILTERED})

    def matrices(self) -> Tuple[Tuple[Tuple[float, ...], ...], Tuple[float, ...], Tuple[float, ...]]:
        """(A, b, c): dz = A z dt + b h(t) dW, a_g = c . z."""
        raise NotImplementedError

    def core_options(self) -> Dict[str, Any]:
        a, b, c = self.matrices()
        out = {"excitation": "filtered", "filter_a": [x for row in a for x in row],
               "filter_b": list(b), "filter_c": list(c)}
        if self.ring_down:
            out["ring_down"] = True
        return out

    def _plain(self, **fields) -> Dict[str, Any]:
        out = {"kind": self.kind, **fields}
        if self.h is not None:
            out["h"] = self.h
        if self.ring_down:
            out["ring_down"] = True
        return out

    def psd(self, omega):
        """The ground acceleration's two-sided power spectral density at angular frequency
        ``omega`` (rad/s), per unit driving density (S0 = 1): |H(i omega)|^2."""
        raise NotImplementedError


def _oscillator(omega: float, zeta: float, name: str):
    return (_positive(f"omega{name}", omega), _positive(f"zeta{name}", zeta))


@dataclass(frozen=True)
class KanaiTajimi(Filtered):
    """Kanai-Tajimi filtered white noise.

    Parameters
    ----------
    omega : float
        The ground layer's natural (angular) frequency, rad/s, > 0 (15.6 rad/s is the value
        Kanai and Tajimi's firm ground is often given).
    zeta : float
        Its damping ratio, > 0 (typically 0.6).
    h : float, optional
        The driving white noise's intensity, m s^-3/2 (or give ``S0``, its two-sided spectral
        density in (m/s^2)^2 per rad/s: h^2 = 2 pi S0). Default: the scene's ``h`` (or its
        envelope), which is then the driving intensity.
    ring_down : bool, default False
        What the scene's switch-off t0 ends: the shaking (False: a_g = 0 from t0 on, as
        under white noise), or only the driving noise (True: the layer rings down freely and
        the ground keeps moving, ever less; the stop is the last time the body comes to rest).
    """

    omega: float
    zeta: float
    h: Optional[float] = None
    S0: Optional[float] = None
    ring_down: bool = False
    kind = "kanai_tajimi"

    def __post_init__(self) -> None:
        omega, zeta = _oscillator(self.omega, self.zeta, "")
        object.__setattr__(self, "omega", omega)
        object.__setattr__(self, "zeta", zeta)
        _intensity(self)

    def matrices(self):
        w, z = self.omega, self.zeta
        return ((0.0, 1.0), (-w * w, -2.0 * z * w)), (0.0, -1.0), (-w * w, -2.0 * z * w)

    def psd(self, omega):
        w2, z = self.omega ** 2, self.zeta
        x2 = omega * omega
        return (w2 * w2 + 4 * z * z * w2 * x2) / ((w2 - x2) ** 2 + 4 * z * z * w2 * x2)

    def to_dict(self) -> Dict[str, Any]:
        return self._plain(omega=self.omega, zeta=self.zeta)

    def time_scale(self) -> float:
        return 1.0 / self.omega


@dataclass(frozen=True)
class CloughPenzien(Filtered):
    """Clough-Penzien filtered white noise: Kanai-Tajimi (``omega``, ``zeta``) followed by a
    second-order high-pass (``omega_f``, ``zeta_f``; typically omega_f = 0.1 omega to 0.2
    omega, zeta_f = zeta). ``h`` or ``S0``, ``ring_down``: as for
    :class:`KanaiTajimi`."""

    omega: float
    zeta: float
    omega_f: float
    zeta_f: float
    h: Optional[float] = None
    S0: Optional[float] = None
    ring_down: bool = False
    kind = "clough_penzien"

    def __post_init__(self) -> None:
        omega, zeta = _oscillator(self.omega, self.zeta, "")
        omega_f, zeta_f = _oscillator(self.omega_f, self.zeta_f, "_f")
        for name, v in (("omega", omega), ("zeta", zeta), ("omega_f", omega_f),
                        ("zeta_f", zeta_f)):
            object.__setattr__(self, name, v)
        _intensity(self)

    def matrices(self):
        w, z, wf, zf = self.omega, self.zeta, self.omega_f, self.zeta_f
        kt = (-w * w, -2.0 * z * w)
        a = ((0.0, 1.0, 0.0, 0.0), kt + (0.0, 0.0), (0.0, 0.0, 0.0, 1.0),
             kt + (-wf * wf, -2.0 * zf * wf))
        return a, (0.0, -1.0, 0.0, 0.0), kt + (-wf * wf, -2.0 * zf * wf)

    def psd(self, omega):
        x2 = omega * omega
        wf2, zf = self.omega_f ** 2, self.zeta_f
        high = x2 * x2 / ((wf2 - x2) ** 2 + 4 * zf * zf * wf2 * x2)
        return KanaiTajimi(self.omega, self.zeta).psd(omega) * high

    def to_dict(self) -> Dict[str, Any]:
        return self._plain(omega=self.omega, zeta=self.zeta, omega_f=self.omega_f,
                           zeta_f=self.zeta_f)

    def time_scale(self) -> float:
        return 1.0 / max(self.omega, self.omega_f)


def _intensity(x) -> None:
    """Sets ``h`` from ``S0`` (one of them at most; the plain data keep h); checks
    ``ring_down``."""
    if not isinstance(x.ring_down, (bool, np.bool_)):
        raise ParameterError("ring_down", f"ring_down must be True or False, got {x.ring_down!r}")
    object.__setattr__(x, "ring_down", bool(x.ring_down))
    if x.h is not None and x.S0 is not None:
        raise ParameterError("h, S0", "h, S0: give one of them (h^2 = 2 pi S0)")
    if x.S0 is not None:
        object.__setattr__(x, "h", psd_intensity(x.S0))
        object.__setattr__(x, "S0", None)
    elif x.h is not None:
        object.__setattr__(x, "h", _positive("h", x.h, zero=True))


KINDS = {k.kind: k for k in (WhiteNoise, KanaiTajimi, CloughPenzien)}


def from_dict(data: Any) -> Excitation:
    """An excitation from its plain data (``to_dict``), or the excitation itself."""
    if isinstance(data, Excitation):
        return data
    if data is None:
        return WhiteNoise()
    if not isinstance(data, dict) or "kind" not in data:
        raise ParameterError("excitation", "excitation must be a crandall excitation "
                             "(WhiteNoise, KanaiTajimi, CloughPenzien) or its plain data "
                             f"{{'kind': ...}}, got {data!r}")
    data = dict(data)
    kind = data.pop("kind")
    if kind not in KINDS:
        raise ParameterError("excitation", f"excitation: unknown kind {kind!r}; one of "
                             f"{', '.join(sorted(KINDS))}")
    try:
        return KINDS[kind](**data)
    except TypeError as exc:
        raise ParameterError("excitation", f"excitation: {exc}") from None
