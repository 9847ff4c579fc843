// Runs are bitwise independent of the thread count; streams are distinct per path and step;
// plans and options reject bad input.
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <stdexcept>
#include <cstdlib>
#include <limits>
#include <set>
#include <utility>
#include <vector>

#include "crandall/coast.hpp"
#include "crandall/dispatch.hpp"
#include "crandall/rng.hpp"
#include "crandall/run.hpp"
#include "crandall/skeleton.hpp"

namespace {

crandall::Options scene() {
  crandall::Options o;
  o.switch_off = 1.0;
  o.times = {0.25, 0.5, 1.0, 1.5};
  o.dt = 0.05;
  o.displacement = o.distance = o.stop = true;
  o.seed = 42;
  o.paths = 3000;  // not a multiple of the block or lane size: partial blocks are exercised
  return o;
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

TEST(Rng, StreamsDependOnSeedPathAndStep) {
  std::set<double> seen;
  for (std::uint64_t seed : {0ull, 1ull})
    for (std::uint64_t path : {0ull, 1ull, 1ull << 40})
      for (std::uint64_t pair : {0ull, 1ull, 1ull << 33}) {
        crandall::StepNoise z[2];
        crandall::draw_pair(seed, path, pair, z);
        seen.insert(z[0].normal);
        seen.insert(z[1].normal);
      }
  EXPECT_EQ(seen.size(), 2u * 2 * 3 * 3);
}

// The vectorised Philox (the AVX-512 and AVX2 variants) against Random123's scalar generator,
// over counters whose words cross 32-bit boundaries, and a group of paths that is not a
// multiple of the vector width; every variant this host supports.
TEST(Rng, VectorPhiloxMatchesRandom123) {
  for (const crandall::KernelTable* kernel : crandall::compiled_kernels()) {
    if (!crandall::kernel_supported(*kernel)) continue;
    for (std::uint64_t seed : {0ull, 42ull, 0xFFFFFFFFFFFFFFFFull, 0x0123456789ABCDEFull})
      for (std::uint64_t path0 : {0ull, 1000ull, 0xFFFFFFF8ull, (1ull << 63) - 5})
        for (std::uint64_t pair : {0ull, 7ull, 0xFFFFFFFFull, 1ull << 40}) {
          std::uint64_t w[4 * crandall::kLanes];
          kernel->philox_words(seed, path0, pair, 13, w);
          for (int l = 0; l < 13; ++l) {
            using Philox = r123::Philox4x32;
            const Philox::key_type key = {{static_cast<std::uint32_t>(seed),
                                           static_cast<std::uint32_t>(seed >> 32)}};
            const std::uint64_t path = path0 + static_cast<std::uint64_t>(l);
            const Philox::ctr_type ctr = {{static_cast<std::uint32_t>(pair),
                                           static_cast<std::uint32_t>(pair >> 32),
                                           static_cast<std::uint32_t>(path),
                                           static_cast<std::uint32_t>(path >> 32)}};
            const Philox::ctr_type want = Philox()(ctr, key);
            for (int j = 0; j < 4; ++j)
              ASSERT_EQ(static_cast<std::uint32_t>(w[j * crandall::kLanes + l]), want[j])
                  << kernel->name << " seed " << seed << " path " << path << " pair " << pair
                  << " word " << j;
          }
        }
  }
}

// A host with AVX2 or AVX-512 runs (and the test above checks) the vector Philox by default.
TEST(Rng, VectorPhiloxIsChosenWhereTheHostHasIt) {
  if (std::getenv("CRANDALL_ISA")) GTEST_SKIP() << "CRANDALL_ISA forces a variant";
  const auto& k = crandall::active_kernel();
#if defined(__x86_64__)
  if (__builtin_cpu_supports("avx2")) {
    EXPECT_GT(k.philox_paths_per_register, 1);
  }
  if (__builtin_cpu_supports("avx512f")) {
    EXPECT_EQ(k.philox_paths_per_register, 8);
    EXPECT_STREQ(k.name, "avx512");
  }
#else
  EXPECT_STREQ(k.name, "baseline");
#endif
}

// Random123's published known-answer vectors for Philox4x32-10 (kat_vectors), so the scalar
// reference above is itself pinned.
TEST(Rng, PhiloxKnownAnswers) {
  using Philox = r123::Philox4x32;
  struct Kat {
    Philox::ctr_type ctr;
    Philox::key_type key;
    Philox::ctr_type want;
  };
  const Kat kats[] = {
      {{{0u, 0u, 0u, 0u}}, {{0u, 0u}}, {{0x6627e8d5u, 0xe169c58du, 0xbc57ac4cu, 0x9b00dbd8u}}},
      {{{0xffffffffu, 0xffffffffu, 0xffffffffu, 0xffffffffu}},
       {{0xffffffffu, 0xffffffffu}},
       {{0x408f276du, 0x41c83b0eu, 0xa20bc7c6u, 0x6d5451fdu}}},
      {{{0x243f6a88u, 0x85a308d3u, 0x13198a2eu, 0x03707344u}},
       {{0xa4093822u, 0x299f31d0u}},
       {{0xd16cfe09u, 0x94fdccebu, 0x5001e420u, 0x24126ea1u}}},
  };
  for (const Kat& k : kats) {
    const Philox::ctr_type got = Philox()(k.ctr, k.key);
    for (int j = 0; j < 4; ++j) EXPECT_EQ(got[j], k.want[j]);
    // And through the vector path: counter (pair = words 0-1, path = words 2-3).
    alignas(64) std::uint64_t w[4][8];
    const std::uint64_t pair = k.ctr[0] | (std::uint64_t{k.ctr[1]} << 32);
    const std::uint64_t path = k.ctr[2] | (std::uint64_t{k.ctr[3]} << 32);
    const std::uint64_t seed = k.key[0] | (std::uint64_t{k.key[1]} << 32);
    crandall::philox_paths<8>(seed, path - 3, pair, 8, w);
    for (int j = 0; j < 4; ++j) EXPECT_EQ(static_cast<std::uint32_t>(w[j][3]), k.want[j]);
  }
}

// A path's draws do not depend on the group it is drawn in.
TEST(Rng, BatchedDrawsEqualSingleDraws) {
  crandall::PairNoise<16> z;
  crandall::draw_pairs<16>(5, 1234, 77, z);
  for (int l = 0; l < 16; ++l) {
    crandall::StepNoise one[2];
    crandall::draw_pair(5, 1234 + static_cast<std::uint64_t>(l), 77, one);
    for (int j = 0; j < 2; ++j) {
      EXPECT_EQ(z.normal[j][l], one[j].normal);
      EXPECT_EQ(z.exponential[j][l], one[j].exponential);
      EXPECT_EQ(z.coin[j][l] != 0.0, one[j].coin);
    }
  }
}

TEST(Rng, MomentsOfTheDraws) {
  const int n = 400000;
  double sz = 0, szz = 0, se = 0, coins = 0;
  for (int i = 0; i < n / 2; ++i) {
    crandall::StepNoise z[2];
    crandall::draw_pair(9, 3, static_cast<std::uint64_t>(i), z);
    for (const auto& s : z) {
      sz += s.normal;
      szz += s.normal * s.normal;
      se += s.exponential;
      coins += s.coin;
    }
  }
  // 5 standard errors each: normal mean (1/sqrt n), normal second moment (sqrt(2/n)),
  // exponential mean (1/sqrt n), coin (0.5/sqrt n).
  EXPECT_NEAR(sz / n, 0.0, 5.0 / std::sqrt(n));
  EXPECT_NEAR(szz / n, 1.0, 5.0 * std::sqrt(2.0 / n));
  EXPECT_NEAR(se / n, 1.0, 5.0 / std::sqrt(n));
  EXPECT_NEAR(coins / n, 0.5, 2.5 / std::sqrt(n));
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

}  // namespace

namespace {

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

TEST(Methods, NamesRoundTripAndUnknownNamesThrow) {
  for (auto m : {crandall::Method::exact, crandall::Method::euler, crandall::Method::richardson,
                 crandall::Method::richardson2, crandall::Method::refine})
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

TEST(Methods, RichardsonGridsNestSegmentBySegment) {
  auto o = scene();  // segments of 5, 5, 10 steps at dt = 0.05
  o.method = crandall::Method::richardson;
  const crandall::Plan plan(o);
  for (const auto& seg : plan.segments()) EXPECT_EQ(seg.steps % 4, 0u);
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

}  // namespace

namespace {

TEST(Kernel, LanesEqualTheScalarExactStep) {
  // The kernel evaluates the exact step lane by lane in vector form; with one path, the mean of
  // an output slot is that path's velocity itself, which must be exact_step's bits on the same
  // draws (step k uses half k of pair 0), in the regular and in the scaled range of steps.
  for (const auto& [drift, noise] : std::vector<std::pair<double, double>>{
           {2.0, std::sqrt(2.0)}, {2.943, 1e-9}, {0.0, 1.0}, {2.0, 0.0}}) {
    for (double step : {1e-300, 1e-200, 1e-12, 0.01, 1.0, 1e3, 1e15, 1e17, 1e100, 1e200, 1e300}) {
      crandall::Options o;
      o.drift = drift;
      o.noise = noise;
      o.times = {step, 2.0 * step};
      o.paths = 1;
      for (std::uint64_t seed = 0; seed < 64; ++seed) {
        o.seed = seed;
        const crandall::Plan plan(o);
        ASSERT_EQ(plan.segments().size(), 2u);
        const auto r = crandall::run_chunk(plan, 0, 1);
        crandall::StepNoise z[2];
        crandall::draw_pair(seed, 0, 0, z);
        double x = 0.0;
        for (int k = 0; k < 2; ++k) {
          x = crandall::exact_step(x, plan.segments()[k].step, drift, noise, z[k].normal,
                                   z[k].exponential, z[k].coin)
                  .velocity;
          EXPECT_EQ(r.times.means()[k * crandall::kVariables], x)
              << "drift=" << drift << " noise=" << noise << " step=" << step << " seed=" << seed;
        }
      }
    }
  }
}

}  // namespace

namespace {

TEST(Rng, DrawsStayWithinTheirDocumentedBounds) {
  // The extreme uniforms (w = 0 and w = 2^32 - 1) give the extreme draws; the kernel's
  // segment_regular relies on these bounds.
  const double k2m32 = std::ldexp(1.0, -32);
  const double u_min = 0.5 * k2m32, u_max = (4294967295.0 + 0.5) * k2m32;
  EXPECT_GE(-std::log(u_max), crandall::kMinExponential);
  EXPECT_LE(-std::log(u_min), crandall::kMaxExponential);
  EXPECT_LE(std::sqrt(-2.0 * std::log(u_min)), crandall::kMaxAbsNormal);
  double lo = 1.0, hi = 0.0, z = 0.0;
  for (std::uint64_t pair = 0; pair < 200000; ++pair) {
    crandall::StepNoise w[2];
    crandall::draw_pair(9, 3, pair, w);
    for (const auto& v : w) {
      lo = std::min(lo, v.exponential);
      hi = std::max(hi, v.exponential);
      z = std::max(z, std::abs(v.normal));
    }
  }
  EXPECT_GE(lo, crandall::kMinExponential);
  EXPECT_LE(hi, crandall::kMaxExponential);
  EXPECT_LE(z, crandall::kMaxAbsNormal);
}

}  // namespace

namespace {

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

}  // namespace

namespace {

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
