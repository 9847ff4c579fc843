#include "crandall/split.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <numeric>
#include <stdexcept>
#include <string>
#if defined(__SSE2__)
#include <emmintrin.h>
#endif

#include "crandall/detfunc.hpp"
#include "crandall/dispatch.hpp"
#include "crandall/rng.hpp"
#include "crandall/run.hpp"

namespace crandall {

namespace {
// The points of a block of ranks whose maximum a replica keeps (Replica::branch_point).
constexpr std::size_t kBlock = 16;

// The maximum of x[0, count) (-infinity if empty); `nan` set if one of them is a NaN. Max is
// exact: any order of comparisons gives the same number (but for the sign of a zero, which no
// comparison of splitting's sees).
inline double block_max(const double* x, std::size_t count, bool& nan) {
  std::size_t k = 0;
  double a = -std::numeric_limits<double>::infinity();
#if defined(__SSE2__)
  if (count >= 4) {
    __m128d m0 = _mm_loadu_pd(x), m1 = _mm_loadu_pd(x + 2);
    __m128d bad = _mm_or_pd(_mm_cmpunord_pd(m0, m0), _mm_cmpunord_pd(m1, m1));
    for (k = 4; k + 4 <= count; k += 4) {
      const __m128d y0 = _mm_loadu_pd(x + k), y1 = _mm_loadu_pd(x + k + 2);
      bad = _mm_or_pd(bad, _mm_or_pd(_mm_cmpunord_pd(y0, y0), _mm_cmpunord_pd(y1, y1)));
      m0 = _mm_max_pd(m0, y0);
      m1 = _mm_max_pd(m1, y1);
    }
    nan |= _mm_movemask_pd(bad) != 0;
    alignas(16) double two[2];
    _mm_store_pd(two, _mm_max_pd(m0, m1));
    a = std::max(two[0], two[1]);
  }
#endif
  for (; k < count; ++k) {
    nan |= std::isnan(x[k]);
    a = std::max(a, x[k]);
  }
  return a;
}
// The paths' streams of replica r: r * 2^40 + 0, 1, ... (splitting.py's _REPLICA_STREAMS).
constexpr std::uint64_t kReplicaStreams = std::uint64_t(1) << 40;
// The parents' blocks use pairs from 2^63 on (split_parents).
constexpr std::uint64_t kParentPairs = std::uint64_t(1) << 63;
}  // namespace

void split_parents(std::uint64_t key, std::uint64_t replica, std::uint64_t iteration,
                   std::uint64_t survivors, std::size_t count, std::int64_t* out) {
  if (survivors < 1 || survivors >= (std::uint64_t(1) << 32))
    throw std::invalid_argument("survivors must be in [1, 2^32), got " + std::to_string(survivors));
  if (replica >= (std::uint64_t(1) << 32))
    throw std::invalid_argument("replica must be < 2^32, got " + std::to_string(replica));
  if (iteration >= kParentPairs)
    throw std::invalid_argument("iteration must be < 2^63");
  const std::uint64_t m = survivors;
  // Lemire (2019): x m / 2^32 for a uniform 32-bit x, rejecting the x whose low product falls
  // below 2^32 mod m, is exactly uniform on [0, m).
  const std::uint32_t threshold = static_cast<std::uint32_t>((std::uint64_t(1) << 32) % m);
  std::uint64_t words[4];
  std::uint64_t block = 0;
  int used = 4;
  for (std::size_t j = 0; j < count; ++j) {
    for (;;) {
      if (used == 4) {
        detail::philox_scalar(key, (replica << 32) + block, kParentPairs + iteration, words);
        ++block;
        used = 0;
      }
      const std::uint64_t x = words[used++] & 0xFFFFFFFFu;
      const std::uint64_t product = x * m;
      if (static_cast<std::uint32_t>(product) >= threshold) {
        out[j] = static_cast<std::int64_t>(product >> 32);
        break;
      }
    }
  }
}

void split_score_row(const SplitScore& sc, std::size_t steps, const double* row, std::size_t from,
                     double* rank, double* plain) {
  const double c = sc.drift;
  const double twice = 2.0 * c;
  const double shift = c * sc.coast;
  const bool coasted = sc.coast != 0.0;
  const double* rem = sc.remaining;
  const double energy = sc.mass * c;
  // _Problem.score, a loop per quantity (each vectorises), the same operations in the same order.
  switch (sc.quantity) {
    case SplitQuantity::stop_time:
      for (std::size_t k = from; k <= steps; ++k) plain[k] = sc.horizon + std::abs(row[3 * k]) / c;
      break;
    case SplitQuantity::velocity:
    case SplitQuantity::speed:
      for (std::size_t k = from; k <= steps; ++k) {
        const double v = row[3 * k];
        double w = v;
        if (coasted) {
          const double sign = v > 0.0 ? 1.0 : (v < 0.0 ? -1.0 : v);
          w = sign * std::max(std::abs(v) - shift, 0.0);
        }
        plain[k] = sc.quantity == SplitQuantity::speed ? std::abs(w) : w;
      }
      break;
    case SplitQuantity::distance_at_stop:
      for (std::size_t k = from; k <= steps; ++k) {
        const double v = row[3 * k];
        plain[k] = row[3 * k + 2] + v * v / twice + rem[k];
      }
      break;
    case SplitQuantity::dissipated_energy_at_stop:
      for (std::size_t k = from; k <= steps; ++k) {
        const double v = row[3 * k];
        plain[k] = (row[3 * k + 2] + v * v / twice + rem[k]) * energy;
      }
      break;
    case SplitQuantity::displacement_at_stop:
      for (std::size_t k = from; k <= steps; ++k) {
        const double v = row[3 * k];
        plain[k] = row[3 * k + 1] + v * std::abs(v) / twice;
      }
      break;
    case SplitQuantity::residual_displacement:
      for (std::size_t k = from; k <= steps; ++k) {
        const double v = row[3 * k];
        plain[k] = std::abs(row[3 * k + 1] + v * std::abs(v) / twice);
      }
      break;
    case SplitQuantity::peak_displacement_at_stop:
      for (std::size_t k = from; k <= steps; ++k) plain[k] = std::abs(row[3 * k + 1]);
      if (from <= steps) {
        const double v = row[3 * steps];
        plain[steps] = std::max(plain[steps], std::abs(row[3 * steps + 1] + v * std::abs(v) / twice));
      }
      break;
    default:  // peak_speed_at_stop
      for (std::size_t k = from; k <= steps; ++k) plain[k] = std::abs(row[3 * k]);
      break;
  }
  if (sc.normalised && sc.normalised_rank != nullptr) {
    sc.normalised_rank(sc, steps, row, from, plain, rank);
  } else if (sc.normalised) {
    // _Problem.split_score's normalised form.
    for (std::size_t k = from; k <= steps; ++k) {
      const double q = std::abs(row[3 * k]) / c;
      const double end = sc.points[k] + q;
      const double ahead = std::ceil(std::min(q / sc.step[k], double(steps)));
      const std::size_t e = std::min(k + static_cast<std::size_t>(ahead), steps);
      double var = end * end * (sc.cum0[e] - sc.cum0[k]) - 2.0 * end * (sc.cum1[e] - sc.cum1[k]) +
                   (sc.cum2[e] - sc.cum2[k]);
      var = std::max(var, 0.0);
      var += sc.stationary[k];
      if (k == steps) var = 0.0;
      var += sc.floor2;
      rank[k] = (plain[k] - sc.top) / (sc.scale * std::sqrt(var));
    }
  } else if (sc.uncoast) {
    const bool speed = sc.quantity == SplitQuantity::speed;
    for (std::size_t k = from; k <= steps; ++k) {
      const double v = row[3 * k];
      rank[k] = (speed ? std::abs(v) : v) - shift;
    }
  } else {
    for (std::size_t k = from; k <= steps; ++k) rank[k] = plain[k];
  }
}

namespace {

// One replica's particles: their states (rows of the group's shared array, which the lanes
// continue), the running maxima of their ranks and scores, and the replica's loop between two
// continuations of its clones (split_replicas runs several such loops in step, their clones
// continued together).
class Replica {
 public:
  Replica(const SplitScore& score, const SplitRun& run, std::uint64_t replica, double* states,
          std::int64_t row0, std::size_t steps)
      : score_(score), run_(run), n_(run.particles), steps_(steps), points_(steps + 1),
        peak_(score.quantity == SplitQuantity::peak_displacement_at_stop ||
              score.quantity == SplitQuantity::peak_speed_at_stop),
        states_(states), row0_(row0), base_(replica * kReplicaStreams), replica_(replica),
        blocks_per_row_((points_ + kBlock - 1) / kBlock), ranks_(n_ * points_),
        blocks_(n_ * blocks_per_row_), peaks_(peak_ ? n_ * points_ : 0), plain_(points_),
        level_(n_), value_(n_), sorted_(n_), order_(run.level_count) {
    out_.estimates.assign(run.level_count, std::numeric_limits<double>::quiet_NaN());
    std::iota(order_.begin(), order_.end(), std::size_t(0));
    std::stable_sort(order_.begin(), order_.end(),
                     [&](std::size_t a, std::size_t b) { return run.levels[a] < run.levels[b]; });
    killed_.reserve(n_);
    survivors_.reserve(n_);
    out_.steps = static_cast<std::int64_t>(n_ * steps_);
  }

