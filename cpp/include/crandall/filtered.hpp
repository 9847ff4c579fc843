// The path loop of the filtered excitation (Options::excitation filtered; the model is stated in
// plan.hpp and filter.hpp, the derivations in docs/filtered.md). Scalar, one path at a time,
// compiled once for the baseline instruction set (not per kernel variant): its numbers are the
// same bits on every CPU, for any thread count and chunking.
#pragma once

#include <cstddef>
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

// Paths continued from stored states (crandall.tail's splitting; docs/filtered.md, "Continued
// paths"). The walked grid (grids() == 1) has filtered_grid_points(plan) points: 0, and the end
// of every fine step of the plan's segments, in time order. A state at a point is Markov:
// (V, U, S, the time the body last came to rest (0 if it never did), z (the filter's n
// numbers)), filtered_state_columns(plan) = kStateColumns + n doubles. states: rows_total x
// points x columns. For each i < count, row rows[i] is continued from its state at point
// starts[i] to the plan's last point (the ring-down to the stop is not walked), overwriting the
// points after it; its random numbers are those of path streams[i] (< 2^40) under the Philox
// key `key` at steps starts[i], starts[i] + 1, ... (filtered.cpp's counter layout), so a row's
// continuation is a pure function of (key, stream, start state, start point) whatever the
// threads, and with key = the plan's seed a continuation of path p from point 0 (its state
// (start_velocity, start_displacement, 0, 0, z(0))) is the walked grid's path p of
// simulate_filtered_block and filtered_trajectory, bit for bit. The switch-off drops z to 0 at
// the start of the first segment after it (ring_down false), as the block does. Throws
// std::invalid_argument for rows out of range or listed twice, a start that is no grid point, a
// stream >= 2^40 or a start state that is not finite.
constexpr std::size_t kStateColumns = 4;
std::size_t filtered_grid_points(const Plan& plan);
std::size_t filtered_state_columns(const Plan& plan);  // throws unless filtered
void extend_filtered_paths(const Plan& plan, double* states, std::size_t rows_total,
                           const std::int64_t* rows, const std::int64_t* starts,
                           const std::uint64_t* streams, std::size_t count, std::uint64_t key,
                           int threads);

// Control variates of the base level of a run to an accuracy (run_samples with controls;
// docs/filtered.md, "Control variates"): per path and output slot, kGroundFeatures functions
// of the ground motion alone over [0, u], u = min(the slot's time, switch_off) (the stop's:
// the switch-off), on the walked grid's points t_k (k >= 1) with their steps h_k as weights:
//   0  sum h a_g^2        1  sum h vg^2     2  vg(u)^2     3  sum h |a_g|    4  sum h |vg|
//   5  vg(u)              6  dg(u)          7  dg(u)^2     8  sum h dg^2
// with vg = int a_g and dg = int vg the ground's velocity and displacement from 0 (exact: the
// skeleton's G and D). They are functions of a Gaussian process whose law the plan knows, so
// their means are exact: ground_feature_means propagates the mean and covariance of (z, vg,
// dg) step by step with the skeleton's own transitions, (times.size() + 1) x kGroundFeatures
// doubles (the stop last). run_samples subtracts them, so each control has mean exactly 0.
// Features 3 and 4 are 0 (value and mean) unless the filter starts at rest (z(0) = 0: every
// mean then 0, and E|x| = sqrt(2 / pi) sd(x) needs no exp or erf). Throws
// std::invalid_argument unless the plan is filtered.
constexpr int kGroundFeatures = 9;
std::vector<double> ground_feature_means(const Plan& plan);
// After the ground features, kBodyControls sums over the shaking's fine steps k before u of
// the walked grid's body at the step's start (V, U, S there) times e_k = sigma R_G xi_k, the
// innovation of the step's G = int a_g (its part not predicted by z at the step's start):
//   9  sum V e     10  sum S V e     11  sum sgn(V) e     12  sum U e
//   13 sum (switch_off - t_k) V e    14  sum e
// The body's state at a step's start depends on the earlier steps' numbers only, and xi_k is
// independent of them with mean 0, so each sum has mean exactly 0 (nothing to subtract).
constexpr int kBodyControls = 6;
// Then, for the sums of V e (9) and sgn(V) e (11), M_i M_j - sum_k X_i,k X_j,k var(e_k) for
// (i, j) = (9, 9), (9, 11), (11, 11): the product of the two sums minus their quadratic
// covariation, with X_i,k the body factor of sum i at step k and var(e_k) = sigma^2 |R_G|^2
// the innovation's variance. The sums are martingales (X at the step's start, e_k independent
// of it with mean 0), so E[M_i M_j] = E[sum_k X_i,k X_j,k] var(e_k) and these have mean exactly
// 0 too. They let the variance's per-path term, (S - c)^2, borrow the body's own randomness
// (docs/filtered.md, "Control variates"). The other sums' products are left out: their tails
// are so heavy (S V, U and (switch_off - t) V squared) that a pilot of 4096 paths fits them
// worse than not at all.
constexpr int kBodyProducts = 3;
// Then four more martingales over the same steps, for the energy balance's second-order part
// (the realised intensity of the innovations, which the ground features on the grid points
// see only in part) and the variance's per-path term:
//   18 sum V |V| e     19 sum (e^2 - var(e))     20 sum V^2 (e^2 - var(e))
//   21 sum |V| (e^2 - var(e))
// e_k is Gaussian with variance var(e_k) given everything before the step, so e_k^2 - var(e_k)
// has mean 0 given it too, and each has mean exactly 0 (docs/filtered.md, "Control variates")
// up to the generator's own discretisation: Box-Muller's radius from 2^32 midpoints gives
// E xi^2 = 1 - 8.1e-11 (the first-order sums' symmetric normals have mean 0 exactly).
constexpr int kBodySecondOrder = 4;
constexpr int kFilteredControls = kGroundFeatures + kBodyControls + kBodyProducts + kBodySecondOrder;

// The multiple of an interval's a_g spread (its bridge's standard deviation at the midpoint,
// and the curvature of its mean) within which an event is taken as possible (the interval is
// bisected); kEventMargin unless set. Returns the previous value. For the measurement that
// doubling it moves no result (tests); throws std::invalid_argument unless finite and > 0.
constexpr double kEventMargin = 6.0;
double set_event_margin(double margin);

}  // namespace crandall
