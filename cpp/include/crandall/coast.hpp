// After the noise is switched off at t0 the motion is deterministic (paper eq13a-eq14, here
// for a general deceleration c; the paper's scaled units have c = 2): the body decelerates at
// rate c and stops at t_s = t0 + |X(t0)| / c, then stays at rest.
#pragma once

#include <algorithm>
#include <cmath>
#include <limits>

namespace crandall {

struct State {
  double velocity;
  double displacement;
  double distance;
};

// State at time t0 + elapsed (elapsed >= 0), from the state at switch-off.
inline State coast(const State& s0, double drift, double elapsed) {
  const double speed = std::abs(s0.velocity);
  const double sign = s0.velocity > 0.0 ? 1.0 : (s0.velocity < 0.0 ? -1.0 : 0.0);
  if (drift > 0.0 && elapsed * drift >= speed) {
    // At rest: exactly zero velocity, and the stopping distance v^2 / (2c) in one rounding.
    const double travelled = 0.5 * speed * speed / drift;
    return {0.0, s0.displacement + sign * travelled, s0.distance + travelled};
  }
  const double travelled = elapsed * (speed - 0.5 * drift * elapsed);
  return {sign * (speed - drift * elapsed), s0.displacement + sign * travelled,
          s0.distance + travelled};
}

// The distance covered over a step of length `step` without noise (a pause, or the coast),
// from speed a0 to the step's end speed a1 = max(a0 - c step, 0) (the exact step's map without
// noise): the trapezoid rule while the speed falls linearly over the whole step (exact there,
// the grid's own rule), and the stopping distance a0^2 / (2c), rounded as coast() rounds it,
// where the body comes to rest inside the step: the speed's kink, where the trapezoid is not
// exact (it is off by up to c step^2 / 8). Used by every path loop that integrates on a grid
// (kernel.hpp: every grid of the exact, Richardson and refine methods).
inline double quiet_distance(double step, double drift, double a0, double a1) {
  return a1 == 0.0 && drift > 0.0 ? 0.5 * a0 * a0 / drift : 0.5 * step * (a0 + a1);
}

// Time from switch-off to the stop; +inf without friction unless already at rest.
inline double time_to_stop(double velocity, double drift) {
  const double speed = std::abs(velocity);
  if (speed == 0.0) return 0.0;
  return drift > 0.0 ? speed / drift : std::numeric_limits<double>::infinity();
}

}  // namespace crandall
