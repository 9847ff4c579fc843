// Closed-form coast after switch-off against direct integration of the deterministic ODE.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "crandall/coast.hpp"

namespace {

TEST(Coast, StopTimeAndStopValues) {
  const crandall::State s0{-3.0, 1.0, 2.0};
  const double c = 2.0;
  EXPECT_DOUBLE_EQ(crandall::time_to_stop(s0.velocity, c), 1.5);  // eq14: |U1| / 2
  const auto at_stop = crandall::coast(s0, c, 1.5);
  EXPECT_EQ(at_stop.velocity, 0.0);
  EXPECT_DOUBLE_EQ(at_stop.distance, 2.0 + 9.0 / 4.0);       // eq13c at tau_s: + U1^2 / 4
  EXPECT_DOUBLE_EQ(at_stop.displacement, 1.0 - 9.0 / 4.0);   // eq13b: sign(U1) U1^2 / 4
  const auto later = crandall::coast(s0, c, 10.0);          // at rest after the stop
  EXPECT_EQ(later.velocity, 0.0);
  EXPECT_EQ(later.distance, at_stop.distance);
  EXPECT_EQ(later.displacement, at_stop.displacement);
}

TEST(Coast, MatchesIntegratedOde) {
  for (double v0 : {2.5, -0.7}) {
    const crandall::State s0{v0, 0.3, 0.4};
    const double c = 1.7, t_end = 0.9 * std::abs(v0) / c;
    const int n = 200000;
    const double step = t_end / n;
    double v = v0, u = s0.displacement, s = s0.distance;
    for (int i = 0; i < n; ++i) {  // midpoint rule: exact for the quadratic integrands
      const double vm = v - c * (v > 0 ? 1 : -1) * 0.5 * step;
      u += step * vm;
      s += step * std::abs(vm);
      v -= c * (v > 0 ? 1 : -1) * step;
    }
    const auto st = crandall::coast(s0, c, t_end);
    EXPECT_NEAR(st.velocity, v, 1e-9);
    EXPECT_NEAR(st.displacement, u, 1e-9);
    EXPECT_NEAR(st.distance, s, 1e-9);
  }
}

TEST(Coast, NoFrictionNeverStops) {
  EXPECT_TRUE(std::isinf(crandall::time_to_stop(1.0, 0.0)));
  EXPECT_EQ(crandall::time_to_stop(0.0, 0.0), 0.0);
  const auto st = crandall::coast({-2.0, 0.0, 0.0}, 0.0, 3.0);
  EXPECT_EQ(st.velocity, -2.0);
  EXPECT_EQ(st.displacement, -6.0);
  EXPECT_EQ(st.distance, 6.0);
}

// A step without noise covers what the coast covers over it: the trapezoid while the speed
// falls linearly, the stopping distance where the body comes to rest inside the step (where the
// trapezoid, 0.5 step a0, is not: the speed's kink).
TEST(Coast, AQuietStepCoversWhatTheCoastCovers) {
  const double c = 2.0, step = 0.5;
  for (double a0 : {3.0, 1.0, 0.4, 0.0}) {
    const double a1 = std::max(a0 - c * step, 0.0);
    const auto st = crandall::coast({a0, 0.0, 0.0}, c, step);
    EXPECT_EQ(std::abs(st.velocity), a1);
    EXPECT_NEAR(crandall::quiet_distance(step, c, a0, a1), st.distance, 1e-15) << a0;
  }
  EXPECT_DOUBLE_EQ(crandall::quiet_distance(step, c, 0.4, 0.0), 0.04);  // 0.4^2 / 4, not 0.1
  EXPECT_EQ(crandall::quiet_distance(step, 0.0, 2.0, 2.0), 1.0);  // no friction: never stops
}

}  // namespace
