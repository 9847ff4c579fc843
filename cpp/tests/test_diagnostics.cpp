// The diagnostics hooks give what they document: exact_steps is exact_step on each path's first
// draws, draw_noise is draw_pair laid out in rows, build_info agrees with the dispatcher, and
// bad input is refused.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

#include "crandall/diagnostics.hpp"
#include "crandall/dispatch.hpp"
#include "crandall/exact_step.hpp"
#include "crandall/rng.hpp"

namespace {

TEST(Diagnostics, ExactStepsIsTheScalarStepOnEachPathsFirstDraws) {
  const std::vector<double> start = {0.0, -0.7, 2.5, 1e-3, -40.0};
  const std::uint64_t seed = 17;
  const auto got = crandall::exact_steps(start, 0.3, 2.0, std::sqrt(2.0), seed);
  ASSERT_EQ(got.size(), start.size());
  for (std::size_t i = 0; i < start.size(); ++i) {
    crandall::StepNoise z[2];
    crandall::draw_pair(seed, i, 0, z);
    EXPECT_EQ(got[i], crandall::exact_step(start[i], 0.3, 2.0, std::sqrt(2.0), z[0].normal,
                                           z[0].exponential, z[0].coin)
                          .velocity);
  }
}

TEST(Diagnostics, DrawNoiseRowsAreTheDrawsOfEachPath) {
  const std::uint64_t seed = 3, path0 = 1000, count = 21, pair = 9;
  const auto rows = crandall::draw_noise(seed, path0, count, pair);
  ASSERT_EQ(rows.size(), 6 * count);
  for (std::uint64_t l = 0; l < count; ++l) {
    crandall::StepNoise z[2];
    crandall::draw_pair(seed, path0 + l, pair, z);
    for (int j = 0; j < 2; ++j) {
      EXPECT_EQ(rows[(0 + j) * count + l], z[j].normal);
      EXPECT_EQ(rows[(2 + j) * count + l], z[j].exponential);
      EXPECT_EQ(rows[(4 + j) * count + l], z[j].coin ? 1.0 : 0.0);
    }
  }
}

TEST(Diagnostics, BuildInfoAgreesWithTheDispatcher) {
  const auto b = crandall::build_info();
  EXPECT_EQ(b.isa, crandall::active_kernel().name);
  EXPECT_EQ(b.isa_available, crandall::available_kernels());
  ASSERT_EQ(b.isa_compiled.size(), crandall::compiled_kernels().size());
  EXPECT_EQ(b.random_stream, crandall::kRandomStream);
  EXPECT_FALSE(b.compiler.empty());
}

TEST(Diagnostics, BadInputIsRefused) {
  EXPECT_THROW(crandall::exact_steps({0.0}, 0.0, 2.0, 1.0, 1), std::invalid_argument);
  EXPECT_THROW(crandall::exact_steps({0.0}, 1e305, 2.0, 1.0, 1), std::invalid_argument);
  EXPECT_THROW(crandall::exact_steps({NAN}, 0.1, 2.0, 1.0, 1), std::invalid_argument);
  EXPECT_THROW(crandall::random_floor(10, 10, 1, -1), std::invalid_argument);
  EXPECT_THROW(crandall::draw_noise(1, 0, 0, 0), std::invalid_argument);
  crandall::Options o;
  o.times = {1.0};
  o.method = crandall::Method::richardson;
  EXPECT_THROW(crandall::simulate_states(crandall::Plan(o)), std::invalid_argument);
}

}  // namespace
