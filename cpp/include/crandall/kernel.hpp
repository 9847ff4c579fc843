// The white-noise path loop, one short function over small parts (docs/architecture.md, "The
// path loop as small parts"): a method type (methods/*.hpp) steps a group of kLanes paths
// (structure of arrays), observers (kernel_observers.hpp) watch it at fixed points, and the
// outputs at the slots (output_slot) are shared with the coast after the switch-off. It is
// instantiated per method, observed integrals and observers (the table in kernel_variant.inc),
// so a scene pays only for what it observes; nothing is allocated inside the loop.
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
#include "crandall/variant.hpp"

namespace crandall {

struct Workspace {
  explicit Workspace(const Plan& plan)
      : times(plan.options().times.size()),
        stop(plan.options().stop_slots()),
        active(active_monomials(plan.options().displacement, plan.options().distance)),
        peaks(plan.options().peaks ? plan.options().times.size() : 0),
        peaks_stop(plan.options().peaks && plan.options().stop ? 1 : 0),
        peak_active(active_monomials(plan.options().displacement, false)),
        energy(plan.options().energy ? plan.options().times.size() : 0),
        energy_active(active_monomials(false, false)),
        histograms(plan.recorded_axes()) {
    for (int j = 1; j < plan.options().grids(); ++j) {
      coarse_times.emplace_back(plan.options().times.size());
      coarse_stop.emplace_back(plan.options().stop_slots());
    }
  }
  // Clears the block's sums; the histograms keep counting across the blocks of a thread.
  void reset() {
    times.reset();
    stop.reset();
    for (auto& c : coarse_times) c.reset();
    for (auto& c : coarse_stop) c.reset();
    peaks.reset();
    peaks_stop.reset();
    energy.reset();
  }
  BlockSums times, stop;
  // Richardson's coarser grids (steps twice and four times the fine one), empty for the other
  // methods.
  std::vector<BlockSums> coarse_times, coarse_stop;
  std::vector<int> active;
  // Peaks (Options::peaks; no slots without): the running maxima of |velocity| and
  // |displacement| (0 when displacement is not observed) at each output time and at the stop,
  // as the first two variables of a BlockSums.
  BlockSums peaks, peaks_stop;
  std::vector<int> peak_active;
  // Options::energy (no slots without): V^2 at each output time, as the first variable of a
  // BlockSums, on the fine grid (the velocity is exact in law on every grid: nothing to
  // extrapolate).
  BlockSums energy;
  std::vector<int> energy_active;
  void add_energy(std::size_t slot, const double* x, int lanes) {
    if (energy.counts.empty()) return;
    double sq[kLanes];
    const double zero[kLanes] = {};
    for (int l = 0; l < lanes; ++l) sq[l] = x[l] * x[l];
    energy.add(slot, sq, zero, zero, lanes, energy_active);
  }
  // The thread's counts over all its blocks (Plan::recorded_axes); integer, so the threads'
  // histograms merge exactly in any order.
  Histograms histograms;
  // Returns true when the run is cancelled; polled every kPollSteps steps so that long paths
  // can be cancelled. May be empty.
  std::function<bool()> cancelled;
  // Diagnostics only (simulate_states): when set, the velocity at the end of the last segment
  // of path p is stored in states[p].
  double* states = nullptr;
  // Per-path values for multilevel runs (levels.hpp): when set, what is added to the sums of
  // slot k on grid g for path p is also stored at
  // samples[(((p - sample_first) * sample_slots + k) * sample_grids + g) * 3 + variable],
  // the stop being slot times.size().
  double* samples = nullptr;
  std::uint64_t sample_first = 0;
  std::size_t sample_slots = 0;
  int sample_grids = 1;
  // Control sums of the base level (kernel_controls.hpp) at the slots control_slots (ascending),
  // path-major like samples: controls[((p - sample_first) * control_slots.size() + a) * kControls
  // + j] for the slot control_slots[a]; and the lanes' buffer.
  double* controls = nullptr;
  std::vector<std::size_t> control_slots;
  std::vector<double> control_lanes;
  void record(std::size_t slot, int grid, std::uint64_t path0, const double* a, const double* b,
              const double* c, int lanes) const {
    if (!samples) return;
    for (int l = 0; l < lanes; ++l) {
      double* v = samples + (((path0 + l - sample_first) * sample_slots + slot) * sample_grids + grid) * 3;
      v[0] = a[l];
      v[1] = b[l];
      v[2] = c[l];
    }
  }
};

constexpr std::uint64_t kPollSteps = 1u << 14;

}  // namespace crandall

