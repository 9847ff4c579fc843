// Richardson's methods (docs/methods/richardson.md): the exact method's steps, and on the same
// path the trapezoid integrals on the grids of every 2nd (and every 4th) point, whose moments
// the run extrapolates to a zero step (plan.hpp's richardson_weights). richardson walks three
// grids, richardson2 two (kMethodTable); with no integral observed there is nothing to
// extrapolate and the loop keeps one grid (grids(m, integrals)).
#pragma once

#include "crandall/methods/exact.hpp"

CRANDALL_BEGIN_VARIANT

template <Method M>
struct RichardsonSteps : MethodOf<M> {
  template <bool kDisp, bool kDist, int G, class Obs>
  [[gnu::always_inline]] static void step(const SegmentSteps& g, const StepDraws& z,
                                          std::uint64_t k, Group<G>& p, Obs& obs) {
    alignas(32) double x1[kLanes];
    exact_lanes<kDisp, kDist>(g, z, p.x, p.u, p.s, x1);
    obs.stepped(p.x, x1, g);
    if constexpr (G > 1) coarse<kDisp, kDist>(g, k, p, x1, obs);
    for (int l = 0; l < kLanes; ++l) p.x[l] = x1[l];
    // The fine grid's points only: the peaks are not extrapolated (the coarse grids are subsets
    // of these points, and a maximum has no error expansion in the step that the extrapolation
    // assumes).
    obs.moved(p.x, p.u);
  }

  // The coarse grids' steps that end with the fine step k (from p.x to x1). Segments have step
  // counts that are multiples of 2^(G - 1), so a coarse step never straddles two segments.
  template <bool kDisp, bool kDist, int G, class Obs>
  [[gnu::always_inline]] static void coarse(const SegmentSteps& g, std::uint64_t k, Group<G>& p,
                                            const double* x1, Obs& obs) {
    const double step = g.step, drift = g.drift;
    for (int c = 1; c < G; ++c) {
      const std::uint64_t mask = (std::uint64_t{1} << c) - 1;
      if ((k & mask) == 0)
        for (int l = 0; l < kLanes; ++l) p.xc[c][l] = p.x[l];
      if ((k & mask) != mask) continue;
      const double coarse_half = 0.5 * step * static_cast<double>(mask + 1);
      if (g.quiet) {
        // The coarse step's own exact integrals: without noise the motion over it is the
        // coast from xc, which ends at x1.
        const double length = step * static_cast<double>(mask + 1);
        for (int l = 0; l < kLanes; ++l) {
          if constexpr (kDisp) p.uc[c][l] += step_displacement(true, length, drift, p.xc[c][l], x1[l]);
          if constexpr (kDist) p.sc[c][l] += step_distance(true, length, drift, p.xc[c][l], x1[l]);
        }
      } else {
#pragma omp simd
        for (int l = 0; l < kLanes; ++l) {
          if constexpr (kDisp) p.uc[c][l] += coarse_half * (p.xc[c][l] + x1[l]);
          if constexpr (kDist) p.sc[c][l] += coarse_half * (std::abs(p.xc[c][l]) + std::abs(x1[l]));
        }
      }
      obs.coarse_stepped(c, p.xc[c], x1, coarse_half, g);
    }
  }
};

using Richardson = RichardsonSteps<Method::richardson>;
using Richardson2 = RichardsonSteps<Method::richardson2>;

CRANDALL_END_VARIANT
