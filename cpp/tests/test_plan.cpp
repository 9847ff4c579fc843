// The plan: the time grid (the graded grid of Options::min_steps reaches every output time and
// the switch-off in at least min_steps steps, and the longest step is still dt where that is
// finer; velocity-only scenes jump), validation of the options, methods and their grids.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

#include "crandall/plan.hpp"
#include "support.hpp"

namespace {

crandall::Options integrals(std::vector<double> times, double dt, std::uint64_t min_steps) {
  crandall::Options o;
  o.times = std::move(times);
  o.dt = dt;
  o.min_steps = min_steps;
  o.distance = true;
  return o;
}

TEST(GradedGrid, OffKeepsTheUniformGrid) {
  const crandall::Plan plan(integrals({0.05, 0.1, 1.0}, 0.5, 0));
  // One step to 0.05, one to 0.1, two to 1.0: dt alone sets the grid.
  EXPECT_EQ(plan.steps_per_path(), 4u);
}

TEST(GradedGrid, EveryOutputTimeGetsAtLeastMinSteps) {
  const crandall::Plan plan(integrals({0.05, 0.1, 1.0}, 0.5, 64));
  const auto& seg = plan.segments();
  ASSERT_EQ(seg.size(), 3u);
  double t = 0.0;
  std::uint64_t before = 0;
  const double ends[] = {0.05, 0.1, 1.0};
  for (std::size_t i = 0; i < seg.size(); ++i) {
    before += seg[i].steps;
    t += seg[i].step * static_cast<double>(seg[i].steps);
    EXPECT_NEAR(t, ends[i], 1e-12);
    EXPECT_GE(before, 64u) << "output " << i;
    // The step of a segment is at most its end over min_steps (up to rounding).
    EXPECT_LE(seg[i].step, ends[i] / 64 * (1 + 1e-12));
  }
  // Graded, not uniform: 64 steps to 0.05, steps of 0.1/64 to 0.1, then of 1/64 to 1.
  EXPECT_EQ(seg[0].steps, 64u);
  EXPECT_EQ(seg[1].steps, 32u);
  EXPECT_EQ(seg[2].steps, 58u);
}

TEST(GradedGrid, DtStillBoundsTheStep) {
  const crandall::Plan plan(integrals({10.0}, 0.01, 8));
  EXPECT_EQ(plan.steps_per_path(), 1000u);
}

TEST(GradedGrid, SwitchOffIsResolvedToo) {
  crandall::Options o = integrals({1e-6, 3.0}, 0.01, 16);
  o.switch_off = 1e-3;
  o.stop = true;
  const crandall::Plan plan(o);
  const auto& seg = plan.segments();
  ASSERT_EQ(seg.size(), 2u);  // to 1e-6, then to the switch-off; 3.0 is in closed form
  EXPECT_EQ(seg[0].steps, 16u);
  EXPECT_GE(seg[0].steps + seg[1].steps, 16u);
  EXPECT_LE(seg[1].step, 1e-3 / 16 * (1 + 1e-12));
}

TEST(GradedGrid, ScaleFreeInTime) {
  // The same scene in other time units has the same step counts: 64 steps to 0.5, then dt
  // (finer than 1/64) to 1.
  for (double unit : {1e-300, 1e-12, 1.0, 1e12, 1e290}) {
    const crandall::Plan plan(integrals({0.5 * unit, 1.0 * unit}, 0.01 * unit, 64));
    EXPECT_EQ(plan.segments()[0].steps, 64u) << unit;
    EXPECT_EQ(plan.segments()[1].steps, 50u) << unit;
  }
}

TEST(GradedGrid, RichardsonGroupsStayWhole) {
  crandall::Options o = integrals({1e-3, 1.0}, 0.01, 10);
  o.method = crandall::Method::richardson;
  const crandall::Plan plan(o);
  for (const auto& s : plan.segments()) EXPECT_EQ(s.steps % 4, 0u);
  EXPECT_GE(plan.segments()[0].steps, 10u);
}

TEST(GradedGrid, VelocityOnlyStillJumps) {
  crandall::Options o;
  o.times = {1e-9, 1.0};
  o.min_steps = 64;
  EXPECT_EQ(crandall::Plan(o).steps_per_path(), 2u);  // the exact step needs no grid
}

TEST(GradedGrid, SubnormalTimes) {
  const crandall::Plan plan(integrals({5e-324, 1e-310}, 1.0, 64));
  EXPECT_EQ(plan.segments()[0].steps, 64u);
  EXPECT_GE(plan.segments()[0].steps + plan.segments()[1].steps, 64u);
}

TEST(GradedGrid, AbsurdMinStepsIsRefused) {
  EXPECT_THROW(crandall::Plan(integrals({1.0}, 0.1, std::uint64_t{1} << 40)),
               std::invalid_argument);
}

TEST(Plan, VelocityOnlyStepsStraightToOutputs) {
  crandall::Options o;
  o.times = {1.0, 1000.0};
  o.dt = 1e-3;
  const crandall::Plan plan(o);
  EXPECT_EQ(plan.steps_per_path(), 2u);  // no internal steps, whatever the horizon
  o.distance = true;
  EXPECT_EQ(crandall::Plan(o).steps_per_path(), 1000000u);
}

TEST(Plan, SwitchOffOffTheGrid) {
  crandall::Options o;
  o.times = {0.3, 0.9};
  o.switch_off = 0.5;
  o.dt = 0.2;
  o.distance = true;
  const crandall::Plan plan(o);
  // Grid to 0.3 (2 steps), then to t0 = 0.5 (1 step); 0.9 is filled by the closed-form coast.
  EXPECT_EQ(plan.steps_per_path(), 3u);
  ASSERT_EQ(plan.coast_slots().size(), 1u);
  EXPECT_DOUBLE_EQ(plan.coast_elapsed()[0], 0.4);
}

TEST(TailGrid, CutsTheSegmentsAtPiecesAndOutputTimes) {
  // Pieces ending at 0.3 (calm), 1.0 and 1.5; output times 0.7 (a break) and 1.2 (the
  // horizon): segments [0, 0.3] (one step, no noise), [0.3, 0.7], [0.7, 1.0], [1.0, 1.2].
  crandall::Options o;
  o.piece_ends = {0.3, 1.0, 1.5};
  o.piece_noise = {0.0, 1.0, 2.0};
  o.switch_off = 1.5;
  o.times = {0.7, 1.2};
  o.dt = 0.1;
  const crandall::Plan plan(o);
  const crandall::TailGrid grid = crandall::tail_grid(plan, 0.1, false, 1e7);
  // ceil(0.4 / 0.1 - 1e-9) = 4, ceil(0.3 / 0.1 - 1e-9) = 3, ceil(0.2 / 0.1 - 1e-9) = 2.
  ASSERT_EQ(grid.lengths.size(), 10u);
  const std::vector<double> noise = {0, 1, 1, 1, 1, 1, 1, 1, 2, 2};
  for (std::size_t k = 0; k < noise.size(); ++k) EXPECT_EQ(grid.noises[k], noise[k]) << k;
  EXPECT_EQ(grid.starts[0], 0.0);
  EXPECT_EQ(grid.lengths[0], 0.3);
  EXPECT_EQ(grid.starts[1], 0.3);
  EXPECT_EQ(grid.starts[5], 0.7);
  EXPECT_EQ(grid.starts[8], 1.0);
  double end = 0.0;
  for (std::size_t k = 0; k < grid.lengths.size(); ++k) {
    EXPECT_NEAR(grid.starts[k], end, 1e-15) << k;
    end = grid.starts[k] + grid.lengths[k];
  }
  EXPECT_NEAR(end, 1.2, 1e-15);
  // Coarse: one step per segment.
  EXPECT_EQ(crandall::tail_grid(plan, 0.1, true, 1e7).lengths.size(), 4u);
  // Too many steps in a segment, and a bad dt, are refused.
  EXPECT_THROW(crandall::tail_grid(plan, 1e-9, false, 1e7), std::invalid_argument);
  EXPECT_THROW(crandall::tail_grid(plan, 0.0, false, 1e7), std::invalid_argument);
}

TEST(Options, RejectBadInput) {
  auto bad = [](auto mutate) {
    auto o = scene();
    mutate(o);
    EXPECT_THROW(crandall::Plan{o}, std::invalid_argument);
  };
  bad([](crandall::Options& o) { o.drift = -1; });
  bad([](crandall::Options& o) { o.noise = std::nan(""); });
  bad([](crandall::Options& o) { o.switch_off = -1; });
  bad([](crandall::Options& o) { o.times = {0.5, 0.2}; });
  bad([](crandall::Options& o) { o.times = {-0.1}; });
  bad([](crandall::Options& o) { o.dt = 0; });
  bad([](crandall::Options& o) { o.paths = 0; });
  bad([](crandall::Options& o) { o.switch_off = std::numeric_limits<double>::infinity(); });  // stop
  bad([](crandall::Options& o) { o.drift = 0; });  // stop without friction
}

TEST(Methods, NamesRoundTripAndUnknownNamesThrow) {
  for (auto m : crandall::kMethods)
    EXPECT_EQ(crandall::parse_method(crandall::method_name(m)), m);
  EXPECT_THROW(crandall::parse_method("milstein"), std::invalid_argument);
}

TEST(Methods, RichardsonWeightsCancelTheBiasExponents) {
  const auto w = crandall::richardson_weights(crandall::Method::richardson);
  ASSERT_EQ(w.size(), 3u);
  EXPECT_NEAR(w[0] + w[1] + w[2], 1.0, 1e-14);
  for (double p : {1.5, 2.0})
    EXPECT_NEAR(w[0] + w[1] * std::pow(2.0, p) + w[2] * std::pow(4.0, p), 0.0, 1e-13);
  const auto w2 = crandall::richardson_weights(crandall::Method::richardson2);
  EXPECT_NEAR(w2[0] + w2[1] * std::pow(2.0, 1.5), 0.0, 1e-14);
  EXPECT_EQ(crandall::richardson_weights(crandall::Method::exact), std::vector<double>{1.0});
}

TEST(Methods, AKnownOrderIsTheFirstExponentTheWeightsLeave) {
  // A method on the exact skeleton (with the trapezoid integrals) has the skeleton's bias
  // exponents (kSkeletonExponents); its Richardson weights cancel the first grids() - 1 of
  // them, so its order is the next one, and unknown (NaN) where the known exponents end. Every
  // other method's order is positive or unknown.
  for (auto m : crandall::kMethods) {
    const std::string name = crandall::method_name(m);
    const double p = crandall::method_order(m);
    EXPECT_TRUE(std::isnan(p) || p > 0.0) << name;
    if (!crandall::skeleton(m)) continue;
    const auto w = crandall::richardson_weights(m);
    const auto left = [&w](double q) {
      double r = 0.0;
      for (std::size_t j = 0; j < w.size(); ++j) r += w[j] * std::pow(2.0, static_cast<double>(j) * q);
      return r;
    };
    const std::size_t cancelled = w.size() - 1;
    for (std::size_t i = 0; i < cancelled; ++i)
      EXPECT_NEAR(left(crandall::kSkeletonExponents[i]), 0.0, 1e-13) << name;
    if (cancelled < crandall::kSkeletonExponentCount) {
      EXPECT_EQ(p, crandall::kSkeletonExponents[cancelled]) << name;
      EXPECT_GT(std::abs(left(p)), 0.1) << name;
    } else {
      EXPECT_TRUE(std::isnan(p)) << name;
    }
  }
  static_assert(crandall::method_order(crandall::Method::exact) == 1.5);
  static_assert(crandall::method_order(crandall::Method::richardson2) == 2.0);
}

TEST(Methods, RichardsonGridsNestSegmentBySegment) {
  auto o = scene();  // segments of 5, 5, 10 steps at dt = 0.05
  o.method = crandall::Method::richardson;
  const crandall::Plan plan(o);
  for (const auto& seg : plan.segments()) EXPECT_EQ(seg.steps % 4, 0u);
}

TEST(Methods, GridCountMatchesTheWeightsAndTheGrid) {
  // grids() is the one place the number of coupled grids is decided: the weights have one entry
  // per grid, a run that observes no integral keeps one grid, and each segment's step count is a
  // multiple of the coarsest grid's stride (scene(): natural counts 5, 5, 10).
  static_assert(crandall::grids(crandall::Method::richardson) == 3);
  static_assert(crandall::grids(crandall::Method::richardson2) == 2);
  for (auto m : crandall::kMethods) {
    EXPECT_EQ(crandall::richardson_weights(m).size(), static_cast<std::size_t>(crandall::grids(m)))
        << crandall::method_name(m);
    EXPECT_EQ(crandall::grids(m, false), 1);
    auto o = scene();
    o.method = m;
    EXPECT_EQ(o.grids(), crandall::grids(m));
    const std::uint64_t stride = std::uint64_t{1} << (crandall::grids(m) - 1);
    const crandall::Plan plan(o);
    for (const auto& seg : plan.segments())
      EXPECT_EQ(seg.steps % stride, 0u) << crandall::method_name(m);
    o.displacement = o.distance = false;
    EXPECT_EQ(o.grids(), 1);
  }
}

}  // namespace