// The path loop is compiled once per instruction-set variant (variant.hpp); the types above are
// shared.
CRANDALL_BEGIN_VARIANT

// Counts x[0, n) (n <= kLanes) into `counts` (the cells of axis e): the same cells as
// e.cell(x[l]), with the automatic scheme's first guess computed for all lanes at once (branch-
// free arithmetic, vectorised) and then checked against the edges lane by lane, exactly as
// cell() does, so the guess's arithmetic can never misplace a value.
inline void count_lanes(const BinEdges& e, const double* x, int n, std::uint64_t* counts) {
  if (!e.automatic()) {
    for (int l = 0; l < n; ++l) ++counts[e.cell(x[l])];
    return;
  }
  const BinEdges::Scheme k = e.scheme();
  const double* edges = e.edges().data();
  const std::size_t bins = e.bins();
  const double lowest = edges[0], top = edges[bins];
  alignas(64) std::int64_t guess[kLanes];
#pragma omp simd
  for (int l = 0; l < n; ++l) {
    const double v = x[l];
    // Out of range (and NaN): any in-range stand-in, so that the conversions stay defined.
    const double a = v >= lowest && v < top ? std::abs(v) : 0.0;
    const bool below = a < k.base;
    // < per_octave <= 2^20: the 32-bit conversion, which every variant has in vector form.
    const auto linear = static_cast<std::int64_t>(static_cast<std::int32_t>((below ? a : k.base) * k.inv_width));
    const auto geometric = k.per_octave + static_cast<std::int64_t>((detmath::bits_of(a) >> k.shift) - k.base_key);
    std::int64_t o = below ? linear : geometric;
    o = o < k.half - 1 ? o : k.half - 1;
    // As BinEdges::cell: above 0 the atom cell [0, 2^-1074) comes first.
    guess[l] = !k.symmetric ? o + 1 : (v < 0.0 ? k.half - 1 - o : k.half + 1 + o);
  }
  for (int l = 0; l < n; ++l) {
    const double v = x[l];
    std::size_t c;
    if (v >= lowest && v < top) {
      auto j = static_cast<std::size_t>(guess[l]);
      while (v < edges[j]) --j;
      while (!(v < edges[j + 1])) ++j;
      c = j + 1;
    } else {
      c = v != v ? bins + 2 : v < lowest ? 0 : bins + 1;
    }
    ++counts[c];
  }
}

// Bins the values of one output slot (Options::histogram_axes): values[v] holds the lanes of
// variable v, or is null for a variable that is not simulated (Options::validate allows no
// axis there). Called at output slots only, never in the step loop, and kept out of line: it
// runs once per slot and lane group, and inlined it would only make the path loop larger (GCC
// inlines less into large functions).
[[gnu::noinline]] inline void bin_slot(const Plan& plan, Histograms& histograms, std::size_t slot,
                     const double* const (&values)[kHistogramVariables], int lanes) {
  for (int v = 0; v < kHistogramVariables; ++v) {
    const long h = plan.histogram_slot(slot, v);
    if (h >= 0 && values[v] != nullptr)
      count_lanes(histograms.axis(static_cast<std::size_t>(h)), values[v], lanes,
                  histograms.counts().data() + histograms.offset(static_cast<std::size_t>(h)));
  }
}


// The outputs at one slot of one grid (0 the fine grid; g >= 1 a coupled coarse grid, whose
// moments are only extrapolated): the moment sums into `sums` and the recorded per-path values
// (Workspace::record) on every grid; on the fine grid also the squared velocity's sums, the
// peaks' sums (peaks.speed set) and the histograms, whose variables disp and dist say which
// integrals are simulated.
[[gnu::always_inline]] inline void output_slot(const Plan& plan, Workspace& ws, BlockSums& sums,
                                               int grid, std::size_t slot, std::uint64_t path0,
                                               int lanes, const double* x, const double* u,
                                               const double* s, PeakView peaks, bool disp,
                                               bool dist) {
  sums.add(slot, x, u, s, lanes, ws.active);
  if (grid == 0) ws.add_energy(slot, x, lanes);
  ws.record(slot, grid, path0, x, u, s, lanes);
  if (grid != 0) return;
  if (peaks.speed != nullptr) {
    const double zero[kLanes] = {};
    ws.peaks.add(slot, peaks.speed, peaks.displacement != nullptr ? peaks.displacement : zero,
                 zero, lanes, ws.peak_active);
  }
  if (plan.histograms())
    bin_slot(plan, ws.histograms, slot,
             {x, disp ? u : nullptr, dist ? s : nullptr, peaks.speed, peaks.displacement}, lanes);
}

