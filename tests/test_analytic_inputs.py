"""crandall.analytic: bad or extreme input gives a ValueError naming the parameter, or a correct
finite value (expected values from the physics' limits, not from the functions under test)."""

import math

import numpy as np
import pytest

import crandall.analytic as A

TAU_FUNCS = [A.velocity_var, A.distance_mean, A.displacement_var, A.distance_second_moment,
             A.distance_var, A.velocity_abs_mean]
TAU0_FUNCS = [A.stop_time_mean, A.stop_time_var, A.distance_at_stop_mean, A.distance_at_stop_var,
              A.displacement_at_stop_var]
BAD = ["1.0", b"1", True, np.True_, 1 + 0j, np.complex128(1), [True, 1.0], ["1"], [1.0, 1j],
       None, object(), np.array(["1"]), np.array([1 + 1j]), np.array([True])]


def _names(param):
    return pytest.raises(ValueError, match=rf"\b{param}\b")


@pytest.mark.parametrize("bad", BAD, ids=[f"{i}-{type(b).__name__}" for i, b in enumerate(BAD)])
def test_bad_types_refused_by_name(bad):
    for f in TAU_FUNCS:
        with _names("tau"):
            f(bad)
        with _names("tau0"):
            f(1.0, bad)
    for f in TAU0_FUNCS:
        with _names("tau0"):
            f(bad)
    for f in (A.velocity_pdf, A.velocity_logpdf):
        with _names("y"):
            f(bad, 1.0)
        with _names("tau"):
            f(0.5, bad)
    with _names("t"):
        A.stop_time_pdf(bad, 1.0)
    with _names("tau0"):
        A.stop_time_pdf(1.5, bad)
    for f in (A.moment, A.signed_moment):
        with _names("tau"):
            f(2, 0, 0, bad)
        with _names("j"):
            f(bad, 0, 0, 1.0)
        with _names("k"):
            f(0, bad, 0, 1.0)
        with _names("l"):
            f(0, 0, bad, 1.0)
    if not isinstance(bad, (complex, np.complexfloating)) and not (
        isinstance(bad, (list, np.ndarray)) and np.asarray(bad).dtype.kind == "c"
    ) and not (isinstance(bad, list) and 1j in bad):
        with _names("p"):
            A.laplace_moment(2, 0, 0, bad)
    with _names("exact"):
        A.laplace_moment(2, 0, 0, 1.0, exact=bad if bad is not True and bad is not np.True_ else 1)
    with _names("signed"):
        A.laplace_moment(2, 0, 0, 1.0, signed=bad if bad is not True and bad is not np.True_ else 1)
    for param in ("mu", "h", "g", "t0"):
        with _names(param):
            A.physical("velocity_var", 1.0, **{"mu": 0.3, "h": 1.0, param: bad})
    with _names("t"):
        A.physical("velocity_var", bad, mu=0.3, h=1.0)
    with _names("name"):
        A.physical(bad, 1.0, mu=0.3, h=1.0)


def test_numpy_real_scalars_and_arrays_stay_accepted():
    ref = A.velocity_var(np.array([0.5, 2.0]), 1.0)
    assert np.array_equal(A.velocity_var(np.array([0.5, 2.0], dtype=np.float32), np.float32(1)), ref)
    assert np.array_equal(A.velocity_var([0.5, 2], np.int64(1)), ref)
    assert A.stop_time_mean(np.int32(3)) == A.stop_time_mean(3.0)
    assert A.moment(np.int64(2), 0, 0, np.float64(1.0)) == A.moment(2, 0, 0, 1.0)
    from fractions import Fraction

    assert A.velocity_var(Fraction(1, 2)) == A.velocity_var(0.5)
    # the Laplace variable may be complex (not the other arguments)
    assert np.isfinite(A.laplace_moment(2, 0, 0, 1 + 1j))


def test_moment_at_extreme_tau():
    # Var U1 -> 1/2 (stationary density e^-2|y|); E U3 = tau/2 - 1/8 + O(e^-tau); Brownian start
    assert A.moment(2, 0, 0, 1e300) == pytest.approx(0.5, rel=1e-14)
    assert A.moment(0, 0, 1, 1e300) == pytest.approx(5e299, rel=1e-14)
    assert A.moment(0, 0, 1, 1e10) == pytest.approx(5e9 - 0.125, rel=1e-14)
    assert A.moment(4, 0, 0, 1e100) == pytest.approx(1.5, rel=1e-14)  # E Y^4 = 4!/2^4
    assert A.moment(2, 0, 0, 1e-300) == pytest.approx(2e-300, rel=1e-14, abs=0)
    with _names("tau"):
        A.moment(0, 0, 2, 1e300)  # tau^2/4 is beyond a double
    with _names("tau"):
        A.signed_moment(1, 0, 0, math.inf)


