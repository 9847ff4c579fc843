"""Property-based test of every public function of crandall.analytic (and analytic.physical):
for arbitrary arguments (floats including nan, inf, negative, huge and tiny, ints, bools,
strings, bytes, complex, None, small lists), the result is either a ValueError whose message
names one of the function's parameters, or a finite value within the bounds the physics gives.
Any other exception (TypeError, OverflowError, ZeroDivisionError, a numpy warning, which
pytest turns into an error) fails the test.

Derandomized (fixed examples, same every run) and few examples per function, so the default run
takes seconds; raise HYPOTHESIS_PROFILE-style settings locally to search longer."""

import inspect
import re

import numpy as np
import pytest
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st

import crandall.analytic as A
from crandall.analytic.physical import PHYSICAL_NAMES

SETTINGS = settings(max_examples=40, derandomize=True, deadline=None, database=None,
                    suppress_health_check=[HealthCheck.too_slow])

reals = st.one_of(
    st.floats(allow_nan=True, allow_infinity=True),
    st.floats(min_value=0, max_value=50),
    st.sampled_from([0.0, 5e-324, 1e-300, 1e-30, 0.049, 0.051, 1.0, 1e30, 1e300, 1.7e308]),
    st.integers(min_value=-10, max_value=10**6),
    st.integers(min_value=2**63, max_value=2**1100),
)
junk = st.one_of(
    st.booleans(), st.text(max_size=4), st.binary(max_size=3), st.none(),
    st.complex_numbers(max_magnitude=1e6), st.sampled_from([np.True_, np.complex64(1), "1.0"]),
)
anything = st.one_of(reals, reals, junk, st.lists(st.one_of(reals, junk), max_size=3),
                     st.lists(st.floats(min_value=0, max_value=1e6), min_size=1, max_size=3))
orders = st.one_of(st.integers(min_value=-2, max_value=3), st.sampled_from([25, 10**9, 2**70]),
                   junk, st.floats(allow_nan=True))


def _params(func):
    return [p for p in inspect.signature(func).parameters]


def _finite(r):
    a = np.asarray(r)
    assert a.dtype.kind in "fc" and np.all(np.isfinite(a)), r
    return a


def _call(func, *args, **kwargs):
    """func(...) as a finite array, or None if it raised a ValueError naming one of its
    parameters."""
    try:
        r = func(*args, **kwargs)
    except ValueError as exc:
        names = _params(func)
        assert any(re.search(rf"\b{re.escape(n)}\b", str(exc)) for n in names), (
            f"{func.__name__}: ValueError names none of {names}: {exc}")
        return None
    return _finite(r)


TAU_TAU0 = [A.velocity_var, A.distance_mean, A.displacement_var, A.distance_second_moment,
            A.distance_var, A.velocity_abs_mean, A.velocity_displacement_cov,
            A.velocity_abs_distance_cov]


@pytest.mark.parametrize("func", TAU_TAU0, ids=[f.__name__ for f in TAU_TAU0])
@SETTINGS
@given(tau=anything, tau0=st.one_of(anything, st.just(np.inf)))
@example(tau=1e100, tau0=5.0)  # NaN once (0 * inf in the coast)
@example(tau=6.57e-39, tau0=1.9e-54)  # negative once (cancellation after a tiny switch-off)
@example(tau=0.0, tau0=[0.0])
@example(tau=[5.5, 7.0, 1e300], tau0=5.0)  # the coast, then the stop
@example(tau=1e-30, tau0=1e-40)
def test_functions_of_tau(func, tau, tau0):
    a = _call(func, tau, tau0)
    if a is None:
        return
    t = np.asarray(tau, dtype=float)
    assert np.all(a >= 0)
    if func is A.velocity_var:
        assert np.all(a <= 0.5)  # stationary value, approached from below
    if func is A.velocity_abs_mean:
        assert np.all(a <= 0.5)
    if func is A.distance_mean:  # E|U1| <= 1/2 while on, E U3(tau_s) = tau0/2 (eq7)
        assert np.all(a <= np.minimum(t, np.asarray(tau0, dtype=float)) / 2 * (1 + 1e-14) + 1e-300)
    if func is A.distance_second_moment:  # Jensen
        assert np.all(a >= A.distance_mean(tau) ** 2 * (1 - 1e-12))
    if func in (A.velocity_displacement_cov, A.velocity_abs_distance_cov):
        # Cauchy-Schwarz: |Cov(X, Y)| <= sqrt(Var X Var Y), Var |U1| <= E U1^2
        other = A.displacement_var if func is A.velocity_displacement_cov else A.distance_var
        bound = np.sqrt(A.velocity_var(tau, tau0)) * np.sqrt(other(tau, tau0))
        assert np.all(a <= bound * (1 + 1e-9) + 1e-300)
    if func in (A.displacement_var, A.distance_var):
        # during the coast the variances rise from their value at tau0 to that at the stop
        # (docs/analytic.md); while the noise is on, the closed forms are checked elsewhere
        t0 = float(np.asarray(tau0, dtype=float).reshape(()))
        coast = t > t0
        if np.any(coast):
            at_stop = A.displacement_at_stop_var if func is A.displacement_var else A.distance_at_stop_var
            lo, hi = func(t0, t0), at_stop(t0)
            slack = 1e-12 * hi
            assert np.all(a[coast] >= lo - slack) and np.all(a[coast] <= hi + slack)


