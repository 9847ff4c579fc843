#include "crandall/run.hpp"

#include <omp.h>

#include <atomic>
#include <exception>

#include "crandall/kernel.hpp"

namespace crandall {
namespace {

using BlockFn = void (*)(const Plan&, std::uint64_t, std::uint64_t, Workspace&);

template <Method M>
BlockFn pick(bool disp, bool dist) {
  if (disp && dist) return &simulate_block<M, true, true>;
  if (disp) return &simulate_block<M, true, false>;
  if (dist) return &simulate_block<M, false, true>;
  return &simulate_block<M, false, false>;
}

}  // namespace

ChunkResult run_chunk(const Plan& plan, std::uint64_t chunk, int threads,
                      const InterruptCheck& interrupted) {
  if (threads < 0) throw std::invalid_argument("threads must be >= 0");
  const Options& o = plan.options();
  const std::uint64_t first = chunk * kChunkPaths;
  const std::uint64_t count = plan.chunk_paths(chunk);
  const long blocks = static_cast<long>((count + kBlockPaths - 1) / kBlockPaths);
  const BlockFn block_fn = o.method == Method::exact ? pick<Method::exact>(o.displacement, o.distance)
                                                     : pick<Method::euler>(o.displacement, o.distance);
  ChunkResult result{Moments(o.times.size()), Moments(o.stop ? 1 : 0)};
  std::atomic<bool> stop_flag{false};
  std::exception_ptr error;
  const int team = threads > 0 ? threads : omp_get_max_threads();

#pragma omp parallel num_threads(team)
  {
    Workspace ws(plan);
    // static,1 with ordered: blocks of equal cost are handed out round-robin, and each is
    // merged as soon as all earlier blocks are, in block order.
#pragma omp for ordered schedule(static, 1)
    for (long b = 0; b < blocks; ++b) {
      if (omp_get_thread_num() == 0 && interrupted && !stop_flag.load()) {
        try {
          if (interrupted()) stop_flag.store(true);
        } catch (...) {
#pragma omp critical(crandall_error)
          if (!error) error = std::current_exception();
          stop_flag.store(true);
        }
      }
      const bool skip = stop_flag.load();
      if (!skip) {
        try {
          ws.times.reset();
          ws.stop.reset();
          const std::uint64_t start = first + static_cast<std::uint64_t>(b) * kBlockPaths;
          const std::uint64_t n = std::min<std::uint64_t>(kBlockPaths, first + count - start);
          block_fn(plan, start, n, ws);
        } catch (...) {
#pragma omp critical(crandall_error)
          if (!error) error = std::current_exception();
          stop_flag.store(true);
        }
      }
#pragma omp ordered
      {
        if (!stop_flag.load()) {
          ws.times.merge_into(result.times);
          ws.stop.merge_into(result.stop);
        }
      }
    }
  }
  if (error) std::rethrow_exception(error);
  if (stop_flag.load()) throw Interrupted();
  return result;
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
