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

// What runs: the kernel variant in use (dispatch.hpp) and its vector widths, the variants
// compiled in and those this CPU supports, the random-stream version (rng.hpp, kRandomStream)
// and the compiler. Every variant gives the same numbers; this is for benchmark records.
struct BuildInfo {
  std::string isa;
  int philox_paths_per_register;
  int doubles_per_register;
  std::vector<std::string> isa_compiled;
  std::vector<std::string> isa_available;
  int random_stream;
  std::string compiler;
};
BuildInfo build_info();

// Diagnostics (tests/test_reference_rng.py): the velocity of every path at the end of the plan's
// last segment (the switch-off time), velocity only, exact or Euler method, one thread, through
// the kernel in use.
std::vector<double> simulate_states(const Plan& plan);

// Diagnostics: the draws of pair `pair` for paths path0 .. path0 + count - 1, as 6 rows of
// `count` (the two normals, the two exponentials, the two coins), through the kernel in use.
std::vector<double> draw_noise(std::uint64_t seed, std::uint64_t path0, std::uint64_t count,
                               std::uint64_t pair);

}  // namespace crandall
