// The exact step: bridge minimum against its exact law, reflection and sign rules, and the
// whole step against the closed-form transition density of the scaled velocity.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <functional>
#include <random>
#include <vector>

#include "crandall/rng.hpp"
#include "crandall/exact_step.hpp"

namespace {

// Kolmogorov-Smirnov statistic of a sample against a CDF.
double ks_statistic(std::vector<double> sample, const std::function<double(double)>& cdf) {
  std::sort(sample.begin(), sample.end());
  const double n = static_cast<double>(sample.size());
  double d = 0.0;
  for (std::size_t i = 0; i < sample.size(); ++i) {
    const double f = cdf(sample[i]);
    d = std::max({d, std::abs(f - i / n), std::abs((i + 1) / n - f)});
  }
  return d;
}

// 1.95 / sqrt(n) is the 0.1% critical value of the KS statistic: with a fixed seed a correct
// sampler passes deterministically, and a wrong law at this n fails by a wide margin.
double ks_critical(std::size_t n) { return 1.95 / std::sqrt(static_cast<double>(n)); }

std::vector<crandall::StepNoise> noise(std::size_t n, std::uint64_t seed) {
  std::vector<crandall::StepNoise> out(n);
  for (std::size_t i = 0; i + 1 < n; i += 2) crandall::draw_pair(seed, 7, i / 2, &out[i]);
  return out;
}

TEST(BridgeMinimum, MatchesExactLaw) {
  const std::size_t n = 200000;
  for (double d : {-1.5, -0.1, 0.0, 0.4, 3.0}) {
    const double variance = 0.7;
    std::mt19937_64 gen(12345);
    std::exponential_distribution<double> e(1.0);
    std::vector<double> m(n);
    for (auto& x : m) x = crandall::bridge_minimum(d, variance, e(gen));
    const double top = std::min(0.0, d);
    for (double x : m) ASSERT_LE(x, top);
    auto cdf = [&](double x) { return std::exp(-2.0 * x * (x - d) / variance); };
    EXPECT_LT(ks_statistic(m, cdf), ks_critical(n)) << "d = " << d;
  }
}

TEST(BridgeMinimum, AgreesWithFinelyDiscretisedBridges) {
  // Independent check of the formula: the minimum of a Brownian bridge sampled on a fine grid
  // (which overestimates the minimum by O(sqrt(dt))), against the formula's mean.
  const double d = 0.5, variance = 1.0;
  const int grid = 4000, bridges = 4000;
  std::mt19937_64 gen(99);
  std::normal_distribution<double> z(0.0, 1.0);
  double mean_fine = 0.0;
  for (int b = 0; b < bridges; ++b) {
    std::vector<double> w(grid + 1, 0.0);
    for (int i = 1; i <= grid; ++i) w[i] = w[i - 1] + std::sqrt(variance / grid) * z(gen);
    double lo = 0.0;
    for (int i = 0; i <= grid; ++i) lo = std::min(lo, w[i] - (w[grid] - d) * i / grid);
    mean_fine += lo / bridges;
  }
  std::exponential_distribution<double> e(1.0);
  double mean_exact = 0.0;
  const int draws = 400000;
  for (int i = 0; i < draws; ++i) mean_exact += crandall::bridge_minimum(d, variance, e(gen)) / draws;
  // Grid bias: the discrete minimum is higher by about 0.5826 sqrt(variance / grid); the
  // Monte Carlo error of mean_fine is about 0.6 / sqrt(bridges) = 0.01.
  const double bias = 0.5826 * std::sqrt(variance / grid);
  EXPECT_NEAR(mean_fine - bias, mean_exact, 0.04);
}

TEST(BridgeMinimum, StableForLargePositiveIncrement) {
  // d = 1e8: the textbook form returns 0 (cancellation); the true minimum is about -q/(4d).
  const double m = crandall::bridge_minimum(1e8, 1.0, 1.0);
  EXPECT_LT(m, 0.0);
  EXPECT_NEAR(m, -0.5 * 2.0 / (2.0 * 1e8), 1e-20);
}

TEST(ExactStep, DeterministicReflectionRules) {
  // Without noise the body decelerates at rate c and stays at 0 once it gets there.
  auto r = crandall::exact_step(1.0, 0.1, 2.0, 0.0, 0.0, 1.0, true);
  EXPECT_DOUBLE_EQ(r.velocity, 0.8);
  EXPECT_FALSE(r.touched);
  r = crandall::exact_step(-1.0, 0.1, 2.0, 0.0, 0.0, 1.0, true);
  EXPECT_DOUBLE_EQ(r.velocity, -0.8);
  r = crandall::exact_step(0.1, 1.0, 2.0, 0.0, 0.0, 1.0, true);
  EXPECT_EQ(r.velocity, 0.0);
  EXPECT_TRUE(r.touched);
}

TEST(ExactStep, SignKeptUnlessTouched) {
  const auto z = noise(100000, 3);
  int flips_untouched = 0, touched = 0, positive_after_touch = 0;
  for (std::size_t i = 0; i < z.size(); ++i) {
    const double x = 0.3;
    const auto r = crandall::exact_step(x, 0.05, 2.0, std::sqrt(2.0), z[i].normal, z[i].exponential,
                                        z[i].coin);
    if (!r.touched && r.velocity < 0) ++flips_untouched;
    if (r.touched) {
      ++touched;
      if (r.velocity > 0) ++positive_after_touch;
    }
  }
  EXPECT_EQ(flips_untouched, 0);
  ASSERT_GT(touched, 1000);
  // After a touch of zero the sign is a fair coin: 5 binomial standard errors.
  EXPECT_NEAR(static_cast<double>(positive_after_touch) / touched, 0.5, 5.0 * 0.5 / std::sqrt(touched));
}

// Transition density of dX = -2 sign(X) dt + sqrt(2) dW over time t from x (docs/exact-step.md).
double density(double x, double y, double t) {
  return std::exp(-(y - x) * (y - x) / (4 * t) - (std::abs(y) - std::abs(x)) - t) / std::sqrt(4 * M_PI * t) +
         0.5 * std::exp(-2 * std::abs(y)) * std::erfc((std::abs(x) + std::abs(y) - 2 * t) / (2 * std::sqrt(t)));
}

TEST(ExactStep, MatchesTransitionDensity) {
  const std::size_t n = 100000;
  for (double x : {0.0, 0.4, -1.3}) {
    for (double t : {0.01, 0.3, 2.0}) {
      const auto z = noise(n, 11);
      std::vector<double> y(n);
      for (std::size_t i = 0; i < n; ++i)
        y[i] = crandall::exact_step(x, t, 2.0, std::sqrt(2.0), z[i].normal, z[i].exponential, z[i].coin).velocity;
      // CDF by the trapezoid rule on a fine grid spanning the sample (density is smooth).
      const double lo = *std::min_element(y.begin(), y.end()) - 1.0;
      const double hi = *std::max_element(y.begin(), y.end()) + 1.0;
      const int grid = 40000;
      std::vector<double> cdf_grid(grid + 1, 0.0);
      const double step = (hi - lo) / grid;
      double prev = density(x, lo, t);
      for (int i = 1; i <= grid; ++i) {
        const double cur = density(x, lo + i * step, t);
        cdf_grid[i] = cdf_grid[i - 1] + 0.5 * step * (prev + cur);
        prev = cur;
      }
      EXPECT_NEAR(cdf_grid[grid], 1.0, 1e-3) << "x=" << x << " t=" << t;
      auto cdf = [&](double v) {
        const double pos = (v - lo) / step;
        const int i = std::min(grid - 1, std::max(0, static_cast<int>(pos)));
        return cdf_grid[i] + (pos - i) * (cdf_grid[i + 1] - cdf_grid[i]);
      };
      EXPECT_LT(ks_statistic(y, cdf), ks_critical(n)) << "x=" << x << " t=" << t;
    }
  }
}

TEST(ExactStep, AnyStepLengthGivesTheSameLaw) {
  // Ten steps of 0.1 and one step of 1.0 from x = 0 have the same law (exactness in law).
  const std::size_t n = 100000;
  std::vector<double> one(n), ten(n);
  for (std::size_t p = 0; p < n; ++p) {
    crandall::StepNoise z[2];
    crandall::draw_pair(5, p, 0, z);
    one[p] = crandall::exact_step(0.0, 1.0, 2.0, std::sqrt(2.0), z[0].normal, z[0].exponential, z[0].coin).velocity;
    double x = 0.0;
    for (int k = 0; k < 10; ++k) {
      crandall::StepNoise w[2];
      crandall::draw_pair(6, p, static_cast<std::uint64_t>(k / 2), w);
      const auto& s = w[k % 2];
      x = crandall::exact_step(x, 0.1, 2.0, std::sqrt(2.0), s.normal, s.exponential, s.coin).velocity;
    }
    ten[p] = x;
  }
  // Two-sample KS at 0.1%: critical value 1.95 sqrt(2/n).
  std::sort(one.begin(), one.end());
  std::sort(ten.begin(), ten.end());
  double d = 0.0;
  std::size_t i = 0, j = 0;
  while (i < n && j < n) {
    if (one[i] <= ten[j]) ++i; else ++j;
    d = std::max(d, std::abs(static_cast<double>(i) / n - static_cast<double>(j) / n));
  }
  EXPECT_LT(d, 1.95 * std::sqrt(2.0 / n));
}

}  // namespace

