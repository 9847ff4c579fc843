// The exact method's path loop with control variates (docs/methods/adaptive.md, "Control
// variates"): the base level of a run to a requested accuracy. It is simulate_block<Exact, ...>
// itself (the same draws and the same steps, so the same values, bit for bit) with ControlSums
// observing its steps: per path and per output slot, kWhiteControls sums over the steps before that
// slot's time of g_k(state at the step start) times dB, the step's Brownian increment
// sqrt(step) Z. Each has mean exactly 0 whatever g_k (Z is independent of the past):
// subtracting any fixed multiple leaves an estimator unbiased.
#pragma once

#include "crandall/kernel.hpp"
#include "crandall/kernel_observers.hpp"

namespace crandall {

// The weights g_k, from the Ito representations of the integrals (docs/methods/mlmc.md), with
// a = |X|, r the time left to the slot's time (the switch-off for the stop and for times after
// it), k = min(a / c, r) (the time to stop, capped at r), sB = sign(X) dB:
// dB, a dB, r dB, k dB, U3 a dB, U3 k dB, a^2 k dB, U3 dB, sB, r sB, k sB, U2 sB, U2 k sB,
// X a k sB, U2 r sB.
constexpr int kWhiteControls = 15;
// The width of a path's row of control sums per slot (Workspace::controls): the larger of the
// white kernel's kWhiteControls and the filtered walker's (filtered.hpp, kFilteredControls);
// a kernel that has fewer fills the rest with 0.
constexpr int kControls = 22;

}  // namespace crandall

CRANDALL_BEGIN_VARIANT

// The control sums of paths into ws.controls at the slots ws.control_slots (both set by the
// caller), as an observer of simulate_block's steps (kernel_observers.hpp). Each chosen slot's
// sums are updated by every step before its time, so the cost per step grows with the number
// of chosen slots, not with the output times.
class ControlSums : public Unobserving {
 public:
  static constexpr bool kWatchesSteps = true;

  ControlSums(const Plan& plan, Workspace& ws)
      : ws_(ws),
        chosen_(ws.control_slots),
        slots_(chosen_.size()),
        // The time each chosen slot's controls run to: its output time, at most the switch-off
        // (after it the path is a function of its state there); the stop's slot runs to the
        // switch-off.
        until_(slots_, plan.options().switch_off),
        acc_(ws.control_lanes),
        inv_drift_(plan.options().drift > 0.0 ? 1.0 / plan.options().drift : 0.0) {
    const Options& o = plan.options();
    for (std::size_t j = 0; j < slots_; ++j)
      if (chosen_[j] < o.times.size()) until_[j] = std::min(o.times[chosen_[j]], o.switch_off);
    acc_.assign(slots_ * kWhiteControls * kLanes, 0.0);
  }

  void begin(const Options&) {
    std::fill(acc_.begin(), acc_.end(), 0.0);
    pending_ = 0;
  }

  // db = root_step normal, the step's Brownian increment.
  void before_step(const double* x, const double* u, const double* s, const double* normal,
                   double root_step, double time) {
    alignas(64) double db[kLanes];
    for (int l = 0; l < kLanes; ++l) db[l] = root_step * normal[l];
    alignas(64) double a[kLanes], sb[kLanes];
    for (int l = 0; l < kLanes; ++l) {
      a[l] = std::abs(x[l]);
      sb[l] = x[l] > 0.0 ? db[l] : (x[l] < 0.0 ? -db[l] : 0.0);
    }
    for (std::size_t j = pending_; j < slots_; ++j) {
      const double r = until_[j] - time;
      double* g = acc_.data() + j * kWhiteControls * kLanes;
#pragma omp simd
      for (int l = 0; l < kLanes; ++l) {
        const double kk = std::min(a[l] * inv_drift_, r);
        const double b = db[l], sg = sb[l];
        g[0 * kLanes + l] += b;
        g[1 * kLanes + l] += a[l] * b;
        g[2 * kLanes + l] += r * b;
        g[3 * kLanes + l] += kk * b;
        g[4 * kLanes + l] += s[l] * a[l] * b;
        g[5 * kLanes + l] += s[l] * kk * b;
        g[6 * kLanes + l] += a[l] * a[l] * kk * b;
        g[7 * kLanes + l] += s[l] * b;
        g[8 * kLanes + l] += sg;
        g[9 * kLanes + l] += r * sg;
        g[10 * kLanes + l] += kk * sg;
        g[11 * kLanes + l] += u[l] * sg;
        g[12 * kLanes + l] += u[l] * kk * sg;
        g[13 * kLanes + l] += x[l] * a[l] * kk * sg;
        g[14 * kLanes + l] += u[l] * r * sg;
      }
    }
  }

  // Chosen slots up to this one are behind the path: their sums are complete.
  void passed_slot(std::size_t slot) {
    while (pending_ < slots_ && chosen_[pending_] <= slot) ++pending_;
  }

  void end_paths(std::uint64_t path0, int lanes) {
    for (int l = 0; l < lanes; ++l)
      for (std::size_t j = 0; j < slots_; ++j)
        for (int q = 0; q < kControls; ++q)
          ws_.controls[((path0 + l - ws_.sample_first) * slots_ + j) * kControls + q] =
              q < kWhiteControls ? acc_[(j * kWhiteControls + q) * kLanes + l] : 0.0;
  }

 private:
  Workspace& ws_;
  const std::vector<std::size_t>& chosen_;
  std::size_t slots_;
  std::vector<double> until_;
  std::vector<double>& acc_;  // the lanes' sums: acc_[(j * kWhiteControls + q) * kLanes + l]
  double inv_drift_;
  std::size_t pending_ = 0;  // chosen slots before this one are behind the path
};

CRANDALL_END_VARIANT
