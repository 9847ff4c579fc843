// The path loop, instantiated per method and per set of observed integrals, so a scene pays
// only for what it observes. kLanes paths are stepped together (structure of arrays); nothing
// is allocated inside the loop.
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

// The refine method (docs/methods/refine.md): a step of length `step` that starts with
// |x| < kRefineWithin * noise * sqrt(step) is taken as kRefineSubsteps exact substeps, whose
// noise comes from the path's refinement stream (path index with the top bit set; one Philox
// block per two substeps, pair index = k * kRefineSubsteps / 2 + j for the step of index k).
constexpr int kRefineSubsteps = 8;
constexpr double kRefineWithin = 2.0;
constexpr std::uint64_t kRefineStream = 1ull << 63;

}  // namespace crandall

// The path loop is compiled once per instruction-set variant (variant.hpp); the types above are
// shared.
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

// One trapezoid step of the quadratic variation (Options::quadratic_variation) over all lanes:
// q += half (a^2 + b^2), half = step noise^2 / 2.
inline void add_squares(double* q, const double* a, const double* b, double half) {
#pragma omp simd
  for (int l = 0; l < kLanes; ++l) q[l] += half * (a[l] * a[l] + b[l] * b[l]);
}

// Outputs after the switch-off (closed-form coast) and at the stop, from the state at t0.
// The fine grid also passes its peaks at t0 (pv: max |velocity|, pu: max |displacement| or
// null) and its histograms; Richardson's coarse grids pass neither (their moments are only
// extrapolated, the peaks and the distributions come from the fine grid). Each grid passes
// its quadratic variation int noise^2 X^2 dt up to t0 in `quadratic` (Options::quadratic_variation),
// recorded after the stop's values.
//
// Peaks after the switch-off: the speed falls linearly to 0 and stays there (coast.hpp), so
// |X(t)| <= |X(t0)| <= pv and the peak speed does not change. The displacement moves by
// sign(X(t0)) times the distance travelled, which never decreases, so U2 is monotone on
// [t0, t] and its largest modulus there is at an end: the peak of |U2| up to t is
// max(pu, |U2(t)|), and at the stop max(pu, |U2(t_s)|).
inline void add_after_switch_off(const Plan& plan, const double* x, const double* u,
                                 const double* s, int lanes, const std::vector<int>& active,
                                 BlockSums& times, BlockSums& stop, const double* pv = nullptr,
                                 const double* pu = nullptr, Workspace* ws = nullptr,
                                 const Workspace* recorder = nullptr, int grid = 0,
                                 std::uint64_t path0 = 0, const double* quadratic = nullptr) {
  const Options& o = plan.options();
  const auto& slots = plan.coast_slots();
  const auto& elapsed = plan.coast_elapsed();
  const bool peaks = ws != nullptr && pv != nullptr;
  const bool binned = ws != nullptr && plan.histograms();
  double zero[kLanes] = {}, qv[kLanes], qu[kLanes];
  if (peaks)
    for (int l = 0; l < lanes; ++l) {
      qv[l] = pv[l];
      qu[l] = pu != nullptr ? pu[l] : 0.0;
    }
  for (std::size_t j = 0; j < slots.size(); ++j) {
    double cx[kLanes] = {}, cu[kLanes] = {}, cs[kLanes] = {};
    for (int l = 0; l < lanes; ++l) {
      const State st = coast({x[l], u[l], s[l]}, o.drift, elapsed[j]);
      cx[l] = st.velocity;
      cu[l] = st.displacement;
      cs[l] = st.distance;
    }
    const auto slot = static_cast<std::size_t>(slots[j]);
    times.add(slot, cx, cu, cs, lanes, active);
    if (ws != nullptr) ws->add_energy(slot, cx, lanes);
    if (recorder != nullptr) recorder->record(slot, grid, path0, cx, cu, cs, lanes);
    if (peaks) {
      if (pu != nullptr)
        for (int l = 0; l < lanes; ++l) qu[l] = std::max(pu[l], std::abs(cu[l]));
      ws->peaks.add(slot, qv, qu, zero, lanes, ws->peak_active);
    }
    if (binned)
      bin_slot(plan, ws->histograms, slot,
               {cx, o.displacement ? cu : nullptr, o.distance ? cs : nullptr, peaks ? qv : nullptr,
                peaks && pu != nullptr ? qu : nullptr},
               lanes);
  }
  if (o.stop) {
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
    stop.add(0, ts, us, ss, lanes, active);
    if (o.residual) {
      double au[kLanes] = {};
      for (int l = 0; l < lanes; ++l) au[l] = std::abs(us[l]);
      stop.add(1, au, zero, zero, lanes, active);
    }
    if (recorder != nullptr) {
      recorder->record(o.times.size(), grid, path0, ts, us, ss, lanes);
      // The quadratic variation: no noise after the switch-off, so its value at t0.
      if (o.quadratic_variation)
        recorder->record(o.times.size() + 1, grid, path0, quadratic, zero, zero, lanes);
    }
    if (peaks) {
      if (pu != nullptr)
        for (int l = 0; l < lanes; ++l) qu[l] = std::max(pu[l], std::abs(us[l]));
      ws->peaks_stop.add(0, qv, qu, zero, lanes, ws->peak_active);
    }
    if (binned)
      bin_slot(plan, ws->histograms, o.times.size(),
               {ts, o.displacement ? us : nullptr, o.distance ? ss : nullptr, peaks ? qv : nullptr,
                peaks && pu != nullptr ? qu : nullptr},
               lanes);
  }
}

