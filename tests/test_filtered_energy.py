"""The per-path energy identity under a filtered excitation (docs/filtered.md, "The energy
identity"): with V' = -a_g - mu g sgn V while sliding (V = 0 at rest), d(V^2/2) = -a_g V dt -
mu g |V| dt, so at the stop t_s (V = 0)

    mu g S(t_s) = v0^2 / 2 - int_0^t_s a_g V dt,

path by path. The walk computes V and S from the exact integrals of a_g over its steps; the
trajectory (_core.filtered_trajectory) gives a_g and V at the points only, so the integral is
taken here by the trapezoid rule over them (a_g = 0 after the switch-off t0: the shaking ends
there). The residual R = mu g S(t_s) - v0^2/2 + trapezoid is then the trapezoid's error alone.

Its expected size: Kanai-Tajimi's a_g = -omega^2 x - 2 zeta omega x' carries the Brownian part
k W with k = 2 zeta omega h, so over a step of length dt a_g leaves its chord by a bridge whose
integral has variance k^2 dt^3 / 12, independent between steps given the grid; times V, the
errors add to E R^2 = k^2 dt^2 / 12 E int V^2 dt (the smooth part's errors are O(dt^2)). So
the residual's root mean square falls as dt (order 1), and E R^2 over that prediction is 1."""

import math

import numpy as np

from crandall import KanaiTajimi, Scene, _core, engine
from crandall.spec import RunSpec

OMEGA, ZETA, H = 2.0, 0.6, 1.0
K = 2 * ZETA * OMEGA * H
PATHS = 600


def _residuals(dt, seed):
    """Per path: the residual R and the prediction k^2 dt^2 / 12 int V^2 dt."""
    sc = Scene(mu=1.0, g=1.0, excitation=KanaiTajimi(omega=OMEGA, zeta=ZETA, h=H), t0=2.0,
               times=[1.0], observe=["velocity", "distance", "stop"])
    plan = _core.Plan(engine.plan_options(RunSpec.create(sc, paths=PATHS, seed=seed, dt=dt)))
    r, p = np.empty(PATHS), np.empty(PATHS)
    for i in range(PATHS):
        tr = _core.filtered_trajectory(plan, i)
        t, a, v, s = (np.asarray(tr[key]) for key in ("t", "a_g", "V", "S"))
        assert t[-1] >= sc.t0 and v[-1] == 0.0  # the trajectory runs to the stop
        keep = t <= sc.t0
        tt, f, vv = t[keep], a[keep] * v[keep], v[keep]
        r[i] = sc.drift * s[-1] + np.sum(np.diff(tt) * (f[:-1] + f[1:]) / 2)  # v0 = 0
        p[i] = K * K * dt * dt / 12 * np.sum(np.diff(tt) * (vv[:-1] ** 2 + vv[1:] ** 2) / 2)
    return r, p


def _ratio(r, p):
    """E R^2 / E prediction and its standard error (delta method on the two means)."""
    r2 = r * r
    ratio = r2.mean() / p.mean()
    c = np.cov(r2, p)
    rel = (c[0, 0] / r2.mean() ** 2 + c[1, 1] / p.mean() ** 2
           - 2 * c[0, 1] / (r2.mean() * p.mean()))
    return ratio, ratio * math.sqrt(rel / len(r))


def test_the_energy_identity_holds_per_path_to_the_quadratures_error_of_order_one():
    steps = (0.05, 0.025, 0.0125)
    rms, rel_se = {}, {}
    for j, dt in enumerate(steps):
        r, p = _residuals(dt, seed=11 + j)
        # No systematic part: the mean residual within 4 standard errors of 0 (about 7e-4,
        # 4e-4, 2e-4 against a mean dissipated energy near 0.6).
        assert abs(r.mean()) <= 4 * r.std(ddof=1) / math.sqrt(PATHS), (dt, r.mean())
        # The residual is the trapezoid's error: E R^2 over k^2 dt^2 / 12 E int V^2 dt is 1
        # (measured 0.86 +- 0.16, 1.03 +- 0.15, 1.01 +- 0.11 here; 1.16, 1.03, 0.82 with other
        # seeds): within 4 standard errors.
        ratio, se = _ratio(r, p)
        assert abs(ratio - 1.0) <= 4 * se, (dt, ratio, se)
        r2 = r * r
        rms[dt] = math.sqrt(r2.mean())
        rel_se[dt] = 0.5 * r2.std(ddof=1) / math.sqrt(PATHS) / r2.mean()  # of the rms, relative
    # Order 1: each halving of the step halves the root mean square (measured 1.79, 2.20
    # here; 1.82, 1.98 and 2.05, 2.17 with other seeds); the order log2(ratio) within 4
    # standard errors of 1 (its standard error from the two rms' relative ones, about 0.1).
    for a, b in zip(steps, steps[1:]):
        order = math.log2(rms[a] / rms[b])
        se = math.hypot(rel_se[a], rel_se[b]) / math.log(2)
        assert abs(order - 1.0) <= 4 * se, (a, b, order, se)
    # At dt = 0.0125 the rms residual is about 0.005, under 1 % of the mean dissipated energy
    # mu g E S(t_s) (about 0.6): below 0.01.
    assert rms[0.0125] < 0.01
