// The kernel's lanes give exact_step's bits on the same draws, and the skeleton methods walk the
// same velocity path.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <string>
#include <utility>
#include <vector>

#include "crandall/accumulators.hpp"
#include "crandall/diagnostics.hpp"
#include "crandall/dispatch.hpp"
#include "crandall/exact_step.hpp"
#include "crandall/rng.hpp"
#include "crandall/run.hpp"
#include "support.hpp"

namespace {

// Two output times, step and 2 step, velocity only: two exact steps of length `step` per path.
crandall::Options two_steps(double drift, double noise, double step, std::uint64_t paths,
                            std::uint64_t seed) {
  crandall::Options o;
  o.drift = drift;
  o.noise = noise;
  o.times = {step, 2.0 * step};
  o.paths = paths;
  o.seed = seed;
  return o;
}

// exact_step's velocity of path p after each of the plan's two steps, on the path's draws (step k
// uses half k of pair 0).
std::vector<double> scalar_velocities(const crandall::Plan& plan, std::uint64_t path) {
  const crandall::Options& o = plan.options();
  crandall::StepNoise z[2];
  crandall::draw_pair(o.seed, path, 0, z);
  std::vector<double> out;
  double x = 0.0;
  for (int k = 0; k < 2; ++k) {
    x = crandall::exact_step(x, plan.segments()[k].step, o.drift, o.noise, z[k].normal,
                             z[k].exponential, z[k].coin)
            .velocity;
    out.push_back(x);
  }
  return out;
}

TEST(Kernel, LanesEqualTheScalarExactStep) {
  // The kernel evaluates the exact step lane by lane in vector form; with one path, the mean of
  // an output slot is that path's velocity itself, which must be exact_step's bits on the same
  // draws (step k uses half k of pair 0), in the regular and in the scaled range of steps.
  for (const auto& [drift, noise] : std::vector<std::pair<double, double>>{
           {2.0, std::sqrt(2.0)}, {2.943, 1e-9}, {0.0, 1.0}, {2.0, 0.0}}) {
    for (double step : {1e-300, 1e-200, 1e-12, 0.01, 1.0, 1e3, 1e15, 1e17, 1e100, 1e200, 1e300}) {
      for (std::uint64_t seed = 0; seed < 64; ++seed) {
        const crandall::Plan plan(two_steps(drift, noise, step, 1, seed));
        ASSERT_EQ(plan.segments().size(), 2u);
        const auto r = crandall::run_chunk(plan, 0, 1);
        const auto want = scalar_velocities(plan, 0);
        for (int k = 0; k < 2; ++k)
          EXPECT_EQ(r.times.means()[k * crandall::kVariables], want[k])
              << "drift=" << drift << " noise=" << noise << " step=" << step << " seed=" << seed;
      }
    }
  }
}

TEST(Methods, SkeletonMethodsShareTheVelocityAndTheStopTime) {
  // On a grid whose segments already have multiples of 4 steps, exact and richardson walk the
  // same skeleton: the extrapolation must leave the velocity and the stop time as they are.
  auto o = scene();
  o.times = {0.2, 0.4, 0.8, 1.5};
  const auto exact = crandall::run_chunk(crandall::Plan(o), 0, 1);
  o.method = crandall::Method::richardson;
  const auto rich = crandall::run_chunk(crandall::Plan(o), 0, 1);
  for (std::size_t s = 0; s < exact.times.slots(); ++s) {
    EXPECT_NEAR(exact.times.means()[s * crandall::kVariables],
                rich.times.means()[s * crandall::kVariables], 1e-13);
    const int k = crandall::monomial_index(2, 0, 0);
    EXPECT_NEAR(exact.times.central()[s * crandall::kMonomials + k],
                rich.times.central()[s * crandall::kMonomials + k], 1e-9);
  }
  EXPECT_NEAR(exact.stop.means()[0], rich.stop.means()[0], 1e-13);
}

TEST(Kernel, EveryLaneOfEveryVariantEqualsTheScalarExactStep) {
  // Through simulate_states, the velocity of 37 paths after two exact steps: two full lane
  // groups and a partial one, so every lane position is checked, in every variant this host
  // supports, against exact_step (compiled here for the baseline) on the same draws.
  KeepKernel keep;
  for (const crandall::KernelTable* kernel : crandall::compiled_kernels()) {
    if (!crandall::kernel_supported(*kernel)) continue;
    crandall::select_kernel(kernel->name);
    for (const auto& [drift, noise] : std::vector<std::pair<double, double>>{
             {2.0, std::sqrt(2.0)}, {2.943, 1e-9}, {0.0, 1.0}}) {
      for (double step : {1e-300, 1e-12, 0.01, 1.0, 1e17, 1e300}) {
        const crandall::Plan plan(two_steps(drift, noise, step, 37, 5));
        ASSERT_EQ(plan.segments().size(), 2u);
        const std::vector<double> got = crandall::simulate_states(plan);
        ASSERT_EQ(got.size(), 37u);
        for (std::uint64_t p = 0; p < 37; ++p) {
          const double x = scalar_velocities(plan, p)[1];
          EXPECT_EQ(std::memcmp(&got[p], &x, sizeof x), 0)
              << kernel->name << " drift=" << drift << " noise=" << noise << " step=" << step
              << " path=" << p;
        }
      }
    }
  }
}

}  // namespace