def test_laplace_moment_near_zero():
    # exact transform of E U1^2 is 2/(p (s+1)^2), s = sqrt(p+1): 1/(2p) as p -> 0
    assert A.laplace_moment(2, 0, 0, 1e-300) == pytest.approx(5e299, rel=1e-14)
    assert A.laplace_moment(2, 0, 0, 1e-20) == pytest.approx(5e19, rel=1e-14)
    with _names("p"):
        A.laplace_moment(0, 0, 2, 1e-300)  # ~ 1/(2 p^3) overflows
    with _names("p"):
        A.laplace_moment(2, 0, 0, -1.0)


def test_orders_bounded_by_name():
    with _names("j"):
        A.laplace_moment(10**9, 0, 0, 1.0)
    with _names("k"):
        A.moment(0, 13, 0, 1.0)
    with _names("l"):
        A.laplace_moment(0, 0, 5, None, exact=True)
    with _names("j"):
        A.moment(-1, 0, 0, 1.0)


def test_physical_extreme_scales():
    g = 9.81
    # negligible friction: V = h W, Var V = h^2 t, E S = h sqrt(2/pi) (2/3) t^(3/2)
    assert A.physical("velocity_var", 2.0, mu=1e-300, h=3.0) == pytest.approx(9.0 * 2.0, rel=1e-12)
    assert A.physical("distance_mean", 1.0, mu=1e-300, h=1.0) == pytest.approx(
        math.sqrt(2 / math.pi) * 2 / 3, rel=1e-12)
    # eq7: mu g E S(t_s) = h^2 t0 / 2
    assert A.physical("distance_at_stop_mean", mu=1e-300, h=1.0, t0=2.0) == pytest.approx(
        1.0 / (1e-300 * g), rel=1e-12)
    # huge friction: the stationary Var V = (h^2/(mu g))^2 / 2
    assert A.physical("velocity_var", 1.0, mu=1e300, h=1e150) == pytest.approx(
        0.5 * (1e300 / (1e300 * g)) ** 2, rel=1e-12)
    with _names("mu"):
        A.physical("stop_time_var", mu=1e-300, h=1.0, t0=1.0)  # ~1e598 s^2
    with _names("t"):
        A.physical("velocity_var", 3.0, mu=1e-300, h=1.0, t0=1.0)
    with _names("t"):  # E|U1| after the switch-off is not provided
        A.physical("velocity_abs_mean", 3.0, mu=0.3, h=1.0, t0=1.0)
    # the variances of displacement and distance continue past t0 (the coast), in SI units
    ts = 2 * (1.0 / (0.3 * g)) ** 2  # time scale 2 h^2 / (mu g)^2
    ls = 2 / (0.3 * g) ** 3  # length scale 2 h^4 / (mu g)^3
    assert A.physical("distance_var", 3.0, mu=0.3, h=1.0, t0=1.0) == pytest.approx(
        ls**2 * A.distance_var(3.0 / ts, 1.0 / ts), rel=1e-12)
    assert A.physical("displacement_var", 3.0, mu=0.3, h=1.0, t0=1.0) == pytest.approx(
        ls**2 * A.displacement_var(3.0 / ts, 1.0 / ts), rel=1e-12)
    for param, value in [("mu", 0.0), ("h", -1.0), ("g", math.inf), ("mu", math.nan), ("t0", -1.0)]:
        with _names(param):
            A.physical("velocity_var", 1.0, **{"mu": 0.3, "h": 1.0, param: value})


def test_laplace_moment_keeps_digits_near_zero():
    """s - 1 = p / (s + 1): the transform near p = 0 (which decides the large-tau behaviour)
    matches the exact sympy transform to rounding, where sqrt(p + 1) - 1 lost ~|log10 p| digits."""
    sympy = pytest.importorskip("sympy")
    ps = np.array([1e-12, 1e-8, 1e-4, 1e-2 + 1e-3j, 1e-9 + 1e-6j])
    for jkl in [(2, 0, 0), (0, 0, 2), (0, 2, 0), (2, 0, 1)]:
        expr = A.laplace_moment(*jkl, None, exact=True)
        p = list(expr.free_symbols)[0]
        ref = np.array([complex(expr.subs(p, sympy.nsimplify(x, rational=True)).evalf(40))
                        for x in ps])
        np.testing.assert_allclose(A.laplace_moment(*jkl, ps), ref, rtol=1e-13)
