// The Newmark block on hand-derived records (docs/records.md): each expected value below is
// worked out on paper for a record of a few samples, in m/s^2 with yields of 1 or 2 m/s^2.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <vector>

#include "crandall/newmark.hpp"

namespace {

namespace nm = crandall::newmark;
constexpr double kInf = std::numeric_limits<double>::infinity();

TEST(Newmark, StopTimeIsTheFirstRootOfTheQuadratic) {
  // 1 - 3x + x^2 (c = 2): roots (3 -+ sqrt 5) / 2; the first is 0.3819660112501051.
  EXPECT_NEAR(nm::stop_time(1.0, -3.0, 2.0, 1.0), (3.0 - std::sqrt(5.0)) / 2.0, 1e-15);
  // 2 + x - x^2 (c = -2): the positive root is 2.
  EXPECT_NEAR(nm::stop_time(2.0, 1.0, -2.0, 5.0), 2.0, 1e-15);
  EXPECT_LT(nm::stop_time(2.0, 1.0, -2.0, 1.5), 0.0);  // beyond the limit
  EXPECT_LT(nm::stop_time(1.0, 1.0, 0.0, 1e9), 0.0);   // accelerating: never
  EXPECT_LT(nm::stop_time(1.0, -1.0, 2.0, 1e9), 0.0);  // 1 - x + x^2 > 0: no real root
  // Tiny w with r < 0: no cancellation (the naive formula gives 0 here).
  EXPECT_NEAR(nm::stop_time(1e-20, -1.0, 1.0, 1.0), 1e-20, 1e-35);
}

TEST(Newmark, OneWayConstantPulse) {
  // a = 2, 2, 0, 0, 0 (dt 1), ky g = 1: W' = 1 on [0,1]; 1 - 2s on [1,2] (W = 1 + s - s^2);
  // -1 after (W = 1 - s, stop at t = 3). D = 1/2 + 7/6 + 1/2 = 13/6.
  const std::vector<double> a{2, 2, 0, 0, 0, 0};
  std::vector<nm::Event> events;
  std::vector<double> v(a.size()), d(a.size());
  const auto s = nm::exact(a.data(), a.size(), 1.0, 1.0, {1, kInf, 1, kInf},
                           {v.data(), d.data(), &events});
  EXPECT_NEAR(s.displacement, 13.0 / 6.0, 1e-15);
  EXPECT_EQ(s.slips, 1);
  ASSERT_EQ(events.size(), 1u);
  EXPECT_EQ(events[0].onset, 0.0);
  EXPECT_NEAR(events[0].stop, 3.0, 1e-15);
  EXPECT_NEAR(v[1], 1.0, 1e-15);
  EXPECT_NEAR(d[2], 0.5 + 7.0 / 6.0, 1e-15);
}

TEST(Newmark, StaticAboveKineticStartsAtTheStaticYield) {
  // a = 0, 3, 3, 0, ... (dt 1), kinetic 1, static 1.5: onset at t = 0.5 with W' = 0.5;
  // D = 1/8 + 13/8 + 25/8 + 3.125^2 / 2 = 9.7578125, stop at 6.125.
  const std::vector<double> a{0, 3, 3, 0, 0, 0, 0, 0, 0};
  std::vector<nm::Event> events;
  const auto s = nm::exact(a.data(), a.size(), 1.0, 1.0, {1, 1, 1.5, 1.5},
                           {nullptr, nullptr, &events});
  EXPECT_NEAR(s.displacement, 9.7578125, 1e-14);
  ASSERT_EQ(events.size(), 1u);
  EXPECT_NEAR(events[0].onset, 0.5, 1e-15);
  EXPECT_NEAR(events[0].stop, 6.125, 1e-14);
}

TEST(Newmark, UpslopeOnAnIncline) {
  // a = 0, -4, -4, 0, ... (dt 1), kd = 1, ku = 2: upslope from t = 0.5, stop at 4.25;
  // D = -1/12 - 3/2 - 17/6 - 25/16 = -287/48.
  const std::vector<double> a{0, -4, -4, 0, 0, 0, 0};
  const auto s = nm::exact(a.data(), a.size(), 1.0, 1.0, {1, 2, 1, 2});
  EXPECT_NEAR(s.displacement, -287.0 / 48.0, 1e-14);
  EXPECT_NEAR(s.min_displacement, -287.0 / 48.0, 1e-14);
  EXPECT_EQ(s.max_displacement, 0.0);
  // The mirror image: the inverse polarity on the incline with kd and ku swapped.
  const auto m = nm::exact(a.data(), a.size(), 1.0, -1.0, {2, 1, 2, 1});
  EXPECT_NEAR(m.displacement, 287.0 / 48.0, 1e-14);
}

TEST(Newmark, SlammerRecursionByHand) {
  // ky = 0.1 g; a = 2 g, 2 g: step 0 from rest: n = 1, acc = 2g - 0.1g... written out with the
  // same operations: vel1 = 0 + 0.005 * acc, pos1 = 0 + 0.005 * vel1.
  const double g = nm::kStandardGravity, ky = 0.1 * g;
  const std::vector<double> a{2 * g, 2 * g};
  std::vector<double> v(2), d(2);
  nm::slammer(a.data(), 2, 0.01, 1.0, 0.1, {v.data(), d.data(), nullptr});
  const double acc = 2 * g - 1.0 * ky;
  const double vel1 = 0.0 + 0.005 * (acc + 0.0);
  EXPECT_EQ(v[0], vel1);
  EXPECT_EQ(d[0], 0.0 + 0.005 * (vel1 + 0.0));
  EXPECT_EQ(v[1], vel1 + 0.005 * (acc + acc));
}

TEST(Newmark, SweepDoesNotDependOnThreads) {
  std::vector<double> a(5000);
  for (std::size_t i = 0; i < a.size(); ++i) a[i] = 3.0 * std::sin(0.37 * double(i)) * std::cos(0.011 * double(i));
  std::vector<nm::RecordView> recs{{a.data(), a.size(), 0.01}, {a.data(), 3000, 0.02}};
  std::vector<nm::Yield> ys;
  for (double k : {0.5, 1.0, 2.0}) ys.push_back({k, kInf, k, kInf});
  const std::vector<double> signs{1.0, -1.0};
  std::vector<nm::Summary> one(12), many(12);
  nm::sweep(recs, ys, signs, nm::Method::kExact, 1, one.data());
  nm::sweep(recs, ys, signs, nm::Method::kExact, 4, many.data());
  for (std::size_t k = 0; k < one.size(); ++k) {
    EXPECT_EQ(one[k].displacement, many[k].displacement);
    const auto& r = recs[k / 6];
    const auto alone = nm::exact(r.a, r.n, r.dt, signs[k % 2], ys[(k % 6) / 2]);
    EXPECT_EQ(one[k].displacement, alone.displacement);
    EXPECT_GT(alone.displacement, 0.0);
  }
}

TEST(Newmark, RefusesBadInput) {
  const std::vector<double> a{0, 1, std::nan("")};
  EXPECT_THROW(nm::exact(a.data(), 3, 0.01, 1.0, {1, kInf, 1, kInf}), std::invalid_argument);
  EXPECT_THROW(nm::exact(a.data(), 2, 0.0, 1.0, {1, kInf, 1, kInf}), std::invalid_argument);
  EXPECT_THROW(nm::exact(a.data(), 2, 0.01, 1.0, {-1, kInf, 1, kInf}), std::invalid_argument);
  EXPECT_THROW(nm::exact(a.data(), 2, 0.01, 1.0, {1, 1, 0.5, 1}), std::invalid_argument);
  EXPECT_THROW(nm::slammer(a.data(), 2, 0.01, 1.0, 0.0), std::invalid_argument);
}

}  // namespace
