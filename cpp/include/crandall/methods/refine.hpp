// The refine method (docs/methods/refine.md): a step of length `step` that starts with
// |x| < kRefineWithin * noise * sqrt(step) is taken as kRefineSubsteps exact substeps, whose
// noise comes from the path's refinement stream (path index with the top bit set; one Philox
// block per two substeps, pair index = k * kRefineSubsteps / 2 + j for the step of index k);
// the others are the exact method's steps (methods/exact.hpp says what a method type holds).
#pragma once

#include <algorithm>

#include "crandall/kernel_lanes.hpp"

namespace crandall {

constexpr int kRefineSubsteps = 8;
constexpr double kRefineWithin = 2.0;
constexpr std::uint64_t kRefineStream = 1ull << 63;

}  // namespace crandall

CRANDALL_BEGIN_VARIANT

struct Refine : MethodOf<Method::refine> {
  static void segment(SegmentSteps& g) { g.near = kRefineWithin * g.noise * std::sqrt(g.step); }
  template <bool kDisp, bool kDist, int G, class Obs>
  [[gnu::always_inline]] static void step(const SegmentSteps& g, const StepDraws& z,
                                          std::uint64_t k, Group<G>& p, Obs& obs) {
    const double step = g.step, drift = g.drift, noise = g.noise;
    for (int l = 0; l < p.lanes; ++l) {
      const double x0 = p.x[l];
      double x1;
      if (std::abs(x0) < g.near) {
        x1 = substeps<kDisp, kDist>(g, k, (p.path0 + l) | kRefineStream, l, x0, p.u[l], p.s[l], obs);
      } else {
        x1 = exact_step(x0, step, drift, noise, z.normal[l], z.exponential[l], z.coin[l] != 0.0)
                 .velocity;
        if constexpr (kDisp) p.u[l] += step_displacement(g.quiet, step, drift, x0, x1);
        if constexpr (kDist) p.s[l] += step_distance(g.quiet, step, drift, x0, x1);
      }
      p.x[l] = x1;
    }
    obs.moved(p.x, p.u);
  }

  // The substeps of lane l's step k from x0, on the refinement stream `stream`; returns the
  // velocity at the step's end. The substeps are points of the path too: the observers see them.
  template <bool kDisp, bool kDist, class Obs>
  [[gnu::always_inline]] static double substeps(const SegmentSteps& g, std::uint64_t k,
                                                std::uint64_t stream, int l, double x0,
                                                double& u, double& s, Obs& obs) {
    constexpr int kPairs = kRefineSubsteps / 2;
    const double substep = g.step / kRefineSubsteps;
    double xa = x0;
    for (int j = 0; j < kPairs; ++j) {
      StepNoise r[2];
      draw_pair(g.seed, stream, k * kPairs + j, r);
      for (const StepNoise& q : r) {
        const double xb =
            exact_step(xa, substep, g.drift, g.noise, q.normal, q.exponential, q.coin).velocity;
        if constexpr (kDisp) u += trapezoid(substep, xa, xb);
        if constexpr (kDist) s += trapezoid(substep, std::abs(xa), std::abs(xb));
        xa = xb;
        obs.substep(l, xa, u);
      }
    }
    return xa;
  }
};

CRANDALL_END_VARIANT
