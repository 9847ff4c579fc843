#include "crandall/split.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <numeric>
#include <stdexcept>
#include <string>

#include "crandall/dispatch.hpp"
#include "crandall/rng.hpp"
#include "crandall/run.hpp"

namespace crandall {

namespace {
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

SplitOutcome split_replica(const BranchGrid& grid, const SplitScore& given, const SplitRun& run) {
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
  const bool peak = score.quantity == SplitQuantity::peak_displacement_at_stop ||
                    score.quantity == SplitQuantity::peak_speed_at_stop;
  // Per particle: its states (only the point it continues from is read after it moved on),
  // the running maximum of its rank from the first point on (`reach`: its path maximum is the
  // last, and its branch point for a kill level z the first point above z), and for the peaks
  // the running maximum of the quantity's score (the quantity is the last).
  std::vector<double> states(n * points * 3), reach(n * points), peaks(peak ? n * points : 0);
  std::vector<double> rank(points), plain(points);  // one row's scores
  std::vector<double> level(n), value(n);
  // The paths continue in the vector lanes of the kernel's variant (branch_lanes.inc): the
  // scalar extend_paths' bits.
  const LaneGridData lanes(grid);
  const std::uint64_t base = run.replica * kReplicaStreams;
  constexpr double kLowest = -std::numeric_limits<double>::infinity();

  // The scores of row i from point `from` on (the points before it are its parent's).
  auto rescore = [&](std::size_t i, std::size_t from) {
    split_score_row(score, steps, states.data() + i * points * 3, from, rank.data(), plain.data());
    double* r = reach.data() + i * points;
    const std::size_t k0 = std::max(from, run.first);
    double top = k0 > run.first ? r[k0 - 1] : kLowest;
    bool nan = false;
    for (std::size_t k = k0; k <= steps; ++k) {
      nan |= std::isnan(rank[k]);
      top = std::max(top, rank[k]);
      r[k] = top;
    }
    // The paths' states are finite (the exact step's range), so are their scores; a NaN would
    // make the running maxima meaningless.
    if (nan) throw std::runtime_error("splitting: a path's score is not a number");
    level[i] = top;
    if (peak) {
      double* m = peaks.data() + i * points;
      double v = from > 0 ? m[from - 1] : kLowest;
      for (std::size_t k = from; k <= steps; ++k) {
        v = std::max(v, plain[k]);
        m[k] = v;
      }
      value[i] = v;
    } else {
      value[i] = plain[steps];
    }
  };

  std::vector<std::int64_t> rows(n), starts(n, 0);
  std::vector<std::uint64_t> streams(n);
  for (std::size_t i = 0; i < n; ++i) {
    double* row = states.data() + i * points * 3;
    row[0] = run.v0;
    row[1] = run.u0;
    row[2] = 0.0;
    rows[i] = static_cast<std::int64_t>(i);
    streams[i] = base + i;
  }
  extend_rows_in_lanes(states.data(), lanes, rows.data(), starts.data(), streams.data(), n,
                       run.key, run.threads);
  for (std::size_t i = 0; i < n; ++i) rescore(i, 0);

  SplitOutcome out;
  out.estimates.assign(run.level_count, std::numeric_limits<double>::quiet_NaN());
  std::vector<std::size_t> order(run.level_count);
  std::iota(order.begin(), order.end(), std::size_t(0));
  std::stable_sort(order.begin(), order.end(),
                   [&](std::size_t a, std::size_t b) { return run.levels[a] < run.levels[b]; });
  std::uint64_t branches = n;
  out.steps = static_cast<std::int64_t>(n * steps);
  std::size_t done = 0;
  std::vector<double> sorted(n);
  std::vector<std::int64_t> killed, survivors, picks;
  killed.reserve(n);
  survivors.reserve(n);
  for (;;) {
    if (run.cancelled && run.cancelled()) throw Cancelled();
    if (run.has_deadline) {
      const double now =
          std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count();
      if (now > run.deadline) {
        out.timed_out = true;
        return out;
      }
    }
    std::copy(level.begin(), level.end(), sorted.begin());
    std::nth_element(sorted.begin(), sorted.begin() + static_cast<long>(run.kill - 1), sorted.end());
    const double z = sorted[run.kill - 1];
    while (done < order.size() && run.thresholds[order[done]] <= z) {
      std::size_t above = 0;
      for (std::size_t i = 0; i < n; ++i) above += value[i] > run.levels[order[done]];
      out.estimates[order[done]] = std::exp(out.log_weight) * (double(above) / double(n));
      ++done;
    }
    if (done == order.size()) break;
    killed.clear();
    survivors.clear();
    for (std::size_t i = 0; i < n; ++i) {
      if (level[i] <= z) killed.push_back(static_cast<std::int64_t>(i));
      if (level[i] > z) survivors.push_back(static_cast<std::int64_t>(i));
    }
    if (killed.size() == n) {
      for (std::size_t j = done; j < order.size(); ++j) out.estimates[order[j]] = 0.0;
      out.extinct = true;
      break;
    }
    if (out.iterations >= run.max_iterations)
      throw std::runtime_error("splitting did not reach the level after " +
                               std::to_string(out.iterations) + " iterations");
    out.log_weight += std::log1p(-double(killed.size()) / double(n));
    const std::size_t kc = killed.size();
    picks.resize(kc);
    split_parents(run.key, run.replica, static_cast<std::uint64_t>(out.iterations),
                  survivors.size(), kc, picks.data());
    starts.resize(kc);
    streams.resize(kc);
    for (std::size_t j = 0; j < kc; ++j) {
      const std::size_t parent = static_cast<std::size_t>(survivors[static_cast<std::size_t>(picks[j])]);
      const std::size_t child = static_cast<std::size_t>(killed[j]);
      // The first point from `first` on where the parent's score exceeds z (it has one: its
      // level is above z).
      const double* r = reach.data() + parent * points;
      const std::size_t b =
          static_cast<std::size_t>(std::upper_bound(r + run.first, r + points, z) - r);
      starts[j] = static_cast<std::int64_t>(b);
      streams[j] = base + branches + j;
      // What the child reads of its parent: the state it continues from, and the scores before
      // it (the path maxima; the branch points of later clones). The states before it are
      // never read again.
      std::copy_n(states.data() + (parent * points + b) * 3, 3, states.data() + (child * points + b) * 3);
      std::copy_n(reach.data() + parent * points, b, reach.data() + child * points);
      if (peak) std::copy_n(peaks.data() + parent * points, b, peaks.data() + child * points);
      out.steps += static_cast<std::int64_t>(steps - b);
    }
    extend_rows_in_lanes(states.data(), lanes, killed.data(), starts.data(), streams.data(), kc,
                         run.key, run.threads);
    for (std::size_t j = 0; j < kc; ++j)
      rescore(static_cast<std::size_t>(killed[j]), static_cast<std::size_t>(starts[j]));
    branches += kc;
    ++out.iterations;
  }
  return out;
}

}  // namespace crandall
