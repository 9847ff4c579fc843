"""A NumPy reference of crandall's random stream (docs/random-numbers.md), for tests only.

Everything the kernel does between a seed and a path's velocity, written independently of the
C++ code: Philox4x32-10 in NumPy integer arithmetic (uint64 arrays holding 32-bit words), the
deterministic log and sine/cosine (cpp/include/crandall/detmath.hpp) with the same operations
in the same order on float64 arrays (NumPy's +, -, *, / and sqrt are IEEE 754 correctly rounded
and never fused), Box-Muller as draw_pairs does it, and the exact step as the kernel evaluates
it (cpp/include/crandall/kernel.hpp). Bitwise agreement with the kernel (tests/
test_reference_rng.py) shows that the numbers are a function of the seed alone, not of the CPU
or of the vector width the kernel happens to use.
"""

from __future__ import annotations

import numpy as np

MASK32 = np.uint64(0xFFFFFFFF)
_M0, _M1 = np.uint64(0xD2511F53), np.uint64(0xCD9E8D57)
_W0, _W1 = 0x9E3779B9, 0xBB67AE85


def _u64(x) -> np.ndarray:
    return np.asarray(x, dtype=np.uint64)


def philox4x32_10(counter, key) -> list[np.ndarray]:
    """Random123's Philox4x32-10 on arrays: counter = 4 arrays of 32-bit words, key = 2 ints.

    Returns the 4 output words (uint64 arrays holding 32-bit values).
    """
    c0, c1, c2, c3 = (_u64(c) & MASK32 for c in counter)
    k0, k1 = int(key[0]) & 0xFFFFFFFF, int(key[1]) & 0xFFFFFFFF
    for r in range(10):
        if r > 0:
            k0, k1 = (k0 + _W0) & 0xFFFFFFFF, (k1 + _W1) & 0xFFFFFFFF
        p0 = c0 * _M0  # < 2^64: exact in uint64
        p1 = c2 * _M1
        c0, c1, c2, c3 = ((p1 >> np.uint64(32)) ^ c1 ^ np.uint64(k0), p1 & MASK32,
                          (p0 >> np.uint64(32)) ^ c3 ^ np.uint64(k1), p0 & MASK32)
    return [c0, c1, c2, c3]


def philox_words(seed: int, paths: np.ndarray, pair: int) -> list[np.ndarray]:
    """The block of (seed, path, pair): key = seed, counter = (pair, path), 64 bits each."""
    paths = _u64(paths)
    n = paths.shape
    counter = [np.full(n, pair & 0xFFFFFFFF, np.uint64), np.full(n, (pair >> 32) & 0xFFFFFFFF, np.uint64),
               paths & MASK32, paths >> np.uint64(32)]
    return philox4x32_10(counter, (seed & 0xFFFFFFFF, (seed >> 32) & 0xFFFFFFFF))


def _bits(x: np.ndarray) -> np.ndarray:
    return np.ascontiguousarray(x, dtype=np.float64).view(np.uint64)


def _double(b: np.ndarray) -> np.ndarray:
    return np.ascontiguousarray(b, dtype=np.uint64).view(np.float64)


# fdlibm e_log.c and FreeBSD k_sin.c / k_cos.c constants, as in detmath.hpp.
LN2_HI, LN2_LO = float.fromhex("0x1.62e42feep-1"), float.fromhex("0x1.a39ef35793c76p-33")
LG = [float.fromhex(x) for x in ("0x1.5555555555593p-1", "0x1.999999997fa04p-2", "0x1.2492494229359p-2",
                                 "0x1.c71c51d8e78afp-3", "0x1.7466496cb03dep-3", "0x1.39a09d078c69fp-3",
                                 "0x1.2f112df3e5244p-3")]
S = [float.fromhex(x) for x in ("-0x1.5555555555549p-3", "0x1.111111110f8a6p-7", "-0x1.a01a019c161d5p-13",
                                "0x1.71de357b1fe7dp-19", "-0x1.ae5e68a2b9cebp-26", "0x1.5d93a5acfd57cp-33")]
C = [float.fromhex(x) for x in ("0x1.555555555554cp-5", "-0x1.6c16c16c15177p-10", "0x1.a01a019cb159p-16",
                                "-0x1.27e4f809c52adp-22", "0x1.1ee9ebdb4b1c4p-29", "-0x1.8fae9be8838d4p-37")]
TURN_HI, TURN_LO = float.fromhex("0x1.921fb5p-28"), float.fromhex("0x1.110b4611a6263p-54")


def unit_of_word(w: np.ndarray) -> np.ndarray:
    """(w + 1/2) 2^-32 for the low 32 bits of w."""
    w = _u64(w) & MASK32
    return _double(np.uint64(0x3FF0000000000000) | (w << np.uint64(20)) | np.uint64(1 << 19)) - 1.0


