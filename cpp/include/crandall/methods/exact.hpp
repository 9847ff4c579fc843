// The exact method: the exact skeleton (exact_step.hpp, docs/exact-step.md) on the grid,
// the integrals by the trapezoid rule on it (docs/integrals.md).
//
// A method is a small type the path loop (simulate_block, kernel.hpp) is instantiated with;
// the first four come from its base MethodOf<its Method> (kernel_lanes.hpp):
//   kMethod    its Method (plan.hpp; its row in kMethodTable names it, counts its grids,
//              says whether its steps are the exact skeleton's and states its order),
//   kSkeleton  that row's answer (an observer of the Brownian increments and the quadratic
//              variation need the exact skeleton's steps),
//   kOrder     that row's order: the exponent p of its moments' leading bias term c dt^p
//              (NaN: not known); Python reads it as crandall.methods.ORDERS,
//   segment(g) its own constants of a segment's steps (SegmentSteps; most have none),
//   step<kDisp, kDist>(g, draws, k, group, observers)
//              the step of index k of a group of paths, the integrals asked for added, the
//              observers told (kernel_observers.hpp: stepped, coarse_stepped, substep, moved).
#pragma once

#include "crandall/kernel_lanes.hpp"

CRANDALL_BEGIN_VARIANT

// exact_step over all lanes from x to x1, its parts in separate loops so that they vectorise,
// the integrals added to u and s: the trapezoid rule on the exact skeleton, or in a pause the
// coast's.
template <bool kDisp, bool kDist>
[[gnu::always_inline]] inline void exact_lanes(const SegmentSteps& g, const StepDraws& z,
                                               const double* x, double* u, double* s,
                                               double* x1) {
  const double mean_d = g.c.mean, scale_d = g.c.scale, twice_var = g.c.twice_variance;
  const double step = g.step, drift = g.drift, noise = g.noise;
  const double* zn = z.normal;
  const double* ze = z.exponential;
  const double* zc = z.coin;
  alignas(32) double d[kLanes], q[kLanes], root[kLanes];
#pragma omp simd
  for (int l = 0; l < kLanes; ++l) {
    d[l] = step_increment(mean_d, scale_d, zn[l]);
    q[l] = step_spread(twice_var, ze[l]);
    root[l] = step_root_square(d[l], q[l]);
  }
  sqrt_lanes(root);
  int irregular = 0;
  if (!g.all_regular) {
#pragma omp simd reduction(| : irregular)
    for (int l = 0; l < kLanes; ++l) irregular |= !step_regular(root[l]);
  }
  if (irregular == 0 && !g.quiet) {
#pragma omp simd
    for (int l = 0; l < kLanes; ++l) {
      const double x0 = x[l];
      x1[l] = regular_step(x0, d[l], q[l], root[l], zc[l] != 0.0);
      if constexpr (kDisp) u[l] += trapezoid(step, x0, x1[l]);
      if constexpr (kDist) s[l] += trapezoid(step, std::abs(x0), std::abs(x1[l]));
    }
  } else {
    // A step far outside the usual range in some lane (over- or underflow of d^2 + q), or a
    // step without noise (a pause, whose integrals are the coast's in the step where the body
    // comes to rest): exact_step, which takes its scaled form out of range and gives the
    // vector loop's bits elsewhere; the integrals as above, or the coast's.
    for (int l = 0; l < kLanes; ++l) {
      const double x0 = x[l];
      x1[l] = exact_step(x0, step, drift, noise, zn[l], ze[l], zc[l] != 0.0).velocity;
      if constexpr (kDisp) u[l] += step_displacement(g.quiet, step, drift, x0, x1[l]);
      if constexpr (kDist) s[l] += step_distance(g.quiet, step, drift, x0, x1[l]);
    }
  }
}

struct Exact : MethodOf<Method::exact> {
  template <bool kDisp, bool kDist, int G, class Obs>
  [[gnu::always_inline]] static void step(const SegmentSteps& g, const StepDraws& z,
                                          std::uint64_t, Group<G>& p, Obs& obs) {
    alignas(32) double x1[kLanes];
    exact_lanes<kDisp, kDist>(g, z, p.x, p.u, p.s, x1);
    obs.stepped(p.x, x1, g);
    for (int l = 0; l < kLanes; ++l) p.x[l] = x1[l];
    obs.moved(p.x, p.u);
  }
};

CRANDALL_END_VARIANT