  // Every particle from the start state, at the group's rows row0 + i.
  void start(std::vector<std::int64_t>& rows, std::vector<std::int64_t>& starts,
             std::vector<std::uint64_t>& streams) {
    for (std::size_t i = 0; i < n_; ++i) {
      double* row = this->row(i);
      row[0] = run_.v0;
      row[1] = run_.u0;
      row[2] = 0.0;
      rows.push_back(row0_ + static_cast<std::int64_t>(i));
      starts.push_back(0);
      streams.push_back(base_ + i);
    }
    branches_ = n_;
  }

  void scored_start() {
    for (std::size_t i = 0; i < n_; ++i) rescore(i, 0);
  }

  // The replica's next iteration up to its clones' continuation: false when it has ended (its
  // levels all reached, an extinction or a time-out), else its clones appended to the group's
  // rows, starts and streams.
  bool branch(std::vector<std::int64_t>& rows, std::vector<std::int64_t>& starts,
              std::vector<std::uint64_t>& streams) {
    if (run_.has_deadline) {
      const double now =
          std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count();
      if (now > run_.deadline) {
        out_.timed_out = true;
        return false;
      }
    }
    std::copy(level_.begin(), level_.end(), sorted_.begin());
    std::nth_element(sorted_.begin(), sorted_.begin() + static_cast<long>(run_.kill - 1),
                     sorted_.end());
    const double z = sorted_[run_.kill - 1];
    while (done_ < order_.size() && run_.thresholds[order_[done_]] <= z) {
      std::size_t above = 0;
      for (std::size_t i = 0; i < n_; ++i) above += value_[i] > run_.levels[order_[done_]];
      out_.estimates[order_[done_]] = out_.weight * (double(above) / double(n_));
      ++done_;
    }
    if (done_ == order_.size()) return false;
    killed_.clear();
    survivors_.clear();
    for (std::size_t i = 0; i < n_; ++i) {
      if (level_[i] <= z) killed_.push_back(static_cast<std::int64_t>(i));
      if (level_[i] > z) survivors_.push_back(static_cast<std::int64_t>(i));
    }
    if (killed_.size() == n_) {
      for (std::size_t j = done_; j < order_.size(); ++j) out_.estimates[order_[j]] = 0.0;
      out_.extinct = true;
      return false;
    }
    if (out_.iterations >= run_.max_iterations)
      throw std::runtime_error("splitting did not reach the level after " +
                               std::to_string(out_.iterations) + " iterations");
    out_.weight = out_.weight * (double(n_ - killed_.size()) / double(n_));
    out_.log_weight += detfunc::log1p(-double(killed_.size()) / double(n_));
    const std::size_t kc = killed_.size();
    picks_.resize(kc);
    from_.resize(kc);
    split_parents(run_.key, replica_, static_cast<std::uint64_t>(out_.iterations),
                  survivors_.size(), kc, picks_.data());
    for (std::size_t j = 0; j < kc; ++j) {
      const std::size_t parent =
          static_cast<std::size_t>(survivors_[static_cast<std::size_t>(picks_[j])]);
      const std::size_t child = static_cast<std::size_t>(killed_[j]);
      // The first point from `first` on where the parent's rank exceeds z (it has one: its
      // level is above z). The points before the parent's own branch point hold the ranks
      // of the path it replaced, at most the level it was killed at, below z.
      const std::size_t b = branch_point(parent, z);
      from_[j] = b;
      rows.push_back(row0_ + static_cast<std::int64_t>(child));
      starts.push_back(static_cast<std::int64_t>(b));
      streams.push_back(base_ + branches_ + j);
      // What the child reads of its parent: the state it continues from, and for the peaks
      // the running maximum before it. Its states and ranks before b are never read again
      // (the ranks it keeps there, its killed path's, are at most z, and every later kill
      // level is above z: no later branch point falls there, and its level is its ranks'
      // maximum from b on, where the rank, the parent's, exceeds z).
      std::copy_n(row(parent) + b * 3, 3, row(child) + b * 3);
      if (peak_) std::copy_n(peaks_.data() + parent * points_, b, peaks_.data() + child * points_);
      out_.steps += static_cast<std::int64_t>(steps_ - b);
    }
    return true;
  }

