// Observers of the white-noise path loop (simulate_block, kernel.hpp): small types whose hooks
// the loop calls at fixed points (a hook with nothing to do compiles to nothing). Those that
// watch the steps are chosen at compile time, so that a loop pays only for what it observes:
// the peaks, the quadratic variation (here) and the control sums (kernel_controls.hpp). Those
// that write the outputs at an output slot and at the stop (the moment sums, the squared
// velocity's, the recorded values, the peaks' sums and the histograms: kernel_outputs.hpp) are
// in every loop, each with its run-time switch.
#pragma once

#include <cstddef>
#include <cstdint>

#include "crandall/kernel_lanes.hpp"

namespace crandall {
struct Workspace;
}  // namespace crandall

CRANDALL_BEGIN_VARIANT

// The running maxima an observer holds at an output slot: of |velocity| and of |displacement|
// (null when not tracked).
struct PeakView {
  const double* speed = nullptr;
  const double* displacement = nullptr;
};

// What the outputs see at an output slot of one grid (0 the fine grid; g >= 1 a coupled coarse
// grid): the lanes' velocity x, displacement u and distance s there, and the running maxima
// (the fine grid's, when peaks are observed; none on a coarse grid).
struct SlotView {
  int grid;
  std::size_t slot;
  std::uint64_t path0;
  int lanes;
  const double* x;
  const double* u;
  const double* s;
  PeakView peaks;
};

// What the outputs see at the stop on one grid: the time from the switch-off to the stop, the
// displacement u and distance s there, the peaks over the whole path (as at a slot) and the
// quadratic variation up to the switch-off (null when not integrated).
struct StopView {
  int grid;
  std::uint64_t path0;
  int lanes;
  const double* time;
  const double* u;
  const double* s;
  PeakView peaks;
  const double* quadratic;
};

// The hooks, every one empty. An observer derives from it and hides the ones it uses.
struct Unobserving {
  // Whether it sees the Brownian increments before each step (before_step): an exact-skeleton
  // method only, and every step is then taken (a pause is not skipped at rest).
  static constexpr bool kWatchesSteps = false;
  // Whether it needs the exact skeleton's steps (stepped, coarse_stepped).
  static constexpr bool kNeedsSkeleton = false;
  // A group of paths at its start state.
  void begin(const Options&) {}
  // Before the step from `time`: the lanes' state there and the step's normals (its Brownian
  // increment is root_step times them).
  void before_step(const double*, const double*, const double*, const double*, double, double) {}
  // An exact-skeleton step of the fine grid from x0 to x1 (the integrals already added).
  void stepped(const double*, const double*, const SegmentSteps&) {}
  // A step of the coarse grid c from x0 to x1, of half-length `half`.
  void coarse_stepped(int, const double*, const double*, double, const SegmentSteps&) {}
  // A point inside a step of lane l: its velocity and displacement.
  void substep(int, double, double) {}
  // The fine grid's state after a step (every lane).
  void moved(const double*, const double*) {}
  // An output slot of a grid, reached by the loop; or by the coast after the switch-off, which
  // calls the outputs' hooks only (kernel.hpp, after_switch_off; kernel_outputs.hpp).
  void at_slot(const SlotView&) {}
  // The stop of a grid (from the coast after the switch-off: the outputs' hooks only).
  void at_stop(const StopView&) {}
  // The path has reached the output time of `slot` (after its outputs there on every grid).
  void passed_slot(std::size_t) {}
  // The group's paths path0 .. path0 + lanes - 1 have taken all their steps.
  void end_paths(std::uint64_t, int) {}
  // What the outputs show of it: its peaks, its quadratic variation on grid g.
  void peaks(PeakView&) const {}
  void quadratic(int, const double*&) const {}
};

// One step's update of the running maxima, over all lanes (the padding lanes of a partial group
// compute harmless values that are never read). p < a ? a : p is exact and becomes a vector max,
// so every variant gives the same bits. Not std::max: instantiated outside the variant's target
// region, it kept this loop from vectorising (the peaks then cost 22 % of the full kernel's time
// instead of 6 %).
template <bool kDisp>
inline void track_peaks(const double* x, const double* u, double* pv, double* pu) {
#pragma omp simd
  for (int l = 0; l < kLanes; ++l) {
    const double ax = std::abs(x[l]);
    pv[l] = pv[l] < ax ? ax : pv[l];
    if constexpr (kDisp) {
      const double au = std::abs(u[l]);
      pu[l] = pu[l] < au ? au : pu[l];
    }
  }
}

// The running maxima of |velocity| and (kDisp) |displacement| over the points computed so far
// from the start (Options::peaks): the fine grid's points and refine's substeps.
template <bool kDisp>
struct Peaks : Unobserving {
  Peaks(const Plan&, Workspace&) {}
  void begin(const Options& o) {
    for (int l = 0; l < kLanes; ++l) {
      pv[l] = std::abs(o.start_velocity);
      pu[l] = std::abs(o.start_displacement);
    }
  }
  void substep(int l, double x, double u) {
    pv[l] = std::max(pv[l], std::abs(x));
    if constexpr (kDisp) pu[l] = std::max(pu[l], std::abs(u));
  }
  void moved(const double* x, const double* u) { track_peaks<kDisp>(x, u, pv, pu); }
  void peaks(PeakView& v) const {
    v.speed = pv;
    v.displacement = kDisp ? pu : nullptr;
  }
  alignas(32) double pv[kLanes], pu[kLanes];
};

