// Euler-Maruyama (the baseline): the left-point rule for the velocity and the integrals.
// Its steps are not the exact skeleton's, so no observer of the Brownian increments or of the
// quadratic variation runs with it (methods/exact.hpp says what a method type holds).
#pragma once

#include "crandall/kernel_lanes.hpp"

CRANDALL_BEGIN_VARIANT

struct Euler : MethodOf<Method::euler> {
  template <bool kDisp, bool kDist, int G, class Obs>
  [[gnu::always_inline]] static void step(const SegmentSteps& g, const StepDraws& z,
                                          std::uint64_t, Group<G>& p, Obs& obs) {
    const double step = g.step, drift = g.drift, noise = g.noise;
    for (int l = 0; l < kLanes; ++l) {
      const double x0 = p.x[l];
      if constexpr (kDisp) p.u[l] += step * x0;
      if constexpr (kDist) p.s[l] += step * std::abs(x0);
      p.x[l] = euler_step(x0, step, drift, noise, z.normal[l]);
    }
    obs.moved(p.x, p.u);
  }
};

CRANDALL_END_VARIANT
