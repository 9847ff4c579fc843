"""The filtered excitation's event search (bridges in noise space, docs/filtered.md) against
independent numbers: the mean distance at the stop against fine-step Euler anchors, and a_g over
every point of the trajectories (bridge points included) against the filter's stationary law.

Before the noise-space bridges, Kanai-Tajimi at omega = 0.5 (omega L from 1e-2 down to 4e-5 in
the bisection) gave a_g ~ 1e3 at bridge points and a mean distance at the stop of 1.0x the
white-noise value instead of 0.168x."""

import math

import numpy as np
import pytest
from scipy.linalg import expm, solve_continuous_lyapunov

import crandall
from crandall import KanaiTajimi, Scene, _core, engine
from crandall.spec import RunSpec

ZETA = 0.6
T0 = 10.0
WHITE = 1.0 ** 2 * T0 / (2 * 1.0 * 1.0)  # h^2 t0 / (2 mu g): the white-noise mean distance


def _scene(omega):
    return Scene(mu=1.0, g=1.0, excitation=KanaiTajimi(omega=omega, zeta=ZETA, h=1.0), t0=T0,
                 times=[5.0, 10.0])


# Independent anchors: an explicit Euler simulation of the same model (Kanai-Tajimi state, the
# body's stick/slip), 32,000 paths at dt = 2.5e-4 s: mean distance at the stop / WHITE and its
# standard error. Euler's own step bias there is a few 1e-3, hence the extra 0.01 below.
ANCHORS = {2.0: (0.776, 0.003), 0.5: (0.168, 0.002)}


@pytest.mark.parametrize("omega", sorted(ANCHORS))
def test_distance_at_stop_matches_fine_euler(omega):
    r = crandall.simulate(_scene(omega), paths=8000, seed=20240611)
    ratio = float(r.mean("distance_at_stop")) / WHITE
    se = float(r.stderr("distance_at_stop")) / WHITE  # about 0.006 (omega 2), 0.0045 (0.5)
    anchor, se_anchor = ANCHORS[omega]
    # 3 combined standard errors, plus 0.01 for the anchor's Euler step bias.
    assert abs(ratio - anchor) <= 3 * math.hypot(se, se_anchor) + 0.01, (ratio, se, anchor)


# The white-noise limit (omega t* = 64, t* = 2 s: omega = 32). The same explicit Euler model
# (bench/peers/numba_kt.py, seed 7) on 20,000 paths, coupled at dt = 1.25e-4 and 2.5e-4 s: mean
# distance at the stop / WHITE 1.02665 and 1.02705 +- 0.0030, extrapolated to dt -> 0 (first order)
# 1.0263. It is within 3 % of the white-noise energy law but does not close on it (1.0268 at
# omega t* = 16 in the same run; docs/filtered.md, "The white-noise limit").
WHITE_LIMIT = (32.0, 1.0263, 0.0030)


def test_distance_at_stop_nears_the_white_noise_law_at_large_omega():
    omega, anchor, se_anchor = WHITE_LIMIT
    r = crandall.simulate(_scene(omega), paths=8000, seed=20240612)
    ratio = float(r.mean("distance_at_stop")) / WHITE
    se = float(r.stderr("distance_at_stop")) / WHITE  # about 0.0047
    # Against the Euler anchor: 3 combined standard errors plus its extrapolation's residual
    # (the coupled difference 4e-4 is resolved to 2e-6; 4e-4 more covers a second-order part).
    assert abs(ratio - anchor) <= 3 * math.hypot(se, se_anchor) + 4e-4, (ratio, se)
    # The white-noise law h^2 t0 / (2 mu g), within 3 % (at 3 standard errors).
    assert abs(ratio - 1.0) <= 0.03 + 3 * se, (ratio, se)


@pytest.mark.parametrize("omega, paths", [(2.0, 500), (0.5, 1500)])
def test_ground_acceleration_over_every_point_has_the_stationary_spread(omega, paths):
    # a_g over t in [5, 10] of every path, at every point the walk computed (skeleton points,
    # bridge points of the event search, rest times). The points are weighted by the time
    # their linear pieces span (the integral of the piecewise-linear a_g^2): an unweighted sd
    # over the points is biased even for an exact path, because the search puts its points
    # where an event is possible, i.e. selected by a_g itself (about 1.11 against 1.43 at
    # omega = 2, 0.92 against 0.71 at omega = 0.5). The linear interpolation between skeleton
    # points (dt 0.02) loses about (2 zeta omega)^2 dt / 6 of the variance, < 1 %.
    a = np.array([[0.0, 1.0], [-omega ** 2, -2 * ZETA * omega]])
    b = np.array([[0.0], [-1.0]])
    c = np.array([-omega ** 2, -2 * ZETA * omega])
    sigma = solve_continuous_lyapunov(a, -b @ b.T)  # A S + S A^T + b b^T = 0
    stationary = c @ sigma @ c
    # From rest the variance is c (S - e^{At} S e^{A^T t}) c: its average over [5, 10] is 1.2 %
    # short of the stationary one at omega = 0.5 (0.6 % in sd; nothing at omega = 2).
    ts = np.linspace(5.0, 10.0, 501)
    transient = np.mean([c @ (sigma - expm(a * t) @ sigma @ expm(a * t).T) @ c for t in ts])
    assert math.sqrt(transient) == pytest.approx(math.sqrt(stationary), rel=0.01)

    spec = RunSpec.create(_scene(omega), paths=paths, seed=3)
    options = engine.plan_options(spec)
    plan = _core.Plan(options)
    per_path = np.empty(paths)
    largest = 0.0
    for p in range(paths):
        tr = _core.filtered_trajectory(plan, p)
        t, ag = np.asarray(tr["t"]), np.asarray(tr["a_g"])
        keep = (t >= 5.0) & (t <= 10.0)
        t, ag = t[keep], ag[keep]
        step = np.diff(t)
        integral = np.sum(step * (ag[:-1] ** 2 + ag[:-1] * ag[1:] + ag[1:] ** 2) / 3)
        per_path[p] = integral / (t[-1] - t[0])
        largest = max(largest, float(np.abs(ag).max()))
    sd = math.sqrt(per_path.mean())
    # The sd's standard error is about 1 % with these paths (per-path spread / sqrt(paths) /
    # (2 sd); a_g decorrelates over 1 / (zeta omega), so omega = 0.5 needs more paths): 5 % is 5.
    assert sd == pytest.approx(math.sqrt(stationary), rel=0.05)
    # And no point is wild (the old bridges reached 1e5 at omega = 0.5): 10 stationary sds.
    assert largest < 10 * math.sqrt(stationary)