TAU0_ONLY = [A.stop_time_mean, A.stop_time_var, A.distance_at_stop_mean, A.distance_at_stop_var,
             A.displacement_at_stop_var]


@pytest.mark.parametrize("func", TAU0_ONLY, ids=[f.__name__ for f in TAU0_ONLY])
@SETTINGS
@given(tau0=anything)
@example(tau0=8.98846567431158e307)  # overflow warning once (K tau in the erfc forms)
def test_functions_of_tau0(func, tau0):
    a = _call(func, tau0)
    if a is None:
        return
    t0 = np.asarray(tau0, dtype=float)
    assert np.all(a >= 0)
    if func is A.stop_time_mean:  # tau_s = tau0 + |U1(tau0)|/2, E|U1| <= 1/2
        assert np.all(a >= t0) and np.all(a - t0 <= 0.25 + 1e-15 * t0)
    if func is A.stop_time_var:  # Var |U1|/4 <= E U1^2 / 4 <= 1/8
        assert np.all(a <= 0.125)
    if func is A.distance_at_stop_mean:  # eq7
        np.testing.assert_allclose(a, t0 / 2, rtol=1e-13, atol=1e-300)


@pytest.mark.parametrize("func", [A.velocity_pdf, A.velocity_logpdf, A.stop_time_pdf],
                         ids=["velocity_pdf", "velocity_logpdf", "stop_time_pdf"])
@SETTINGS
@given(x=anything, t=anything)
@example(x=0.0, t=8.98846567431158e307)  # overflow once (2 (t - tau0), 4 pi tau)
def test_densities(func, x, t):
    a = _call(func, x, t)
    if a is None:
        return
    if func is not A.velocity_logpdf:
        assert np.all(a >= 0)
    else:
        # f <= sup over y of the density <= (4 pi tau)^-1/2 + 1
        sup = 0.5 / (np.sqrt(np.pi) * np.sqrt(np.asarray(t, float))) + 1
        assert np.all(a <= np.log(sup) + 1e-12)


@pytest.mark.parametrize("func", [A.moment, A.signed_moment], ids=["moment", "signed_moment"])
@settings(max_examples=25, derandomize=True, deadline=None, database=None,
          suppress_health_check=[HealthCheck.too_slow])
@given(j=orders, k=orders, l=orders,
       tau=st.one_of(reals, junk, st.lists(st.floats(min_value=0, max_value=1e3), max_size=2)))
def test_moments(func, j, k, l, tau):
    a = _call(func, j, k, l, tau)
    if a is None:
        return
    if func is A.moment and j % 2 == 0 and k % 2 == 0:  # an even power of each coordinate
        assert np.all(a >= 0)
    if func is A.moment and j == k == l == 0:
        assert np.all(a == 1)


