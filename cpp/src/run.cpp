#include "crandall/run.hpp"

#include <omp.h>

#include <atomic>
#include <exception>
#include <map>
#include <mutex>

#include "crandall/dispatch.hpp"
#include "crandall/kernel.hpp"

namespace crandall {
namespace {

struct BlockOut {
  BlockSums times, stop;
  std::vector<BlockSums> coarse_times, coarse_stop;
};

}  // namespace

double random_floor(std::uint64_t paths, std::uint64_t steps, std::uint64_t seed, int threads) {
  if (threads < 0) throw std::invalid_argument("threads must be >= 0");
  const long groups = static_cast<long>((paths + kLanes - 1) / kLanes);
  const KernelTable& kernel = active_kernel();
  double total = 0.0;
#pragma omp parallel for schedule(static) reduction(+ : total) num_threads(threads > 0 ? threads : omp_get_max_threads())
  for (long g = 0; g < groups; ++g)
    total += kernel.noise_checksum(seed, static_cast<std::uint64_t>(g) * kLanes, steps);
  return total;
}

ChunkResult run_chunk(const Plan& plan, std::uint64_t chunk, int threads,
                      const InterruptCheck& interrupted) {
  if (threads < 0) throw std::invalid_argument("threads must be >= 0");
  const Options& o = plan.options();
  const std::uint64_t first = chunk * kChunkPaths;
  const std::uint64_t count = plan.chunk_paths(chunk);
  const long blocks = static_cast<long>((count + kBlockPaths - 1) / kBlockPaths);
  const BlockFn block_fn = active_kernel().block_fn(o.method, o.displacement, o.distance);
  const int grids = o.integrals() ? richardson_levels(o.method) : 1;
  ChunkResult result{Moments(o.times.size()), Moments(o.stop ? 1 : 0)};
  std::vector<ChunkResult> coarse_result(
      static_cast<std::size_t>(grids - 1), ChunkResult{Moments(o.times.size()), Moments(o.stop ? 1 : 0)});
  std::atomic<bool> stop_flag{false};
  std::exception_ptr error;
  std::mutex merge_mutex;
  std::map<long, BlockOut> pending;
  long next_block = 0;
  const int team = threads > 0 ? threads : omp_get_max_threads();
  if (interrupted && interrupted()) throw Interrupted();  // a request already pending

#pragma omp parallel num_threads(team)
  {
    Workspace ws(plan);
    const bool caller = omp_get_thread_num() == 0;
    // Only the calling thread may run the check (Python handles signals on its main thread).
    ws.abandon = [&, caller]() {
      if (caller && interrupted && !stop_flag.load()) {
        try {
          if (interrupted()) stop_flag.store(true);
        } catch (...) {
#pragma omp critical(crandall_error)
          if (!error) error = std::current_exception();
          stop_flag.store(true);
        }
      }
      return stop_flag.load();
    };
    // Blocks are handed out dynamically; finished ones wait in `pending` until every earlier
    // block is merged, so the merge order is the block order whatever the threads do, and no
    // thread ever blocks (the calling thread keeps polling for Ctrl-C).
#pragma omp for schedule(dynamic, 1)
    for (long b = 0; b < blocks; ++b) {
      if (ws.abandon()) continue;
      try {
        ws.reset();
        const std::uint64_t start = first + static_cast<std::uint64_t>(b) * kBlockPaths;
        const std::uint64_t n = std::min<std::uint64_t>(kBlockPaths, first + count - start);
        block_fn(plan, start, n, ws);
        if (ws.abandon()) continue;
        std::lock_guard<std::mutex> lock(merge_mutex);
        pending.emplace(b, BlockOut{ws.times, ws.stop, ws.coarse_times, ws.coarse_stop});
        for (auto it = pending.begin(); it != pending.end() && it->first == next_block;
             it = pending.erase(it), ++next_block) {
          it->second.times.merge_into(result.times);
          it->second.stop.merge_into(result.stop);
          for (std::size_t g = 0; g < coarse_result.size(); ++g) {
            it->second.coarse_times[g].merge_into(coarse_result[g].times);
            it->second.coarse_stop[g].merge_into(coarse_result[g].stop);
          }
        }
      } catch (...) {
#pragma omp critical(crandall_error)
        if (!error) error = std::current_exception();
        stop_flag.store(true);
      }
    }
  }
  if (error) std::rethrow_exception(error);
  if (stop_flag.load()) throw Interrupted();
  if (next_block != blocks) throw std::logic_error("run_chunk: a block was not merged");
  if (grids > 1) {
    // Extrapolation to h = 0 over the coupled grids (docs/methods/richardson.md). Linear in
    // the raw sums, so extrapolated chunks still merge exactly.
    std::vector<const Moments*> times{&result.times}, stop{&result.stop};
    for (const auto& c : coarse_result) {
      times.push_back(&c.times);
      stop.push_back(&c.stop);
    }
    const auto w = richardson_weights(o.method);
    ChunkResult combined{combine(times, w), combine(stop, w)};
    result = std::move(combined);
  }
  return result;
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
  std::vector<double> out(o.paths);
  const BlockFn block_fn = active_kernel().block_fn(o.method, false, false);
  Workspace ws(plan);
  ws.states = out.data();
  ws.states_first = 0;
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

std::vector<double> exact_steps(const std::vector<double>& start, double h, double drift,
                                double noise, std::uint64_t seed) {
  if (!(std::isfinite(h) && h > 0.0)) throw std::invalid_argument("h must be finite and > 0");
  if (!(std::isfinite(drift) && drift >= 0.0)) throw std::invalid_argument("drift must be finite and >= 0");
  if (!(std::isfinite(noise) && noise >= 0.0)) throw std::invalid_argument("noise must be finite and >= 0");
  std::vector<double> out(start.size());
  for (std::size_t i = 0; i < start.size(); ++i) {
    if (!std::isfinite(start[i])) throw std::invalid_argument("start must be finite");
    StepNoise z[2];
    draw_pair(seed, i, 0, z);
    out[i] = exact_step(start[i], h, drift, noise, z[0].normal, z[0].exponential, z[0].coin).velocity;
  }
  return out;
}

}  // namespace crandall
