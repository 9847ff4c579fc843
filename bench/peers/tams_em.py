"""Peer for bench/tails_pytams.py: the sign-drift velocity on Euler-Maruyama paths as a
pytams (trajectory-adaptive multilevel splitting, TAMS) forward model.

A benchmark peer only: pytams is installed into the bench's own environment and is no
dependency of crandall (neither required nor optional); importing this module without it
raises an ImportError that says so.

The model, in the project's scaled units, up to the switch-off time tau0:

    X_{k+1} = X_k - 2 sign(X_k) dt + sqrt(2 dt) N_k,   X_0 = 0,   k = 0, ..., n - 1,  n dt = tau0

and the rare event is the stop time's tail, P(t_s > L) = P(|X(tau0)| >= a) with a = 2 (L - tau0)
(after tau0 the body decelerates at rate 2: t_s = tau0 + |X(tau0)| / 2).

pytams's event is "the score reaches ``targetscore`` before the trajectory's end time" (a
first passage within a horizon), and its levels are the running maxima of the score. This
event sits at the final time, so the score is capped below the target (``cap`` < 1) on
every step before the last, and at the last step it is >= 1 exactly when |X_n| >= a: a
trajectory then "converges" exactly when the event happens, and pytams's estimator
(the splitting weight times the fraction of converged trajectories) estimates P(|X_n| >= a)
by generalised AMS. Scores (``[model] score``):

- ``"committor"`` (the default): 1 - c / (2a), c the small-noise cost of reaching |x| >= a
  at tau0 from (t, x) on a straight line, c = max(0, a - |x| + 2s)^2 / (4s) with s = tau0 - t,
  capped at 2a (the cost of climbing from rest, the stationary tail exp(-2a)); at tau0 it is
  |x| / a on the event and 0 off it. A quasi-potential, so log of the committor up to a
  factor: paths that end below a never have their maximum at the last step.
- ``"velocity"``: |x| / a, blind to time (a path that peaked early and came back scores as
  high as one that is still up).
- ``"stop_time"``: (t + |x| / 2) / L, the stop time if the noise stopped now, over the target
  stop time. It grows with t on every path, so most paths take their maximum at the last step;
  a trajectory branched there is an exact copy of its ancestor (pytams branches at the first
  step above the killed level), the ensemble collapses to clones, and pytams stops with
  "Splitting is stalling". Kept to show that failure.

The state handed to pytams is the pair (k, x): the step counter travels with the state, so
that a branched trajectory knows how far it is from tau0 whatever pytams's float clock says.
The trajectory's ``end_time`` should be (n - 1/2) dt (see :func:`tams_parameters`), so that
pytams's loop ``while t < end_time`` takes exactly n steps despite rounding of n * dt.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

try:
    from pytams.fmodel import ForwardModelBaseClass
except ImportError as exc:  # pragma: no cover - depends on the bench environment
    raise ImportError(
        "bench/peers/tams_em.py needs pytams (pip install pytams), which is installed only "
        "for this benchmark and is not a dependency of crandall") from exc

SCORES = ("committor", "velocity", "stop_time")


class SignDriftEM(ForwardModelBaseClass):
    """dX = -2 sign(X) dt + sqrt(2) dW on [0, tau0], Euler-Maruyama, X(0) = 0; score for
    the event |X(tau0)| >= a = 2 (L - tau0). Parameters (the ``[model]`` table): ``dt``,
    ``steps`` (n, with n dt = tau0), ``level`` (L, the stop-time level), ``score`` (one of
    ``SCORES``), ``cap`` (the score's ceiling before the last step, < 1)."""

    def _init_model(self, m_id: int, params: dict[Any, Any]) -> None:
        p = params["model"]
        self._dt = float(p["dt"])
        self._n = int(p["steps"])
        self._tau0 = self._n * self._dt
        self._level = float(p["level"])
        self._a = 2.0 * (self._level - self._tau0)
        if not self._a > 0.0:
            raise ValueError("the stop-time level must exceed tau0")
        self._kind = p.get("score", "committor")
        if self._kind not in SCORES:
            raise ValueError(f"score must be one of {SCORES}")
        self._cap = float(p.get("cap", 1.0 - 1e-9))
        self._sq = math.sqrt(2.0 * self._dt)
        self._k = 0
        self._x = 0.0
        # Fresh OS entropy for every model instance: pytams makes one per trajectory and per
        # branch (in its worker processes), and its own choice of ancestors is unseeded too.
        self._rng = np.random.default_rng()

    def _advance(self, step: int, time: float, dt: float, noise: Any, need_end_state: bool) -> float:
        if self._k >= self._n:
            raise RuntimeError(f"advanced past tau0 (step {self._k} of {self._n})")
        x = self._x
        drift = -2.0 if x > 0.0 else (2.0 if x < 0.0 else 0.0)
        self._x = x + drift * self._dt + self._sq * float(noise)
        self._k += 1
        return self._dt

    def get_current_state(self) -> tuple[int, float]:
        return (self._k, self._x)

    def set_current_state(self, state: tuple[int, float]) -> None:
        self._k, self._x = int(state[0]), float(state[1])

    def score(self) -> float:
        x = abs(self._x)
        a = self._a
        if self._kind == "committor":
            s = (self._n - self._k) * self._dt
            if self._k >= self._n:
                return x / a if x >= a else 0.0
            u = max(0.0, a - x + 2.0 * s)
            return min(1.0 - min(u * u / (4.0 * s), 2.0 * a) / (2.0 * a), self._cap)
        if self._kind == "stop_time":
            v = (self._k * self._dt + 0.5 * x) / self._level
        else:
            v = x / a
        return v if self._k >= self._n else min(v, self._cap)

    def make_noise(self) -> float:
        return float(self._rng.standard_normal())

    @classmethod
    def name(cls) -> str:
        return "SignDriftEM"


def tams_parameters(*, dt: float, tau0: float, level: float, trajectories: int,
                    max_iterations: int, score: str = "committor",
                    walltime: float = 1e6) -> dict[str, Any]:
    """The pytams input (its TOML tables as a dict) for one TAMS run on this model: in-memory
    database without archived trajectories, the asyncio runner with one worker, target score 1."""
    n = round(tau0 / dt)
    if abs(n * dt - tau0) > 1e-9 * tau0:
        raise ValueError("tau0 must be a multiple of dt")
    return {
        "tams": {"ntrajectories": int(trajectories), "nsplititer": int(max_iterations),
                 "walltime": float(walltime), "loglevel": "WARNING", "deterministic": False},
        "runner": {"type": "asyncio", "nworker_init": 1, "nworker_iter": 1},
        "trajectory": {"end_time": (n - 0.5) * dt, "step_size": dt, "targetscore": 1.0},
        "model": {"dt": dt, "steps": n, "level": level, "score": score},
        "database": {"archive_discarded": False},
    }
