// The project's own logarithm and sine/cosine for the random path: the same bits on every CPU.
//
// Library math (glibc's libm and libmvec, SLEEF, Highway) rounds a few values differently from
// one instruction set to another, so a seed would give different numbers on different machines.
// These functions use only +, -, *, / (and integer operations on the bits, which are exact), all
// correctly rounded in IEEE 754 binary64, in a fixed order, compiled without floating-point
// contraction: every variant of the kernel (scalar, SSE2, AVX2, AVX-512) and the NumPy
// reference (tests/reference_rng.py) gets the same bits.
//
// They are written as straight-line code without tables or branches so that GCC vectorises a
// `#pragma omp simd` loop over them, and they only handle the inputs the generator produces
// (docs/random-numbers.md), which saves the special cases:
// - log_positive(u) for u = (w + 1/2) 2^-32, w a 32-bit word: positive, normal, below 1;
// - sincos_turn30(k) = (sin, cos) of 2 pi (k + 1/2) 2^-30 for a 30-bit integer k, reduced
//   exactly from k by octant, so there is no argument-reduction error at all.
//
// The polynomials and their evaluation order are fdlibm's (e_log.c, and FreeBSD's k_sin.c and
// k_cos.c, Bruce D. Evans' branch-free revision of the cosine kernel):
//   Copyright (C) 1993 by Sun Microsystems, Inc. All rights reserved.
//   Developed at SunSoft, a Sun Microsystems, Inc. business. Permission to use, copy, modify,
//   and distribute this software is freely granted, provided that this notice is preserved.
//
// Accuracy, measured over every input against long double (cpp/tests/test_detmath.cpp with
// CRANDALL_EXHAUSTIVE=1; a strided subset by default; tests/test_reference_rng.py against
// mpmath): log within 0.845 ulp over all 2^32 uniforms, sin and cos within 0.797 ulp over all
// 2^30 angles.
#pragma once

#include <cstdint>
#include <cstring>

#include "crandall/variant.hpp"

