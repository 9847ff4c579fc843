#include "crandall/run.hpp"

#include <omp.h>

#if defined(__AVX__) && defined(__GLIBC__) && defined(__x86_64__)
#include <immintrin.h>
#define CRANDALL_LIBMVEC 1
// glibc's libmvec (pulled in by libm's linker script): the widest variants of log, sin and cos
// the build's instruction set allows. The AVX variant (c) runs the SSE code twice; the AVX2
// (d) and AVX-512 (e) variants are native and 2-3 times faster. The variants round a few
// values differently, one more reason a seed's numbers belong to a build.
#if defined(__AVX512F__)
using VecD = __m512d;
constexpr int kMathWidth = 8;
extern "C" __m512d _ZGVeN8v_log(__m512d);
extern "C" __m512d _ZGVeN8v_sin(__m512d);
extern "C" __m512d _ZGVeN8v_cos(__m512d);
inline VecD vec_load(const double* p) { return _mm512_loadu_pd(p); }
inline void vec_store(double* p, VecD v) { _mm512_storeu_pd(p, v); }
inline VecD vec_log(VecD v) { return _ZGVeN8v_log(v); }
inline VecD vec_sin(VecD v) { return _ZGVeN8v_sin(v); }
inline VecD vec_cos(VecD v) { return _ZGVeN8v_cos(v); }
#elif defined(__AVX2__)
using VecD = __m256d;
constexpr int kMathWidth = 4;
extern "C" __m256d _ZGVdN4v_log(__m256d);
extern "C" __m256d _ZGVdN4v_sin(__m256d);
extern "C" __m256d _ZGVdN4v_cos(__m256d);
inline VecD vec_load(const double* p) { return _mm256_loadu_pd(p); }
inline void vec_store(double* p, VecD v) { _mm256_storeu_pd(p, v); }
inline VecD vec_log(VecD v) { return _ZGVdN4v_log(v); }
inline VecD vec_sin(VecD v) { return _ZGVdN4v_sin(v); }
inline VecD vec_cos(VecD v) { return _ZGVdN4v_cos(v); }
#else
using VecD = __m256d;
constexpr int kMathWidth = 4;
extern "C" __m256d _ZGVcN4v_log(__m256d);
extern "C" __m256d _ZGVcN4v_sin(__m256d);
extern "C" __m256d _ZGVcN4v_cos(__m256d);
inline VecD vec_load(const double* p) { return _mm256_loadu_pd(p); }
inline void vec_store(double* p, VecD v) { _mm256_storeu_pd(p, v); }
inline VecD vec_log(VecD v) { return _ZGVcN4v_log(v); }
inline VecD vec_sin(VecD v) { return _ZGVcN4v_sin(v); }
inline VecD vec_cos(VecD v) { return _ZGVcN4v_cos(v); }
#endif
#endif

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <exception>
#include <map>
#include <memory>
#include <mutex>

#include "crandall/kernel.hpp"

