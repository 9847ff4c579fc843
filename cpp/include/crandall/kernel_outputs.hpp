// The outputs of the white-noise path loop (simulate_block, kernel.hpp) as observers
// (kernel_observers.hpp): at an output slot of a grid (at_slot) and at the stop (at_stop), each
// writes its part into the thread's Workspace. They are in every loop (Observers<...> below puts
// them, as one observer Outputs, after a loop's own observers), since whether a run records
// per-path values, counts histograms or sums the squared velocity is a run-time option: each
// holds its run-time switch, tested once per slot and lane group, never per step, so these
// choices add no instantiations. The loop calls them at its slots, the coast after the
// switch-off at the later slots and at the stop (kernel.hpp, after_switch_off). In the order of
// the list:
// - MomentSums: the moment sums of every grid (Workspace::times, stop and the coarse grids');
// - EnergySums: the squared velocity's sums (Options::energy), fine grid;
// - Recording: the per-path values of every grid (Workspace::samples, multilevel runs);
// - PeakSums: the peaks' sums (Options::peaks), fine grid;
// - HistogramCounts: the histograms (Options::histogram_axes), fine grid.
#pragma once

#include <cmath>
#include <cstddef>
#include <cstdint>

#include "crandall/detmath.hpp"
#include "crandall/kernel_observers.hpp"
#include "crandall/plan.hpp"
#include "crandall/variant.hpp"
#include "crandall/workspace.hpp"

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

// The moment sums of the velocity, displacement and distance at each slot of each grid, and at
// the stop those of the time to it, the displacement and distance there (and the residual |U|,
// Options::residual). A coarse grid's sums are only extrapolated (Richardson).
class MomentSums : public Unobserving {
 public:
  MomentSums(const Plan& plan, Workspace& ws) : ws_(ws), residual_(plan.options().residual) {}
  [[gnu::always_inline]] void at_slot(const SlotView& v) {
    BlockSums& sums = v.grid == 0 ? ws_.times : ws_.coarse_times[v.grid - 1];
    sums.add(v.slot, v.x, v.u, v.s, v.lanes, ws_.active);
  }
  void at_stop(const StopView& v) {
    BlockSums& stop = v.grid == 0 ? ws_.stop : ws_.coarse_stop[v.grid - 1];
    stop.add(0, v.time, v.u, v.s, v.lanes, ws_.active);
    if (!residual_) return;
    const double zero[kLanes] = {};
    double au[kLanes] = {};
    for (int l = 0; l < v.lanes; ++l) au[l] = std::abs(v.u[l]);
    stop.add(1, au, zero, zero, v.lanes, ws_.active);
  }

 private:
  Workspace& ws_;
  bool residual_;
};

// The squared velocity's sums at the slots of the fine grid (Workspace::add_energy: nothing
// without Options::energy). The velocity is exact in law on every grid: nothing to extrapolate.
class EnergySums : public Unobserving {
 public:
  EnergySums(const Plan&, Workspace& ws) : ws_(ws) {}
  [[gnu::always_inline]] void at_slot(const SlotView& v) {
    if (v.grid == 0) ws_.add_energy(v.slot, v.x, v.lanes);
  }

 private:
  Workspace& ws_;
};

// The per-path values of every grid (Workspace::record: nothing without Workspace::samples):
// at a slot the velocity, displacement and distance; at the stop (slot times.size()) the time
// to it, the displacement and distance there, and after it (Options::quadratic_variation) the
// quadratic variation up to the switch-off.
class Recording : public Unobserving {
 public:
  Recording(const Plan& plan, Workspace& ws)
      : ws_(ws), stop_slot_(plan.options().times.size()),
        quadratic_(plan.options().quadratic_variation) {}
  [[gnu::always_inline]] void at_slot(const SlotView& v) {
    ws_.record(v.slot, v.grid, v.path0, v.x, v.u, v.s, v.lanes);
  }
  void at_stop(const StopView& v) {
    ws_.record(stop_slot_, v.grid, v.path0, v.time, v.u, v.s, v.lanes);
    if (!quadratic_) return;
    const double zero[kLanes] = {};
    ws_.record(stop_slot_ + 1, v.grid, v.path0, v.quadratic != nullptr ? v.quadratic : zero,
               zero, zero, v.lanes);
  }

 private:
  Workspace& ws_;
  std::size_t stop_slot_;
  bool quadratic_;
};

// The peaks' sums (Options::peaks; the views carry no peaks without): the running maxima of
// |velocity| and |displacement| (0 when not observed) at the fine grid's slots and at the stop.
class PeakSums : public Unobserving {
 public:
  PeakSums(const Plan&, Workspace& ws) : ws_(ws) {}
  [[gnu::always_inline]] void at_slot(const SlotView& v) {
    if (v.grid == 0 && v.peaks.speed != nullptr) add(ws_.peaks, v.slot, v.peaks, v.lanes);
  }
  void at_stop(const StopView& v) {
    if (v.grid == 0 && v.peaks.speed != nullptr) add(ws_.peaks_stop, 0, v.peaks, v.lanes);
  }

 private:
  void add(BlockSums& sums, std::size_t slot, PeakView peaks, int lanes) {
    const double zero[kLanes] = {};
    sums.add(slot, peaks.speed, peaks.displacement != nullptr ? peaks.displacement : zero, zero,
             lanes, ws_.peak_active);
  }
  Workspace& ws_;
};

// The histograms of the fine grid's values (Plan::histograms; bin_slot): at a slot the
// velocity, the integrals simulated and the peaks; at the stop (slot times.size()) the time to
// it, the integrals there and the peaks over the whole path. The integrals simulated are the
// options' (Options::displacement, distance), by which every run picks its loop (only
// simulate_states steps velocity alone whatever they say, and it keeps no histograms).
class HistogramCounts : public Unobserving {
 public:
  HistogramCounts(const Plan& plan, Workspace& ws)
      : plan_(plan), ws_(ws), on_(plan.histograms()), disp_(plan.options().displacement),
        dist_(plan.options().distance), stop_slot_(plan.options().times.size()) {}
  [[gnu::always_inline]] void at_slot(const SlotView& v) {
    if (v.grid == 0 && on_)
      bin_slot(plan_, ws_.histograms, v.slot,
               {v.x, disp_ ? v.u : nullptr, dist_ ? v.s : nullptr, v.peaks.speed,
                v.peaks.displacement},
               v.lanes);
  }
  void at_stop(const StopView& v) {
    if (v.grid == 0 && on_)
      bin_slot(plan_, ws_.histograms, stop_slot_,
               {v.time, disp_ ? v.u : nullptr, dist_ ? v.s : nullptr, v.peaks.speed,
                v.peaks.displacement},
               v.lanes);
  }

 private:
  const Plan& plan_;
  Workspace& ws_;
  bool on_, disp_, dist_;
  std::size_t stop_slot_;
};

// The outputs, in this order, as one observer: one type, so that the coast after the
// switch-off, which feeds them alone (the steps' observers have nothing to see there), is one
// function, not one per loop kind (kernel.hpp, after_switch_off).
using Outputs = ObserverList<MomentSums, EnergySums, Recording, PeakSums, HistogramCounts>;

// A loop's observers: its own Os (the table in kernel_variant.inc), then the outputs. Last, so
// that the step observers' lanes keep their place in the loop's frame: with the outputs first,
// Peaks' running maxima moved off their 64-byte alignment and a run with peaks and histograms
// took 3.7 % more time.
template <class... Os>
using Observers = ObserverList<Os..., Outputs>;

CRANDALL_END_VARIANT
