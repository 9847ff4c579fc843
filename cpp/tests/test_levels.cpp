// Per-path values of the runs to an accuracy (levels.hpp): the same bits for any thread count
// and any split of the path range, with and without control sums; a cancel request stops them,
// also inside a block of long paths; bad ranges throw; sum_products against a plain loop.
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <cstdint>
#include <stdexcept>
#include <vector>

#include "crandall/levels.hpp"
#include "support.hpp"

namespace {

std::vector<double> samples(const crandall::Plan& plan, std::uint64_t first, std::uint64_t count,
                            int threads, std::vector<double>* controls = nullptr) {
  std::vector<double> out(count * crandall::sample_size(plan), -1.0);
  if (controls) {
    const std::size_t slots = plan.options().times.size() + (plan.options().stop ? 1 : 0);
    controls->assign(count * slots * static_cast<std::size_t>(crandall::control_count()), -1.0);
  }
  crandall::run_samples(plan, first, count, threads, out.data(),
                        controls ? controls->data() : nullptr);
  return out;
}

TEST(Levels, SamplesDoNotDependOnThreadsOrSplits) {
  for (auto m : {crandall::Method::exact, crandall::Method::richardson2}) {
    auto o = scene();
    o.method = m;
    const crandall::Plan plan(o);
    const auto one = samples(plan, 5, 1200, 1);
    EXPECT_EQ(one, samples(plan, 5, 1200, 2)) << crandall::method_name(m);
    const auto a = samples(plan, 5, 700, 2), b = samples(plan, 705, 500, 1);
    std::vector<double> joined(a);
    joined.insert(joined.end(), b.begin(), b.end());
    EXPECT_EQ(one, joined) << crandall::method_name(m);
  }
}

TEST(Levels, ControlSumsDoNotChangeTheValues) {
  const crandall::Plan plan(scene());
  std::vector<double> c1, c2;
  const auto with = samples(plan, 0, 600, 1, &c1);
  EXPECT_EQ(with, samples(plan, 0, 600, 1));
  EXPECT_EQ(with, samples(plan, 0, 600, 2, &c2));
  EXPECT_EQ(c1, c2);
}

TEST(Levels, ControlSumsOfChosenSlotsAreThoseOfEverySlot) {
  // A slot's control sums do not depend on which other slots carry them: the sums at the
  // chosen slots are, bit for bit, the same columns of the sums at every slot.
  auto o = scene();
  o.times = {0.1, 0.2, 0.4, 0.7, 1.0, 1.5};
  const crandall::Plan plan(o);
  const std::size_t slots = o.times.size() + (o.stop ? 1 : 0);
  const auto k = static_cast<std::size_t>(crandall::control_count());
  std::vector<double> every;
  const auto values = samples(plan, 3, 300, 1, &every);
  const std::vector<std::size_t> chosen = {1, 4, slots - 1};
  for (int threads : {1, 2}) {
    std::vector<double> out(300 * crandall::sample_size(plan)), some(300 * chosen.size() * k, -1.0);
    crandall::run_samples(plan, 3, 300, threads, out.data(), some.data(), {}, chosen);
    EXPECT_EQ(out, values);
    for (std::size_t p = 0; p < 300; ++p)
      for (std::size_t a = 0; a < chosen.size(); ++a)
        for (std::size_t q = 0; q < k; ++q)
          ASSERT_EQ(some[(p * chosen.size() + a) * k + q], every[(p * slots + chosen[a]) * k + q])
              << "path " << p << " slot " << chosen[a] << " control " << q;
  }
  std::vector<double> out(10 * crandall::sample_size(plan)), some(10 * 2 * k);
  for (const std::vector<std::size_t>& bad :
       {std::vector<std::size_t>{2, 1}, std::vector<std::size_t>{1, 1}, std::vector<std::size_t>{slots}})
    EXPECT_THROW(crandall::run_samples(plan, 0, 10, 1, out.data(), some.data(), {}, bad),
                 std::invalid_argument);
}

TEST(Levels, BadRangesThrow) {
  const crandall::Plan plan(scene());
  std::vector<double> out(10 * crandall::sample_size(plan));
  EXPECT_THROW(crandall::run_samples(plan, 0, 0, 1, out.data()), std::invalid_argument);
  EXPECT_THROW(crandall::run_samples(plan, scene().paths, 1, 1, out.data()), std::invalid_argument);
  EXPECT_THROW(crandall::run_samples(plan, scene().paths - 5, 10, 1, out.data()),
               std::invalid_argument);
}

TEST(Levels, CancelStopsEvenInsideALongBlock) {
  // Paths of 2^27 steps: one block would take minutes. The request, made 50 ms in, must be
  // seen inside the block (every kPollSteps steps), with one thread and with two.
  auto o = scene();
  o.dt = 1e-8;
  o.paths = 64;
  const crandall::Plan plan(o);
  std::vector<double> out(o.paths * crandall::sample_size(plan));
  for (int threads : {1, 2}) {
    const auto start = std::chrono::steady_clock::now();
    auto cancel = [start] {
      return std::chrono::steady_clock::now() - start > std::chrono::milliseconds(50);
    };
    EXPECT_THROW(crandall::run_samples(plan, 0, o.paths, threads, out.data(), nullptr, cancel),
                 crandall::Cancelled);
    EXPECT_LT(std::chrono::steady_clock::now() - start, std::chrono::seconds(2));
  }
}

TEST(Levels, SumProductsIsThePlainSum) {
  const std::uint64_t rows = 1000, cols = 3;
  std::vector<double> f(rows * cols);
  for (std::size_t i = 0; i < f.size(); ++i) f[i] = static_cast<double>((i * 37) % 11) - 5.0;
  // Groups of widths 1 and 2: sums, then the upper triangle of the products, per group.
  const auto got = crandall::sum_products(f.data(), rows, cols, {1, 2}, 2);
  std::vector<double> want(2 + 5, 0.0);
  for (std::uint64_t r = 0; r < rows; ++r) {
    const double* x = &f[r * cols];
    want[0] += x[0];
    want[1] += x[0] * x[0];
    want[2] += x[1];
    want[3] += x[2];
    want[4] += x[1] * x[1];
    want[5] += x[1] * x[2];
    want[6] += x[2] * x[2];
  }
  EXPECT_EQ(got, want);  // small integers: every sum exact, in any order
  EXPECT_EQ(got, crandall::sum_products(f.data(), rows, cols, {1, 2}, 1));
  EXPECT_THROW(crandall::sum_products(f.data(), rows, cols, {1, 1}, 1), std::invalid_argument);
}

}  // namespace
