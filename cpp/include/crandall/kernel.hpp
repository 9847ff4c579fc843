// The white-noise path loop, one short function over small parts (docs/architecture.md, "The
// path loop as small parts"): a method type (methods/*.hpp) steps a group of kLanes paths
// (structure of arrays), observers (kernel_observers.hpp) watch it at fixed points, and output
// observers (kernel_outputs.hpp) write the outputs at its slots, fed by the coast after the
// switch-off too. It is instantiated per method, observed integrals and step observers (the
// table in kernel_variant.inc), so a scene pays only for what it observes; nothing is allocated
// inside the loop.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <functional>
#include <vector>

#include "crandall/accumulators.hpp"
#include "crandall/coast.hpp"
#include "crandall/plan.hpp"
#include "crandall/rng.hpp"
#include "crandall/exact_step.hpp"
#include "crandall/kernel_lanes.hpp"
#include "crandall/kernel_observers.hpp"
#include "crandall/kernel_outputs.hpp"
#include "crandall/variant.hpp"
#include "crandall/workspace.hpp"

// The path loop is compiled once per instruction-set variant (variant.hpp); the Workspace it
// writes into is shared (workspace.hpp).
CRANDALL_BEGIN_VARIANT

// The stop's values on one grid from the state at the switch-off (x, u, s, every path coasts
// to rest: coast.hpp), given to the outputs' at_stop with the peaks over the whole path (as
// after_switch_off's) and the quadratic variation up to the switch-off (no noise after it).
// Kept out of line and uncloned, as after_switch_off.
[[gnu::noinline, gnu::noclone]] inline void stop_outputs(
    const Options& o, Outputs& out, int grid, std::uint64_t path0, int lanes, const double* x,
    const double* u, const double* s, PeakView peaks, const double* quadratic) {
  double ts[kLanes] = {}, us[kLanes] = {}, ss[kLanes] = {}, qu[kLanes] = {};
  for (int l = 0; l < lanes; ++l) {
    const double to_stop = time_to_stop(x[l], o.drift);
    const State st = coast({x[l], u[l], s[l]}, o.drift, to_stop);
    // The time from the switch-off, not the stop instant: at t0 = 1e16 a double cannot
    // resolve t0 + |X| / c (the spacing there is 2), and the stop time's spread would be
    // rounding noise. The mean is shifted by t0 where it is reported (ChunkResult).
    ts[l] = to_stop;
    us[l] = st.displacement;
    ss[l] = st.distance;
  }
  if (peaks.displacement != nullptr)
    for (int l = 0; l < lanes; ++l) qu[l] = std::max(peaks.displacement[l], std::abs(us[l]));
  out.at_stop(StopView{grid, path0, lanes, ts, us, ss,
                       PeakView{peaks.speed, peaks.displacement != nullptr ? qu : nullptr},
                       quadratic});
}

// The outputs after the switch-off (closed-form coast) and at the stop, from the state at t0 on
// one grid, given to the same output observers as the loop's slots (the loop's own observers
// have nothing to see after the switch-off). The fine grid (grid 0) passes its
// peaks at t0; Richardson's coarse grids pass none (their moments are only extrapolated, the
// peaks and the distributions come from the fine grid). Each grid passes its quadratic
// variation up to t0 (or null).
//
// Peaks after the switch-off: the speed falls linearly to 0 and stays there (coast.hpp), so
// |X(t)| <= |X(t0)| <= pv and the peak speed does not change. The displacement moves by
// sign(X(t0)) times the distance travelled, which never decreases, so U2 is monotone on
// [t0, t] and its largest modulus there is at an end: the peak of |U2| up to t is
// max(pu, |U2(t)|), and at the stop max(pu, |U2(t_s)|).
//
// Kept out of line and uncloned: it runs once per group of paths, and the copies GCC made of
// it (clones per grid and inlined ones) grew each kernel unit by about 10 kB.
[[gnu::noinline, gnu::noclone]] inline void after_switch_off(
    const Plan& plan, Outputs& out, int grid, std::uint64_t path0, int lanes, const double* x,
    const double* u, const double* s, PeakView peaks, const double* quadratic) {
  const Options& o = plan.options();
  const auto& slots = plan.coast_slots();
  const auto& elapsed = plan.coast_elapsed();
  double qv[kLanes], qu[kLanes];
  if (peaks.speed != nullptr)
    for (int l = 0; l < lanes; ++l) {
      qv[l] = peaks.speed[l];
      qu[l] = peaks.displacement != nullptr ? peaks.displacement[l] : 0.0;
    }
  for (std::size_t j = 0; j < slots.size(); ++j) {
    double cx[kLanes] = {}, cu[kLanes] = {}, cs[kLanes] = {};
    for (int l = 0; l < lanes; ++l) {
      const State st = coast({x[l], u[l], s[l]}, o.drift, elapsed[j]);
      cx[l] = st.velocity;
      cu[l] = st.displacement;
      cs[l] = st.distance;
    }
    if (peaks.displacement != nullptr)
      for (int l = 0; l < lanes; ++l) qu[l] = std::max(peaks.displacement[l], std::abs(cu[l]));
    const PeakView at = peaks.speed != nullptr
                            ? PeakView{qv, peaks.displacement != nullptr ? qu : nullptr}
                            : PeakView{};
    out.at_slot(SlotView{grid, static_cast<std::size_t>(slots[j]), path0, lanes, cx, cu, cs, at});
  }
  if (o.stop) stop_outputs(o, out, grid, path0, lanes, x, u, s, peaks, quadratic);
}

