// The exact method's path loop with control variates (docs/methods/adaptive.md, "Control
// variates"): the base level of a run to a requested accuracy. The same draws and the same
// steps as simulate_block<Method::exact> (so the same values, bit for bit), plus, per path and
// per output slot, kControls sums over the steps before that slot's time of
// g_k(state at the step start) times dB, the step's Brownian increment sqrt(step) Z. Each has
// mean exactly 0 whatever g_k (Z is independent of the past): subtracting any fixed multiple
// leaves an estimator unbiased.
#pragma once

#include "crandall/kernel.hpp"

namespace crandall {

// The weights g_k, from the Ito representations of the integrals (docs/methods/mlmc.md), with
// a = |X|, r the time left to the slot's time (the switch-off for the stop and for times after
// it), k = min(a / c, r) (the time to stop, capped at r), sB = sign(X) dB:
// dB, a dB, r dB, k dB, U3 a dB, U3 k dB, a^2 k dB, U3 dB, sB, r sB, k sB, U2 sB, U2 k sB,
// X a k sB, U2 r sB.
constexpr int kControls = 15;

}  // namespace crandall

CRANDALL_BEGIN_VARIANT

// Paths [first, first + count) into ws (ws.samples, ws.controls and ws.control_slots set by
// the caller). Each chosen slot's sums are updated by every step before its time, so the cost
// per step grows with the number of chosen slots, not with the output times.
template <bool kDisp, bool kDist>
void simulate_block_controls(const Plan& plan, std::uint64_t first, std::uint64_t count,
                             Workspace& ws) {
  const Options& o = plan.options();
  const double drift = o.drift, noise = o.noise;
  const std::vector<std::size_t>& chosen = ws.control_slots;
  const std::size_t slots = chosen.size();
  // The time each chosen slot's controls run to: its output time, at most the switch-off
  // (after it the path is a function of its state there); the stop's slot runs to the
  // switch-off.
  std::vector<double> until(slots, o.switch_off);
  for (std::size_t j = 0; j < slots; ++j)
    if (chosen[j] < o.times.size()) until[j] = std::min(o.times[chosen[j]], o.switch_off);
  std::vector<double>& acc = ws.control_lanes;
  acc.assign(slots * kControls * kLanes, 0.0);
  const double inv_drift = drift > 0.0 ? 1.0 / drift : 0.0;
  for (std::uint64_t offset = 0; offset < count; offset += kLanes) {
    const int lanes = static_cast<int>(std::min<std::uint64_t>(kLanes, count - offset));
    const std::uint64_t path0 = first + offset;
    std::fill(acc.begin(), acc.end(), 0.0);
    alignas(64) double x[kLanes], u[kLanes], s[kLanes] = {};
    for (int l = 0; l < kLanes; ++l) {
      x[l] = o.start_velocity;
      u[l] = o.start_displacement;
    }
    PairNoise<kLanes> z;
    std::uint64_t k = 0;
    std::size_t pending = 0;  // chosen slots before this one are behind the path
    double start = 0.0;       // the segment's start time
    for (const Segment& seg : plan.segments()) {
      const double step = seg.step;
      const StepConstants c = step_constants(step, drift, noise);
      const bool all_regular = segment_regular(c);
      const double root_step = std::sqrt(step);
      for (std::uint64_t i = 0; i < seg.steps; ++i, ++k) {
        if ((k & (kPollSteps - 1)) == kPollSteps - 1 && ws.cancelled && ws.cancelled()) return;
        const int half = static_cast<int>(k & 1u);
        if (half == 0) draw_pairs<kLanes>(o.seed, path0, k >> 1, z);
        const double* zn = z.normal[half];
        const double* ze = z.exponential[half];
        const double* zc = z.coin[half];
        const double s0 = start + static_cast<double>(i) * step;
        alignas(64) double x1[kLanes], db[kLanes], a[kLanes], sb[kLanes];
        // The exact step as simulate_block takes it (the same functions, so the same bits).
        alignas(64) double d[kLanes], q[kLanes], root[kLanes];
#pragma omp simd
        for (int l = 0; l < kLanes; ++l) {
          d[l] = step_increment(c.mean, c.scale, zn[l]);
          q[l] = step_spread(c.twice_variance, ze[l]);
          root[l] = step_root_square(d[l], q[l]);
        }
        sqrt_lanes(root);
        int irregular = 0;
        if (!all_regular)
          for (int l = 0; l < kLanes; ++l) irregular |= !step_regular(root[l]);
        if (irregular == 0) {
#pragma omp simd
          for (int l = 0; l < kLanes; ++l)
            x1[l] = regular_step(x[l], d[l], q[l], root[l], zc[l] != 0.0);
        } else {
          for (int l = 0; l < kLanes; ++l)
            x1[l] = exact_step(x[l], step, drift, noise, zn[l], ze[l], zc[l] != 0.0).velocity;
        }
        for (int l = 0; l < kLanes; ++l) {
          db[l] = root_step * zn[l];
          a[l] = std::abs(x[l]);
          sb[l] = x[l] > 0.0 ? db[l] : (x[l] < 0.0 ? -db[l] : 0.0);
        }
        for (std::size_t j = pending; j < slots; ++j) {
          const double r = until[j] - s0;
          double* g = acc.data() + j * kControls * kLanes;
#pragma omp simd
          for (int l = 0; l < kLanes; ++l) {
            const double kk = std::min(a[l] * inv_drift, r);
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
        for (int l = 0; l < kLanes; ++l) {
          if constexpr (kDisp) u[l] += trapezoid(step, x[l], x1[l]);
          if constexpr (kDist) s[l] += trapezoid(step, std::abs(x[l]), std::abs(x1[l]));
          x[l] = x1[l];
        }
      }
      start += static_cast<double>(seg.steps) * step;
      if (seg.slot >= 0) {
        ws.times.add(static_cast<std::size_t>(seg.slot), x, u, s, lanes, ws.active);
        ws.record(static_cast<std::size_t>(seg.slot), 0, path0, x, u, s, lanes);
        while (pending < slots && chosen[pending] <= static_cast<std::size_t>(seg.slot)) ++pending;
      }
    }
    if (plan.needs_switch_state())
      add_after_switch_off(plan, x, u, s, lanes, ws.active, ws.times, ws.stop, nullptr, nullptr,
                           nullptr, &ws, 0, path0);
    for (int l = 0; l < lanes; ++l)
      for (std::size_t j = 0; j < slots; ++j)
        for (int q = 0; q < kControls; ++q)
          ws.controls[((path0 + l - ws.sample_first) * slots + j) * kControls + q] =
              acc[(j * kControls + q) * kLanes + l];
  }
}

CRANDALL_END_VARIANT