@SETTINGS
@given(j=orders, k=orders, l=orders,
       p=st.one_of(anything, st.complex_numbers(allow_nan=True, allow_infinity=True)),
       # exact=True is left out: sympy needs seconds to minutes per order (a cost, not a bug)
       exact=st.one_of(st.just(False), junk.filter(lambda v: v is not True and v is not np.True_)),
       signed=st.one_of(st.booleans(), junk))
def test_laplace_moment(j, k, l, p, exact, signed):
    _call(A.laplace_moment, j, k, l, p, exact, signed=signed)  # finite, or a ValueError


@SETTINGS
@given(name=st.one_of(st.sampled_from(PHYSICAL_NAMES), st.text(max_size=3), junk),
       t=anything, mu=anything, h=anything, g=st.one_of(st.just(9.81), anything),
       t0=st.one_of(st.just(np.inf), anything))
def test_physical(name, t, mu, h, g, t0):
    a = _call(A.physical, name, t, mu=mu, h=h, g=g, t0=t0)
    if a is None:
        return
    if "var" in name or name.endswith("_mean"):
        assert np.all(a >= 0)


LAWS = [A.velocity_cdf, A.velocity_sf, A.velocity_quantile]


@pytest.mark.parametrize("func", LAWS, ids=[f.__name__ for f in LAWS])
@SETTINGS
@given(x=st.one_of(anything, st.floats(min_value=0, max_value=1)), tau=anything,
       tau0=st.one_of(st.just(np.inf), anything))
@example(x=0.0, tau=8.98846567431158e307, tau0=1.0)
@example(x=0.0, tau=3.99583814440447e146, tau0=5e-324)
def test_velocity_law(func, x, tau, tau0):
    a = _call(func, x, tau, tau0)
    if a is None:
        return
    if func is not A.velocity_quantile:
        assert np.all((a >= 0) & (a <= 1))


@SETTINGS
@given(tau=anything, tau0=st.one_of(st.just(np.inf), anything))
def test_velocity_atom(tau, tau0):
    a = _call(A.velocity_atom, tau, tau0)
    if a is None:
        return
    assert np.all((a >= 0) & (a <= 1))


STOP_LAWS = [A.stop_time_cdf, A.stop_time_sf, A.stop_time_quantile]


@pytest.mark.parametrize("func", STOP_LAWS, ids=[f.__name__ for f in STOP_LAWS])
@SETTINGS
@given(x=st.one_of(anything, st.floats(min_value=0, max_value=1)), tau0=anything)
@example(x=8.98846567431158e307, tau0=1.0)
@example(x=7.686876742965056e-272, tau0=7.686876742965056e-272)
def test_stop_time_law(func, x, tau0):
    a = _call(func, x, tau0)
    if a is None:
        return
    if func is A.stop_time_quantile:
        assert np.all(a >= np.asarray(tau0, dtype=float))
    else:
        assert np.all((a >= 0) & (a <= 1))


@pytest.mark.parametrize("func,at_stop", [(A.displacement_var, A.displacement_at_stop_var),
                                          (A.distance_var, A.distance_at_stop_var)],
                         ids=["displacement_var", "distance_var"])
@SETTINGS
@given(tau0=st.one_of(st.floats(min_value=0, max_value=1e300),
                      st.sampled_from([5e-324, 1e-310, 1e-300, 1e-100, 0.049, 0.051, 139.9, 140.1, 1e300])),
       ratio=st.one_of(st.floats(min_value=0, max_value=1e3),
                       st.sampled_from([5e-324, 1e-300, 1e-16, 1e300])))
def test_coast_variances(func, at_stop, tau0, ratio):
    """tau = tau0 + ratio * (scale of |U1(tau0)|), anywhere after the switch-off: finite,
    between the value at tau0 and the value at the stop (the variances rise during the coast,
    docs/analytic.md)."""
    with np.errstate(over="ignore"):
        tau = float(np.float64(tau0) + np.float64(ratio) * min(np.sqrt(tau0), 1.0))
    if not np.isfinite(tau):
        tau = 1.7e308
    a = _finite(func(tau, tau0))
    lo, hi = func(tau0, tau0), at_stop(tau0)
    slack = 1e-12 * hi
    assert lo - slack <= a <= hi + slack, (tau0, tau, a, lo, hi)
