// Merging accumulators equals accumulating in one pass, and both equal a two-pass reference.
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <vector>

#include "crandall/accumulators.hpp"

namespace {

using crandall::kMonomials;

struct Point {
  double v[3];
};

std::vector<Point> data(std::size_t n, std::uint64_t seed) {
  std::mt19937_64 gen(seed);
  std::normal_distribution<double> z(0.0, 1.0);
  std::vector<Point> out(n);
  // Correlated, skewed, with a large mean on the third variable (cancellation trap).
  for (auto& p : out) {
    const double a = z(gen), b = z(gen);
    p = {{a, a * 0.5 + b * b, 1e4 + std::exp(0.3 * b)}};
  }
  return out;
}

// Central sums by two passes in long double.
std::vector<long double> reference(const std::vector<Point>& pts) {
  long double mean[3] = {0, 0, 0};
  for (const auto& p : pts)
    for (int v = 0; v < 3; ++v) mean[v] += p.v[v];
  for (auto& m : mean) m /= pts.size();
  std::vector<long double> out(kMonomials, 0.0L);
  const auto& exps = crandall::monomial_exponents();
  for (const auto& p : pts)
    for (int k = 0; k < kMonomials; ++k)
      out[k] += std::pow(p.v[0] - mean[0], exps[k][0]) * std::pow(p.v[1] - mean[1], exps[k][1]) *
                std::pow(p.v[2] - mean[2], exps[k][2]);
  return out;
}

crandall::Moments accumulate(const std::vector<Point>& pts, std::size_t from, std::size_t to) {
  crandall::Moments m(1);
  crandall::BlockSums sums(1);
  const auto active = crandall::active_monomials(true, true);
  for (std::size_t i = from; i < to; i += crandall::kLanes) {
    const int lanes = static_cast<int>(std::min<std::size_t>(crandall::kLanes, to - i));
    double a[crandall::kLanes], b[crandall::kLanes], c[crandall::kLanes];
    for (int l = 0; l < lanes; ++l) {
      a[l] = pts[i + l].v[0];
      b[l] = pts[i + l].v[1];
      c[l] = pts[i + l].v[2];
    }
    sums.add(0, a, b, c, lanes, active);
  }
  sums.merge_into(m);
  return m;
}

void expect_close(const crandall::Moments& m, const std::vector<long double>& ref) {
  for (int k = 0; k < kMonomials; ++k) {
    const double want = static_cast<double>(ref[k]);
    EXPECT_NEAR(m.central()[k], want, 1e-9 * (std::abs(want) + 1.0)) << "monomial " << k;
  }
}

TEST(Moments, MonomialTable) {
  const auto& e = crandall::monomial_exponents();
  EXPECT_EQ(e.size(), 35u);
  EXPECT_EQ(crandall::monomial_index(0, 0, 0), 0);
  EXPECT_EQ(crandall::monomial_index(1, 0, 0), 1);
  EXPECT_EQ(crandall::monomial_index(0, 1, 0), 2);
  EXPECT_EQ(crandall::monomial_index(0, 0, 1), 3);
  EXPECT_EQ(crandall::monomial_index(2, 2, 1), -1);
  for (int k = 0; k < 35; ++k) EXPECT_EQ(crandall::monomial_index(e[k][0], e[k][1], e[k][2]), k);
}

TEST(Moments, OnePassMatchesTwoPassReference) {
  const auto pts = data(5000, 1);
  const auto m = accumulate(pts, 0, pts.size());
  EXPECT_EQ(m.counts()[0], 5000.0);
  expect_close(m, reference(pts));
}

TEST(Moments, MergeEqualsOnePass) {
  const auto pts = data(6000, 2);
  const auto whole = accumulate(pts, 0, pts.size());
  for (std::size_t cut : {1u, 17u, 2500u, 5999u}) {
    auto left = accumulate(pts, 0, cut);
    const auto right = accumulate(pts, cut, pts.size());
    left.merge(right);
    EXPECT_EQ(left.counts()[0], whole.counts()[0]);
    for (int v = 0; v < 3; ++v) EXPECT_NEAR(left.means()[v], whole.means()[v], 1e-12 * (1 + std::abs(whole.means()[v])));
    for (int k = 0; k < kMonomials; ++k)
      EXPECT_NEAR(left.central()[k], whole.central()[k], 1e-9 * (std::abs(whole.central()[k]) + 1.0))
          << "cut " << cut << " monomial " << k;
  }
}

TEST(Moments, MergeWithEmptyIsIdentity) {
  const auto pts = data(100, 3);
  auto m = accumulate(pts, 0, pts.size());
  const auto copy = m;
  m.merge(crandall::Moments(1));
  EXPECT_EQ(m.central(), copy.central());
  crandall::Moments empty(1);
  empty.merge(copy);
  EXPECT_EQ(empty.central(), copy.central());
  EXPECT_EQ(empty.means(), copy.means());
}

TEST(Moments, MismatchedSlotsThrow) {
  crandall::Moments a(2), b(3);
  EXPECT_THROW(a.merge(b), std::invalid_argument);
}

}  // namespace

namespace {

TEST(Combine, WeightedRawMomentsOfTwoSamples) {
  // Two samples of the same size; the combination's raw moments are 2 E_a - E_b.
  const std::vector<std::array<double, 3>> a = {{1, 2, 3}, {0.5, -1, 2}, {2, 0, 1}, {-1, 1, 4}};
  const std::vector<std::array<double, 3>> b = {{1.1, 2, 3}, {0.4, -1, 2.5}, {2, 0.3, 1}, {-1, 1, 4}};
  auto moments = [](const std::vector<std::array<double, 3>>& pts) {
    crandall::Moments m(1);
    for (const auto& p : pts) {
      double raw[crandall::kMonomials];
      const double zero[3] = {0, 0, 0};
      for (int k = 0; k < crandall::kMonomials; ++k) {
        const auto& e = crandall::monomial_exponents()[k];
        raw[k] = std::pow(p[0], e[0]) * std::pow(p[1], e[1]) * std::pow(p[2], e[2]);
      }
      m.merge_raw(0, 1.0, zero, raw);
    }
    return m;
  };
  const auto ma = moments(a), mb = moments(b);
  const auto c = crandall::combine({&ma, &mb}, {2.0, -1.0});
  ASSERT_EQ(c.counts()[0], 4.0);
  double back[crandall::kMonomials];
  // Sums about the mean m become sums about m - delta = 0.
  crandall::recentre(&c.central()[0], &c.means()[0], back);
  for (int k = 0; k < crandall::kMonomials; ++k) {
    const auto& e = crandall::monomial_exponents()[k];
    double ea = 0, eb = 0;
    for (const auto& p : a) ea += std::pow(p[0], e[0]) * std::pow(p[1], e[1]) * std::pow(p[2], e[2]);
    for (const auto& p : b) eb += std::pow(p[0], e[0]) * std::pow(p[1], e[1]) * std::pow(p[2], e[2]);
    EXPECT_NEAR(back[k] / 4.0, (2 * ea - eb) / 4.0, 1e-12) << k;
  }
  EXPECT_THROW(crandall::combine({&ma}, {1.0, 0.0}), std::invalid_argument);
}

}  // namespace
