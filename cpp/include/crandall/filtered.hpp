// The path loop of the filtered excitation (Options::excitation filtered; the model is stated in
// plan.hpp and filter.hpp, the derivations in docs/filtered.md). Scalar, one path at a time,
// compiled once for the baseline instruction set (not per kernel variant): its numbers are the
// same bits on every CPU, for any thread count and chunking.
#pragma once

#include <cstdint>
#include <vector>

#include "crandall/plan.hpp"

namespace crandall {

struct Workspace;

// run_chunk's and run_samples' block function for a filtered plan (dispatch.hpp's BlockFn):
// paths [first, first + count) into ws, on the plan's grids() coupled grids (the moments and
// histograms of the walked grid, run_samples' per-path samples of every grid).
void simulate_filtered_block(const Plan& plan, std::uint64_t first, std::uint64_t count,
                             Workspace& ws);

// One path of the walked grid, point by point: every skeleton point, every end of a substep of
// an event search, and every time the body comes to rest, in time order, with a_g there (on a
// finest substep: the straight line the body is stepped on), and the body's V, U, S. Up to the
// stop when it is observed, else to the plan's last time.
struct Trajectory {
  std::vector<double> time, ground, velocity, displacement, distance;
};
Trajectory filtered_trajectory(const Plan& plan, std::uint64_t path);

// The multiple of an interval's a_g spread (its bridge's standard deviation at the midpoint,
// and the curvature of its mean) within which an event is taken as possible (the interval is
// bisected); kEventMargin unless set. Returns the previous value. For the measurement that
// doubling it moves no result (tests); throws std::invalid_argument unless finite and > 0.
constexpr double kEventMargin = 6.0;
double set_event_margin(double margin);

}  // namespace crandall
