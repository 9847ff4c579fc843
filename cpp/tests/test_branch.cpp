// Paths continued from stored states (branch.hpp): the same numbers as the exact step applied
// by hand with the documented draws, continuation from a midpoint, thread independence, and the
// refusals.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <stdexcept>
#include <vector>

#include "crandall/branch.hpp"
#include "crandall/exact_step.hpp"
#include "crandall/rng.hpp"

namespace {

struct Grid {
  std::vector<double> lengths, noises, drifts;
  crandall::BranchGrid view() const { return {lengths.data(), noises.data(), drifts.data(), lengths.size()}; }
};

// Seven steps: noisy ones of two lengths, a pause (the closed-form coast) and a proposal drift
// of the other sign.
Grid grid() {
  return {{0.1, 0.1, 0.25, 0.5, 0.1, 0.1, 0.3},
          {1.4, 1.4, 0.7, 0.0, 2.0, 2.0, 1.0},
          {2.0, 2.0, 2.0, 2.0, -1.0, 2.0, 2.0}};
}

TEST(Branch, RowsFollowTheExactStepWithTheDocumentedDraws) {
  const Grid g = grid();
  const std::size_t points = g.lengths.size() + 1;
  std::vector<double> states(2 * points * 3, 0.0);
  states[points * 3] = 0.8;  // row 1 starts sliding
  states[points * 3 + 1] = -0.2;
  const std::int64_t rows[] = {0, 1};
  const std::int64_t starts[] = {0, 0};
  const std::uint64_t streams[] = {11, 12};
  crandall::extend_paths(states.data(), 2, g.view(), rows, starts, streams, 2, 99, 1);
  for (int r = 0; r < 2; ++r) {
    double x = r ? 0.8 : 0.0, u = r ? -0.2 : 0.0, s = 0.0;
    crandall::StepNoise z[2];
    for (std::size_t k = 0; k < g.lengths.size(); ++k) {
      if (k % 2 == 0) crandall::draw_pair(99, streams[r], k / 2, z);
      if (g.noises[k] == 0.0) {
        // The pause: a deterministic deceleration, exact integrals.
        const double speed = std::abs(x), t = std::min(g.lengths[k], speed / g.drifts[k]);
        const double travelled = t * (speed - 0.5 * g.drifts[k] * t), sign = x > 0 ? 1.0 : (x < 0 ? -1.0 : 0.0);
        EXPECT_NEAR(states[(r * points + k + 1) * 3 + 2], s + travelled, 1e-15);
        EXPECT_NEAR(states[(r * points + k + 1) * 3 + 1], u + sign * travelled, 1e-15);
        x = states[(r * points + k + 1) * 3];
        EXPECT_NEAR(x, sign * std::max(speed - g.drifts[k] * g.lengths[k], 0.0), 1e-15);
        u = states[(r * points + k + 1) * 3 + 1];
        s = states[(r * points + k + 1) * 3 + 2];
        continue;
      }
      const double x1 = crandall::exact_step(x, g.lengths[k], g.drifts[k], g.noises[k],
                                             z[k % 2].normal, z[k % 2].exponential, z[k % 2].coin).velocity;
      u += 0.5 * g.lengths[k] * (x + x1);
      s += 0.5 * g.lengths[k] * (std::abs(x) + std::abs(x1));
      x = x1;
      EXPECT_EQ(states[(r * points + k + 1) * 3], x) << "row " << r << " step " << k;
      EXPECT_EQ(states[(r * points + k + 1) * 3 + 1], u);
      EXPECT_EQ(states[(r * points + k + 1) * 3 + 2], s);
    }
  }
}

TEST(Branch, TouchedFlagsAreTheExactStepsOwnAndLeaveThePathsAlone) {
  const Grid g = grid();
  const std::size_t points = g.lengths.size() + 1, steps = g.lengths.size();
  std::vector<double> plain(2 * points * 3, 0.0), flagged(2 * points * 3, 0.0);
  plain[points * 3] = flagged[points * 3] = 0.8;
  const std::int64_t rows[] = {0, 1};
  const std::int64_t starts[] = {0, 0};
  const std::uint64_t streams[] = {11, 12};
  std::vector<std::uint8_t> touched(2 * steps, 7);
  crandall::extend_paths(plain.data(), 2, g.view(), rows, starts, streams, 2, 99, 1);
  crandall::extend_paths(flagged.data(), 2, g.view(), rows, starts, streams, 2, 99, 2,
                         touched.data());
  EXPECT_EQ(plain, flagged);
  int touches = 0;
  for (int r = 0; r < 2; ++r) {
    crandall::StepNoise z[2];
    for (std::size_t k = 0; k < steps; ++k) {
      if (k % 2 == 0) crandall::draw_pair(99, streams[r], k / 2, z);
      const double x = flagged[(r * points + k) * 3];
      bool want = false;  // a coast step (no noise) never draws a sign
      if (g.noises[k] != 0.0)
        want = crandall::exact_step(x, g.lengths[k], g.drifts[k], g.noises[k], z[k % 2].normal,
                                    z[k % 2].exponential, z[k % 2].coin).touched;
      EXPECT_EQ(touched[r * steps + k], want ? 1 : 0) << "row " << r << " step " << k;
      touches += want;
    }
  }
  EXPECT_GT(touches, 0);  // the grid's steps from rest touch 0
}

TEST(Branch, ASpeedDependentDriftTakesTheSlowDriftBelowItsThreshold) {
  // A proposal that reverses the friction only while |x| >= 0.5: each step's drift follows
  // the speed at its start, and the steps are the exact step with that drift.
  Grid g{{0.1, 0.1, 0.1, 0.1, 0.1, 0.1, 0.1, 0.1},
         std::vector<double>(8, 1.4), std::vector<double>(8, -1.0)};
  const std::vector<double> slow(8, 0.5), slow_drifts(8, 2.0);
  crandall::BranchGrid view = g.view();
  view.slow = slow.data();
  view.slow_drifts = slow_drifts.data();
  const std::size_t points = 9;
  std::vector<double> states(2 * points * 3, 0.0);
  states[points * 3] = 0.8;
  const std::int64_t rows[] = {0, 1};
  const std::int64_t starts[] = {0, 0};
  const std::uint64_t streams[] = {5, 6};
  crandall::extend_paths(states.data(), 2, view, rows, starts, streams, 2, 31, 1);
  int fast = 0, slow_steps = 0;
  for (int r = 0; r < 2; ++r) {
    double x = r ? 0.8 : 0.0;
    crandall::StepNoise z[2];
    for (std::size_t k = 0; k < 8; ++k) {
      if (k % 2 == 0) crandall::draw_pair(31, streams[r], k / 2, z);
      const double c = std::abs(x) < 0.5 ? 2.0 : -1.0;
      (c < 0 ? fast : slow_steps) += 1;
      x = crandall::exact_step(x, 0.1, c, 1.4, z[k % 2].normal, z[k % 2].exponential,
                               z[k % 2].coin).velocity;
      EXPECT_EQ(states[(r * points + k + 1) * 3], x) << "row " << r << " step " << k;
    }
  }
  EXPECT_GT(fast, 0);
  EXPECT_GT(slow_steps, 0);
  const std::vector<double> bad(8, -1.0);
  view.slow = bad.data();
  EXPECT_THROW(crandall::extend_paths(states.data(), 2, view, rows, starts, streams, 2, 31, 1),
               std::invalid_argument);
}

TEST(Branch, AContinuationKeepsThePrefixAndDependsOnlyOnItsStream) {
  const Grid g = grid();
  const std::size_t points = g.lengths.size() + 1;
  std::vector<double> a(points * 3, 0.0);
  const std::int64_t row[] = {0}, zero[] = {0}, mid[] = {3};
  const std::uint64_t first[] = {5}, second[] = {6};
  crandall::extend_paths(a.data(), 1, g.view(), row, zero, first, 1, 7, 1);
  const std::vector<double> before = a;
  crandall::extend_paths(a.data(), 1, g.view(), row, mid, second, 1, 7, 1);
  for (std::size_t i = 0; i < 4 * 3; ++i) EXPECT_EQ(a[i], before[i]);  // points 0..3 kept
  bool changed = false;
  for (std::size_t i = 4 * 3; i < points * 3; ++i) changed |= a[i] != before[i];
  EXPECT_TRUE(changed);
  // The same continuation again: the same numbers.
  std::vector<double> b = before;
  crandall::extend_paths(b.data(), 1, g.view(), row, mid, second, 1, 7, 1);
  EXPECT_EQ(a, b);
}

TEST(Branch, ThreadsDoNotChangeTheNumbers) {
  const Grid g = grid();
  const std::size_t points = g.lengths.size() + 1, n = 300;
  std::vector<std::int64_t> rows(n), starts(n);
  std::vector<std::uint64_t> streams(n);
  for (std::size_t i = 0; i < n; ++i) {
    rows[i] = static_cast<std::int64_t>(n - 1 - i);
    starts[i] = static_cast<std::int64_t>(i % 3);
    streams[i] = 1000 + i;
  }
  std::vector<double> one(n * points * 3, 0.0), four = one;
  crandall::extend_paths(one.data(), n, g.view(), rows.data(), starts.data(), streams.data(), n, 3, 1);
  crandall::extend_paths(four.data(), n, g.view(), rows.data(), starts.data(), streams.data(), n, 3, 4);
  EXPECT_EQ(one, four);
}

TEST(Branch, RefusesBadInput) {
  Grid g = grid();
  const std::size_t points = g.lengths.size() + 1;
  std::vector<double> states(2 * points * 3, 0.0);
  const std::int64_t twice[] = {1, 1}, zero[] = {0, 0}, far[] = {0, static_cast<std::int64_t>(points)};
  const std::int64_t outside[] = {0, 2};
  const std::uint64_t streams[] = {1, 2};
  EXPECT_THROW(crandall::extend_paths(states.data(), 2, g.view(), twice, zero, streams, 2, 1, 1), std::invalid_argument);
  EXPECT_THROW(crandall::extend_paths(states.data(), 2, g.view(), outside, zero, streams, 2, 1, 1), std::invalid_argument);
  const std::int64_t rows[] = {0, 1};
  EXPECT_THROW(crandall::extend_paths(states.data(), 2, g.view(), rows, far, streams, 2, 1, 1), std::invalid_argument);
  states[0] = NAN;
  EXPECT_THROW(crandall::extend_paths(states.data(), 2, g.view(), rows, zero, streams, 2, 1, 1), std::invalid_argument);
  states[0] = 0.0;
  g.lengths[2] = -1.0;
  EXPECT_THROW(crandall::extend_paths(states.data(), 2, g.view(), rows, zero, streams, 2, 1, 1), std::invalid_argument);
  g.lengths[2] = 0.25;
  g.noises[1] = NAN;
  EXPECT_THROW(crandall::extend_paths(states.data(), 2, g.view(), rows, zero, streams, 2, 1, 1), std::invalid_argument);
}

}  // namespace
