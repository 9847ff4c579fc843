#include "crandall/levels.hpp"

#include <omp.h>

#include <algorithm>
#include <memory>
#include <stdexcept>

#include "crandall/dispatch.hpp"
#include "crandall/filtered.hpp"
#include "crandall/kernel.hpp"
#include "crandall/kernel_controls.hpp"
#include "crandall/team.hpp"

namespace crandall {

int control_count() { return kControls; }
int white_control_count() { return kWhiteControls; }

void run_samples(const Plan& plan, std::uint64_t first, std::uint64_t count, int threads,
                 double* out, double* controls_out, const CancelCheck& cancel,
                 const std::vector<std::size_t>& control_slots) {
  const Options& o = plan.options();
  if (count == 0 || first >= o.paths || count > o.paths - first)
    throw std::invalid_argument("run_samples: paths [first, first + count) must lie in the plan's paths");
  if (count > (std::uint64_t{1} << 24)) throw std::invalid_argument("run_samples: count must be <= 2^24");
  const int team = thread_count(threads, double(count) * double(plan.steps_per_path()));
  const std::size_t slots = o.sample_slots();
  const int grids = o.grids();
  BlockFn block_fn = active_kernel().block_fn(o.method, o.displacement, o.distance, o.peaks,
                                              o.quadratic_variation);
  std::vector<double> means;
  if (o.filtered()) {
    block_fn = &simulate_filtered_block;
    if (controls_out) means = ground_feature_means(plan);
  } else if (controls_out) {
    if (o.method != Method::exact || !o.integrals())
      throw std::invalid_argument("run_samples: controls need the exact method and an observed integral");
    block_fn = active_kernel().controls_fn(o.displacement, o.distance, o.quadratic_variation);
  }
  // Control sums belong to the output times and the stop (not the quadratic variation's slot).
  const std::size_t outputs = o.times.size() + (o.stop ? 1 : 0);
  std::vector<std::size_t> chosen(control_slots);
  if (chosen.empty())
    for (std::size_t j = 0; j < outputs; ++j) chosen.push_back(j);
  for (std::size_t a = 0; a < chosen.size(); ++a)
    if (chosen[a] >= outputs || (a > 0 && chosen[a] <= chosen[a - 1]))
      throw std::invalid_argument("run_samples: control_slots must be ascending, distinct slots");
  const long blocks = static_cast<long>((count + kBlockPaths - 1) / kBlockPaths);
  // Every path writes only its own values, so the order in which blocks are claimed does not
  // matter; the shared team polls the cancel check inside long blocks too.
  run_team(
      team, blocks, cancel,
      [&]() {
        auto ws = std::make_unique<Workspace>(plan);
        ws->samples = out;
        ws->sample_first = first;
        ws->sample_slots = slots;
        ws->sample_grids = grids;
        ws->controls = controls_out;
        ws->control_slots = chosen;
        ws->control_means = means;
        return ws;
      },
      [&](Workspace& ws, long b) {
        const std::uint64_t start = first + static_cast<std::uint64_t>(b) * kBlockPaths;
        block_fn(plan, start, std::min<std::uint64_t>(kBlockPaths, first + count - start), ws);
        return true;
      },
      [](Workspace&) {});
}

std::size_t sample_size(const Plan& plan) {
  const Options& o = plan.options();
  return o.sample_slots() * static_cast<std::size_t>(o.grids()) * 3;
}

namespace {

double column_value(const double* path, int grids, int grid, const FeatureColumns& c,
                    std::size_t j, double two_drift) {
  const int kind = c.kind[j];
  double x = kind == 3 ? 0.0
                       : path[(static_cast<std::size_t>(c.slot[j]) * grids + grid) * 3 +
                              static_cast<std::size_t>(c.variable[j])];
  double v = kind == 0   ? x
             : kind == 1 ? x * x
             : kind == 4 ? std::abs(x)
             : kind == 5 ? c.constant[j] * x
                         : (c.constant[j] - x * x) / two_drift;
  v = v - c.centre[j];
  return c.power[j] == 2 ? v * v : v;
}

}  // namespace

void form_features(const double* samples, std::uint64_t rows, std::uint64_t slots, int grids,
                   const FeatureColumns& c, double two_drift, int level, double* out,
                   const double* controls, std::uint64_t control_slots, int threads) {
  const std::size_t cols = c.slot.size();
  if (c.variable.size() != cols || c.kind.size() != cols || c.power.size() != cols ||
      c.constant.size() != cols || c.centre.size() != cols || c.inexact.size() != cols)
    throw std::invalid_argument("form_features: every column needs each field");
  if (grids < (level > 0 ? 2 : 1))
    throw std::invalid_argument("form_features: a finer level needs the coarse grid's samples");
  const auto k = static_cast<std::size_t>(kControls);
  const bool subtract = controls != nullptr && level == 0;
  if (subtract && (c.control.size() != cols || c.beta.size() != cols * k))
    throw std::invalid_argument("form_features: one control slot and k coefficients per column");
  for (std::size_t j = 0; j < cols; ++j) {
    if (c.slot[j] < 0 || static_cast<std::uint64_t>(c.slot[j]) >= slots || c.variable[j] < 0 ||
        c.variable[j] > 2 || c.kind[j] < 0 || c.kind[j] > 5 || (c.power[j] != 1 && c.power[j] != 2))
      throw std::invalid_argument("form_features: a column's slot, variable, kind or power is out of range");
    if (subtract && (c.control[j] < 0 || static_cast<std::uint64_t>(c.control[j]) >= control_slots))
      throw std::invalid_argument("form_features: a column's control slot is out of range");
  }
  const std::size_t path_size = static_cast<std::size_t>(slots) * static_cast<std::size_t>(grids) * 3;
  const int team = thread_count(threads, double(rows) * double(cols) / kValuesPerStep);
#pragma omp parallel for schedule(static) num_threads(team)
  for (std::int64_t r = 0; r < static_cast<std::int64_t>(rows); ++r) {
    const double* path = samples + static_cast<std::size_t>(r) * path_size;
    double* row = out + static_cast<std::size_t>(r) * cols;
    if (level == 0) {
      for (std::size_t j = 0; j < cols; ++j) row[j] = column_value(path, grids, 0, c, j, two_drift);
      if (!subtract) continue;
      const double* sums = controls + static_cast<std::size_t>(r) * control_slots * k;
      for (std::size_t j = 0; j < cols; ++j) {
        const double* cj = sums + static_cast<std::size_t>(c.control[j]) * k;
        const double* b = c.beta.data() + j * k;
        double v = row[j];
        for (std::size_t q = 0; q < k; ++q) v -= b[q] * cj[q];
        row[j] = v;
      }
    } else {
      for (std::size_t j = 0; j < cols; ++j)
        row[j] = c.inexact[j] ? column_value(path, grids, 0, c, j, two_drift) -
                                    column_value(path, grids, 1, c, j, two_drift)
                              : 0.0;
    }
  }
}

std::vector<double> sum_products(const double* values, std::uint64_t rows, std::uint64_t cols,
                                 const std::vector<int>& widths, int threads) {
  std::uint64_t covered = 0;
  std::size_t width = 0;
  for (int w : widths) {
    if (w < 1 || w > 32) throw std::invalid_argument("sum_products: group widths must be 1 to 32");
    covered += static_cast<std::uint64_t>(w);
    width += static_cast<std::size_t>(w + w * (w + 1) / 2);
  }
  if (covered != cols) throw std::invalid_argument("sum_products: the group widths must add up to the columns");
  const std::uint64_t block = 256;
  const long blocks = static_cast<long>((rows + block - 1) / block);
  std::vector<double> partial(static_cast<std::size_t>(blocks) * width, 0.0);
  const int team = thread_count(threads, double(rows) * double(width) / kValuesPerStep);
#pragma omp parallel for schedule(static) num_threads(team)
  for (long b = 0; b < blocks; ++b) {
    double* acc = partial.data() + static_cast<std::size_t>(b) * width;
    const std::uint64_t end = std::min<std::uint64_t>(rows, (static_cast<std::uint64_t>(b) + 1) * block);
    for (std::uint64_t r = static_cast<std::uint64_t>(b) * block; r < end; ++r) {
      const double* f = values + r * cols;
      std::size_t k = 0;
      for (int w : widths) {
        for (int i = 0; i < w; ++i) acc[k++] += f[i];
        for (int i = 0; i < w; ++i)
          for (int j = i; j < w; ++j) acc[k++] += f[i] * f[j];
        f += w;
      }
    }
  }
  std::vector<double> total(width, 0.0);
  for (long b = 0; b < blocks; ++b)
    for (std::size_t k = 0; k < width; ++k) total[k] += partial[static_cast<std::size_t>(b) * width + k];
  return total;
}

}  // namespace crandall
