"""The kernel's random stream against an independent NumPy reference (tests/reference_rng.py),
bit for bit, and the deterministic log and sin/cos against mpmath."""

import math

import mpmath
import numpy as np
import pytest

from crandall import _core
import reference_rng as ref

SEEDS = [0, 7, 0x0123456789ABCDEF, 2**64 - 1]


def hexes(a):
    return [float(v).hex() for v in np.ravel(a)]


def test_reference_philox_matches_random123_known_answers():
    # Random123's published kat_vectors for Philox4x32-10 (the same as cpp/tests/test_rng.cpp).
    kats = [((0, 0, 0, 0), (0, 0), (0x6627E8D5, 0xE169C58D, 0xBC57AC4C, 0x9B00DBD8)),
            ((0xFFFFFFFF,) * 4, (0xFFFFFFFF,) * 2, (0x408F276D, 0x41C83B0E, 0xA20BC7C6, 0x6D5451FD)),
            ((0x243F6A88, 0x85A308D3, 0x13198A2E, 0x03707344), (0xA4093822, 0x299F31D0),
             (0xD16CFE09, 0x94FDCCEB, 0x5001E420, 0x24126EA1))]
    for ctr, key, want in kats:
        got = ref.philox4x32_10([np.array([c], np.uint64) for c in ctr], key)
        assert [int(g[0]) for g in got] == list(want)


@pytest.mark.parametrize("seed", SEEDS)
@pytest.mark.parametrize("path0", [0, 2**32 - 7, 2**63 + 3])  # the last: the refine stream
@pytest.mark.parametrize("pair", [0, 5, 2**33 + 1])
def test_kernel_draws_are_the_reference_bit_for_bit(seed, path0, pair):
    count = 203  # not a multiple of any vector width or lane count
    got = _core.draw_noise(seed, path0, count, pair)
    want = ref.draw_pairs(seed, path0 + np.arange(count, dtype=np.uint64), pair)
    assert got.shape == want.shape == (6, count)
    assert hexes(got) == hexes(want)


@pytest.mark.parametrize("seed", [3, 2**40 + 9])
@pytest.mark.parametrize("method", ["exact"])
def test_kernel_path_states_are_the_reference_bit_for_bit(seed, method):
    # Integrals observed, so the plan takes dt steps (velocity-only plans jump to the outputs);
    # dt = 1/8 on [0, 1]: 8 steps of exactly 1/8.
    o = _core.Options()
    o.switch_off, o.times, o.dt, o.method = 1.0, [1.0], 0.125, method
    o.displacement = True
    o.drift, o.noise = 2.0, math.sqrt(2.0)
    o.seed, o.paths = seed, 300  # a partial block and a partial lane group
    plan = _core.Plan(o)
    assert plan.steps_per_path == 8
    got = _core.simulate_states(plan)
    want = ref.final_velocities(seed, 300, 0.125, 8, 2.0, math.sqrt(2.0))
    assert hexes(got) == hexes(want)
    assert np.count_nonzero(want > 0) > 50 and np.count_nonzero(want < 0) > 50  # both signs


def test_simulate_states_rejects_methods_without_a_single_state():
    o = _core.Options()
    o.switch_off, o.times, o.dt, o.method = 1.0, [1.0], 0.125, "richardson"
    o.displacement = True
    with pytest.raises(ValueError, match="method"):
        _core.simulate_states(_core.Plan(o))


# -- accuracy of the deterministic math against mpmath -----------------------------------------

def ulp_errors(got, exact_fn, inputs):
    """|got - exact| in units in the last place of the double nearest to the exact value."""
    out = []
    with mpmath.workprec(120):
        for g, x in zip(got, inputs):
            e = exact_fn(x)
            _, exp = math.frexp(float(e))  # e = m 2^exp, m in [0.5, 1)
            out.append(float(abs(mpmath.mpf(float(g)) - e) / mpmath.ldexp(1, exp - 53)))
    return np.array(out)


def test_log_within_one_ulp_of_mpmath():
    rng = np.random.default_rng(20240611)
    words = np.concatenate([
        rng.integers(0, 2**32, 4000, dtype=np.uint64),
        np.arange(0, 200, dtype=np.uint64),                      # u down to 2^-33
        2**32 - 1 - np.arange(0, 200, dtype=np.uint64),          # u up to 1 - 2^-33
        0xB504F333 + np.arange(-100, 100).astype(np.int64).astype(np.uint64),  # u near sqrt(2)/2
        (np.uint64(1) << np.arange(0, 32, dtype=np.uint64)),     # powers of two
    ])
    u = ref.unit_of_word(words)
    got = ref.log_positive(u)
    # The reference is the kernel's log bit for bit (tests above), so this bounds the kernel's.
    err = ulp_errors(got, lambda x: mpmath.log(mpmath.mpf(float(x))), u)
    assert err.max() < 1.0, (err.max(), words[err.argmax()])


def test_sincos_within_one_ulp_of_mpmath():
    rng = np.random.default_rng(97)
    ks = np.concatenate([
        rng.integers(0, 2**30, 3000, dtype=np.uint64),
        # both ends of every octant (angles next to multiples of pi/4)
        (np.arange(8, dtype=np.uint64)[:, None] << np.uint64(27)
         | np.concatenate([np.arange(50), 0x7FFFFFF - np.arange(50)]).astype(np.uint64)[None, :]).ravel(),
    ])
    sn, cs = ref.sincos_turn30(ks)

    def angle(k):
        return 2 * mpmath.pi * (mpmath.mpf(int(k)) + mpmath.mpf(0.5)) / 2**30

    es = ulp_errors(sn, lambda k: mpmath.sin(angle(k)), ks)
    ec = ulp_errors(cs, lambda k: mpmath.cos(angle(k)), ks)
    assert es.max() < 1.0, (es.max(), ks[es.argmax()])
    assert ec.max() < 1.0, (ec.max(), ks[ec.argmax()])


@pytest.mark.parametrize("count", [0, 2**24 + 1])
def test_draw_noise_rejects_a_bad_count(count):
    with pytest.raises(ValueError, match="count"):
        _core.draw_noise(1, 0, count, 0)
