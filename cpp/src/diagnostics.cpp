#include "crandall/diagnostics.hpp"

#include <omp.h>

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "crandall/dispatch.hpp"
#include "crandall/kernel.hpp"
#include "crandall/rng.hpp"
#include "crandall/run.hpp"
#include "crandall/exact_step.hpp"

namespace crandall {

double random_floor(std::uint64_t paths, std::uint64_t steps, std::uint64_t seed, int threads) {
  const int team = thread_count(threads, double(paths) * double(steps));
  const long groups = static_cast<long>((paths + kLanes - 1) / kLanes);
  const KernelTable& kernel = active_kernel();
  double total = 0.0;
#pragma omp parallel for schedule(static) reduction(+ : total) num_threads(team)
  for (long g = 0; g < groups; ++g)
    total += kernel.noise_checksum(seed, static_cast<std::uint64_t>(g) * kLanes, steps);
  return total;
}

BuildInfo build_info() {
  const KernelTable& k = active_kernel();
  BuildInfo b;
  b.isa = k.name;
  b.philox_paths_per_register = k.philox_paths_per_register;
  b.doubles_per_register = k.doubles_per_register;
  for (const KernelTable* c : compiled_kernels()) b.isa_compiled.emplace_back(c->name);
  b.isa_available = available_kernels();
  b.random_stream = kRandomStream;
  b.compiler = __VERSION__;
  return b;
}

std::vector<double> simulate_states(const Plan& plan) {
  const Options& o = plan.options();
  if (o.method != Method::exact && o.method != Method::euler)
    throw std::invalid_argument("simulate_states: method must be 'exact' or 'euler'");
  if (o.filtered()) throw std::invalid_argument("simulate_states: white noise only (use filtered_trajectory)");
  std::vector<double> out(o.paths);
  const BlockFn block_fn = active_kernel().block_fn(o.method, false, false, false, false);
  Workspace ws(plan);
  ws.states = out.data();
  for (std::uint64_t start = 0; start < o.paths; start += kBlockPaths) {
    ws.reset();
    block_fn(plan, start, std::min<std::uint64_t>(kBlockPaths, o.paths - start), ws);
  }
  return out;
}

std::vector<double> draw_noise(std::uint64_t seed, std::uint64_t path0, std::uint64_t count,
                               std::uint64_t pair) {
  if (count < 1 || count > (std::uint64_t{1} << 24))
    throw std::invalid_argument("count must be between 1 and 2^24");
  std::vector<double> out(6 * count);
  active_kernel().draw(seed, path0, pair, count, out.data());
  return out;
}

std::vector<double> exact_steps(const std::vector<double>& start, double step, double drift,
                                double noise, std::uint64_t seed) {
  // `h` is the step's name in the Python signature (crandall._core.exact_steps).
  if (!(std::isfinite(step) && step > 0.0)) throw std::invalid_argument("h must be finite and > 0");
  validate_model(drift, noise);
  if (!step_in_range(step, drift, noise))
    throw std::invalid_argument("h is too long for this drift and noise: the step would exceed the range of doubles");
  std::vector<double> out(start.size());
  for (std::size_t i = 0; i < start.size(); ++i) {
    if (!std::isfinite(start[i])) throw std::invalid_argument("start must be finite");
    StepNoise z[2];
    draw_pair(seed, i, 0, z);
    out[i] = exact_step(start[i], step, drift, noise, z[0].normal, z[0].exponential, z[0].coin).velocity;
  }
  return out;
}

}  // namespace crandall
