// Paths continued from stored states: the building block of the rare-event estimators
// (crandall.tail, docs/methods/tails.md). Splitting restarts a path from a state of another
// path with fresh noise; importance sampling simulates under a changed friction and weighs each
// path by the ratio of the two exact step laws. Both need paths stepped on a fixed grid from
// any stored state, each with its own random stream, the whole trajectory kept.
#pragma once

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <vector>

namespace crandall {

// The grid of a branching run: step k (0 <= k < steps) has length lengths[k], noise intensity
// noises[k] (sigma of the velocity's dX = -c sign(X) dt + sigma dW) and drift drifts[k] (c; may
// be negative: an importance-sampling proposal that pushes the body outward). Optionally the
// drift depends on the speed at the step's start: a step that starts with |x| < slow[k] takes
// slow_drifts[k] instead (a proposal that changes the friction only while the body slides
// fast, so that its weight does not see the time spent near 0); both null: drifts[k] always.
struct BranchGrid {
  const double* lengths;
  const double* noises;
  const double* drifts;
  std::size_t steps;
  const double* slow = nullptr;
  const double* slow_drifts = nullptr;

  double drift(std::size_t k, double x) const {
    return (slow != nullptr && std::abs(x) < slow[k]) ? slow_drifts[k] : drifts[k];
  }
};

// Checks a grid: lengths finite and > 0, noises finite and >= 0, drifts finite, every step in
// the exact step's range. Throws std::invalid_argument naming the array.
void validate_branch_grid(const BranchGrid& grid);

// Checks the rows a continuation is asked for (extend_paths, extend_filtered_paths): each a row
// of `states` (rows_total x points x cols) listed once, its start a grid point, its start state
// finite. Throws std::invalid_argument naming rows, starts or states.
void validate_continued_rows(const double* states, std::size_t rows_total, std::size_t points,
                             std::size_t cols, const std::int64_t* rows,
                             const std::int64_t* starts, std::size_t count);

// states: rows x (grid.steps + 1) x 3 doubles, (velocity, displacement, distance) at every
// grid point of every row. For each i < count, row rows[i] is continued from its state at grid
// point starts[i] to the end of the grid, overwriting the points after it; its noise is the
// stream streams[i] of key `key` (docs/random-numbers.md: step k draws the half k % 2 of the
// Philox block (key, stream, pair k / 2)), so a row's continuation is a pure function of
// (key, stream, start state, start point) whatever the threads. Displacement and distance are
// integrated by the trapezoid rule on the grid (the exact method's integrals); a step without
// noise and with a drift >= 0 is the closed-form coast (exact integrals, and the stop inside
// the step). Rows listed twice are refused. touched (optional: rows x grid.steps, or nullptr)
// receives, for every step a row takes, whether its velocity reached 0 during the step (the
// exact step's touch, after which the sign is a fresh fair coin; 0 for a coast step): what
// importance sampling needs to re-draw the signs (docs/methods/tails.md).
void extend_paths(double* states, std::size_t rows_total, const BranchGrid& grid,
                  const std::int64_t* rows, const std::int64_t* starts,
                  const std::uint64_t* streams, std::size_t count, std::uint64_t key,
                  int threads, std::uint8_t* touched = nullptr);

// A grid prepared for the lanes (extend_rows_in_lanes): per step its length, drift and noise,
// exact_step's constants (step_constants: the same rounding) and whether it is the coast (no
// noise, drift >= 0).
struct LaneGrid {
  const double* lengths;
  const double* drifts;
  const double* noises;
  const double* mean;
  const double* scale;
  const double* twice_variance;
  const unsigned char* coast;
  std::size_t steps;
};

// Rows continued together in the vector lanes of the kernel's variants (dispatch.hpp): 16, as
// many as the kernel's lanes (measured faster than 8 for splitting's clones, 0.34 against 0.30
// of the kernel's path-step rate for the distance at 1e-9).
constexpr int kBranchLanes = 16;

// The arrays behind a LaneGrid of a BranchGrid without slow law.
struct LaneGridData {
  explicit LaneGridData(const BranchGrid& grid);
  LaneGrid view() const;
  const BranchGrid grid;
  std::vector<double> mean, scale, twice_variance;
  std::vector<unsigned char> coast;
};

struct KernelTable;
// extend_rows (no touched flags, no slow law) with the rows in the vector lanes of `kernel`
// (the active variant when null): the same bits. An odd start takes its first step alone, so
// that every lane draws a pair of steps at the same time.
void extend_rows_in_lanes(double* states, const LaneGridData& grid, const std::int64_t* rows,
                          const std::int64_t* starts, const std::uint64_t* streams,
                          std::size_t count, std::uint64_t key, int threads,
                          const KernelTable* kernel = nullptr);

// extend_paths without its checks (the grid, the rows, the start states): for callers that
// made them once (split_replica, split.hpp).
void extend_rows(double* states, const BranchGrid& grid, const std::int64_t* rows,
                 const std::int64_t* starts, const std::uint64_t* streams, std::size_t count,
                 std::uint64_t key, int threads, std::uint8_t* touched = nullptr);

}  // namespace crandall
