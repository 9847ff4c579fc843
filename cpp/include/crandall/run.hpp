// Running a plan: one chunk of paths at a time (the unit of checkpoints and of distributed
// tasks), threads inside a chunk, block results merged in block order.
#pragma once

#include <cstdint>
#include <string>
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
};

// Polled by the calling thread only: before the run, between blocks, every kPollSteps steps
// of its own blocks, and every 10 ms while it waits for the other threads' blocks. Returning
// true abandons the run (every thread stops within kPollSteps steps) and run_chunk throws
// Interrupted; an exception it throws abandons the run and is rethrown by run_chunk.
using InterruptCheck = std::function<bool()>;

class Interrupted : public std::runtime_error {
 public:
  Interrupted() : std::runtime_error("run interrupted") {}
};

// Simulate chunk `chunk` of the plan on `threads` threads (0: OpenMP's default). The result
// is bitwise the same for any thread count. No exception escapes the threads: the first one
// (std::bad_alloc included) is rethrown here.
ChunkResult run_chunk(const Plan& plan, std::uint64_t chunk, int threads,
                      const InterruptCheck& interrupted = {});

// One exact step of length h from each start[i], path i of the seed's streams (step 0).
// For testing the step against its transition law.
std::vector<double> exact_steps(const std::vector<double>& start, double h, double drift,
                                double noise, std::uint64_t seed);

// The random-number floor of the kernel: the same Philox streams and normal/exponential/coin
// generation for `paths` paths and `steps` steps, no physics. Returns a checksum (so that the
// work is not optimised away). For bench/throughput.py.
double random_floor(std::uint64_t paths, std::uint64_t steps, std::uint64_t seed, int threads);

// What the build targets, for benchmark records: paths per Philox register (1 = scalar
// Random123), values per libmvec call (1 = scalar libm), the vector extensions compiled in, and
// the compiler. A seed's numbers belong to a build; this says which.
struct BuildInfo {
  int philox_paths_per_register;
  int math_values_per_call;
  std::string isa;
  std::string compiler;
};
BuildInfo build_info();

}  // namespace crandall