def log_positive(x: np.ndarray) -> np.ndarray:
    """detmath::log_positive: fdlibm's log, one form, for positive normal doubles."""
    b = _bits(x)
    mantissa = b & np.uint64(0x000FFFFFFFFFFFFF)
    halve = (mantissa + np.uint64(0x95F64 << 32)) & np.uint64(1 << 52)
    m = _double(mantissa | (halve ^ np.uint64(0x3FF0000000000000)))
    biased = (b >> np.uint64(52)) + (halve >> np.uint64(52))
    dk = _double(np.uint64(0x4330000000000000) | biased) - float.fromhex("0x1.00000000003ffp+52")
    f = m - 1.0
    s = f / (2.0 + f)
    z = s * s
    w = z * z
    t1 = w * (LG[1] + w * (LG[3] + w * LG[5]))
    t2 = z * (LG[0] + w * (LG[2] + w * (LG[4] + w * LG[6])))
    r = t2 + t1
    hfsq = 0.5 * f * f
    return dk * LN2_HI - ((hfsq - (s * (hfsq + r) + dk * LN2_LO)) - f)


def sincos_turn30(k: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """detmath::sincos_turn30: sin and cos of 2 pi (k + 1/2) 2^-30, k = bits 0..29."""
    k = _u64(k)
    octant = (k >> np.uint64(27)) & np.uint64(7)
    r0 = k & np.uint64(0x7FFFFFF)
    r = np.where(octant & np.uint64(1), np.uint64(0x7FFFFFF) - r0, r0)
    t = _double(np.uint64(0x4330000000000000) | r) - float.fromhex("0x1.fffffffffffffp+51")
    hi = TURN_HI * t
    lo = TURN_LO * t
    x = hi + lo
    y = (hi - x) + lo
    z = x * x
    w = z * z
    rs = S[1] + z * (S[2] + z * S[3]) + z * w * (S[4] + z * S[5])
    v = z * x
    sn = x - ((z * (0.5 * y - v * rs) - y) - v * S[0])
    rc = z * (C[0] + z * (C[1] + z * C[2])) + w * w * (C[3] + z * (C[4] + z * C[5]))
    hz = 0.5 * z
    one_hz = 1.0 - hz
    cs = one_hz + (((1.0 - one_hz) - hz) + (z * rc - x * y))
    swap = ((octant ^ (octant >> np.uint64(1))) & np.uint64(1)).astype(bool)
    a, c = np.where(swap, cs, sn), np.where(swap, sn, cs)
    sin_negative = (octant & np.uint64(4)).astype(bool)
    cos_negative = ((octant + np.uint64(2)) & np.uint64(4)).astype(bool)
    return np.where(sin_negative, -a, a), np.where(cos_negative, -c, c)


def draw_pairs(seed: int, paths, pair: int) -> np.ndarray:
    """The noise of steps 2 pair and 2 pair + 1 of the given paths, shape (6, n): the two
    normals, the two exponentials, the two coins (1.0 or 0.0), as _core.draw_noise."""
    w0, w1, w2, w3 = philox_words(seed, paths, pair)
    radius = np.sqrt(-2.0 * log_positive(unit_of_word(w0)))
    sn, cs = sincos_turn30(w1 >> np.uint64(2))
    return np.stack([radius * cs, radius * sn,
                     -log_positive(unit_of_word(w2)), -log_positive(unit_of_word(w3)),
                     (w1 & np.uint64(1)).astype(np.float64), ((w1 >> np.uint64(1)) & np.uint64(1)).astype(np.float64)])


def exact_step(x0: np.ndarray, dt: float, drift: float, noise: float, normal: np.ndarray,
               exponential: np.ndarray, coin: np.ndarray) -> np.ndarray:
    """The exact velocity step as the kernel evaluates it (docs/exact-step.md), elementwise."""
    # The regular case of exact_step.hpp (every step here has a normal root = sqrt(d^2 + q)):
    # with r = q / (2 (root + |d|)), the bridge minimum is min(d, 0) - r and d - m is
    # max(d, 0) + r, sums of terms of one sign (no cancellation for either sign of d).
    mean_d, scale_d = -drift * dt, noise * np.sqrt(dt)
    twice_var = 2.0 * (noise * noise * dt)
    d = scale_d * normal + mean_d
    q = twice_var * exponential
    root = np.sqrt(d * d + q)
    assert np.all((root >= 2.0**-450) & np.isfinite(root)), "the reference has the regular case only"
    a = np.abs(x0)
    r = 0.5 * q / (root + np.abs(d))
    m = np.minimum(d, 0.0) - r
    up, down = a + d, np.maximum(d, 0.0) + r
    magnitude = np.where(up < down, down, up)
    touched = a <= -m
    positive = (touched & (coin != 0.0)) | (~touched & (x0 > 0.0))
    return np.where(positive, magnitude, -magnitude)


def final_velocities(seed: int, paths: int, dt: float, steps: int, drift: float, noise: float) -> np.ndarray:
    """Velocities of paths 0 .. paths - 1 after `steps` exact steps of length dt from rest."""
    idx = np.arange(paths, dtype=np.uint64)
    x = np.zeros(paths)
    noise_pair = None
    for k in range(steps):
        if k % 2 == 0:
            noise_pair = draw_pairs(seed, idx, k // 2)
        j = k % 2
        x = exact_step(x, dt, drift, noise, noise_pair[j], noise_pair[2 + j], noise_pair[4 + j])
    return x
