"""The tail estimators' deterministic math (crandall/tail/detmath.py over _core.det_exp, det_log,
det_log1p, det_log_erfc: cpp/src/detfunc.cpp) against mpmath, its special cases and errors.
The same bits on every CPU follow from the construction (+, -, *, / only, no contraction); here
the accuracy: measured within 0.89 ulp for exp, log and log1p (cpp/tests/test_detfunc.cpp's
denser sweep against long double agrees), log erfc within 1.7 ulps of max(|log erfc|, 1/2)."""

from __future__ import annotations

import math

import mpmath
import numpy as np
import pytest

import crandall
from crandall import _core
from crandall.analytic import schedule
from crandall.tail import _check_samples, sample
from crandall.tail import detmath as dm


def _ulps(got, exact, floor=0.0):
    """|got - exact| in ulps of the double nearest to max(|exact|, floor)."""
    out = []
    with mpmath.workprec(120):
        for g, e in zip(got, exact):
            _, ex = math.frexp(max(abs(float(e)), floor))
            out.append(float(abs(mpmath.mpf(float(g)) - e) / mpmath.ldexp(1, ex - 53)))
    return np.array(out)


def _exact(fn, xs):
    with mpmath.workprec(120):
        return [fn(mpmath.mpf(float(x))) for x in xs]


RNG = np.random.default_rng(20261127)


@pytest.mark.parametrize("name, fn, xs", [
    ("det_exp", mpmath.exp, np.concatenate([RNG.uniform(-708, 709.7, 800), RNG.uniform(-1, 1, 400),
                                            RNG.uniform(-1e-7, 1e-7, 100)])),
    ("det_log", mpmath.log, np.concatenate([np.exp(RNG.uniform(-690, 690, 800)),
                                            RNG.uniform(0.5, 2.0, 400), [5e-324, 1e-310]])),
    ("det_log1p", mpmath.log1p, np.concatenate([RNG.uniform(-1, 1, 600), -RNG.integers(1, 1000, 300) / 1000,
                                                RNG.uniform(-1e-9, 1e-9, 100), np.exp(RNG.uniform(0, 600, 200))])),
])
def test_within_one_ulp_of_mpmath(name, fn, xs):
    err = _ulps(getattr(_core, name)(xs), _exact(fn, xs))
    assert err.max() < 1.0, (name, err.max(), xs[err.argmax()])


def test_log_erfc_against_mpmath():
    xs = np.concatenate([RNG.uniform(-30, 3, 800), RNG.uniform(3, 200, 400), [1e3, 1e6, 1e100]])
    err = _ulps(_core.det_log_erfc(xs), _exact(lambda x: mpmath.log(mpmath.erfc(x)), xs), 0.5)
    assert err.max() < 2.0, (err.max(), xs[err.argmax()])


def test_special_cases_and_domain_errors():
    inf, nan = math.inf, math.nan
    assert list(_core.det_exp([-inf, inf, 710.0, -746.0, 0.0])) == [0.0, inf, inf, 0.0, 1.0]
    assert list(_core.det_log([0.0, inf, 1.0])) == [-inf, inf, 0.0]
    assert list(_core.det_log1p([-1.0, inf, 0.0])) == [-inf, inf, 0.0]
    assert list(_core.det_log_erfc([inf, -inf])) == [-inf, dm.LN2]
    assert all(math.isnan(f(nan)) for f in (_core.det_exp, _core.det_log, _core.det_log1p))
    with pytest.raises(ValueError, match="det_log: -1.0 is outside"):
        _core.det_log(np.array([1.0, -1.0]))
    with pytest.raises(ValueError, match="det_log1p"):
        _core.det_log1p(-1.5)
    # The shape is kept; a scalar gives a 0-d array.
    assert _core.det_exp(np.zeros((2, 3))).shape == (2, 3)
    assert _core.det_exp(0.5).shape == ()


def test_built_functions_against_mpmath_and_numpy():
    a, b = RNG.normal(0, 30, 500), RNG.normal(0, 30, 500)
    with mpmath.workprec(120):
        want = [mpmath.log(mpmath.exp(x) + mpmath.exp(y)) for x, y in zip(a.tolist(), b.tolist())]
    assert _ulps(dm.logaddexp(a, b), want).max() < 2.0
    assert list(dm.logaddexp([-math.inf, math.inf, 1.0], [-math.inf, math.inf, -math.inf])) == \
        [-math.inf, math.inf, 1.0]
    rows = RNG.normal(0, 5, (4, 50))
    np.testing.assert_allclose(dm.logaddexp_reduce(rows), np.logaddexp.reduce(rows, axis=0),
                               rtol=1e-15, atol=1e-15)
    x = np.concatenate([RNG.normal(0, 3, 500), [0.0, -0.0, 40.0, -800.0]])
    # tanh's error is absolute (1 - e cancels for small |x|): a few ulps of 1.
    assert np.max(np.abs(dm.tanh(x) - np.tanh(x))) <= 4 * 2.0 ** -53
    np.testing.assert_allclose(dm.log_cosh(x[:-1]), np.log(np.cosh(x[:-1])), rtol=1e-15,
                               atol=4 * 2.0 ** -53)
    assert dm.log_cosh(-800.0) == 800.0 - dm.LN2  # cosh overflows there; log cosh does not


@pytest.mark.parametrize("c", [2.0, 0.0, -1.0])
def test_log_transition_density_matches_the_analytic_one(c):
    """The tail's deterministic propagator against crandall.analytic.schedule's (scipy's
    log_ndtr): the same formula, so the same to rounding (a relative 1e-13 of the log, and
    1e-9 of the density far in the tails, where both sides round -x^2-sized terms)."""
    x, x0 = RNG.normal(0, 3, 400), RNG.normal(0, 3, 400)
    for t, sigma in ((0.05, 1.0), (1.3, 0.7), (10.0, 2.0)):
        got = dm.log_transition_density(x, x0, t, c, sigma)
        want = schedule.log_transition_density(x, x0, t, c, sigma)
        np.testing.assert_allclose(got, want, rtol=1e-13, atol=1e-13)


def test_a_replicas_estimate_is_at_most_the_product_bound_the_checkpoint_check_uses():
    """Splitting's weight is a product of (n - K_j) / n with K_j >= kill, so (rounding being
    monotone) a replica's last estimate is at most the same product of (n - kill) / n, which
    run._check_samples compares it with, exactly; above that bound a sample is refused."""
    scene = crandall.Scene.scaled(tau0=2.0, times=[2.0])
    job = {"scene": scene.to_dict(), "quantity": "stop_time", "time": None, "dt": 0.05,
           "levels": [3.5], "particles": 40, "key": 9, "proposal": None}
    s = sample(job, 0)
    assert s["estimates"][0] > 0 and s["iterations"] > 5
    bound = 1.0
    for _ in range(s["iterations"]):
        bound = bound * ((40 - 4) / 40)
    assert s["estimates"][0] <= bound
    _check_samples([s], job, 1)
    with pytest.raises(ValueError, match=r"samples\[0\].estimates: .* above the weight"):
        _check_samples([dict(s, estimates=[bound * (1 + 1e-8)])], job, 1)
