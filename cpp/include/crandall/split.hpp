// Adaptive multilevel splitting's loop for a white-noise scene (crandall.tail, splitting.py's
// _splitting_replica; docs/methods/tails.md): one replica's kill-and-branch iterations, the
// paths continued with the exact step (branch.hpp) and ranked by the quantity's score, all in
// the core. The Python loop stays the reference for every other scene and gives the same bits
// (tests/test_tail_split_core.py): the same parents (split_parents), the same streams, the same
// scores operation by operation.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <vector>

#include "crandall/branch.hpp"

namespace crandall {

// The parents of one iteration's clones: `count` indices, each uniform on [0, survivors) and
// independent, drawn from Philox4x32-10 with key `key` and counters (pair 2^63 + iteration,
// path replica * 2^32 + b) for blocks b = 0, 1, ...: the 32-bit words of the blocks in order,
// each turned into an index by Lemire's multiply-and-shift with rejection (exactly uniform).
// The paths' own draws use pairs below 2^62 (branch.hpp), so the two never share a block.
// Throws std::invalid_argument for survivors outside [1, 2^32) or replica >= 2^32.
void split_parents(std::uint64_t key, std::uint64_t replica, std::uint64_t iteration,
                   std::uint64_t survivors, std::size_t count, std::int64_t* out);

// The quantities whose score the core's loop computes (split_score_row). Python reads their
// names from the core (_core.SPLIT_QUANTITIES, kSplitQuantityNames) and passes the index of
// its quantity's name there; a tail quantity the core does not name runs splitting's Python
// loop.
enum class SplitQuantity : int {
  stop_time = 0,
  velocity,
  speed,
  distance_at_stop,
  dissipated_energy_at_stop,
  displacement_at_stop,
  residual_displacement,
  peak_displacement_at_stop,
  peak_speed_at_stop,
};

// SplitQuantity's names, in its order: the names of the quantities (crandall.quantities).
inline constexpr std::array<const char*, 9> kSplitQuantityNames = {
    "stop_time",
    "velocity",
    "speed",
    "distance_at_stop",
    "dissipated_energy_at_stop",
    "displacement_at_stop",
    "residual_displacement",
    "peak_displacement_at_stop",
    "peak_speed_at_stop",
};
static_assert(kSplitQuantityNames.size() ==
                  static_cast<std::size_t>(SplitQuantity::peak_speed_at_stop) + 1,
              "a name for every SplitQuantity");

// The score of _Problem.split_score, point by point (points 0 .. steps of a row): `plain` the
// quantity's score (_Problem.score), `rank` what splitting ranks by (plain, the uncoasted
// velocity or speed, or the normalised score when `normalised`).
struct SplitScore {
  SplitQuantity quantity = SplitQuantity::stop_time;
  double drift = 0.0;    // c
  double horizon = 0.0;  // the grid's end
  double coast = 0.0;    // the noiseless time after the grid (velocity, speed)
  double mass = 1.0;
  const double* remaining = nullptr;  // steps + 1: the distance's drift still to come
  bool uncoast = false;
  bool normalised = false;
  double top = 0.0;
  // _Problem._normaliser's arrays (steps + 1 each), floor2() and _scale().
  const double* points = nullptr;
  const double* cum0 = nullptr;
  const double* cum1 = nullptr;
  const double* cum2 = nullptr;
  const double* stationary = nullptr;
  const double* step = nullptr;
  double floor2 = 0.0;
  double scale = 1.0;
  // The normalised rank's loop of a kernel variant (KernelTable::normalised_rank: the same
  // bits, vectorised), or null: split_score_row's own.
  void (*normalised_rank)(const SplitScore&, std::size_t steps, const double* row,
                          std::size_t from, const double* plain, double* rank) = nullptr;
};

// rank[k] and plain[k] for k in [from, steps] of a row of states (steps + 1 points x 3).
void split_score_row(const SplitScore& score, std::size_t steps, const double* row,
                     std::size_t from, double* rank, double* plain);

struct SplitOutcome {
  std::vector<double> estimates;  // per level; NaN where not reached (a time-out)
  std::int64_t iterations = 0;
  std::int64_t steps = 0;
  // prod_j (n - K_j) / n over the iterations so far (K_j killed at iteration j): each factor a
  // correctly rounded division, multiplied in iteration order, so the estimates (weight times
  // the fraction above the level) are the same bits on every CPU. It stays a normal double
  // down to about 1e-308 (each factor is at least 1/n).
  double weight = 1.0;
  // sum_j log1p(-K_j / n) with detfunc::log1p (the same bits on every CPU): for messages.
  double log_weight = 0.0;
  bool extinct = false;  // weight and log_weight are then the extinction's
  bool timed_out = false;
};

struct SplitRun {
  std::size_t particles = 0;
  std::size_t kill = 0;
  std::uint64_t key = 0;
  std::uint64_t replica = 0;
  std::int64_t max_iterations = 0;
  double deadline = 0.0;  // seconds since the epoch (time.time()); has_deadline
  bool has_deadline = false;
  double v0 = 0.0, u0 = 0.0;
  std::size_t first = 0;  // the first grid point the path maxima are taken over
  const double* levels = nullptr;
  const double* thresholds = nullptr;  // the levels on the rank's scale
  std::size_t level_count = 0;
  int threads = 1;
  // Asked between iterations (may be empty): true cancels the replica (Cancelled, run.hpp).
  std::function<bool()> cancelled;
};

// One replica of _splitting_replica (splitting.py), with the paths on `grid` (drifts only: no
// slow law). Throws std::runtime_error("splitting did not reach the level after N
// iterations") past max_iterations, as the Python loop does.
SplitOutcome split_replica(const BranchGrid& grid, const SplitScore& score, const SplitRun& run);

// Replicas replicas[0, count) of one run (run.replica is not read) in step: their iterations
// taken in turn, the clones of all of them continued together in the vector lanes, so that the
// lanes are kept busy (an iteration continues a tenth of a replica's particles). Each outcome
// is the one split_replica gives that replica alone, bit for bit.
std::vector<SplitOutcome> split_replicas(const BranchGrid& grid, const SplitScore& score,
                                         const SplitRun& run, const std::uint64_t* replicas,
                                         std::size_t count);

}  // namespace crandall
