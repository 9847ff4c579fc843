// Per-path values of the runs to an accuracy (levels.hpp): the same bits for any thread count
// and any split of the path range, with and without control sums; a cancel request stops them,
// also inside a block of long paths; bad ranges throw; sum_products against a plain loop.
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <cstdint>
#include <cstring>
#include <stdexcept>
#include <vector>

#include "crandall/dispatch.hpp"
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

TEST(Levels, QuadraticVariationIsTheTrapezoidOfTheSquaredVelocity) {
  // Output times on every point of a grid with a pause and a change of intensity: the slot
  // after the stop's holds int noise^2 X^2 dt by the trapezoid rule over those points, on the
  // fine grid (exact) and on Richardson's coarse grid of every 2nd point (richardson2, whose
  // fine grid halves each segment), computed here from the recorded velocities. Adding the slot
  // changes no other value.
  for (auto m : {crandall::Method::exact, crandall::Method::richardson2}) {
    auto o = scene();
    o.method = m;
    o.switch_off = 1.2;
    o.piece_ends = {0.4, 0.6, 1.2};
    o.piece_noise = {1.5, 0.0, 0.7};
    o.start_velocity = 0.8;
    o.times.clear();
    for (int i = 1; i <= 30; ++i) o.times.push_back(0.04 * i);
    o.times.back() = 1.2;
    o.dt = 0.04;
    const crandall::Plan without(o);
    o.quadratic_variation = true;
    const crandall::Plan plan(o);
    const std::size_t slots = o.times.size() + 2, grids = static_cast<std::size_t>(o.grids());
    ASSERT_EQ(crandall::sample_size(plan), slots * grids * 3);
    const std::uint64_t n = 300;
    const auto got = samples(plan, 0, n, 2);
    const auto plain = samples(without, 0, n, 2);
    const std::size_t stride = slots * grids * 3, plain_stride = (slots - 1) * grids * 3;
    const int grid = m == crandall::Method::exact ? 0 : 1;
    for (std::uint64_t p = 0; p < n; ++p) {
      const double* v = &got[p * stride];
      for (std::size_t i = 0; i < plain_stride; ++i)
        ASSERT_EQ(v[i], plain[p * plain_stride + i]) << crandall::method_name(m);
      double want = 0.0, x0 = o.start_velocity, t0 = 0.0;
      for (std::size_t k = 0; k < o.times.size(); ++k) {
        const double x1 = v[(k * grids + 0) * 3 + 0], t1 = o.times[k];
        const double mid = 0.5 * (t0 + t1);
        const double h = mid < 0.4 ? 1.5 : mid < 0.6 ? 0.0 : 0.7;
        want += 0.5 * (t1 - t0) * h * h * (x0 * x0 + x1 * x1);
        x0 = x1;
        t0 = t1;
      }
      const double* q = v + ((slots - 1) * grids + static_cast<std::size_t>(grid)) * 3;
      EXPECT_NEAR(q[0], want, 1e-13 * (1.0 + want)) << crandall::method_name(m) << " path " << p;
      EXPECT_EQ(q[1], 0.0);
      EXPECT_EQ(q[2], 0.0);
    }
  }
}

TEST(Levels, QuadraticVariationIsTheSameInEveryVariant) {
  // The loops that integrate it are compiled per instruction set like the others: the values
  // and the control sums must be the same bits in every variant this CPU runs.
  KeepKernel keep;
  for (auto m : {crandall::Method::exact, crandall::Method::richardson2}) {
    auto o = scene();
    o.method = m;
    o.quadratic_variation = true;
    o.piece_ends = {0.4, 1.0};
    o.piece_noise = {1.5, 0.7};
    const crandall::Plan plan(o);
    std::vector<double> want, want_controls;
    for (const auto* k : crandall::compiled_kernels()) {
      if (!crandall::kernel_supported(*k)) continue;
      crandall::select_kernel(k->name);
      std::vector<double> controls;
      const auto got = samples(plan, 3, 203, 2, m == crandall::Method::exact ? &controls : nullptr);
      if (want.empty()) {
        want = got;
        want_controls = controls;
      }
      EXPECT_EQ(0, std::memcmp(got.data(), want.data(), got.size() * sizeof(double)))
          << k->name << " " << crandall::method_name(m);
      EXPECT_EQ(controls, want_controls) << k->name;
    }
  }
}

TEST(Levels, QuadraticVariationNeedsTheStopAnIntegralAndAnExactSkeleton) {
  auto o = scene();
  o.quadratic_variation = true;
  for (auto m : {crandall::Method::exact, crandall::Method::richardson, crandall::Method::richardson2}) {
    o.method = m;
    EXPECT_NO_THROW(crandall::Plan{o});
  }
  for (auto m : {crandall::Method::euler, crandall::Method::refine}) {
    o.method = m;
    EXPECT_THROW(crandall::Plan{o}, std::invalid_argument);
  }
  o.method = crandall::Method::exact;
  auto no_stop = o;
  no_stop.stop = false;
  EXPECT_THROW(crandall::Plan{no_stop}, std::invalid_argument);
  auto no_integral = o;
  no_integral.displacement = no_integral.distance = false;
  EXPECT_THROW(crandall::Plan{no_integral}, std::invalid_argument);
  auto peaks = o;
  peaks.peaks = true;
  EXPECT_THROW(crandall::Plan{peaks}, std::invalid_argument);
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