// What the exact method's path loop shows an observer besides the outputs: for each group of
// kLanes paths, every step with the state before it and its Brownian increment, and every
// output slot the path passes (ControlSums, kernel_controls.hpp, sums functions of the state
// times the increments). This one observes nothing: its calls compile to nothing, and
// simulate_block with it is the plain path loop.
struct NoObserver {
  static constexpr bool kActive = false;
  NoObserver(const Plan&, Workspace&) {}
  // A group of paths starts at rest.
  void begin_paths() {}
  // Before the step from `time`: x, u, s the lanes' state there, db = sqrt(step) Z the step's
  // Brownian increment (Z the normals the step takes).
  void step(const double*, const double*, const double*, const double*, double) {}
  // The path has reached the output time of `slot`.
  void passed_slot(std::size_t) {}
  // The group's paths path0 .. path0 + lanes - 1 have taken all their steps.
  void end_paths(std::uint64_t, int) {}
};

// Whether the group's first `lanes` paths are at rest.
inline bool at_rest(const double* x, int lanes) {
  for (int l = 0; l < lanes; ++l)
    if (x[l] != 0.0) return false;
  return true;
}

// Simulate paths [first, first + count) (count <= kBlockPaths) into ws (reset by the caller).
// kPeaks: track the running maxima of |velocity| and |displacement| (Options::peaks), compiled
// in only when asked for. Histograms are a run-time choice made at output slots only.
// Observer: what else the exact method's steps feed (NoObserver: nothing).
// kQuad: integrate the quadratic variation (Options::quadratic_variation; runs to an accuracy
// only), compiled in only when asked for, as the peaks are: the other loops stay as they were.
template <Method M, bool kDisp, bool kDist, bool kPeaks, class Observer = NoObserver,
          bool kQuad = false>
