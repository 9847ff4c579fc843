// Accuracy of the deterministic log and sin/cos (detmath.hpp) over the inputs the generator
// produces, against x87 long double (64-bit significand: its own error is about 2^-11 of a
// double ulp, negligible at the 1-ulp bound checked here). A strided subset by default (seconds);
// every input (2^32 logs, 2^30 angles; minutes) with CRANDALL_EXHAUSTIVE=1.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstdio>

#include "crandall/detmath.hpp"

namespace {

namespace dm = crandall::detmath;

bool exhaustive() {
  const char* e = std::getenv("CRANDALL_EXHAUSTIVE");
  return e && *e && *e != '0';
}

// |got - want| in units in the last place of the double nearest to want.
double ulp_error(double got, long double want) {
  int e;
  std::frexp(static_cast<double>(want), &e);  // want = m 2^e, m in [0.5, 1)
  const long double ulp = std::ldexp(1.0L, e - 53);
  return static_cast<double>(std::fabs(static_cast<long double>(got) - want) / ulp);
}

struct Worst {
  double err = 0.0;
  std::uint64_t at = 0;
  void take(double e, std::uint64_t k) {
    if (e > err) {
      err = e;
      at = k;
    }
  }
};

TEST(DetMath, UnitOfWordIsTheGeneratorsUniform) {
  for (std::uint64_t w : {0ull, 1ull, 12345ull, 0x80000000ull, 0xFFFFFFFFull, 0xABCDEF0123456789ull}) {
    const double want = (static_cast<double>(w & 0xFFFFFFFFull) + 0.5) * 0x1p-32;
    EXPECT_EQ(dm::unit_of_word(w), want) << w;
  }
}

// Worst error of log over words w (u = (w + 1/2) 2^-32) in [begin, end) with a stride.
Worst log_errors(std::uint64_t begin, std::uint64_t end, std::uint64_t stride) {
  Worst worst;
  for (std::uint64_t w = begin; w < end; w += stride) {
    const double u = dm::unit_of_word(w);
    worst.take(ulp_error(dm::log_positive(u), std::log(static_cast<long double>(u))), w);
  }
  return worst;
}

TEST(DetMath, LogWithinOneUlpOverTheGeneratorsInputs) {
  Worst worst;
  if (exhaustive()) {
    worst = log_errors(0, 1ull << 32, 1);
  } else {
    // The smallest words (u down to 2^-33: the largest |log u|, every exponent), the words
    // next to 1 (u up to 1 - 2^-33: log u near 0, where cancellation would show), a stride
    // across the rest, and both sides of the sqrt(2) mantissa boundary.
    for (const Worst& w : {log_errors(0, 1u << 20, 1), log_errors((1ull << 32) - (1u << 20), 1ull << 32, 1),
                           log_errors(0, 1ull << 32, 4093), log_errors(0xB504F333ull - 4096, 0xB504F333ull + 4096, 1),
                           log_errors(0x5A827999ull - 4096, 0x5A827999ull + 4096, 1)})
      worst.take(w.err, w.at);
  }
  std::printf("log: worst error %.4f ulp at w = %llu\n", worst.err, static_cast<unsigned long long>(worst.at));
  EXPECT_LT(worst.err, 1.0) << "at w = " << worst.at;
}

// sin and cos of 2 pi (k + 1/2) 2^-30, reference reduced the same exact way (octant from k,
// then the angle within it in long double, so the reference has no reduction error either).
void sincos_reference(std::uint64_t k, long double& s, long double& c) {
  const std::uint64_t octant = k >> 27, r0 = k & 0x7FFFFFF;
  const std::uint64_t r = (octant & 1) ? 0x7FFFFFF - r0 : r0;
  const long double pi = 3.141592653589793238462643383279502884L;
  const long double x = 2.0L * pi * (static_cast<long double>(r) + 0.5L) / 1073741824.0L;
  long double a = std::sin(x), b = std::cos(x);
  if ((octant ^ (octant >> 1)) & 1) std::swap(a, b);
  s = (octant & 4) ? -a : a;
  c = ((octant + 2) & 4) ? -b : b;
}

TEST(DetMath, SinCosReductionMatchesTheLibraryAtModerateAccuracy) {
  // Independent of the octant logic above: the library's sin/cos of the rounded angle agree to
  // 1e-15 (the angle's own rounding is about 4e-16 at 2 pi).
  for (std::uint64_t k = 0; k < (1ull << 30); k += 65521) {
    double s, c;
    dm::sincos_turn30(k, s, c);
    const double a = 6.283185307179586476925286766559 * ((static_cast<double>(k) + 0.5) * 0x1p-30);
    ASSERT_NEAR(s, std::sin(a), 1e-15) << k;
    ASSERT_NEAR(c, std::cos(a), 1e-15) << k;
  }
}

TEST(DetMath, SinCosWithinOneUlpOverTheGeneratorsAngles) {
  Worst ws, wc;
  const std::uint64_t stride = exhaustive() ? 1 : 1021;
  auto check = [&](std::uint64_t k) {
    double s, c;
    dm::sincos_turn30(k, s, c);
    long double rs, rc;
    sincos_reference(k, rs, rc);
    ws.take(ulp_error(s, rs), k);
    wc.take(ulp_error(c, rc), k);
  };
  for (std::uint64_t k = 0; k < (1ull << 30); k += stride) check(k);
  if (!exhaustive())
    for (std::uint64_t octant = 0; octant < 8; ++octant)  // both ends of every octant
      for (std::uint64_t r = 0; r < 2048; ++r) {
        check((octant << 27) | r);
        check((octant << 27) | (0x7FFFFFF - r));
      }
  std::printf("sin: worst %.4f ulp at k = %llu; cos: worst %.4f ulp at k = %llu\n", ws.err,
              static_cast<unsigned long long>(ws.at), wc.err, static_cast<unsigned long long>(wc.at));
  EXPECT_LT(ws.err, 1.0) << "at k = " << ws.at;
  EXPECT_LT(wc.err, 1.0) << "at k = " << wc.at;
}

TEST(DetMath, SinCosSymmetries) {
  // Angles k and 2^30 - 1 - k are 2 pi minus each other: sin flips, cos stays (exactly, since
  // both are computed from the same reduced argument).
  for (std::uint64_t k : {0ull, 1ull, 12345ull, 1ull << 27, (1ull << 28) + 77, (1ull << 30) - 1}) {
    double s1, c1, s2, c2;
    dm::sincos_turn30(k, s1, c1);
    dm::sincos_turn30((1ull << 30) - 1 - k, s2, c2);
    EXPECT_EQ(s1, -s2) << k;
    EXPECT_EQ(c1, c2) << k;
  }
}

}  // namespace
