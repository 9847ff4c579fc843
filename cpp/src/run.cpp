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
  BlockSums peaks, peaks_stop;
};

ChunkResult empty_result(const Options& o) {
  ChunkResult r;
  r.times = Moments(o.times.size());
  r.stop = Moments(o.stop ? 1 : 0);
  r.peaks = Moments(o.peaks ? o.times.size() : 0);
  r.peaks_stop = Moments(o.peaks && o.stop ? 1 : 0);
  return r;
}

}  // namespace

int thread_count(int threads) {
  if (threads < 0) throw std::invalid_argument("threads must be >= 0");
  return threads > 0 ? threads : omp_get_max_threads();
}

ChunkResult run_chunk(const Plan& plan, std::uint64_t chunk, int threads,
                      const CancelCheck& cancel) {
  const int team = thread_count(threads);
  const Options& o = plan.options();
  const std::uint64_t first = chunk * kChunkPaths;
  const std::uint64_t count = plan.chunk_paths(chunk);
  const long blocks = static_cast<long>((count + kBlockPaths - 1) / kBlockPaths);
  const BlockFn block_fn = active_kernel().block_fn(o.method, o.displacement, o.distance, o.peaks);
  const int coupled = o.grids();
  ChunkResult result = empty_result(o);
  std::vector<ChunkResult> coarse_result(static_cast<std::size_t>(coupled - 1), empty_result(o));
  // The threads' histograms, added up as each thread finishes (integer counts: any order).
  Histograms histograms(plan.recorded_axes());
  std::atomic<bool> cancelled{false};
  std::atomic<long> next_claim{0}, finished{0};
  std::exception_ptr error;
  std::mutex error_mutex, merge_mutex, done_mutex;
  std::condition_variable done;  // signalled when the last block finishes or the run fails
  std::map<long, BlockOut> pending;
  long next_block = 0;
  if (cancel && cancel()) throw Cancelled();  // a request already pending

  // No exception may leave an OpenMP region (that terminates the process): every one is
  // caught here, the run is cancelled, and the first is rethrown on the calling thread.
  auto fail = [&](std::exception_ptr e) noexcept {
    {
      std::lock_guard<std::mutex> lock(error_mutex);
      if (!error) error = e;
    }
    cancelled.store(true);
    std::lock_guard<std::mutex> lock(done_mutex);
    done.notify_all();
  };
  // Only the calling thread runs the check (Python handles signals on its main thread); the
  // others read the flag it sets. Polled between blocks and every kPollSteps steps in a block.
  auto poll = [&]() noexcept {
    if (cancel && !cancelled.load()) {
      try {
        if (cancel()) cancelled.store(true);
      } catch (...) {
        fail(std::current_exception());
      }
    }
    return cancelled.load();
  };

#pragma omp parallel num_threads(team)
  {
    const bool caller = omp_get_thread_num() == 0;
    std::unique_ptr<Workspace> ws;
    try {
      ws = std::make_unique<Workspace>(plan);
      if (caller)
        ws->cancelled = poll;
      else
        ws->cancelled = [&cancelled]() { return cancelled.load(std::memory_order_relaxed); };
    } catch (...) {
      fail(std::current_exception());
    }
    // Blocks are claimed in order from a shared counter; finished ones wait in `pending` until
    // every earlier block is merged, so the merge order is the block order whatever the
    // threads do.
    while (ws && !ws->cancelled()) {
      const long b = next_claim.fetch_add(1);
      if (b >= blocks) break;
      try {
        ws->reset();
        const std::uint64_t start = first + static_cast<std::uint64_t>(b) * kBlockPaths;
        const std::uint64_t n = std::min<std::uint64_t>(kBlockPaths, first + count - start);
        block_fn(plan, start, n, *ws);
        if (ws->cancelled()) break;
        std::lock_guard<std::mutex> lock(merge_mutex);
        pending.emplace(b, BlockOut{ws->times, ws->stop, ws->coarse_times, ws->coarse_stop,
                                    ws->peaks, ws->peaks_stop});
        for (auto it = pending.begin(); it != pending.end() && it->first == next_block;
             it = pending.erase(it), ++next_block) {
          it->second.times.merge_into(result.times);
          it->second.stop.merge_into(result.stop);
          it->second.peaks.merge_into(result.peaks);
          it->second.peaks_stop.merge_into(result.peaks_stop);
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
      // than cores with this one descheduled): keep checking for a cancel request until they are
      // done instead of waiting for them at the end of the region.
      while (!poll()) {
        std::unique_lock<std::mutex> lock(done_mutex);  // not held while polling: fail() takes it
        if (finished.load() >= blocks || cancelled.load()) break;
        done.wait_for(lock, std::chrono::milliseconds(10));
      }
    }
    if (ws && plan.histograms() && !cancelled.load()) {
      try {
        std::lock_guard<std::mutex> lock(merge_mutex);
        histograms.merge(ws->histograms);
      } catch (...) {
        fail(std::current_exception());
      }
    }
  }
  if (error) std::rethrow_exception(error);
  if (cancelled.load()) throw Cancelled();
  if (next_block != blocks) throw std::logic_error("run_chunk: a block was not merged");
  if (coupled > 1) {
    // Extrapolation to a zero step over the coupled grids (docs/methods/richardson.md). Linear in
    // the raw sums, so extrapolated chunks still merge exactly.
    std::vector<const Moments*> times{&result.times}, stop{&result.stop};
    for (const auto& c : coarse_result) {
      times.push_back(&c.times);
      stop.push_back(&c.stop);
    }
    const auto w = richardson_weights(o.method);
    // The peaks and the histograms stay those of the fine grid.
    result.times = combine(times, w);
    result.stop = combine(stop, w);
  }
  result.histogram_counts.resize(o.histogram_axes.size());
  for (std::size_t i = 0; i < o.histogram_axes.size(); ++i) {
    const long h = plan.histogram_slot(i / kHistogramVariables, static_cast<int>(i % kHistogramVariables));
    if (h < 0) continue;
    const std::uint64_t* c = histograms.slot_counts(static_cast<std::size_t>(h));
    result.histogram_counts[i].assign(c, c + histograms.axis(static_cast<std::size_t>(h)).cells());
  }
  return result;
}

}  // namespace crandall