void simulate_block(const Plan& plan, std::uint64_t first, std::uint64_t count, Workspace& ws) {
  static_assert(M == Method::exact || !Observer::kActive, "only the exact method's steps are observed");
  static_assert(!kQuad || M == Method::exact || M == Method::richardson || M == Method::richardson2,
                "the quadratic variation is integrated on the exact skeleton's grids only");
  constexpr int kGrids = grids(M, kDisp || kDist);
  constexpr bool kCoarse = kGrids > 1;
  const Options& o = plan.options();
  const double drift = o.drift;
  Observer observer(plan, ws);
  for (std::uint64_t offset = 0; offset < count; offset += kLanes) {
    const int lanes = static_cast<int>(std::min<std::uint64_t>(kLanes, count - offset));
    const std::uint64_t path0 = first + offset;
    observer.begin_paths();
    // Every path starts at the plan's start state (velocity, displacement; distance 0).
    double x[kLanes], u[kLanes], s[kLanes] = {};
    // Running maxima of |x| and |u| over the points computed so far (from the start).
    alignas(32) double pv[kLanes], pu[kLanes];
    [[maybe_unused]] const double zero[kLanes] = {};
    // Richardson's coarse grids g = 1, 2 (steps 2^g times the fine one): integrals, and x where
    // their step began.
    double xc[kGrids][kLanes], uc[kGrids][kLanes], sc[kGrids][kLanes] = {};
    // Options::quadratic_variation: int noise^2 X^2 dt by the trapezoid rule, on the fine grid
    // (qv) and on the coarse grids (qc).
    [[maybe_unused]] alignas(64) double qv[kLanes] = {};
    [[maybe_unused]] double qc[kGrids][kLanes] = {};
    for (int l = 0; l < kLanes; ++l) {
      x[l] = o.start_velocity;
      u[l] = o.start_displacement;
      pv[l] = std::abs(o.start_velocity);
      pu[l] = std::abs(o.start_displacement);
      for (int g = 0; g < kGrids; ++g) {
        xc[g][l] = o.start_velocity;
        uc[g][l] = o.start_displacement;
      }
    }
    PairNoise<kLanes> z;
    std::uint64_t k = 0;  // step index along the path; selects the random numbers
    // The step's constants, rounded exactly as exact_step rounds them; recomputed only when the
    // step length changes (a velocity-only scene has one step per segment, and these square
    // roots would otherwise cost about a tenth of its time).
    double cached_step = -1.0, cached_noise = -1.0, near = 0.0, noise = 0.0;
    StepConstants c{};
    bool all_regular = false;
    // A segment without noise (a pause): deterministic steps, whose integrals are the coast's
    // (step_displacement, step_distance).
    bool quiet = false;
    // For the observer: sqrt(step), and the segment's start time.
    [[maybe_unused]] double root_step = 0.0, start = 0.0;
    for (const Segment& seg : plan.segments()) {
      const double step = seg.step;
      if (step != cached_step || seg.noise != cached_noise) {
        cached_step = step;
        cached_noise = noise = seg.noise;
        quiet = noise == 0.0;
        near = kRefineWithin * noise * std::sqrt(step);
        if constexpr (Observer::kActive) root_step = std::sqrt(step);
        c = step_constants(step, drift, noise);
        all_regular = segment_regular(c);
      }
      const double mean_d = c.mean, scale_d = c.scale, twice_var = c.twice_variance;
      for (std::uint64_t i = 0; i < seg.steps; ++i, ++k) {
        if ((k & (kPollSteps - 1)) == kPollSteps - 1 && ws.cancelled && ws.cancelled()) return;
        if constexpr (!Observer::kActive) {
          // A pause (no noise) in which every path of the group is at rest: a body at rest with
          // no noise stays at rest (every method's step from 0 without noise is 0), so the rest
          // of the pause costs nothing. The step index moves on as if the steps were taken, so
          // later steps draw the numbers they always drew, and Richardson's coarse steps are
          // only skipped whole (their trapezoids then add 0).
          if (noise == 0.0 && (k & ((std::uint64_t{1} << (kGrids - 1)) - 1)) == 0 &&
              at_rest(x, lanes)) {
            k += seg.steps - i;
            // An odd index takes the second half of a pair that the skipped steps would have
            // drawn.
            if (k & 1u) draw_pairs<kLanes>(o.seed, path0, k >> 1, z);
            break;
          }
        }
        const int half = static_cast<int>(k & 1u);
        if (half == 0) draw_pairs<kLanes>(o.seed, path0, k >> 1, z);
        const double* zn = z.normal[half];
        const double* ze = z.exponential[half];
        const double* zc = z.coin[half];
        if constexpr (M == Method::euler) {
          for (int l = 0; l < kLanes; ++l) {
            const double x0 = x[l];
            if constexpr (kDisp) u[l] += step * x0;
            if constexpr (kDist) s[l] += step * std::abs(x0);
            x[l] = euler_step(x0, step, drift, noise, zn[l]);
          }
          if constexpr (kPeaks) track_peaks<kDisp>(x, u, pv, pu);
        } else if constexpr (M == Method::refine) {
          for (int l = 0; l < lanes; ++l) {
            const double x0 = x[l];
            double x1;
            if (std::abs(x0) < near) {
              constexpr int kPairs = kRefineSubsteps / 2;
              const double substep = step / kRefineSubsteps;
              double xa = x0;
              for (int j = 0; j < kPairs; ++j) {
                StepNoise r[2];
                draw_pair(o.seed, (path0 + l) | kRefineStream, k * kPairs + j, r);
                for (const StepNoise& q : r) {
                  const double xb =
                      exact_step(xa, substep, drift, noise, q.normal, q.exponential, q.coin).velocity;
                  if constexpr (kDisp) u[l] += trapezoid(substep, xa, xb);
                  if constexpr (kDist) s[l] += trapezoid(substep, std::abs(xa), std::abs(xb));
                  xa = xb;
                  // The substeps are points of the path too: their maxima count.
                  if constexpr (kPeaks) {
                    pv[l] = std::max(pv[l], std::abs(xa));
                    if constexpr (kDisp) pu[l] = std::max(pu[l], std::abs(u[l]));
                  }
                }
              }
              x1 = xa;
            } else {
              x1 = exact_step(x0, step, drift, noise, zn[l], ze[l], zc[l] != 0.0).velocity;
              if constexpr (kDisp) u[l] += step_displacement(quiet, step, drift, x0, x1);
              if constexpr (kDist) s[l] += step_distance(quiet, step, drift, x0, x1);
            }
            x[l] = x1;
          }
          if constexpr (kPeaks) track_peaks<kDisp>(x, u, pv, pu);
        } else {
          if constexpr (Observer::kActive) {
            alignas(64) double db[kLanes];
            for (int l = 0; l < kLanes; ++l) db[l] = root_step * zn[l];
            observer.step(x, u, s, db, start + static_cast<double>(i) * step);
          }
          // exact_step (exact_step.hpp) over all lanes, its parts in separate loops so that they
          // vectorise; the padding lanes of a partial group compute harmless values that are
          // never read.
          alignas(32) double d[kLanes], q[kLanes], root[kLanes], x1[kLanes];
#pragma omp simd
          for (int l = 0; l < kLanes; ++l) {
            d[l] = step_increment(mean_d, scale_d, zn[l]);
            q[l] = step_spread(twice_var, ze[l]);
            root[l] = step_root_square(d[l], q[l]);
          }
          sqrt_lanes(root);
          int irregular = 0;
          if (!all_regular) {
#pragma omp simd reduction(| : irregular)
            for (int l = 0; l < kLanes; ++l) irregular |= !step_regular(root[l]);
          }
          if (irregular == 0 && !quiet) {
#pragma omp simd
            for (int l = 0; l < kLanes; ++l) {
              const double x0 = x[l];
              x1[l] = regular_step(x0, d[l], q[l], root[l], zc[l] != 0.0);
              // Trapezoid rule on the exact skeleton (docs/integrals.md).
              if constexpr (kDisp) u[l] += trapezoid(step, x0, x1[l]);
              if constexpr (kDist) s[l] += trapezoid(step, std::abs(x0), std::abs(x1[l]));
            }
          } else {
            // A step far outside the usual range in some lane (over- or underflow of d^2 + q),
            // or a step without noise (a pause, whose integrals are the coast's in the step
            // where the body comes to rest): exact_step, which takes its scaled form out of
            // range and gives the vector loop's bits elsewhere; the integrals as above, or the
            // coast's.
            for (int l = 0; l < kLanes; ++l) {
              const double x0 = x[l];
              x1[l] = exact_step(x0, step, drift, noise, zn[l], ze[l], zc[l] != 0.0).velocity;
              if constexpr (kDisp) u[l] += step_displacement(quiet, step, drift, x0, x1[l]);
              if constexpr (kDist) s[l] += step_distance(quiet, step, drift, x0, x1[l]);
            }
          }
          if constexpr (kQuad) add_squares(qv, x, x1, 0.5 * step * (noise * noise));
          if constexpr (kCoarse) {
            // Segments have step counts that are multiples of 2^(kGrids - 1), so a coarse step
            // never straddles two segments.
            for (int g = 1; g < kGrids; ++g) {
              const std::uint64_t mask = (std::uint64_t{1} << g) - 1;
              if ((k & mask) == 0)
                for (int l = 0; l < kLanes; ++l) xc[g][l] = x[l];
              if ((k & mask) == mask) {
                const double coarse_half = 0.5 * step * static_cast<double>(mask + 1);
                if (quiet) {
                  // The coarse step's own exact integrals: without noise the motion over it is
                  // the coast from xc, which ends at x1.
                  const double coarse = step * static_cast<double>(mask + 1);
                  for (int l = 0; l < kLanes; ++l) {
                    if constexpr (kDisp) uc[g][l] += step_displacement(true, coarse, drift, xc[g][l], x1[l]);
                    if constexpr (kDist) sc[g][l] += step_distance(true, coarse, drift, xc[g][l], x1[l]);
                  }
                } else {
#pragma omp simd
                  for (int l = 0; l < kLanes; ++l) {
                    if constexpr (kDisp) uc[g][l] += coarse_half * (xc[g][l] + x1[l]);
                    if constexpr (kDist) sc[g][l] += coarse_half * (std::abs(xc[g][l]) + std::abs(x1[l]));
                  }
                }
                if constexpr (kQuad) add_squares(qc[g], xc[g], x1, coarse_half * (noise * noise));
              }
            }
          }
          for (int l = 0; l < kLanes; ++l) x[l] = x1[l];
          // The fine grid's points only: the peaks are not extrapolated (Richardson's coarse
          // grids are subsets of these points, and a maximum has no error expansion in the step
          // that the extrapolation assumes).
          if constexpr (kPeaks) track_peaks<kDisp>(x, u, pv, pu);
        }
      }
      if constexpr (Observer::kActive) start += static_cast<double>(seg.steps) * step;
      if (seg.slot >= 0) {
        ws.times.add(static_cast<std::size_t>(seg.slot), x, u, s, lanes, ws.active);
        ws.add_energy(static_cast<std::size_t>(seg.slot), x, lanes);
        ws.record(static_cast<std::size_t>(seg.slot), 0, path0, x, u, s, lanes);
        if constexpr (kPeaks)
          ws.peaks.add(static_cast<std::size_t>(seg.slot), pv, kDisp ? pu : zero, zero, lanes,
                       ws.peak_active);
        if (plan.histograms())
          bin_slot(plan, ws.histograms, static_cast<std::size_t>(seg.slot),
                   {x, kDisp ? u : nullptr, kDist ? s : nullptr, kPeaks ? pv : nullptr,
                    kPeaks && kDisp ? pu : nullptr},
                   lanes);
        if constexpr (kCoarse)
          for (int g = 1; g < kGrids; ++g) {
            ws.coarse_times[g - 1].add(static_cast<std::size_t>(seg.slot), x, uc[g], sc[g], lanes,
                                       ws.active);
            ws.record(static_cast<std::size_t>(seg.slot), g, path0, x, uc[g], sc[g], lanes);
          }
        observer.passed_slot(static_cast<std::size_t>(seg.slot));
      }
    }
    observer.end_paths(path0, lanes);
    if (ws.states)
      for (int l = 0; l < lanes; ++l) ws.states[path0 + l] = x[l];
    if (!plan.needs_switch_state()) continue;
    add_after_switch_off(plan, x, u, s, lanes, ws.active, ws.times, ws.stop,
                         kPeaks ? pv : nullptr, kPeaks && kDisp ? pu : nullptr, &ws, &ws, 0, path0,
                         qv);
    if constexpr (kCoarse)
      for (int g = 1; g < kGrids; ++g)
        add_after_switch_off(plan, x, uc[g], sc[g], lanes, ws.active, ws.coarse_times[g - 1],
                             ws.coarse_stop[g - 1], nullptr, nullptr, nullptr, &ws, g, path0,
                             qc[g]);
  }
}

CRANDALL_END_VARIANT
