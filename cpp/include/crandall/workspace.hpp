// What one thread's path loops write into (kernel.hpp, filtered.cpp): the block's moment sums
// per grid, the peaks' and the squared velocity's sums, the thread's histograms, and the
// caller's buffers for recorded per-path values and control sums. The loops' output observers
// (kernel_outputs.hpp) write here; the caller reads it after each block.
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <vector>

#include "crandall/accumulators.hpp"
#include "crandall/histogram.hpp"
#include "crandall/plan.hpp"

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
  // A filtered plan's: the exact means of its ground features per slot (filtered.hpp,
  // ground_feature_means), subtracted from each path's.
  std::vector<double> control_means;
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
