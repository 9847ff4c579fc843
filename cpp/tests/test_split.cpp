// Splitting's pieces in the core (split.hpp, branch.hpp): rows continued in the vector lanes of
// every variant give extend_paths' bits, and the parents' draws are uniform and pure functions
// of their key.
#include <gtest/gtest.h>

#include <cstdint>
#include <vector>

#include "crandall/branch.hpp"
#include "crandall/dispatch.hpp"
#include "crandall/split.hpp"

namespace {

// Steps of several lengths and intensities, a pause (the coast), a negative drift, and a step
// too short for the regular formulas (the lanes' scalar fallback); an odd grid (its last step
// is taken alone) and an even one.
class BranchLanes : public ::testing::TestWithParam<int> {};

TEST_P(BranchLanes, EveryVariantGivesTheScalarBits) {
  std::vector<double> lengths, noises, drifts;
  for (int k = 0; k < GetParam(); ++k) {
    lengths.push_back(k == 17 ? 1e-300 : 0.05 + 0.01 * (k % 3));
    noises.push_back(k >= 20 && k < 24 ? 0.0 : 1.0 + 0.5 * (k % 2));
    drifts.push_back(k == 30 ? -0.5 : 1.5);
  }
  const crandall::BranchGrid grid{lengths.data(), noises.data(), drifts.data(), lengths.size()};
  const crandall::LaneGridData lanes(grid);
  const std::size_t points = lengths.size() + 1, n = 37;
  std::vector<double> start(n * points * 3, 0.0);
  std::vector<std::int64_t> rows(n), starts(n);
  std::vector<std::uint64_t> streams(n);
  for (std::size_t i = 0; i < n; ++i) {
    rows[i] = static_cast<std::int64_t>((i * 11) % n);
    starts[i] = static_cast<std::int64_t>((i * 7) % points);
    streams[i] = 5000 + 3 * i;
    double* p = start.data() + (static_cast<std::size_t>(rows[i]) * points + static_cast<std::size_t>(starts[i])) * 3;
    p[0] = 0.3 * (double(i % 5) - 2.0);
    p[1] = 0.1 * double(i);
    p[2] = 0.2;
  }
  std::vector<double> scalar = start;
  crandall::extend_paths(scalar.data(), n, grid, rows.data(), starts.data(), streams.data(), n, 42, 1);
  int ran = 0;
  for (const crandall::KernelTable* k : crandall::compiled_kernels()) {
    if (!crandall::kernel_supported(*k)) continue;
    for (int threads : {1, 3}) {
      std::vector<double> out = start;
      crandall::extend_rows_in_lanes(out.data(), lanes, rows.data(), starts.data(),
                                     streams.data(), n, 42, threads, k);
      EXPECT_EQ(out, scalar) << k->name << " threads " << threads;
    }
    ++ran;
  }
  EXPECT_GE(ran, 1);
}

INSTANTIATE_TEST_SUITE_P(Grids, BranchLanes, ::testing::Values(41, 40));

TEST(SplitParents, UniformAndAPureFunctionOfTheirKey) {
  std::vector<std::int64_t> a(70000), b(10), c(10);
  crandall::split_parents(8, 2, 5, 7, a.size(), a.data());
  std::vector<int> counts(7, 0);
  for (const auto x : a) {
    ASSERT_GE(x, 0);
    ASSERT_LT(x, 7);
    ++counts[static_cast<std::size_t>(x)];
  }
  for (const int k : counts) EXPECT_NEAR(k, 10000, 560);  // 6 binomial sd
  crandall::split_parents(8, 2, 5, 7, b.size(), b.data());
  EXPECT_EQ(b, std::vector<std::int64_t>(a.begin(), a.begin() + 10));
  crandall::split_parents(8, 2, 6, 7, c.size(), c.data());
  EXPECT_NE(b, c);
  EXPECT_THROW(crandall::split_parents(8, 2, 5, 0, 1, c.data()), std::invalid_argument);
}

}  // namespace
