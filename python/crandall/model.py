"""Model features: the effects a scene holds beyond the paper's, and the identities and
formulas that may be used for it.

The paper's scene is a body at rest at the origin on a foundation shaken by white noise of
one constant intensity, switched off once (Berezin & Zayats). Several numbers crandall reports
rest on that: the mean distance through the Ito identity E S(t) = (sigma^2 min(t, t0) -
E V(t)^2) / (2 c), the mean distance at the stop sigma^2 t0 / (2 c), the analytic layer's
closed forms. A scene that holds more (an initial state, a piecewise intensity, ...) names
each extra effect in :attr:`crandall.Scene.effects`; every identity below lists the effects
under which it still holds, and is used only for scenes whose effects it all supports.
Otherwise the estimator falls back to simulating the quantity (with its bias estimated) and
nothing is reported exact for it. The core likewise lists the effects it simulates, and a
scene with an effect it does not simulate is refused before any path is drawn.

To add an effect: give it a name here, let the scenes that hold it list it in ``effects``,
add it to :data:`SIMULATED` once the core steps it, and to the ``supports`` of each identity
proven to hold with it (with a test against the simulation).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import FrozenSet

from .errors import ParameterError
from .quantities import DISTANCE, VELOCITY, quantity

__all__ = ["Identity", "INITIAL_STATE", "PIECEWISE_INTENSITY", "ENVELOPE", "SCHEDULE", "exact", "ito_constant", "noise_energy", "EXACT_STEP", "ITO_DISTANCE", "ISOMETRY", "ZERO_FRICTION", "ANALYTIC", "SCALING", "SIMULATED",
           "FILTERED_EXCITATION", "STATIC_FRICTION", "RING_DOWN", "LEVELS", "FILTERED_LEVELS", "TAIL_MODEL", "TAIL_SPLITTING", "MOVING_AT_SWITCH_OFF", "GRID_ORDERS", "require", "holds", "isometry_applies", "check_simulated", "exact_in_law"]


#: The body starts with a velocity v0 or a displacement u0 (Scene(v0=, u0=)).
INITIAL_STATE = "initial_state"
#: The intensity is piecewise constant (Scene(h=[...], t0=[...])): pauses, envelopes,
#: aftershocks.
PIECEWISE_INTENSITY = "piecewise_intensity"
#: The pieces stand for a smooth envelope (Scene(envelope=...)): the scene's intensity is the
#: envelope, which the pieces only approximate.
ENVELOPE = "envelope"
#: The ground acceleration is a linear filter of white noise (Scene(excitation=KanaiTajimi(...)),
#: crandall.excitation): the body's velocity is no longer a diffusion, it sticks and slips.
FILTERED_EXCITATION = "filtered_excitation"
#: Static friction above the kinetic (Scene(mu_static=)): a body at rest stays at rest while
#: the ground's acceleration is at most mu_static g (with a filtered excitation only).
STATIC_FRICTION = "static_friction"
#: The switch-off ends only a filtered excitation's driving noise (KanaiTajimi(...,
#: ring_down=True)): the filter rings on after t0, so the ground keeps moving, ever less, and
#: the stop is the last time the body comes to rest. Without it a_g = 0 from t0 on.
RING_DOWN = "ring_down"


@dataclass(frozen=True)
class Identity:
    """A shortcut, an exactness claim or a closed form, and the extra effects it holds under."""

    name: str
    #: What it states.
    what: str
    #: The scene effects (beyond the paper's scene) under which it still holds.
    supports: FrozenSet[str] = frozenset()


#: The velocity's step is exact in law from any state, so the statistics of the velocity at
#: the output times, of functions of it (the kinetic energy) and of the stop time have no step
#: bias.
EXACT_STEP = Identity(
    "exact_step", "statistics of the velocity, the kinetic energy and the stop time are exact "
    "in law at any step (no step bias)",
    frozenset({INITIAL_STATE, PIECEWISE_INTENSITY, ENVELOPE}))
#: The mean distance from the velocity's second moment (Ito's formula for V^2 with the energy
#: balance, from any start, under any intensity schedule): E S(t) = (v0^2 + int_0^t sigma^2
#: - E V(t)^2) / (2 c), and at the stop (V = 0) the constant (v0^2 + int sigma^2) / (2 c).
#: :func:`ito_constant` gives the numerator's constant part.
ITO_DISTANCE = Identity(
    "ito_distance", "E S(t) = (v0^2 + int_0^t sigma(s)^2 ds - E V(t)^2) / (2 c), and "
    "(v0^2 + int sigma^2) / (2 c) at the stop",
    frozenset({INITIAL_STATE, PIECEWISE_INTENSITY, ENVELOPE}))
#: The variance of the distance at the stop from the velocity alone (Ito's isometry): by Ito's
#: formula c S(t_s) = (v0^2 + int sigma^2) / 2 + int_0^t0 sigma V dW, so
#: Var S(t_s) = E int_0^t0 sigma(t)^2 V(t)^2 dt / c^2, from any start and under any intensity
#: schedule (V(t_s) = 0 at the stop, and the noise's work after t0 is 0). A run to an accuracy
#: estimates it from that integral, whose per-path variance is far smaller than that of
#: (S(t_s) - E S(t_s))^2; the integral keeps a grid bias (the trapezoid rule), which the
#: levels estimate as for any integral.
ISOMETRY = Identity(
    "isometry", "Var S(t_s) = E int_0^t0 sigma(t)^2 V(t)^2 dt / c^2",
    frozenset({INITIAL_STATE, PIECEWISE_INTENSITY, ENVELOPE}))
#: Without friction the dissipated energy is 0 on every path.
ZERO_FRICTION = Identity(
    "zero_friction", "without friction (mu = 0) the dissipated energy is 0 on every path",
    frozenset({INITIAL_STATE, PIECEWISE_INTENSITY, ENVELOPE, FILTERED_EXCITATION,
               STATIC_FRICTION, RING_DOWN}))
#: The simulated schedule is the scene's intensity. Not for an envelope: its pieces keep the
#: envelope's mean h^2 on each piece but not its law, so a statistic of the pieces (even one
#: exact in law for them) differs from the envelope's by the piece error, which
#: crandall.bias estimates by halving the pieces and reports in the bias. A ring-down changes
#: what happens after the pieces, not the pieces.
SCHEDULE = Identity(
    "schedule", "the simulated pieces are the scene's intensity (not an envelope's "
    "approximation)", frozenset({INITIAL_STATE, PIECEWISE_INTENSITY, FILTERED_EXCITATION,
                                 STATIC_FRICTION, RING_DOWN}))
#: The analytic layer's closed forms (crandall.analytic): the paper's scene only.
ANALYTIC = Identity("analytic", "the closed forms of crandall.analytic (the paper's scene)")

#: The scaling of eq8: t = tau 2 h^2 / c^2, V = U1 h^2 / c, U and S = U2, U3 times 2 h^4 / c^3
#: (c = mu g). From rest under one intensity h until t0, the scaled motion is the paper's
#: eq3 with tau0 = t0 c^2 / (2 h^2) alone, so P(Q > q) of any quantity depends on q over its
#: scale and on tau0 only (for the distance: on d c^3 / h^4 and t0 c^2 / h^2). Grid points
#: (h, mu) with the same tau0 are one scaled run (crandall.fragility shares it). Not for a
#: start in motion (v0 / (h^2 / c) is one more number), a piecewise schedule (its pieces'
#: relative intensities and ends are more) or an envelope (its shape's times are more).
SCALING = Identity(
    "scaling", "from rest under one intensity, P(Q > q) depends on q over its scaled unit "
    "and on tau0 = t0 (mu g)^2 / (2 h^2) only")

#: The body is in motion at the switch-off (white noise never lets it rest before), so the
#: stop comes at or after t0: the stop time, kept from the switch-off, is >= 0. Under a
#: filtered excitation a body may rest for good before t0 (its stop time is then earlier).
MOVING_AT_SWITCH_OFF = Identity(
    "moving_at_switch_off", "the stop comes at or after the switch-off t0",
    frozenset({INITIAL_STATE, PIECEWISE_INTENSITY, ENVELOPE}))
#: The grid bias of the white-noise skeleton's statistics expands as c1 h^1.5 + c2 h^2
#: (docs/methods/richardson.md): the Richardson methods' weights and the fixed-step bias
#: estimate (crandall.bias) extrapolate with these orders. A filtered excitation's bias (its
#: events located on substeps) has orders of its own, which the bias estimate measures.
GRID_ORDERS = Identity(
    "grid_orders", "the grid bias expands as c1 h^1.5 + c2 h^2 (the white-noise skeleton)",
    frozenset({INITIAL_STATE, PIECEWISE_INTENSITY, ENVELOPE}))
#: Runs to an accuracy (crandall.adaptive): their levels' bias order (ALPHA), their exact
#: and Ito targets and their control variates are those of the white-noise skeleton.
LEVELS = Identity(
    "levels", "runs to an accuracy: the multilevel estimator built on the white-noise "
    "skeleton", frozenset({INITIAL_STATE, PIECEWISE_INTENSITY, ENVELOPE}))
#: Runs to an accuracy of a filtered excitation (crandall.adaptive): levels on the filtered
#: core's exactly coupled grids (the same noise tree on every grid), no control variates and
#: no exact or Ito targets (none holds there), the bias from the measured ratio of the finest
#: levels' means, first order where it is not resolved (docs/methods/adaptive.md). An envelope's
#: pieces are chosen and their error estimated by coupled runs of the filtered core (crandall.pieces,
#: bias.piece_method), as for white noise. A ring-down is walked by the same coupled grids (the
#: stop located with its decay bound on each), and nothing of the estimator assumes a_g = 0
#: after t0.
FILTERED_LEVELS = Identity(
    "filtered_levels", "runs to an accuracy: the multilevel estimator on the filtered core's "
    "coupled grids, its bias from the measured order of the finest levels",
    frozenset({FILTERED_EXCITATION, STATIC_FRICTION, INITIAL_STATE, PIECEWISE_INTENSITY, ENVELOPE,
               RING_DOWN}))
#: Tail probabilities (crandall.tail), the sign-drift parts: the velocity is a diffusion whose
#: drift is -c sign(V), with its transition density (importance sampling's weights), the
#: normalised splitting score and its formulas, and crandall.paths' white-noise steps.
TAIL_MODEL = Identity(
    "tail_model", "tail probabilities: the velocity is a diffusion with drift -c sign(V) "
    "(its scores, coast and transition density)",
    frozenset({INITIAL_STATE, PIECEWISE_INTENSITY, ENVELOPE}))
#: Tail probabilities by splitting (crandall.tail): the body's state on the grid, with the
#: filter's under a filtered excitation, is Markov, so a path can be continued from any grid
#: point with fresh noise; the shaking ends at t0 (a_g = 0 after it), so the coast after the
#: grid is the deceleration c as under white noise. Not with a ring-down (RING_DOWN): the
#: filter's acceleration after t0 would move the body on, and the tail's scores (the stop
#: time, the velocity after the grid, where the body stops) would no longer end at the
#: quantity.
TAIL_SPLITTING = Identity(
    "tail_splitting", "tail probabilities by splitting: the state on the grid is Markov, and "
    "the shaking ends at t0 (no filter ringing on after it), so the coast after the grid is "
    "the deceleration mu g",
    frozenset({INITIAL_STATE, PIECEWISE_INTENSITY, ENVELOPE, FILTERED_EXCITATION,
               STATIC_FRICTION}))

#: The effects the core simulates: a start from any state, a piecewise intensity (no step
#: straddles a piece's end), also as an envelope's pieces, and a filtered excitation with
#: static friction and its ring-down (its exact Gaussian skeleton, cpp/src/filtered.cpp).
SIMULATED: FrozenSet[str] = frozenset({INITIAL_STATE, PIECEWISE_INTENSITY, ENVELOPE,
                                       FILTERED_EXCITATION, STATIC_FRICTION, RING_DOWN})


def isometry_applies(q, scene) -> bool:
    """Whether the variance of quantity ``q`` may be taken through :data:`ISOMETRY`: the
    distance at the stop or a constant times it (the dissipated energy), on a scene with
    friction whose effects the isometry supports."""
    return (q.variable == DISTANCE and q.at_stop and q.power == 1 and not q.magnitude
            and scene.drift > 0 and holds(scene, ISOMETRY))


def require(scene, identity: Identity, what: str) -> None:
    """Refuse, naming ``scene`` and the effects, a scene for which ``what`` (an estimator or
    a formula resting on ``identity``) does not hold."""
    missing = sorted(frozenset(scene.effects) - identity.supports)
    if missing:
        raise ParameterError("scene", f"scene: {what} is not available for a scene with "
                             f"{', '.join(missing)} ({identity.what} does not hold there)")


def holds(scene, identity: Identity) -> bool:
    """Whether ``identity`` may be used for ``scene``: it supports every effect the scene holds."""
    return frozenset(scene.effects) <= identity.supports


def check_simulated(scene) -> None:
    """Refuse, naming the effects, a scene that holds an effect the core does not simulate
    (its paths would be the paper's scene's, silently): a :class:`ParameterError` naming
    ``scene``. Every entry point reaches it through :func:`crandall.spec.check_scene`."""
    missing = sorted(frozenset(scene.effects) - SIMULATED)
    if missing:
        raise ParameterError("scene", f"scene: holds {', '.join(missing)}, which this crandall "
                             "does not simulate")


def exact_in_law(name: str, scene) -> bool:
    """Whether every statistic of the quantity is exact at any step for this scene: a function
    of the velocity at the output times, or the stop time (not the peaks, maxima over the
    grid), where :data:`EXACT_STEP` holds."""
    q = quantity(name)
    return q.variable == VELOCITY and not q.peak and holds(scene, EXACT_STEP)


def exact(name: str, scene) -> bool:
    """Whether every statistic of the quantity is exact for the scene as stated: exact in law
    at any step (:func:`exact_in_law`) and simulated on the scene's own intensity
    (:data:`SCHEDULE`; an envelope's pieces are an approximation)."""
    return exact_in_law(name, scene) and holds(scene, SCHEDULE)


def ito_constant(scene, elapsed: float) -> float:
    """The constant part v0^2 + int_0^elapsed sigma(s)^2 ds of :data:`ITO_DISTANCE`'s
    numerator, with ``elapsed`` the time so far (min(t, t0))."""
    return scene.v0 ** 2 + noise_energy(scene, elapsed)


def noise_energy(scene, until: float) -> float:
    """int_0^until sigma(s)^2 ds: twice the energy per unit mass the noise has fed in by
    ``until`` (at most the last switch-off)."""
    if scene.pieces is None:
        return scene.noise ** 2 * until
    total, start = 0.0, 0.0
    for end, noise in scene.pieces:
        if until > start:
            total += noise ** 2 * (min(end, until) - start)
        start = end
    return total
