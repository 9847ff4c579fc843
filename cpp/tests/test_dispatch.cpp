// Every kernel variant this host supports gives bitwise the same numbers: draws, and runs of
// every method and observable set.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <cstring>
#include <stdexcept>
#include <string>
#include <vector>

#include "crandall/dispatch.hpp"
#include "crandall/diagnostics.hpp"
#include "crandall/run.hpp"
#include "support.hpp"

namespace {

std::vector<const crandall::KernelTable*> supported() {
  std::vector<const crandall::KernelTable*> out;
  for (const auto* k : crandall::compiled_kernels())
    if (crandall::kernel_supported(*k)) out.push_back(k);
  return out;
}

bool same_bits(const std::vector<double>& a, const std::vector<double>& b) {
  return a.size() == b.size() && (a.empty() || std::memcmp(a.data(), b.data(), a.size() * sizeof(double)) == 0);
}

TEST(Dispatch, BaselineIsAlwaysAvailableAndTheBestIsChosen) {
  const auto names = crandall::available_kernels();
  ASSERT_FALSE(names.empty());
  EXPECT_EQ(names.front(), "baseline");
  if (!std::getenv("CRANDALL_ISA")) {
    EXPECT_EQ(crandall::active_kernel().name, names.back());
  }
#if defined(__x86_64__)
  EXPECT_EQ(crandall::compiled_kernels().size(), 3u);
  if (__builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512bw")) {
    EXPECT_EQ(names.back(), "avx512");
  }
#endif
}

TEST(Dispatch, UnknownOrUnsupportedVariantIsRefused) {
  KeepKernel keep;
  EXPECT_THROW(crandall::select_kernel("avx1024"), std::invalid_argument);
  for (const auto* k : crandall::compiled_kernels())
    if (!crandall::kernel_supported(*k)) {
      EXPECT_THROW(crandall::select_kernel(k->name), std::invalid_argument);
    }
}

TEST(Dispatch, DrawsAreBitwiseTheSameInEveryVariant) {
  const auto kernels = supported();
  const std::uint64_t count = 203;  // not a multiple of the lane count
  for (std::uint64_t seed : {0ull, 7ull, 0xFFFFFFFFFFFFFFFFull})
    for (std::uint64_t path0 : {0ull, 1ull << 40, (1ull << 63) + 5})
      for (std::uint64_t pair : {0ull, 3ull, 1ull << 35}) {
        std::vector<double> want(6 * count);
        kernels.front()->draw(seed, path0, pair, count, want.data());
        for (const auto* k : kernels) {
          std::vector<double> got(6 * count);
          k->draw(seed, path0, pair, count, got.data());
          EXPECT_TRUE(same_bits(got, want)) << k->name << " seed " << seed << " path0 " << path0;
        }
      }
}

std::vector<double> flatten(const crandall::ChunkResult& r) {
  std::vector<double> out;
  for (const crandall::Moments* m : {&r.times, &r.stop}) {
    out.insert(out.end(), m->counts().begin(), m->counts().end());
    out.insert(out.end(), m->means().begin(), m->means().end());
    out.insert(out.end(), m->central().begin(), m->central().end());
  }
  return out;
}

TEST(Dispatch, RunsAreBitwiseTheSameInEveryVariant) {
  KeepKernel keep;
  const auto kernels = supported();
  for (const char* method : {"exact", "euler", "richardson", "richardson2", "refine"})
    for (int observed = 0; observed < 4; ++observed)
      for (bool stop : {false, true}) {
        crandall::Options o;
        o.switch_off = 1.0;
        o.times = {0.25, 1.0, 1.75};
        o.dt = 0.05;
        o.method = crandall::parse_method(method);
        o.displacement = observed & 1;
        o.distance = observed & 2;
        o.stop = stop;
        o.seed = 11;
        o.paths = 700;  // partial blocks and lane groups
        const crandall::Plan plan(o);
        std::vector<double> want;
        for (const auto* k : kernels) {
          crandall::select_kernel(k->name);
          const auto got = flatten(crandall::run_chunk(plan, 0, 1));
          if (want.empty()) want = got;
          EXPECT_TRUE(same_bits(got, want))
              << k->name << " " << method << " observed " << observed << " stop " << stop;
        }
      }
}

TEST(Dispatch, RandomFloorIsTheSameInEveryVariant) {
  KeepKernel keep;
  double want = 0.0;
  bool first = true;
  for (const auto* k : supported()) {
    crandall::select_kernel(k->name);
    const double got = crandall::random_floor(100, 20, 3, 1);
    if (first) want = got;
    first = false;
    EXPECT_EQ(std::memcmp(&got, &want, sizeof got), 0) << k->name;
  }
}

}  // namespace

// The dispatch table (kernel_variant.inc) holds a loop for every method of the methods' table
// (plan.hpp) in every variant compiled in, with and without peaks, for every set of integrals;
// the quadratic variation's for the exact skeleton's methods with an integral, the control
// sums' for the exact method; and refuses, with std::logic_error, what no kind holds. A method
// given a row but no type in KernelMethods fails to compile (kernel_variant.inc's
// static_assert), and one whose type has no loop of a kind fails here. Every row states an
// order, positive or unknown (NaN): Python's bias estimate and runs to an accuracy read it
// (crandall.methods.ORDERS; tests/test_spec.py follows a new row there).
TEST(Dispatch, TheTableHasALoopForEveryMethodAndKind) {
  for (crandall::Method m : crandall::kMethods) {
    const double order = crandall::method_order(m);
    EXPECT_TRUE(std::isnan(order) || (std::isfinite(order) && order > 0.0)) << crandall::method_name(m);
  }
  for (const auto* k : crandall::compiled_kernels()) {
    for (crandall::Method m : crandall::kMethods)
      for (bool disp : {false, true})
        for (bool dist : {false, true}) {
          const std::string what = std::string(k->name) + " " + crandall::method_name(m) +
                                   (disp ? " disp" : "") + (dist ? " dist" : "");
          EXPECT_NE(k->block_fn(m, disp, dist, false, false), nullptr) << what;
          EXPECT_NE(k->block_fn(m, disp, dist, true, false), nullptr) << what;
          EXPECT_NE(k->block_fn(m, disp, dist, false, false), k->block_fn(m, disp, dist, true, false)) << what;
          if (crandall::skeleton(m) && (disp || dist))
            EXPECT_NE(k->block_fn(m, disp, dist, false, true), nullptr) << what;
          else
            EXPECT_THROW(k->block_fn(m, disp, dist, false, true), std::logic_error) << what;
          EXPECT_THROW(k->block_fn(m, disp, dist, true, true), std::logic_error) << what;
        }
    for (bool disp : {false, true})
      for (bool dist : {false, true}) {
        EXPECT_NE(k->controls_fn(disp, dist, false), nullptr) << k->name;
        if (disp || dist)
          EXPECT_NE(k->controls_fn(disp, dist, true), nullptr) << k->name;
        else
          EXPECT_THROW(k->controls_fn(disp, dist, true), std::logic_error) << k->name;
      }
  }
}
