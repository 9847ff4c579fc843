#include "crandall/branch.hpp"

#include <omp.h>

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>
#include <vector>

#include "crandall/coast.hpp"
#include "crandall/dispatch.hpp"
#include "crandall/exact_step.hpp"
#include "crandall/kernel.hpp"
#include "crandall/rng.hpp"
#include "crandall/run.hpp"

namespace crandall {

void validate_branch_grid(const BranchGrid& g) {
  for (std::size_t k = 0; k < g.steps; ++k) {
    if (!(std::isfinite(g.lengths[k]) && g.lengths[k] > 0.0))
      throw std::invalid_argument("lengths must be finite and > 0 (step " + std::to_string(k) + ")");
    if (!(std::isfinite(g.noises[k]) && g.noises[k] >= 0.0))
      throw std::invalid_argument("noises must be finite and >= 0 (step " + std::to_string(k) + ")");
    if (!std::isfinite(g.drifts[k]))
      throw std::invalid_argument("drifts must be finite (step " + std::to_string(k) + ")");
    if (!step_in_range(g.lengths[k], std::abs(g.drifts[k]), g.noises[k]))
      throw std::invalid_argument("lengths: step " + std::to_string(k) +
                                  " is too long for its drift and noise");
    if ((g.slow == nullptr) != (g.slow_drifts == nullptr))
      throw std::invalid_argument("slow and slow_drifts: give both or neither");
    if (g.slow != nullptr) {
      if (!(std::isfinite(g.slow[k]) && g.slow[k] >= 0.0))
        throw std::invalid_argument("slow must be finite and >= 0 (step " + std::to_string(k) + ")");
      if (!std::isfinite(g.slow_drifts[k]) ||
          !step_in_range(g.lengths[k], std::abs(g.slow_drifts[k]), g.noises[k]))
        throw std::invalid_argument("slow_drifts: step " + std::to_string(k) +
                                    " is not finite or too long for it");
    }
  }
}

namespace {

void extend_one(double* row, std::uint8_t* touched, const BranchGrid& g, std::size_t start,
                std::uint64_t stream, std::uint64_t key, std::size_t end) {
  double x = row[3 * start], u = row[3 * start + 1], s = row[3 * start + 2];
  StepNoise z[2];
  for (std::size_t k = start; k < end; ++k) {
    if (k == start || k % 2 == 0) draw_pair(key, stream, k / 2, z);
    const StepNoise& n = z[k % 2];
    const double len = g.lengths[k], c = g.drift(k, x), sigma = g.noises[k];
    if (sigma == 0.0 && c >= 0.0) {
      const State next = coast({x, u, s}, c, len);
      x = next.velocity;
      u = next.displacement;
      s = next.distance;
      if (touched != nullptr) touched[k] = 0;
    } else {
      const StepResult r = exact_step(x, len, c, sigma, n.normal, n.exponential, n.coin);
      const double x1 = r.velocity;
      if (touched != nullptr) touched[k] = r.touched ? 1 : 0;
      u += trapezoid(len, x, x1);
      s += trapezoid(len, std::abs(x), std::abs(x1));
      x = x1;
    }
    double* p = row + 3 * (k + 1);
    p[0] = x;
    p[1] = u;
    p[2] = s;
  }
}

}  // namespace

void validate_continued_rows(const double* states, std::size_t rows_total, std::size_t points,
                             std::size_t cols, const std::int64_t* rows,
                             const std::int64_t* starts, std::size_t count) {
  std::vector<char> seen(rows_total, 0);
  for (std::size_t i = 0; i < count; ++i) {
    if (rows[i] < 0 || static_cast<std::size_t>(rows[i]) >= rows_total)
      throw std::invalid_argument("rows: " + std::to_string(rows[i]) + " is not a row of states");
    if (seen[static_cast<std::size_t>(rows[i])]++)
      throw std::invalid_argument("rows: row " + std::to_string(rows[i]) + " is listed twice");
    if (starts[i] < 0 || static_cast<std::size_t>(starts[i]) >= points)
      throw std::invalid_argument("starts: " + std::to_string(starts[i]) + " is not a grid point");
    const double* p = states + (static_cast<std::size_t>(rows[i]) * points +
                                static_cast<std::size_t>(starts[i])) * cols;
    for (std::size_t c = 0; c < cols; ++c)
      if (!std::isfinite(p[c]))
        throw std::invalid_argument("states: the start state of row " + std::to_string(rows[i]) +
                                    " is not finite");
  }
}

void extend_paths(double* states, std::size_t rows_total, const BranchGrid& grid,
                  const std::int64_t* rows, const std::int64_t* starts,
                  const std::uint64_t* streams, std::size_t count, std::uint64_t key,
                  int threads, std::uint8_t* touched) {
  validate_branch_grid(grid);
  const std::size_t points = grid.steps + 1;
  validate_continued_rows(states, rows_total, points, 3, rows, starts, count);
  extend_rows(states, grid, rows, starts, streams, count, key, threads, touched);
}

void extend_rows(double* states, const BranchGrid& grid, const std::int64_t* rows,
                 const std::int64_t* starts, const std::uint64_t* streams, std::size_t count,
                 std::uint64_t key, int threads, std::uint8_t* touched) {
  const std::size_t points = grid.steps + 1;
  double work = 0.0;  // the steps to take: splitting extends a few short paths at a time
  for (std::size_t i = 0; i < count; ++i)
    work += double(grid.steps - static_cast<std::size_t>(starts[i]));
  const int team = thread_count(threads, work);
  const long n = static_cast<long>(count);
#pragma omp parallel for schedule(dynamic, 16) num_threads(team)
  for (long i = 0; i < n; ++i)
    extend_one(states + static_cast<std::size_t>(rows[i]) * points * 3,
               touched == nullptr ? nullptr
                                  : touched + static_cast<std::size_t>(rows[i]) * grid.steps,
               grid, static_cast<std::size_t>(starts[i]), streams[i], key, grid.steps);
}

LaneGridData::LaneGridData(const BranchGrid& g)
    : grid(g), mean(g.steps), scale(g.steps), twice_variance(g.steps), coast(g.steps) {
  if (g.slow != nullptr) throw std::invalid_argument("the lanes take no slow law");
  for (std::size_t k = 0; k < g.steps; ++k) {
    const StepConstants c = step_constants(g.lengths[k], g.drifts[k], g.noises[k]);
    mean[k] = c.mean;
    scale[k] = c.scale;
    twice_variance[k] = c.twice_variance;
    coast[k] = g.noises[k] == 0.0 && g.drifts[k] >= 0.0;
  }
}

LaneGrid LaneGridData::view() const {
  return {grid.lengths, grid.drifts, grid.noises, mean.data(), scale.data(),
          twice_variance.data(), coast.data(), grid.steps};
}

void extend_rows_in_lanes(double* states, const LaneGridData& data, const std::int64_t* rows,
                          const std::int64_t* starts, const std::uint64_t* streams,
                          std::size_t count, std::uint64_t key, int threads,
                          const KernelTable* kernel) {
  const KernelTable& table = kernel != nullptr ? *kernel : active_kernel();
  const BranchGrid& g = data.grid;
  const std::size_t points = g.steps + 1;
  // An odd start's first step alone (the second half of its pair); then every start is even.
  std::vector<std::size_t> order;
  std::vector<std::int64_t> even(count);
  order.reserve(count);
  double work = 0.0;
  for (std::size_t i = 0; i < count; ++i) {
    auto k = static_cast<std::size_t>(starts[i]);
    if (k % 2 == 1 && k < g.steps) {
      extend_one(states + static_cast<std::size_t>(rows[i]) * points * 3, nullptr, g, k,
                 streams[i], key, k + 1);
      ++k;
    }
    even[i] = static_cast<std::int64_t>(k);
    if (k < g.steps) {
      order.push_back(i);
      work += double(g.steps - k);
    }
  }
  // The longest first: the lanes' last rows are short ones.
  std::stable_sort(order.begin(), order.end(),
                   [&](std::size_t a, std::size_t b) { return even[a] < even[b]; });
  const std::size_t m = order.size();
  std::vector<std::int64_t> r(m), st(m);
  std::vector<std::uint64_t> sm(m);
  for (std::size_t j = 0; j < m; ++j) {
    r[j] = rows[order[j]];
    st[j] = even[order[j]];
    sm[j] = streams[order[j]];
  }
  const LaneGrid view = data.view();
  const int team = std::max(1, std::min(thread_count(threads, work), static_cast<int>(m)));
#pragma omp parallel for schedule(static, 1) num_threads(team) if (team > 1)
  for (int b = 0; b < team; ++b) {
    const std::size_t from = m * static_cast<std::size_t>(b) / static_cast<std::size_t>(team);
    const std::size_t to = m * static_cast<std::size_t>(b + 1) / static_cast<std::size_t>(team);
    table.extend_lanes(states, points, view, r.data() + from, st.data() + from, sm.data() + from,
                       static_cast<int>(to - from), key);
  }
  // The lanes end at the last even point: the last step of an odd grid alone.
  if (g.steps % 2 == 1)
    for (std::size_t j = 0; j < m; ++j)
      extend_one(states + static_cast<std::size_t>(r[j]) * points * 3, nullptr, g, g.steps - 1,
                 sm[j], key, g.steps);
}

}  // namespace crandall