  // The scores of the clones continued since branch().
  void scored_clones() {
    for (std::size_t j = 0; j < killed_.size(); ++j)
      rescore(static_cast<std::size_t>(killed_[j]), from_[j]);
    branches_ += killed_.size();
    ++out_.iterations;
  }

  SplitOutcome& outcome() { return out_; }

 private:
  double* row(std::size_t i) {
    return states_ + (static_cast<std::size_t>(row0_) + i) * points_ * 3;
  }

  // The first point from `first` on where row i's rank exceeds z: in the block of `first`
  // point by point, then the first later block whose maximum exceeds z, point by point.
  std::size_t branch_point(std::size_t i, double z) const {
    const double* r = ranks_.data() + i * points_;
    const std::size_t block = run_.first / kBlock;
    const std::size_t end = std::min(points_, (block + 1) * kBlock);
    for (std::size_t k = run_.first; k < end; ++k)
      if (r[k] > z) return k;
    const double* m = blocks_.data() + i * blocks_per_row_;
    std::size_t j = block + 1;
    while (!(m[j] > z)) ++j;
    std::size_t k = j * kBlock;
    while (!(r[k] > z)) ++k;
    return k;
  }

  // The scores of row i from point `from` on (the points before it are its parent's), the
  // maxima of its blocks of ranks from `from`'s on, and its level: the maximum of its ranks
  // from `first` on, which is their maximum from max(from, first) on (a clone's rank at its
  // branch point exceeds every rank before it: they are at most an earlier kill level), so
  // for a clone the maximum of its blocks from `from`'s on. Max is exact: the order of the
  // reductions does not matter.
  void rescore(std::size_t i, std::size_t from) {
    const double* rank = ranks_.data() + i * points_;
    split_score_row(score_, steps_, row(i), from, ranks_.data() + i * points_, plain_.data());
    double* m = blocks_.data() + i * blocks_per_row_;
    double top = -std::numeric_limits<double>::infinity();
    bool nan = false;
    for (std::size_t j = from / kBlock; j < blocks_per_row_; ++j) {
      // The block's points from `first` on (the later blocks': all of them).
      const std::size_t k1 = std::min(points_, (j + 1) * kBlock);
      const std::size_t k0 = std::max(j * kBlock, run_.first);
      const double a = block_max(rank + k0, k1 > k0 ? k1 - k0 : 0, nan);
      m[j] = a;
      top = std::max(top, a);
    }
    // The paths' states are finite (the exact step's range), so are their scores; a NaN would
    // make the maxima meaningless.
    if (nan) throw std::runtime_error("splitting: a path's score is not a number");
    level_[i] = top;
    if (peak_) {
      double* m = peaks_.data() + i * points_;
      double v = from > 0 ? m[from - 1] : -std::numeric_limits<double>::infinity();
      for (std::size_t k = from; k <= steps_; ++k) {
        v = std::max(v, plain_[k]);
        m[k] = v;
      }
      value_[i] = v;
    } else {
      value_[i] = plain_[steps_];
    }
  }

