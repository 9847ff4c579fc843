// Hooks for tests and benchmarks, apart from the run API (run.hpp): single exact steps, the
// kernel's draws and end states, the random-number floor of the kernel, and what the build
// runs. Each goes through the kernel variant in use (dispatch.hpp), so the tests that call them
// check every variant.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "crandall/plan.hpp"

namespace crandall {

// One exact step of length `step` from each start[i], path i of the seed's streams (step 0).
// For testing the step against its transition law.
std::vector<double> exact_steps(const std::vector<double>& start, double step, double drift,
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

// The velocity of every path at the end of the plan's last segment (the switch-off time),
// velocity only, exact or Euler method, one thread, through the kernel in use
// (tests/test_reference_rng.py).
std::vector<double> simulate_states(const Plan& plan);

// The draws of pair `pair` for paths path0 .. path0 + count - 1, as 6 rows of `count` (the two
// normals, the two exponentials, the two coins), through the kernel in use.
std::vector<double> draw_noise(std::uint64_t seed, std::uint64_t path0, std::uint64_t count,
                               std::uint64_t pair);

}  // namespace crandall
