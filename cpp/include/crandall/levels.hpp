// Per-path values for the multilevel (adaptive-accuracy) runs of python/crandall/adaptive.py
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
// time from the switch-off to the stop and the displacement and distance there. Variables not
// observed are 0. `cancel` is polled as run_chunk polls it (team.hpp: by the calling thread,
// inside long blocks too); returning true throws Cancelled.
// Written into out (count x sample_size(plan) doubles, every one of them written), and with
// controls_out (exact method only, at least one integral observed) the control sums of
// kernel_controls.hpp at the slots control_slots (ascending, distinct; empty: every slot),
// count x control_slots.size() x kControls doubles: a slot's sums are the same bits whichever
// other slots are chosen. The caller's buffers are reused between calls: a fresh allocation
// per call cost more in page faults than the paths.
void run_samples(const Plan& plan, std::uint64_t first, std::uint64_t count, int threads,
                 double* out, double* controls_out = nullptr, const CancelCheck& cancel = {},
                 const std::vector<std::size_t>& control_slots = {});
// Doubles per path of run_samples' out: slots x grids x 3.
std::size_t sample_size(const Plan& plan);
// Number of control sums per path and slot.
int control_count();

// In place, for a rows x cols row-major matrix F and the control sums C (rows x slots x k,
// row-major): column j of F minus sum_q beta[j k + q] C[:, slot_of[j], q], subtracted term by
// term in the order q = 0, 1, ... (plain multiplies and subtractions, no BLAS): the same bits on
// every machine, and the same as one column at a time.
void subtract_controls(double* f, std::uint64_t rows, std::uint64_t cols, const double* controls,
                       std::uint64_t slots, std::uint64_t k, const std::vector<std::int64_t>& slot_of,
                       const std::vector<double>& beta);

// For a rows x cols row-major matrix F whose columns form consecutive groups of the given
// widths (each 1 to 32, summing to cols): per group, its column sums (w numbers) followed by the
// upper triangle of its F_g^T F_g, row by row (w (w + 1) / 2 numbers). Summed in blocks of 256
// rows, the blocks in order, so the result does not depend on the thread count.
std::vector<double> sum_products(const double* values, std::uint64_t rows, std::uint64_t cols,
                                 const std::vector<int>& widths, int threads);

}  // namespace crandall