CRANDALL_BEGIN_VARIANT
namespace detmath {

// The generator's loops (rng.hpp, draw_pairs) vectorise only if these are inlined into them.
// GCC's inlining also weighs the size of the whole translation unit, so a kernel unit with more
// instantiations of the path loop once left log_positive and sincos_turn30 out of line (the
// kernel ran 2.6 times slower); forcing them in keeps the speed independent of what else the
// unit compiles. Inlining changes no value (no contraction: -ffp-contract=off).
#define CRANDALL_HOT [[gnu::always_inline]] inline

CRANDALL_HOT std::uint64_t bits_of(double x) {
  std::uint64_t b;
  std::memcpy(&b, &x, sizeof b);
  return b;
}

CRANDALL_HOT double from_bits(std::uint64_t b) {
  double x;
  std::memcpy(&x, &b, sizeof x);
  return x;
}

// fdlibm's e_log.c constants (exact binary values as hexadecimal literals).
constexpr double kLn2Hi = 0x1.62e42feep-1;          // 6.93147180369123816490e-01
constexpr double kLn2Lo = 0x1.a39ef35793c76p-33;    // 1.90821492927058770002e-10
constexpr double kLg1 = 0x1.5555555555593p-1;       // 6.666666666666735130e-01
constexpr double kLg2 = 0x1.999999997fa04p-2;       // 3.999999999940941908e-01
constexpr double kLg3 = 0x1.2492494229359p-2;       // 2.857142874366239149e-01
constexpr double kLg4 = 0x1.c71c51d8e78afp-3;       // 2.222219843214978396e-01
constexpr double kLg5 = 0x1.7466496cb03dep-3;       // 1.818357216161805012e-01
constexpr double kLg6 = 0x1.39a09d078c69fp-3;       // 1.531383769920937332e-01
constexpr double kLg7 = 0x1.2f112df3e5244p-3;       // 1.479819860511658591e-01
// Natural log of a positive normal double (fdlibm's algorithm without the branches for zero,
// subnormals, infinities and NaN, which the generator never produces). Write x = 2^k (1 + f)
// with 1 + f in [sqrt(2)/2, sqrt(2)); then log(1 + f) = 2 atanh(s), s = f / (2 + f).
CRANDALL_HOT double log_positive(double x) {
  const std::uint64_t b = bits_of(x);
  const std::uint64_t mantissa = b & 0x000FFFFFFFFFFFFFull;
  // Carries into bit 52 when the mantissa is at least about sqrt(2) - 1: then x/2 is used.
  const std::uint64_t halve = (mantissa + (std::uint64_t{0x95f64} << 32)) & (std::uint64_t{1} << 52);
  const double m = from_bits(mantissa | (halve ^ 0x3FF0000000000000ull));
  // k as a double without an integer conversion (SSE2 and AVX2 have none for 64-bit integers):
  // the bits 0x433 << 52 | e are the double 2^52 + e, exactly.
  const std::uint64_t biased = (b >> 52) + (halve >> 52);
  const double dk = from_bits(0x4330000000000000ull | biased) - 0x1.00000000003ffp+52;  // 2^52 + 1023
  const double f = m - 1.0;
  const double s = f / (2.0 + f);
  const double z = s * s;
  const double w = z * z;
  const double t1 = w * (kLg2 + w * (kLg4 + w * kLg6));
  const double t2 = z * (kLg1 + w * (kLg3 + w * (kLg5 + w * kLg7)));
  const double r = t2 + t1;
  const double hfsq = 0.5 * f * f;
  // fdlibm uses this form (with hfsq = f^2 / 2) where x is near sqrt(2) times a power of 2 and
  // a cheaper one elsewhere; FreeBSD's and musl's revisions use it everywhere, and so does this
  // one: one form, no select (a select of two forms does not vectorise for SSE2). With dk = +0
  // it gives the same bits as fdlibm's k == 0 form.
  return dk * kLn2Hi - ((hfsq - (s * (hfsq + r) + dk * kLn2Lo)) - f);
}

// The uniform (w + 1/2) 2^-32 of the low 32 bits of `word` (the higher bits are ignored),
// built from the bits: 1 + (w + 1/2) 2^-32 is exact in a double, and so is subtracting 1.
CRANDALL_HOT double unit_of_word(std::uint64_t word) {
  const std::uint64_t w = word & 0xFFFFFFFFull;
  return from_bits(0x3FF0000000000000ull | (w << 20) | (std::uint64_t{1} << 19)) - 1.0;
}

// FreeBSD k_sin.c / k_cos.c coefficients: minimax on [-pi/4, pi/4].
constexpr double kS1 = -0x1.5555555555549p-3;  // -1.66666666666666324348e-01
constexpr double kS2 = 0x1.111111110f8a6p-7;   // 8.33333333332248946124e-03
constexpr double kS3 = -0x1.a01a019c161d5p-13; // -1.98412698298579493134e-04
constexpr double kS4 = 0x1.71de357b1fe7dp-19;  // 2.75573137070700676789e-06
constexpr double kS5 = -0x1.ae5e68a2b9cebp-26; // -2.50507602534068634195e-08
constexpr double kS6 = 0x1.5d93a5acfd57cp-33;  // 1.58969099521155010221e-10
constexpr double kC1 = 0x1.555555555554cp-5;   // 4.16666666666666019037e-02
constexpr double kC2 = -0x1.6c16c16c15177p-10; // -1.38888888888741095749e-03
constexpr double kC3 = 0x1.a01a019cb159p-16;   // 2.48015872894767294178e-05
constexpr double kC4 = -0x1.27e4f809c52adp-22; // -2.75573143513906633035e-07
constexpr double kC5 = 0x1.1ee9ebdb4b1c4p-29;  // 2.08757232129817482790e-09
constexpr double kC6 = -0x1.8fae9be8838d4p-37; // -1.13596475577881948265e-11
// 2 pi 2^-30 = kTurnHi + kTurnLo (+ 2e-33): kTurnHi has 25 significant bits, so its product
// with t = r + 1/2 (28 significant bits) is exact.
constexpr double kTurnHi = 0x1.921fb5p-28;
constexpr double kTurnLo = 0x1.110b4611a6263p-54;

// sin and cos of 2 pi (k + 1/2) 2^-30 for k = bits 0..29 of `k30` (higher bits ignored).
// The top three bits of k pick the octant; within it the angle (or its complement to pi/4,
// in odd octants) is 2 pi (r + 1/2) 2^-30 with r < 2^27, formed as the exact double-double
// x + y = kTurnHi t + kTurnLo t, and fdlibm's kernels take x + y on [0, pi/4] to < 1 ulp.
CRANDALL_HOT void sincos_turn30(std::uint64_t k30, double& sin_out, double& cos_out) {
  const std::uint64_t octant = (k30 >> 27) & 7u;
  const std::uint64_t r0 = k30 & 0x7FFFFFFull;
  // Odd octants: pi/4 minus the angle of r0, i.e. the angle of 2^27 - 1 - r0 (exact).
  const std::uint64_t odd = octant & 1u;
  const std::uint64_t r = r0 ^ (0x7FFFFFFull & (0 - odd));
  // r + 1/2 as a double, exactly, from the bits of 2^52 + r.
  const double t = from_bits(0x4330000000000000ull | r) - 0x1.fffffffffffffp+51;  // 2^52 - 1/2
  const double hi = kTurnHi * t;  // exact
  const double lo = kTurnLo * t;
  const double x = hi + lo;
  const double y = (hi - x) + lo;
  const double z = x * x;
  const double w = z * z;
  // k_sin.c with a tail y
  const double rs = kS2 + z * (kS3 + z * kS4) + z * w * (kS5 + z * kS6);
  const double v = z * x;
  const double sn = x - ((z * (0.5 * y - v * rs) - y) - v * kS1);
  // k_cos.c
  const double rc = z * (kC1 + z * (kC2 + z * kC3)) + w * w * (kC4 + z * (kC5 + z * kC6));
  const double hz = 0.5 * z;
  const double one_hz = 1.0 - hz;
  const double cs = one_hz + (((1.0 - one_hz) - hz) + (z * rc - x * y));
  // Quadrant q = octant / 2 rotates by q pi / 2; odd octants exchange sin and cos once more.
  // Selections and signs on the bits, with 64-bit integer arithmetic only (SSE2 has no 64-bit
  // compare, and a compare would stop the baseline loop from vectorising).
  const std::uint64_t swap = 0 - ((octant ^ (octant >> 1)) & 1u);        // all ones or zero
  const std::uint64_t sin_sign = ((octant >> 2) & 1u) << 63;             // q = 2, 3
  const std::uint64_t cos_sign = (((octant + 2u) >> 2) & 1u) << 63;      // q = 1, 2
  const std::uint64_t bs = bits_of(sn), bc = bits_of(cs);
  sin_out = from_bits(((bc & swap) | (bs & ~swap)) ^ sin_sign);
  cos_out = from_bits(((bs & swap) | (bc & ~swap)) ^ cos_sign);
}

}  // namespace detmath
CRANDALL_END_VARIANT