// Whether the first `lanes` paths are at rest.
inline bool at_rest(const double* x, int lanes) {
  for (int l = 0; l < lanes; ++l)
    if (x[l] != 0.0) return false;
  return true;
}

// A pause (no noise) in which every path of the group is at rest: a body at rest with no noise
// stays at rest (every method's step from 0 without noise is 0), so the rest of the pause costs
// nothing. Returns whether the segment's steps from i on are skipped: the step index k moves on
// as if they were taken, so later steps draw the numbers they always drew, and a method's
// coupled coarse steps (kGrids) are only skipped whole (their trapezoids then add 0). An odd
// index takes the second half of a pair that the skipped steps would have drawn.
template <int kGrids>
[[gnu::always_inline]] inline bool skip_pause(const SegmentSteps& g, const Segment& seg,
                                              std::uint64_t i, std::uint64_t& k,
                                              const Group<kGrids>& p, PairNoise<kLanes>& z) {
  if (!(g.noise == 0.0 && (k & ((std::uint64_t{1} << (kGrids - 1)) - 1)) == 0 &&
        at_rest(p.x, p.lanes)))
    return false;
  k += seg.steps - i;
  if (k & 1u) draw_pairs<kLanes>(g.seed, p.path0, k >> 1, z);
  return true;
}

// Simulate paths [first, first + count) (count <= kBlockPaths) into ws (reset by the caller):
// method M (methods/*.hpp) with the integrals kDisp, kDist, watched by the observers Obs
// (Observers<...>: the step observers of kernel_observers.hpp, compiled in only when asked
// for, then the outputs of kernel_outputs.hpp). The outputs' run-time choices
// (histograms, the squared velocity, the recorded values) are made at output slots only.
template <class M, bool kDisp, bool kDist, class Obs = Observers<>>
void simulate_block(const Plan& plan, std::uint64_t first, std::uint64_t count, Workspace& ws) {
  static_assert(M::kSkeleton || !(Obs::kWatchesSteps || Obs::kNeedsSkeleton),
                "only the exact skeleton's steps are observed");
  constexpr int kGrids = grids(M::kMethod, kDisp || kDist);
  const Options& o = plan.options();
  Obs obs(plan, ws);
  for (std::uint64_t offset = 0; offset < count; offset += kLanes) {
    Group<kGrids> p(o, first + offset,
                    static_cast<int>(std::min<std::uint64_t>(kLanes, count - offset)));
    obs.begin(o);
    SegmentSteps g(o);
    PairNoise<kLanes> z;
    std::uint64_t k = 0;  // step index along the path; selects the random numbers
    [[maybe_unused]] double start = 0.0;  // the segment's start time, for Obs::kWatchesSteps
    for (const Segment& seg : plan.segments()) {
      g.update<M, Obs::kWatchesSteps>(seg.step, seg.noise);
      for (std::uint64_t i = 0; i < seg.steps; ++i, ++k) {
        if ((k & (kPollSteps - 1)) == kPollSteps - 1 && ws.cancelled && ws.cancelled()) return;
        if constexpr (!Obs::kWatchesSteps)
          if (skip_pause(g, seg, i, k, p, z)) break;
        const int half = static_cast<int>(k & 1u);
        if (half == 0) draw_pairs<kLanes>(o.seed, p.path0, k >> 1, z);
        const StepDraws d{z.normal[half], z.exponential[half], z.coin[half]};
        if constexpr (Obs::kWatchesSteps)
          obs.before_step(p.x, p.u, p.s, d.normal, g.root_step,
                          start + static_cast<double>(i) * seg.step);
        M::template step<kDisp, kDist>(g, d, k, p, obs);
      }
      if constexpr (Obs::kWatchesSteps) start += static_cast<double>(seg.steps) * seg.step;
      if (seg.slot < 0) continue;
      const auto slot = static_cast<std::size_t>(seg.slot);
      obs.at_slot(SlotView{0, slot, p.path0, p.lanes, p.x, p.u, p.s, obs.peaks()});
      for (int c = 1; c < kGrids; ++c)
        obs.at_slot(SlotView{c, slot, p.path0, p.lanes, p.x, p.uc[c], p.sc[c], PeakView{}});
      obs.passed_slot(slot);
    }
    obs.end_paths(p.path0, p.lanes);
    if (ws.states)
      for (int l = 0; l < p.lanes; ++l) ws.states[p.path0 + l] = p.x[l];
    if (!plan.needs_switch_state()) continue;
    after_switch_off(plan, obs, 0, p.path0, p.lanes, p.x, p.u, p.s, obs.peaks(), obs.quadratic(0));
    for (int c = 1; c < kGrids; ++c)
      after_switch_off(plan, obs, c, p.path0, p.lanes, p.x, p.uc[c], p.sc[c], PeakView{},
                       obs.quadratic(c));
  }
}

CRANDALL_END_VARIANT
