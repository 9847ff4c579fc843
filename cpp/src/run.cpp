#include "crandall/run.hpp"

#include <omp.h>

#include <atomic>
#include <cmath>
#include <map>
#include <memory>
#include <mutex>

#include "crandall/dispatch.hpp"
#include "crandall/filtered.hpp"
#include "crandall/kernel.hpp"
#include "crandall/team.hpp"

namespace crandall {
namespace {

struct BlockOut {
  BlockSums times, stop;
  std::vector<BlockSums> coarse_times, coarse_stop;
  BlockSums peaks, peaks_stop;
  BlockSums energy;
};

ChunkResult empty_result(const Options& o) {
  ChunkResult r;
  r.times = Moments(o.times.size());
  r.stop = Moments(o.stop_slots());
  r.peaks = Moments(o.peaks ? o.times.size() : 0);
  r.peaks_stop = Moments(o.peaks && o.stop ? 1 : 0);
  r.energy = Moments(o.energy ? o.times.size() : 0);
  return r;
}

}  // namespace

namespace {
std::atomic<double> thread_work{kThreadWork};
}  // namespace

double set_thread_work(double steps) {
  if (!(std::isfinite(steps) && steps >= 1.0))
    throw std::invalid_argument("thread work must be finite and >= 1 step");
  return thread_work.exchange(steps);
}

int thread_count(int threads, double work) {
  if (threads < 0) throw std::invalid_argument("threads must be >= 0");
  const int asked = threads > 0 ? threads : omp_get_max_threads();
  const double useful = std::floor(work / thread_work.load());
  return useful < 1.0 ? 1 : useful < asked ? static_cast<int>(useful) : asked;
}

ChunkResult run_chunk(const Plan& plan, std::uint64_t chunk, int threads,
                      const CancelCheck& cancel) {
  const Options& o = plan.options();
  const std::uint64_t first = chunk * kChunkPaths;
  const std::uint64_t count = plan.chunk_paths(chunk);
  const int team = thread_count(threads, double(count) * double(plan.steps_per_path()));
  const long blocks = static_cast<long>((count + kBlockPaths - 1) / kBlockPaths);
  if (o.filtered() && o.method != Method::exact)
    throw std::invalid_argument(std::string("run_chunk: excitation 'filtered' needs method 'exact', got '") +
                                method_name(o.method) +
                                "' (Richardson's coupled grids are for run_samples' bias estimates)");
  // The quadratic variation is only recorded with run_samples' values: not integrated here.
  // The filtered excitation's loop is one scalar function for every CPU (filtered.hpp).
  const BlockFn block_fn = o.filtered() ? &simulate_filtered_block
                                        : active_kernel().block_fn(o.method, o.displacement,
                                                                   o.distance, o.peaks, false);
  const int coupled = o.grids();
  ChunkResult result = empty_result(o);
  std::vector<ChunkResult> coarse_result(static_cast<std::size_t>(coupled - 1), empty_result(o));
  // The threads' histograms, added up as each thread finishes (integer counts: any order).
  Histograms histograms(plan.recorded_axes());
  std::mutex merge_mutex;
  std::map<long, BlockOut> pending;
  long next_block = 0;
  run_team(
      team, blocks, cancel, [&]() { return std::make_unique<Workspace>(plan); },
      [&](Workspace& ws, long b) {
        const std::uint64_t start = first + static_cast<std::uint64_t>(b) * kBlockPaths;
        const std::uint64_t n = std::min<std::uint64_t>(kBlockPaths, first + count - start);
        block_fn(plan, start, n, ws);
        if (ws.cancelled()) return false;
        // Finished blocks wait in `pending` until every earlier block is merged, so the merge
        // order is the block order whatever the threads do.
        std::lock_guard<std::mutex> lock(merge_mutex);
        pending.emplace(b, BlockOut{ws.times, ws.stop, ws.coarse_times, ws.coarse_stop,
                                    ws.peaks, ws.peaks_stop, ws.energy});
        for (auto it = pending.begin(); it != pending.end() && it->first == next_block;
             it = pending.erase(it), ++next_block) {
          it->second.times.merge_into(result.times);
          it->second.stop.merge_into(result.stop);
          it->second.peaks.merge_into(result.peaks);
          it->second.peaks_stop.merge_into(result.peaks_stop);
          it->second.energy.merge_into(result.energy);
          for (std::size_t g = 0; g < coarse_result.size(); ++g) {
            it->second.coarse_times[g].merge_into(coarse_result[g].times);
            it->second.coarse_stop[g].merge_into(coarse_result[g].stop);
          }
        }
        return true;
      },
      [&](Workspace& ws) {
        if (!plan.histograms()) return;
        std::lock_guard<std::mutex> lock(merge_mutex);
        histograms.merge(ws.histograms);
      });
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