  const SplitScore& score_;
  const SplitRun& run_;
  const std::size_t n_, steps_, points_;
  const bool peak_;
  double* const states_;
  const std::int64_t row0_;
  const std::uint64_t base_, replica_;
  // Per particle: its ranks (its branch point for a kill level z is the first point from
  // `first` on above z), and for the peaks the running maximum of the quantity's score (the
  // quantity is the last).
  const std::size_t blocks_per_row_;
  std::vector<double> ranks_, blocks_, peaks_;
  std::vector<double> plain_;  // one row's quantity scores
  std::vector<double> level_, value_, sorted_;
  std::vector<std::size_t> order_, from_;
  std::vector<std::int64_t> killed_, survivors_, picks_;
  std::uint64_t branches_ = 0;
  std::size_t done_ = 0;
  SplitOutcome out_;
};

}  // namespace

std::vector<SplitOutcome> split_replicas(const BranchGrid& grid, const SplitScore& given,
                                         const SplitRun& run, const std::uint64_t* replicas,
                                         std::size_t count) {
  SplitScore score = given;
  if (score.normalised && score.normalised_rank == nullptr)
    score.normalised_rank = active_kernel().normalised_rank;
  validate_branch_grid(grid);
  if (grid.slow != nullptr) throw std::invalid_argument("split_replica: a slow law is not supported");
  const std::size_t n = run.particles, steps = grid.steps, points = steps + 1;
  if (n < 2) throw std::invalid_argument("particles must be >= 2, got " + std::to_string(n));
  if (run.kill < 1 || run.kill > n)
    throw std::invalid_argument("kill must be in [1, particles], got " + std::to_string(run.kill));
  if (run.first > steps)
    throw std::invalid_argument("first must be a grid point, got " + std::to_string(run.first));
  if (!(std::isfinite(run.v0) && std::isfinite(run.u0)))
    throw std::invalid_argument("v0 and u0 must be finite");
  if (count < 1) throw std::invalid_argument("split_replicas: no replica");
  // The replicas' particles in one array of states, continued together in the vector lanes of
  // the kernel's variant (branch_lanes.inc: the scalar extend_paths' bits, whatever rows share
  // the lanes): an iteration of one replica continues only a tenth of its particles, too few to
  // keep the lanes busy, those of several replicas fill them.
  std::vector<double> states(count * n * points * 3);
  const LaneGridData lanes(grid);
  std::vector<Replica> group;
  group.reserve(count);
  std::vector<std::int64_t> rows, starts;
  std::vector<std::uint64_t> streams;
  rows.reserve(count * n);
  starts.reserve(count * n);
  streams.reserve(count * n);
  for (std::size_t r = 0; r < count; ++r) {
    group.emplace_back(score, run, replicas[r], states.data(),
                       static_cast<std::int64_t>(r * n), steps);
    group.back().start(rows, starts, streams);
  }
  extend_rows_in_lanes(states.data(), lanes, rows.data(), starts.data(), streams.data(),
                       rows.size(), run.key, run.threads);
  for (auto& replica : group) replica.scored_start();
  std::vector<char> active(count, 1);
  for (;;) {
    if (run.cancelled && run.cancelled()) throw Cancelled();
    rows.clear();
    starts.clear();
    streams.clear();
    bool any = false;
    for (std::size_t r = 0; r < count; ++r) {
      if (active[r]) active[r] = group[r].branch(rows, starts, streams) ? 1 : 0;
      any |= active[r] != 0;
    }
    if (!any) break;
    extend_rows_in_lanes(states.data(), lanes, rows.data(), starts.data(), streams.data(),
                         rows.size(), run.key, run.threads);
    for (std::size_t r = 0; r < count; ++r)
      if (active[r]) group[r].scored_clones();
  }
  std::vector<SplitOutcome> out;
  out.reserve(count);
  for (auto& replica : group) out.push_back(std::move(replica.outcome()));
  return out;
}

SplitOutcome split_replica(const BranchGrid& grid, const SplitScore& score, const SplitRun& run) {
  const std::uint64_t replica = run.replica;
  return std::move(split_replicas(grid, score, run, &replica, 1).front());
}

}  // namespace crandall
