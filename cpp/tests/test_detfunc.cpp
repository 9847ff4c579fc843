// Accuracy and special cases of the deterministic exp, log, log1p and log erfc (detfunc.hpp),
// against x87 long double (64-bit significand: its own error is about 2^-11 of a double ulp).
// Arguments: a fine stride over each function's range plus pseudo-random bit patterns (a
// fixed-seed generator), a few seconds in all.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <limits>

#include "crandall/detfunc.hpp"

namespace {

namespace df = crandall::detfunc;

// |got - want| in units in the last place of the double nearest to want (normal range).
double ulp_error(double got, long double want) {
  int e;
  std::frexp(static_cast<double>(want), &e);
  const long double ulp = std::ldexp(1.0L, e - 53);
  return static_cast<double>(std::fabs(static_cast<long double>(got) - want) / ulp);
}

struct Worst {
  double err = 0.0;
  double at = 0.0;
  void take(double e, double x) {
    if (e > err) {
      err = e;
      at = x;
    }
  }
};

// A fixed-seed splitmix64 stream of uniforms in [a, b).
struct Uniforms {
  std::uint64_t s = 0x9E3779B97F4A7C15ull;
  double next(double a, double b) {
    std::uint64_t z = (s += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    z ^= z >> 31;
    return a + (b - a) * (static_cast<double>(z >> 11) * 0x1p-53);
  }
};

template <class F, class R>
Worst sweep(F f, R ref, double a, double b, int count) {
  Worst w;
  Uniforms u;
  for (int i = 0; i <= count; ++i) {
    const double x = a + (b - a) * (static_cast<double>(i) / count);
    w.take(ulp_error(f(x), ref(static_cast<long double>(x))), x);
    const double y = u.next(a, b);
    w.take(ulp_error(f(y), ref(static_cast<long double>(y))), y);
  }
  return w;
}

constexpr double kInf = std::numeric_limits<double>::infinity();

TEST(DetFunc, ExpWithinOneUlp) {
  auto f = [](double x) { return df::exp(x); };
  auto r = [](long double x) { return std::exp(x); };
  Worst w = sweep(f, r, -708.0, 709.78, 2000000);  // normal results
  for (const Worst& v : {sweep(f, r, -1.0, 1.0, 200000), sweep(f, r, -1e-6, 1e-6, 20000)})
    w.take(v.err, v.at);
  std::printf("exp: worst %.4f ulp at %.17g\n", w.err, w.at);
  EXPECT_LT(w.err, 1.0) << w.at;
}

TEST(DetFunc, ExpSpecialCases) {
  EXPECT_EQ(df::exp(0.0), 1.0);
  EXPECT_EQ(df::exp(-kInf), 0.0);
  EXPECT_EQ(df::exp(kInf), kInf);
  EXPECT_EQ(df::exp(710.0), kInf);
  EXPECT_EQ(df::exp(-746.0), 0.0);
  EXPECT_TRUE(std::isnan(df::exp(std::numeric_limits<double>::quiet_NaN())));
  // Subnormal results: within one subnormal step of the library's (glibc rounds correctly).
  for (double x : {-709.5, -720.0, -740.0, -745.0})
    EXPECT_LE(std::fabs(df::exp(x) - std::exp(x)), 0x1p-1074) << x;
  EXPECT_LT(ulp_error(df::exp(709.7), std::exp(static_cast<long double>(709.7))), 1.0);  // k = 1024
}

TEST(DetFunc, LogWithinOneUlp) {
  auto f = [](double x) { return df::log(x); };
  auto r = [](long double x) { return std::log(x); };
  Worst w = sweep(f, r, 0.5, 2.0, 1000000);  // log near 0 (x near 1): cancellation would show
  for (const Worst& v : {sweep(f, r, 1e-300, 1e-290, 100000), sweep(f, r, 1.0, 1e300, 1000000),
                         sweep(f, r, 1e-12, 1.0, 1000000)})
    w.take(v.err, v.at);
  // Subnormal arguments.
  for (double x : {0x1p-1074, 3 * 0x1p-1070, 0x1.8p-1030, 0x1.fffffffffffffp-1023}) {
    w.take(ulp_error(df::log(x), std::log(static_cast<long double>(x))), x);
  }
  std::printf("log: worst %.4f ulp at %.17g\n", w.err, w.at);
  EXPECT_LT(w.err, 1.0) << w.at;
  EXPECT_EQ(df::log(1.0), 0.0);
  EXPECT_EQ(df::log(0.0), -kInf);
  EXPECT_EQ(df::log(kInf), kInf);
  EXPECT_TRUE(std::isnan(df::log(-1.0)));
}

TEST(DetFunc, Log1pWithinOneUlp) {
  auto f = [](double x) { return df::log1p(x); };
  auto r = [](long double x) { return std::log1p(x); };
  Worst w = sweep(f, r, -1.0 + 0x1p-52, 1.0, 2000000);
  for (const Worst& v : {sweep(f, r, -1e-6, 1e-6, 100000), sweep(f, r, -1e-12, 1e-12, 10000),
                         sweep(f, r, 1.0, 1e20, 200000), sweep(f, r, 1e20, 1e300, 20000),
                         sweep(f, r, -0.9999999, -0.99, 100000)})
    w.take(v.err, v.at);
  // The splitting fractions -k / n.
  for (int n = 1; n <= 4096; n *= 2)
    for (int k = 1; k < n; ++k) {
      const double x = -static_cast<double>(k) / n;
      w.take(ulp_error(df::log1p(x), std::log1p(static_cast<long double>(x))), x);
    }
  for (int k = 1; k < 1000; ++k) {
    const double x = -static_cast<double>(k) / 1000.0;
    w.take(ulp_error(df::log1p(x), std::log1p(static_cast<long double>(x))), x);
  }
  std::printf("log1p: worst %.4f ulp at %.17g\n", w.err, w.at);
  EXPECT_LT(w.err, 1.0) << w.at;
  EXPECT_EQ(df::log1p(0.0), 0.0);
  EXPECT_EQ(df::log1p(-1.0), -kInf);
  EXPECT_EQ(df::log1p(kInf), kInf);
  EXPECT_TRUE(std::isnan(df::log1p(-1.5)));
}

// log erfc against long double's erfc (glibc's erfcl: within a few long double ulps) up to
// x = 100 (erfcl underflows past 106), its asymptotic series beyond. The error is in ulps of
// max(|log erfc x|, 1/2): near x = 0, log erfc x = log(1 - 1.13 x) keeps the absolute error of
// erfc x (fractions of 1e-16) and no better.
long double log_erfc_reference(long double x) {
  if (x < 100) return std::log(std::erfc(x));
  long double t = 1, sum = 1;
  const long double h = 1 / (2 * x * x);
  for (int k = 1; k < 12; ++k) {
    t *= -(2 * k - 1) * h;
    sum += t;
  }
  const long double log_sqrt_pi = 0.5723649429247000870717136756012478L;
  return -x * x - std::log(x) - log_sqrt_pi + std::log(sum);
}

double log_erfc_error(double x) {
  const long double want = log_erfc_reference(x);
  const long double scale = std::fabs(want) < 0.5L ? 0.5L : want;
  int e;
  std::frexp(static_cast<double>(scale), &e);
  return static_cast<double>(std::fabs(static_cast<long double>(df::log_erfc(x)) - want) /
                             std::ldexp(1.0L, e - 53));
}

TEST(DetFunc, LogErfcAccuracy) {
  Worst w;
  Uniforms u;
  auto take = [&](double x) { w.take(log_erfc_error(x), x); };
  for (int i = 0; i <= 400000; ++i) {
    take(-40.0 + 240.0 * i / 400000.0);
    take(u.next(-3.0, 30.0));
    take(u.next(1e2, 1e6));
  }
  for (double x : {1e10, 1e100, 1e150}) take(x);
  std::printf("log_erfc: worst %.4f ulp (of max(|log erfc|, 1/2)) at %.17g\n", w.err, w.at);
  EXPECT_LT(w.err, 2.0) << w.at;
  EXPECT_EQ(df::log_erfc(kInf), -kInf);
  EXPECT_EQ(df::log_erfc(1e155), -kInf);  // -x^2 overflows
  EXPECT_EQ(df::log_erfc(-kInf), static_cast<double>(std::log(2.0L)));
  EXPECT_EQ(df::log_erfc(0.0), 0.0);
}

}  // namespace
