// What a method's step sees in the white-noise path loop (kernel.hpp, methods/*.hpp): the
// segment's step constants, the step's draws and the state of a group of kLanes paths, with the
// integrals' rules shared by every method.
#pragma once

#include <cmath>
#include <cstdint>

#include "crandall/coast.hpp"
#include "crandall/exact_step.hpp"
#include "crandall/plan.hpp"
#include "crandall/rng.hpp"
#include "crandall/variant.hpp"

namespace crandall {

// The trapezoid rule over one step of length `step` between the values a and b
// (docs/integrals.md): how every method integrates displacement and distance on its grid.
inline double trapezoid(double step, double a, double b) { return 0.5 * step * (a + b); }

// The integrals over one step from velocity x0 to x1: the trapezoid rule, or in a step without
// noise (`quiet`: a pause) the deterministic coast's exact integrals (coast.hpp,
// quiet_distance), which differ from the trapezoid only in the step where the body comes to
// rest. In a quiet step x1 keeps x0's sign (or is 0), so the displacement is the distance with
// that sign: where the trapezoid holds, these are its bits.
inline double step_displacement(bool quiet, double step, double drift, double x0, double x1) {
  if (!quiet) return trapezoid(step, x0, x1);
  const double d = quiet_distance(step, drift, std::abs(x0), std::abs(x1));
  return x0 < 0.0 ? -d : d;
}
inline double step_distance(bool quiet, double step, double drift, double x0, double x1) {
  return quiet ? quiet_distance(step, drift, std::abs(x0), std::abs(x1))
               : trapezoid(step, std::abs(x0), std::abs(x1));
}

}  // namespace crandall

CRANDALL_BEGIN_VARIANT

// In-place square root of kLanes non-negative doubles. sqrt is correctly rounded, so the
// vector and scalar forms give the same bits; the explicit form is needed because std::sqrt
// (which may set errno) does not vectorise without -fno-math-errno.
inline void sqrt_lanes(double* v) {
#if CRANDALL_VARIANT_LEVEL >= 3
  for (int l = 0; l + 4 <= kLanes; l += 4) _mm256_store_pd(v + l, _mm256_sqrt_pd(_mm256_load_pd(v + l)));
#else
  for (int l = 0; l < kLanes; ++l) v[l] = std::sqrt(v[l]);
#endif
}

// The constants of the steps of the current segment, rounded exactly as exact_step rounds
// them; recomputed only when the step length or the intensity changes (a velocity-only scene
// has one step per segment, and these square roots would otherwise cost about a tenth of its
// time). A method adds its own (M::segment: refine's threshold).
struct SegmentSteps {
  explicit SegmentSteps(const Options& o) : drift(o.drift), seed(o.seed) {}
  // M: the method; kRoot: sqrt(step) too (for an observer of the Brownian increments).
  template <class M, bool kRoot>
  [[gnu::always_inline]] void update(double seg_step, double seg_noise) {
    if (seg_step == step && seg_noise == noise) return;
    step = seg_step;
    noise = seg_noise;
    // A segment without noise (a pause): deterministic steps, whose integrals are the coast's
    // (step_displacement, step_distance).
    quiet = noise == 0.0;
    M::segment(*this);
    if constexpr (kRoot) root_step = std::sqrt(step);
    c = step_constants(step, drift, noise);
    all_regular = segment_regular(c);
  }
  const double drift;
  const std::uint64_t seed;
  double step = -1.0, noise = -1.0;
  double root_step = 0.0;
  double near = 0.0;  // refine's threshold (methods/refine.hpp)
  StepConstants c{};
  bool all_regular = false;
  bool quiet = false;
};

// The draws of one step for every lane (rng.hpp's PairNoise, one half of a pair).
struct StepDraws {
  const double* normal;
  const double* exponential;
  const double* coin;
};

// The state of a group of kLanes paths (paths path0 .. path0 + lanes - 1; the padding lanes of
// a partial group compute harmless values that are never read) on the fine grid and, for a
// method with coupled coarse grids, on its grids g = 1 .. kGrids - 1 (steps 2^g times the fine
// one): their integrals, and x where their step began. Every path starts at the plan's start
// state (velocity, displacement; distance 0).
template <int kGrids>
struct Group {
  [[gnu::always_inline]] Group(const Options& o, std::uint64_t first, int n) : path0(first), lanes(n) {
    for (int l = 0; l < kLanes; ++l) {
      x[l] = o.start_velocity;
      u[l] = o.start_displacement;
      for (int g = 0; g < kGrids; ++g) {
        xc[g][l] = o.start_velocity;
        uc[g][l] = o.start_displacement;
      }
    }
  }
  const std::uint64_t path0;
  const int lanes;
  // Aligned to a cache line: at a known misalignment the vectoriser peels scalar iterations off
  // the loops over the lanes to align them (the control sums' and the coarse grids' loops ran
  // 6 of 16 lanes in scalar code, 17 % slower for a run to an accuracy).
  alignas(64) double x[kLanes];
  alignas(64) double u[kLanes];
  alignas(64) double s[kLanes] = {};
  alignas(64) double xc[kGrids][kLanes];
  alignas(64) double uc[kGrids][kLanes];
  alignas(64) double sc[kGrids][kLanes] = {};
};

// What a method type reads from its row of kMethodTable (plan.hpp), as its base: kMethod, and
// the row's kSkeleton and kOrder; segment(g), no constants of its own (a method with some hides
// it). methods/exact.hpp says what a method type holds.
template <Method M>
struct MethodOf {
  static constexpr Method kMethod = M;
  static constexpr bool kSkeleton = skeleton(M);
  static constexpr double kOrder = method_order(M);
  static void segment(SegmentSteps&) {}
};

CRANDALL_END_VARIANT
