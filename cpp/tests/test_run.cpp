// Runs are bitwise independent of the thread count for every method; a run can be cancelled,
// from the calling thread, even while another thread holds the only block; an exception in the
// cancel check comes back to the caller; the stop time keeps its precision at a huge switch-off.
#include <gtest/gtest.h>
#include <omp.h>

#include <chrono>
#include <cmath>
#include <stdexcept>
#include <vector>

#include "crandall/coast.hpp"
#include "crandall/rng.hpp"
#include "crandall/run.hpp"
#include "crandall/exact_step.hpp"
#include "support.hpp"

namespace {

// The tests' runs are small: every parallel loop goes parallel anyway (one step of work per
// thread), so that the thread-count tests do run on several threads. Run.ThreadsGetEnoughWork
// checks the rule a run follows.
class SmallRunsGoParallel : public ::testing::Environment {
 public:
  void SetUp() override { crandall::set_thread_work(1.0); }
};
[[maybe_unused]] ::testing::Environment* const kSmallRuns =
    ::testing::AddGlobalTestEnvironment(new SmallRunsGoParallel);

TEST(Run, ThreadsGetEnoughWork) {
  const double before = crandall::set_thread_work(crandall::kThreadWork);
  const double w = crandall::kThreadWork;
  EXPECT_EQ(crandall::thread_count(4, 0.0), 1);
  EXPECT_EQ(crandall::thread_count(4, 2 * w - 1), 1);  // one thread below twice the least work
  EXPECT_EQ(crandall::thread_count(4, 2 * w), 2);
  EXPECT_EQ(crandall::thread_count(4, 3.5 * w), 3);
  EXPECT_EQ(crandall::thread_count(4, 1e300), 4);
  EXPECT_EQ(crandall::thread_count(0, 1e300), omp_get_max_threads());
  EXPECT_EQ(crandall::thread_count(1, 1e300), 1);
  // splitting's usual extension: 20 paths of a few hundred steps
  EXPECT_EQ(crandall::thread_count(2, 20.0 * 400.0), 1);
  EXPECT_THROW(crandall::thread_count(-1, 1e300), std::invalid_argument);
  EXPECT_THROW(crandall::set_thread_work(0.5), std::invalid_argument);
  EXPECT_THROW(crandall::set_thread_work(std::nan("")), std::invalid_argument);
  EXPECT_EQ(crandall::set_thread_work(before), w);
}

TEST(Run, BitwiseIdenticalForAnyThreadCount) {
  const crandall::Plan plan(scene());
  const auto one = crandall::run_chunk(plan, 0, 1);
  for (int threads : {2, 3, 5}) {
    const auto many = crandall::run_chunk(plan, 0, threads);
    EXPECT_EQ(one.times.counts(), many.times.counts());
    EXPECT_EQ(one.times.means(), many.times.means());
    EXPECT_EQ(one.times.central(), many.times.central());
    EXPECT_EQ(one.stop.central(), many.stop.central());
  }
}

TEST(Methods, EveryMethodIsBitwiseIdenticalForAnyThreadCount) {
  for (auto m : {crandall::Method::euler, crandall::Method::richardson,
                 crandall::Method::richardson2, crandall::Method::refine}) {
    auto o = scene();
    o.method = m;
    const crandall::Plan plan(o);
    const auto one = crandall::run_chunk(plan, 0, 1);
    const auto two = crandall::run_chunk(plan, 0, 2);
    EXPECT_EQ(one.times.means(), two.times.means()) << crandall::method_name(m);
    EXPECT_EQ(one.times.central(), two.times.central()) << crandall::method_name(m);
    EXPECT_EQ(one.stop.central(), two.stop.central()) << crandall::method_name(m);
  }
}

TEST(Run, SeedChangesResult) {
  auto o = scene();
  const auto a = crandall::run_chunk(crandall::Plan(o), 0, 1);
  o.seed = 43;
  const auto b = crandall::run_chunk(crandall::Plan(o), 0, 1);
  EXPECT_NE(a.times.means(), b.times.means());
}

TEST(Run, CancelEndsTheRun) {
  const crandall::Plan plan(scene());
  EXPECT_THROW(crandall::run_chunk(plan, 0, 2, [] { return true; }), crandall::Cancelled);
}

TEST(Run, StopTimeMomentsExactAtAHugeSwitchOff) {
  // At t0 = 1e16 the spacing of doubles is 2, while the time to stop, |X(t0)| / 2, is of order
  // 1/4: the stop slot keeps the time from the switch-off, whose moments must match those of
  // the paths' own |X(t0)| / 2 to double precision (the velocity jumps to t0 in one exact step,
  // step 0 of each path).
  crandall::Options o;
  o.switch_off = 1e16;
  o.stop = true;
  o.seed = 5;
  o.paths = 3000;
  const auto r = crandall::run_chunk(crandall::Plan(o), 0, 2);
  long double sum = 0.0L, sum2 = 0.0L;
  std::vector<double> t(o.paths);
  for (std::uint64_t p = 0; p < o.paths; ++p) {
    crandall::StepNoise z[2];
    crandall::draw_pair(o.seed, p, 0, z);
    const double x = crandall::exact_step(0.0, o.switch_off, o.drift, o.noise, z[0].normal,
                                          z[0].exponential, z[0].coin)
                         .velocity;
    t[p] = crandall::time_to_stop(x, o.drift);
    sum += t[p];
  }
  const long double mean = sum / o.paths;
  for (double v : t) sum2 += (v - mean) * (v - mean);
  ASSERT_EQ(r.stop.counts()[0], 3000.0);
  EXPECT_NEAR(r.stop.means()[0], static_cast<double>(mean), 1e-15);
  const double c2 = r.stop.central()[crandall::monomial_index(2, 0, 0)];
  EXPECT_NEAR(c2, static_cast<double>(sum2), 1e-12 * static_cast<double>(sum2));
}

TEST(Run, ExceptionInTheCheckIsRethrownOnTheCaller) {
  // An exception thrown inside the threads must come back to the caller, never terminate.
  const crandall::Plan plan(scene());
  int calls = 0;
  auto check = [&calls]() -> bool {
    if (++calls > 1) throw std::runtime_error("check failed");
    return false;
  };
  EXPECT_THROW(crandall::run_chunk(plan, 0, 3, check), std::runtime_error);
}

TEST(Run, CancelNoticedWhileAnotherThreadRunsTheOnlyBlock) {
  // One block (100 paths) of a long run on 4 threads: the calling thread may hold no block;
  // it must keep checking, and the block's thread must quit within kPollSteps steps.
  auto o = scene();
  o.paths = 100;
  o.times = {5.0};
  o.switch_off = 5.0;
  o.dt = 1e-7;  // 5e7 steps: minutes of work
  const crandall::Plan plan(o);
  const auto start = std::chrono::steady_clock::now();
  auto check = [start]() { return std::chrono::steady_clock::now() - start > std::chrono::milliseconds(200); };
  EXPECT_THROW(crandall::run_chunk(plan, 0, 4, check), crandall::Cancelled);
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  EXPECT_LT(seconds, 5.0);
}

}  // namespace
