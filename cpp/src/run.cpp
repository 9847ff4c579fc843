#include "crandall/run.hpp"

#include <omp.h>

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <exception>
#include <map>
#include <memory>
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
  const int coupled = o.grids();
  ChunkResult result{Moments(o.times.size()), Moments(o.stop ? 1 : 0)};
  std::vector<ChunkResult> coarse_result(
      static_cast<std::size_t>(coupled - 1), ChunkResult{Moments(o.times.size()), Moments(o.stop ? 1 : 0)});
  std::atomic<bool> stop_flag{false};
  std::atomic<long> next_claim{0}, finished{0};
  std::exception_ptr error;
  std::mutex error_mutex, merge_mutex, done_mutex;
  std::condition_variable done;  // signalled when the last block finishes or the run fails
  std::map<long, BlockOut> pending;
  long next_block = 0;
  const int team = threads > 0 ? threads : omp_get_max_threads();
  if (interrupted && interrupted()) throw Interrupted();  // a request already pending

  // No exception may leave an OpenMP region (that terminates the process): every one is
  // caught here, the run is abandoned, and the first is rethrown on the calling thread.
  auto fail = [&](std::exception_ptr e) noexcept {
    {
      std::lock_guard<std::mutex> lock(error_mutex);
      if (!error) error = e;
    }
    stop_flag.store(true);
    std::lock_guard<std::mutex> lock(done_mutex);
    done.notify_all();
  };
  // Only the calling thread runs the check (Python handles signals on its main thread); the
  // others read the flag it sets. Polled between blocks and every kPollSteps steps in a block.
  auto poll = [&]() noexcept {
    if (interrupted && !stop_flag.load()) {
      try {
        if (interrupted()) stop_flag.store(true);
      } catch (...) {
        fail(std::current_exception());
      }
    }
    return stop_flag.load();
  };

#pragma omp parallel num_threads(team)
  {
    const bool caller = omp_get_thread_num() == 0;
    std::unique_ptr<Workspace> ws;
    try {
      ws = std::make_unique<Workspace>(plan);
      if (caller)
        ws->abandon = poll;
      else
        ws->abandon = [&stop_flag]() { return stop_flag.load(std::memory_order_relaxed); };
    } catch (...) {
      fail(std::current_exception());
    }
    // Blocks are claimed in order from a shared counter; finished ones wait in `pending` until
    // every earlier block is merged, so the merge order is the block order whatever the
    // threads do.
    while (ws && !ws->abandon()) {
      const long b = next_claim.fetch_add(1);
      if (b >= blocks) break;
      try {
        ws->reset();
        const std::uint64_t start = first + static_cast<std::uint64_t>(b) * kBlockPaths;
        const std::uint64_t n = std::min<std::uint64_t>(kBlockPaths, first + count - start);
        block_fn(plan, start, n, *ws);
        if (ws->abandon()) break;
        std::lock_guard<std::mutex> lock(merge_mutex);
        pending.emplace(b, BlockOut{ws->times, ws->stop, ws->coarse_times, ws->coarse_stop});
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
        fail(std::current_exception());
        break;
      }
      if (finished.fetch_add(1) + 1 == blocks) {
        std::lock_guard<std::mutex> lock(done_mutex);
        done.notify_all();
      }
    }
    if (caller) {
      // The other threads may still be running blocks (a single long block, or more threads
      // than cores with this one descheduled): keep checking for an interrupt until they are
      // done instead of waiting for them at the end of the region.
      while (!poll()) {
        std::unique_lock<std::mutex> lock(done_mutex);  // not held while polling: fail() takes it
        if (finished.load() >= blocks || stop_flag.load()) break;
        done.wait_for(lock, std::chrono::milliseconds(10));
      }
    }
  }
  if (error) std::rethrow_exception(error);
  if (stop_flag.load()) throw Interrupted();
  if (next_block != blocks) throw std::logic_error("run_chunk: a block was not merged");
  if (coupled > 1) {
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
  if (!step_in_range(h, drift, noise))
    throw std::invalid_argument("h is too long for this drift and noise: the step would exceed the range of doubles");
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
