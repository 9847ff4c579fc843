"""The residual displacement |U(t_s)| (observe "residual"): the magnitude of where the body
comes to rest, beside the signed displacement_at_stop. Its moments come from the core (the
stop's second slot), its distribution from the signed one's histogram folded at 0."""

from __future__ import annotations

import numpy as np
import pytest

import crandall

OBS = ["velocity", "displacement", "stop", "residual"]


def test_its_second_moment_is_the_signed_one_s():
    # |U|^2 = U^2 on every path: Var|U| + (E|U|)^2 = Var U + (E U)^2 to rounding (the exact
    # method: no extrapolation between grids), and E|U| >= |E U|.
    sc = crandall.Scene(mu=0.3, h=1.0, t0=1.0, times=[0.5], observe=OBS)
    r = crandall.simulate(sc, paths=20_000, seed=2, method="exact")
    m, v = r.mean("residual_displacement"), r.var("residual_displacement")
    ms, vs = r.mean("displacement_at_stop"), r.var("displacement_at_stop")
    n = 20_000
    # Sample variances: (n-1)/n Var + mean^2 is the mean square.
    assert (n - 1) / n * v + m * m == pytest.approx((n - 1) / n * vs + ms * ms, rel=1e-10)
    assert m > abs(ms) and m > 0
    assert r.scene.units_of("residual_displacement") == "m"
    assert r.var_stderr("residual_displacement") > 0


def test_its_distribution_is_the_signed_one_folded():
    sc = crandall.Scene(mu=0.3, h=1.0, t0=1.0, times=[0.5], observe=OBS,
                        distributions=["displacement_at_stop", "residual_displacement"])
    r = crandall.simulate(sc, paths=20_000, seed=3, method="exact")
    for a in (0.02, 0.1, 0.2):
        mag = r.exceedance("residual_displacement", a)
        above = r.exceedance("displacement_at_stop", a)
        below = 1.0 - r.exceedance("displacement_at_stop", -a).value
        # P(|U| > a) = P(U > a) + P(U < -a): equal up to the bins holding +-a.
        tol = mag.resolution + above.resolution + 1e-12
        assert abs(mag.value - (above.value + below)) <= tol, (a, mag, above, below)
    q = r.quantile("residual_displacement", 0.5)
    assert q.low <= q.value <= q.high and q.value > 0
    assert r.histogram("residual_displacement").axes[0].label == "residual_displacement [m]"


def test_a_run_to_an_accuracy_and_files_agree():
    sc = crandall.Scene(mu=0.3, h=1.0, t0=1.0, times=[0.5], observe=OBS)
    f = crandall.simulate(sc, paths=40_000, seed=5)
    a = crandall.simulate(sc, error=0.005, seed=5)
    gap = abs(a.mean("residual_displacement") - f.mean("residual_displacement"))
    assert gap <= 4 * np.hypot(a.error("residual_displacement"), f.error("residual_displacement"))


def test_saved_checkpointed_and_refused(tmp_path):
    sc = crandall.Scene(mu=0.3, h=1.0, t0=1.0, times=[0.5], observe=OBS + ["peaks"])
    r = crandall.simulate(sc, paths=3000, seed=6, checkpoint=tmp_path / "c.ckpt")
    again = crandall.simulate(sc, paths=3000, seed=6, checkpoint=tmp_path / "c.ckpt")
    assert again.mean("residual_displacement") == r.mean("residual_displacement")
    r.save(tmp_path / "r.nc")
    back = crandall.load(tmp_path / "r.nc")
    assert back.var("residual_displacement") == r.var("residual_displacement")
    with pytest.raises(ValueError, match="observe: 'residual' .* needs 'stop' and 'displacement'"):
        crandall.Scene(mu=0.3, h=1.0, t0=1.0, times=[0.5], observe=["velocity", "stop",
                                                                     "residual"])