namespace crandall {
namespace {

using BlockFn = void (*)(const Plan&, std::uint64_t, std::uint64_t, Workspace&);

template <Method M>
BlockFn pick_for(bool disp, bool dist) {
  if (disp && dist) return &simulate_block<M, true, true>;
  if (disp) return &simulate_block<M, true, false>;
  if (dist) return &simulate_block<M, false, true>;
  return &simulate_block<M, false, false>;
}

BlockFn pick(Method m, bool disp, bool dist) {
  switch (m) {
    case Method::exact: return pick_for<Method::exact>(disp, dist);
    case Method::euler: return pick_for<Method::euler>(disp, dist);
    case Method::richardson: return pick_for<Method::richardson>(disp, dist);
    case Method::richardson2: return pick_for<Method::richardson2>(disp, dist);
    case Method::refine: return pick_for<Method::refine>(disp, dist);
  }
  throw std::logic_error("run_chunk: unknown method");
}

struct BlockOut {
  BlockSums times, stop;
  std::vector<BlockSums> coarse_times, coarse_stop;
};

}  // namespace

void log_n(const double* in, double* out, int n) {
  int i = 0;
#ifdef CRANDALL_LIBMVEC
  constexpr int W = kMathWidth;
  for (; i + W <= n; i += W) vec_store(out + i, vec_log(vec_load(in + i)));
  if (i < n) {
    // The tail goes through the same vector function (padded), so the value of a draw does
    // not depend on where it sits in a batch.
    double a[W], b[W];
    for (int j = 0; j < W; ++j) a[j] = i + j < n ? in[i + j] : 1.0;
    vec_store(b, vec_log(vec_load(a)));
    for (int j = i; j < n; ++j) out[j] = b[j - i];
    return;
  }
#endif
  for (; i < n; ++i) out[i] = std::log(in[i]);
}

void sincos_n(const double* in, double* sin_out, double* cos_out, int n) {
  int i = 0;
#ifdef CRANDALL_LIBMVEC
  constexpr int W = kMathWidth;
  for (; i + W <= n; i += W) {
    const VecD v = vec_load(in + i);
    vec_store(sin_out + i, vec_sin(v));
    vec_store(cos_out + i, vec_cos(v));
  }
  if (i < n) {
    double a[W], b[W], c[W];
    for (int j = 0; j < W; ++j) a[j] = i + j < n ? in[i + j] : 0.0;
    const VecD v = vec_load(a);
    vec_store(b, vec_sin(v));
    vec_store(c, vec_cos(v));
    for (int j = i; j < n; ++j) {
      sin_out[j] = b[j - i];
      cos_out[j] = c[j - i];
    }
    return;
  }
#endif
  for (; i < n; ++i) {
    sin_out[i] = std::sin(in[i]);
    cos_out[i] = std::cos(in[i]);
  }
}

double random_floor(std::uint64_t paths, std::uint64_t steps, std::uint64_t seed, int threads) {
  if (threads < 0) throw std::invalid_argument("threads must be >= 0");
  const long groups = static_cast<long>((paths + kLanes - 1) / kLanes);
  double total = 0.0;
#pragma omp parallel for schedule(static) reduction(+ : total) num_threads(threads > 0 ? threads : omp_get_max_threads())
  for (long g = 0; g < groups; ++g) {
    PairNoise<kLanes> z;
    double acc = 0.0;
    for (std::uint64_t pair = 0; 2 * pair < steps; ++pair) {
      draw_pairs<kLanes>(seed, static_cast<std::uint64_t>(g) * kLanes, pair, kLanes, z);
      for (int l = 0; l < kLanes; ++l)
        acc += z.normal[0][l] + z.normal[1][l] + z.exponential[0][l] + z.exponential[1][l] +
               z.coin[0][l];
    }
    total += acc;
  }
  return total;
}

ChunkResult run_chunk(const Plan& plan, std::uint64_t chunk, int threads,
                      const InterruptCheck& interrupted) {
  if (threads < 0) throw std::invalid_argument("threads must be >= 0");
  const Options& o = plan.options();
  const std::uint64_t first = chunk * kChunkPaths;
  const std::uint64_t count = plan.chunk_paths(chunk);
  const long blocks = static_cast<long>((count + kBlockPaths - 1) / kBlockPaths);
  const BlockFn block_fn = pick(o.method, o.displacement, o.distance);
  const int grids = o.integrals() ? richardson_levels(o.method) : 1;
  ChunkResult result{Moments(o.times.size()), Moments(o.stop ? 1 : 0)};
  std::vector<ChunkResult> coarse_result(
      static_cast<std::size_t>(grids - 1), ChunkResult{Moments(o.times.size()), Moments(o.stop ? 1 : 0)});
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
  BuildInfo b;
  b.philox_paths_per_register = detail::kPhiloxWidth;
#ifdef CRANDALL_LIBMVEC
  b.math_values_per_call = kMathWidth;
#else
  b.math_values_per_call = 1;
#endif
#if defined(__AVX512F__)
  b.isa = "avx512f";
#elif defined(__AVX2__)
  b.isa = "avx2";
#elif defined(__AVX__)
  b.isa = "avx";
#else
  b.isa = "baseline";
#endif
#if defined(__FMA__)
  b.isa += "+fma";
#endif
  b.compiler = __VERSION__;
  return b;
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