namespace {

TEST(ExactStep, ScaledFormAgreesWithTheRegularForm) {
  // Where both apply, the two evaluations of the step (the regular one, and the one in units
  // of the noise's standard deviation used outside the regular range) give the same magnitude
  // and touch to a few ulps: the scaled form is the same formula, not an approximation.
  const auto z = noise(20000, 17);
  int touched = 0;
  for (double step : {1e-6, 0.01, 1.0, 100.0, 1e8}) {
    for (double x : {0.0, 0.3, -2.0, 40.0}) {
      for (const auto& s : z) {
        const double d = -2.0 * step + std::sqrt(2.0) * std::sqrt(step) * s.normal;
        const double q = 2.0 * crandall::step_variance(std::sqrt(2.0), step) * s.exponential;
        const double root = std::sqrt(d * d + q);
        ASSERT_TRUE(crandall::step_regular(root));
        const double a = std::abs(x);
        const double magnitude = crandall::step_regular_magnitude(a, d, q, root);
        const double m = crandall::step_regular_minimum(d, q, root);
        const auto k = crandall::step_constants(step, 2.0, std::sqrt(2.0));
        const auto c = crandall::step_scaled_parts(a, k, crandall::step_increment(k.mean, k.scale, s.normal),
                                                   s.normal, s.exponential);
        EXPECT_NEAR(magnitude, c.magnitude, 1e-14 * std::max(1.0, magnitude))
            << "step=" << step << " x=" << x;
        EXPECT_NEAR(m, c.minimum, 1e-14 * std::max(1.0, -m)) << "step=" << step << " x=" << x;
        touched += crandall::step_touched(a, m);
      }
    }
  }
  EXPECT_GT(touched, 1000);
}

TEST(ExactStep, LongStepsReachTheStationaryLaw) {
  // From any start, a step of 1e15 .. 1e300 scaled units lands in the stationary law,
  // density e^{-2|y|}: |X| is exponential with mean 1/2 (KS), and the sign a fair coin. The
  // textbook d - m lost every digit here (Var U1 was 1.26 at 1e16 and 0 from 1e17).
  const std::size_t n = 100000;
  for (double step : {1e15, 1e16, 1e17, 1e150, 1e160, 1e300}) {
    for (double x : {0.0, -3.0}) {
      const auto z = noise(n, 23);
      std::vector<double> a(n);
      int positive = 0;
      for (std::size_t i = 0; i < n; ++i) {
        const auto r = crandall::exact_step(x, step, 2.0, std::sqrt(2.0), z[i].normal,
                                            z[i].exponential, z[i].coin);
        ASSERT_TRUE(std::isfinite(r.velocity));
        ASSERT_TRUE(r.touched);
        a[i] = std::abs(r.velocity);
        positive += r.velocity > 0.0;
      }
      EXPECT_LT(ks_statistic(a, [](double v) { return 1.0 - std::exp(-2.0 * v); }), ks_critical(n))
          << "step=" << step;
      EXPECT_NEAR(static_cast<double>(positive) / n, 0.5, 5.0 * 0.5 / std::sqrt(n));
    }
  }
}

TEST(ExactStep, NoNoiseAndTinySteps) {
  // Deterministic steps below the regular range (d^2 underflows): the body decelerates by
  // c h and stops at 0; the textbook form returned a negative magnitude here.
  for (double step : {1e-300, 1e-320, 1.0}) {
    const auto r = crandall::exact_step(-1e-310, step, 2.0, 0.0, 0.3, 1.0, true);
    EXPECT_EQ(r.velocity, step * 2.0 >= 1e-310 ? 0.0 : -(1e-310 - 2.0 * step));
    EXPECT_GE(std::abs(r.velocity), 0.0);
    const auto s = crandall::exact_step(0.5, step, 2.0, 0.0, 0.3, 1.0, false);
    EXPECT_EQ(s.velocity, std::max(0.0, 0.5 - 2.0 * step));
  }
  // Without friction and noise nothing moves.
  const auto r = crandall::exact_step(-0.7, 3.0, 0.0, 0.0, 0.3, 1.0, true);
  EXPECT_EQ(r.velocity, -0.7);
  EXPECT_FALSE(r.touched);
}

// The scaled step's sqrt(delta^2 + 2E) (scaled_root, +, -, *, / and sqrt only, in place of the
// C library's hypot): within 0.5 ulp of long double over a million arguments of the ranges the
// step meets (and far beyond), measured 0.500 (normal results); no overflow or underflow at
// the ends.
TEST(ExactStep, ScaledRootWithinHalfAnUlp) {
  std::mt19937_64 gen(20261127);
  std::uniform_real_distribution<double> mant(1.0, 2.0);
  std::uniform_int_distribution<int> ex(-1070, 1020);
  double worst = 0.0;
  auto check = [&](double x, double y) {
    const long double want = std::sqrt(static_cast<long double>(x) * x + static_cast<long double>(y) * y);
    int e;
    std::frexp(static_cast<double>(want), &e);
    const double err = static_cast<double>(std::fabs(crandall::scaled_root(x, y) - want) /
                                           std::ldexp(1.0L, std::max(e, -1021) - 53));
    // Subnormal results are rounded twice (to 53 bits, then to the subnormal's): 1 ulp there.
    if (want >= 0x1p-1022L) worst = std::max(worst, err);
    else EXPECT_LE(err, 1.0) << x << " " << y;
  };
  for (int i = 0; i < 500000; ++i) {
    check(mant(gen) * 64.0 - 160.0, std::sqrt(2.0 * mant(gen) * 20.0));  // delta, sqrt(2E)
    const int k = ex(gen);
    check(std::ldexp(mant(gen), k), std::ldexp(mant(gen), k + ex(gen) % 40));
  }
  std::printf("scaled_root: worst %.4f ulp\n", worst);
  EXPECT_LE(worst, 0.5 + 1e-3);
  const double inf = std::numeric_limits<double>::infinity();
  EXPECT_EQ(crandall::scaled_root(-inf, 3.0), inf);
  EXPECT_EQ(crandall::scaled_root(0.0, 0.0), 0.0);
  EXPECT_EQ(crandall::scaled_root(3 * 0x1p900, 4 * 0x1p900), 5 * 0x1p900);
  EXPECT_EQ(crandall::scaled_root(3 * 0x1p-1070, 4 * 0x1p-1070), 5 * 0x1p-1070);
  EXPECT_EQ(crandall::scaled_root(3 * 0x1p-600, -4 * 0x1p-600), 5 * 0x1p-600);
  EXPECT_TRUE(std::isnan(crandall::scaled_root(std::nan(""), 1.0)));
}

}  // namespace
