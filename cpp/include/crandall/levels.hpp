// Per-path values for the multilevel (adaptive-accuracy) runs of python/crandall/adaptive/
// (docs/methods/adaptive.md): the values a run would add to its sums, returned path by path so
// that the level differences of any statistic can be formed, and a fixed-order sum of their
// products. Both are pure functions of their arguments: the same bits for any thread count and
// on every machine.
#pragma once

#include <cstdint>
#include <vector>

#include "crandall/plan.hpp"
#include "crandall/run.hpp"

namespace crandall {

// Paths [first, first + count) of the plan (within its `paths`):
// count x slots x grids x 3 doubles, path-major: slot k < times.size() holds (velocity,
// displacement, distance) at output time k on each grid (grid g: steps 2^g times the fine
// one, as many grids as the method walks), slot times.size() (when the stop is observed) the
// time from the switch-off to the stop and the displacement and distance there, and with
// Options::quadratic_variation slot times.size() + 1 (Q, 0, 0), Q = int_0^t0 noise^2 X^2 dt on
// that grid. Variables not observed are 0. `cancel` is polled as run_chunk polls it (team.hpp: by the calling thread,
// inside long blocks too); returning true throws Cancelled.
// Written into out (count x sample_size(plan) doubles, every one of them written), and with
// controls_out (exact method only, at least one integral observed) the control sums of
// kernel_controls.hpp, or for a filtered plan its ground features minus their exact means
// (filtered.hpp, kFilteredControls of the kControls, the rest 0), at the slots control_slots
// (ascending, distinct; empty: every slot),
// count x control_slots.size() x kControls doubles: a slot's sums are the same bits whichever
// other slots are chosen. The caller's buffers are reused between calls: a fresh allocation
// per call cost more in page faults than the paths.
void run_samples(const Plan& plan, std::uint64_t first, std::uint64_t count, int threads,
                 double* out, double* controls_out = nullptr, const CancelCheck& cancel = {},
                 const std::vector<std::size_t>& control_slots = {});
// Doubles per path of run_samples' out: Options::sample_slots() x grids x 3.
std::size_t sample_size(const Plan& plan);
// Number of control sums per path and slot.
int control_count();
// Of them, those the white-noise kernel fills (kWhiteControls, kernel_controls.hpp; the rest
// are 0 on its plans); a filtered plan fills all (filtered.hpp, kFilteredControls).
int white_control_count();

// The feature columns of a run to an accuracy (python/crandall/adaptive/), one entry per
// column. A column's value on a grid is its target's: the sample x = samples[slot, grid,
// variable] itself (kind 0), its square x * x (kind 1), the Ito identity's
// (constant - x * x) / two_drift (kind 2; kind 3 the same with x = 0, at the stop), or its
// magnitude |x| (kind 4), or constant * x (kind 5); minus
// centre, to the power `power` (1 or 2; squared as x * x).
struct FeatureColumns {
  std::vector<std::int64_t> slot;
  std::vector<std::int32_t> variable, kind, power;
  std::vector<double> constant, centre;
  // Per column: false for a target exact in law (its level differences are 0).
  std::vector<std::uint8_t> inexact;
  // Per column, with control sums: the index among the control slots of the sums it uses,
  // and its kControls coefficients.
  std::vector<std::int64_t> control;
  std::vector<double> beta;
};

// out (rows x cols, row-major, every element written) from the per-path samples (rows x
// slots x grids x 3, run_samples' layout): on level 0 the fine grid's value of each column,
// minus sum_q beta[j k + q] controls[row, control[j], q] (controls: rows x control_slots x k;
// subtracted term by term, q = 0, 1, ...) when controls is given; on a finer level the fine
// value minus the coarse one (grid 1), 0 for columns not inexact. Plain IEEE operations in a
// fixed order per element (no FMA, -ffp-contract=off): the bits NumPy's elementwise formulas
// give, for any thread count.
void form_features(const double* samples, std::uint64_t rows, std::uint64_t slots, int grids,
                   const FeatureColumns& cols, double two_drift, int level, double* out,
                   const double* controls, std::uint64_t control_slots, int threads);

// For a rows x cols row-major matrix F whose columns form consecutive groups of the given
// widths (each 1 to 32, summing to cols): per group, its column sums (w numbers) followed by the
// upper triangle of its F_g^T F_g, row by row (w (w + 1) / 2 numbers). Summed in blocks of 256
// rows, the blocks in order, so the result does not depend on the thread count.
std::vector<double> sum_products(const double* values, std::uint64_t rows, std::uint64_t cols,
                                 const std::vector<int>& widths, int threads);

}  // namespace crandall