// One trapezoid step of the quadratic variation over all lanes: q += half (a^2 + b^2),
// half = step noise^2 / 2.
inline void add_squares(double* q, const double* a, const double* b, double half) {
#pragma omp simd
  for (int l = 0; l < kLanes; ++l) q[l] += half * (a[l] * a[l] + b[l] * b[l]);
}

// Options::quadratic_variation (runs to an accuracy only): int noise^2 X^2 dt by the trapezoid
// rule on the fine grid (qv) and on each coupled coarse grid (qc), recorded after the stop's
// values.
template <int kGrids>
struct Quadratic : Unobserving {
  static constexpr bool kNeedsSkeleton = true;
  Quadratic(const Plan&, Workspace&) {}
  void begin(const Options&) {
    for (int l = 0; l < kLanes; ++l) {
      qv[l] = 0.0;
      for (int g = 0; g < kGrids; ++g) qc[g][l] = 0.0;
    }
  }
  void stepped(const double* x0, const double* x1, const SegmentSteps& g) {
    add_squares(qv, x0, x1, 0.5 * g.step * (g.noise * g.noise));
  }
  void coarse_stepped(int c, const double* x0, const double* x1, double half, const SegmentSteps& g) {
    add_squares(qc[c], x0, x1, half * (g.noise * g.noise));
  }
  void quadratic(int g, const double*& q) const { q = g == 0 ? qv : qc[g]; }
  alignas(64) double qv[kLanes];
  double qc[kGrids][kLanes];
};

// A list of observers, each hook calling theirs in turn; itself an observer (a list's entry may
// be a list). A loop's list is Observers<...> (kernel_outputs.hpp): the loop's own, then the
// outputs.
template <class... Os>
struct ObserverList : Os... {
  static constexpr bool kWatchesSteps = (false || ... || Os::kWatchesSteps);
  static constexpr bool kNeedsSkeleton = (false || ... || Os::kNeedsSkeleton);
  ObserverList([[maybe_unused]] const Plan& plan, [[maybe_unused]] Workspace& ws) : Os(plan, ws)... {}
  void begin([[maybe_unused]] const Options& o) { (Os::begin(o), ...); }
  void before_step([[maybe_unused]] const double* x, [[maybe_unused]] const double* u,
                   [[maybe_unused]] const double* s, [[maybe_unused]] const double* normal,
                   [[maybe_unused]] double root_step, [[maybe_unused]] double time) {
    (Os::before_step(x, u, s, normal, root_step, time), ...);
  }
  void stepped([[maybe_unused]] const double* x0, [[maybe_unused]] const double* x1,
               [[maybe_unused]] const SegmentSteps& g) {
    (Os::stepped(x0, x1, g), ...);
  }
  void coarse_stepped([[maybe_unused]] int c, [[maybe_unused]] const double* x0,
                      [[maybe_unused]] const double* x1, [[maybe_unused]] double half,
                      [[maybe_unused]] const SegmentSteps& g) {
    (Os::coarse_stepped(c, x0, x1, half, g), ...);
  }
  void substep([[maybe_unused]] int l, [[maybe_unused]] double x, [[maybe_unused]] double u) {
    (Os::substep(l, x, u), ...);
  }
  void moved([[maybe_unused]] const double* x, [[maybe_unused]] const double* u) { (Os::moved(x, u), ...); }
  // Inlined into the loop, which calls it at every output slot (the outputs' switches are then
  // tested there, as when they were one inlined function).
  [[gnu::always_inline]] void at_slot([[maybe_unused]] const SlotView& v) {
    (Os::at_slot(v), ...);
  }
  void at_stop([[maybe_unused]] const StopView& v) { (Os::at_stop(v), ...); }
  void passed_slot([[maybe_unused]] std::size_t slot) { (Os::passed_slot(slot), ...); }
  void end_paths([[maybe_unused]] std::uint64_t path0, [[maybe_unused]] int lanes) {
    (Os::end_paths(path0, lanes), ...);
  }
  PeakView peaks() const {
    PeakView v;
    peaks(v);
    return v;
  }
  const double* quadratic(int g) const {
    const double* q = nullptr;
    quadratic(g, q);
    return q;
  }
  // The hooks' forms, so that a list can be one observer of another.
  void peaks([[maybe_unused]] PeakView& v) const { (Os::peaks(v), ...); }
  void quadratic([[maybe_unused]] int g, [[maybe_unused]] const double*& q) const {
    (Os::quadratic(g, q), ...);
  }
};

CRANDALL_END_VARIANT
