// Running a plan: one chunk of paths at a time (the unit of checkpoints and of distributed
// tasks), threads inside a chunk, block results merged in block order.
#pragma once

#include <cstdint>
#include <functional>
#include <stdexcept>
#include <vector>

#include "crandall/accumulators.hpp"
#include "crandall/plan.hpp"

namespace crandall {

struct ChunkResult {
  Moments times;  // slot per output time: (velocity, displacement, distance)
  // One slot, or none: (time from the switch-off to the stop, displacement at the stop,
  // distance at the stop). The stop instant is switch_off plus the first variable: its mean is
  // switch_off + means()[0], its central moments are those of the first variable. Kept
  // relative so that they stay exact to double precision at any switch_off.
  Moments stop;
  // Options::peaks: one slot per output time, and one for the stop if observed (none without
  // peaks). Variables: the largest speed max |U1| over [0, t], the largest |U2| over [0, t]
  // (0 when displacement is not observed), and 0. Maxima over the fine grid's points, never
  // extrapolated (Richardson's methods).
  Moments peaks;
  Moments peaks_stop;
  // Options::energy: one slot per output time (none without): (V^2, 0, 0) on the fine grid,
  // never extrapolated.
  Moments energy;
  // Options::histogram_axes: for each axis its counts (cells(): underflow, the bins, overflow,
  // NaN), or nothing for an axis that is not recorded. Integer counts: chunks merge exactly by
  // adding them. From the fine grid for Richardson's methods (not extrapolated).
  std::vector<std::vector<std::uint64_t>> histogram_counts;
};

// Asks whether to cancel the run. Polled by the calling thread only: before the run, between
// blocks, every kPollSteps steps of its own blocks, and every 10 ms while it waits for the other
// threads' blocks. Returning true cancels the run (every thread quits within kPollSteps steps)
// and run_chunk throws Cancelled; an exception it throws cancels the run and is rethrown by
// run_chunk.
using CancelCheck = std::function<bool()>;

class Cancelled : public std::runtime_error {
 public:
  Cancelled() : std::runtime_error("run cancelled") {}
};

// The least work (in path steps) a thread of a parallel loop must get: about 10 ms of one
// core. A smaller loop runs on fewer threads (one below twice this). Waking a thread and
// waiting for it at the loop's end costs microseconds on an idle machine but up to a time
// slice of the scheduler (milliseconds) on a busy one, and splitting's thousands of small
// path extensions paid it each time (issue 30: 28x slower than one thread under load).
constexpr double kThreadWork = double(1u << 17);
// Sets the least work per thread for the process (kThreadWork until then) and returns the
// previous value. The tests set 1 so that their small runs still go parallel and check that
// results do not depend on the thread count; nothing else changes it. Throws
// std::invalid_argument unless steps is finite and >= 1.
double set_thread_work(double steps);
// Values formed or summed per path step, for loops over stored values (a step costs about
// 100 ns, a value a nanosecond or two).
constexpr double kValuesPerStep = 64.0;

// The threads a parallel loop of the core uses for a `threads` argument (that many, or
// OpenMP's default for 0) and its `work` in path steps: at most one per kThreadWork steps (or
// set_thread_work's value), at least one. Every loop's result is the same for any thread
// count, so this only changes the time. Throws std::invalid_argument for a negative count.
int thread_count(int threads, double work);

// Simulate chunk `chunk` of the plan on `threads` threads (0: OpenMP's default). The result
// is bitwise the same for any thread count. No exception escapes the threads: the first one
// (std::bad_alloc included) is rethrown here.
ChunkResult run_chunk(const Plan& plan, std::uint64_t chunk, int threads,
                      const CancelCheck& cancel = {});

}  // namespace crandall