// The stop's outputs on one grid from the state at the switch-off (as add_after_switch_off):
// the time from the switch-off to the stop, the displacement and distance there, the residual
// |U|, the recorded values and the quadratic variation up to t0 (no noise after the
// switch-off); on the fine grid the peaks over the whole path and the histograms.
inline void add_stop(const Plan& plan, Workspace& ws, BlockSums& stop, int grid,
                     std::uint64_t path0, int lanes, const double* x, const double* u,
                     const double* s, PeakView peaks, const double* quadratic) {
  const Options& o = plan.options();
  const double zero[kLanes] = {};
  double ts[kLanes] = {}, us[kLanes] = {}, ss[kLanes] = {};
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
  stop.add(0, ts, us, ss, lanes, ws.active);
  if (o.residual) {
    double au[kLanes] = {};
    for (int l = 0; l < lanes; ++l) au[l] = std::abs(us[l]);
    stop.add(1, au, zero, zero, lanes, ws.active);
  }
  ws.record(o.times.size(), grid, path0, ts, us, ss, lanes);
  if (o.quadratic_variation)
    ws.record(o.times.size() + 1, grid, path0, quadratic != nullptr ? quadratic : zero, zero,
              zero, lanes);
  if (grid != 0) return;
  double qu[kLanes] = {};
  if (peaks.speed != nullptr) {
    if (peaks.displacement != nullptr)
      for (int l = 0; l < lanes; ++l) qu[l] = std::max(peaks.displacement[l], std::abs(us[l]));
    ws.peaks_stop.add(0, peaks.speed, qu, zero, lanes, ws.peak_active);
  }
  if (plan.histograms())
    bin_slot(plan, ws.histograms, o.times.size(),
             {ts, o.displacement ? us : nullptr, o.distance ? ss : nullptr, peaks.speed,
              peaks.displacement != nullptr ? qu : nullptr},
             lanes);
}

// Outputs after the switch-off (closed-form coast) and at the stop, from the state at t0 on
// one grid. The fine grid (grid 0) passes its peaks at t0; Richardson's coarse grids pass none
// (their moments are only extrapolated, the peaks and the distributions come from the fine
// grid). Each grid passes its quadratic variation up to t0 (or null).
//
// Peaks after the switch-off: the speed falls linearly to 0 and stays there (coast.hpp), so
// |X(t)| <= |X(t0)| <= pv and the peak speed does not change. The displacement moves by
// sign(X(t0)) times the distance travelled, which never decreases, so U2 is monotone on
// [t0, t] and its largest modulus there is at an end: the peak of |U2| up to t is
// max(pu, |U2(t)|), and at the stop max(pu, |U2(t_s)|).
inline void add_after_switch_off(const Plan& plan, Workspace& ws, BlockSums& times,
                                 BlockSums& stop, int grid, std::uint64_t path0, int lanes,
                                 const double* x, const double* u, const double* s,
                                 PeakView peaks, const double* quadratic) {
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
    output_slot(plan, ws, times, grid, static_cast<std::size_t>(slots[j]), path0, lanes, cx, cu,
                cs, at, o.displacement, o.distance);
  }
  if (o.stop) add_stop(plan, ws, stop, grid, path0, lanes, x, u, s, peaks, quadratic);
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
// (kernel_observers.hpp; compiled in only when asked for). Histograms, the squared velocity
// and the recorded values are run-time choices made at output slots only (output_slot).
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
      output_slot(plan, ws, ws.times, 0, slot, p.path0, p.lanes, p.x, p.u, p.s, obs.peaks(),
                  kDisp, kDist);
      for (int c = 1; c < kGrids; ++c)
        output_slot(plan, ws, ws.coarse_times[c - 1], c, slot, p.path0, p.lanes, p.x, p.uc[c],
                    p.sc[c], PeakView{}, kDisp, kDist);
      obs.passed_slot(slot);
    }
    obs.end_paths(p.path0, p.lanes);
    if (ws.states)
      for (int l = 0; l < p.lanes; ++l) ws.states[p.path0 + l] = p.x[l];
    if (!plan.needs_switch_state()) continue;
    add_after_switch_off(plan, ws, ws.times, ws.stop, 0, p.path0, p.lanes, p.x, p.u, p.s,
                         obs.peaks(), obs.quadratic(0));
    for (int c = 1; c < kGrids; ++c)
      add_after_switch_off(plan, ws, ws.coarse_times[c - 1], ws.coarse_stop[c - 1], c, p.path0,
                           p.lanes, p.x, p.uc[c], p.sc[c], PeakView{}, obs.quadratic(c));
  }
}

CRANDALL_END_VARIANT
