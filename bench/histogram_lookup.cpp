// Cost of binning one value (ns), for the automatic edges (formula + comparison) and for the
// same edges given by hand (binary search), on Laplace-distributed values like the velocity's.
// Build and run from the repository root (the core's floating-point flags):
//   g++ -O3 -std=c++17 -ffp-contract=off -fno-trapping-math -fno-math-errno -Icpp/include
//       bench/histogram_lookup.cpp cpp/src/histogram.cpp -o /tmp/histogram_lookup
//   /tmp/histogram_lookup
#include <algorithm>
#include <ctime>
#include <cmath>
#include <cstdio>
#include <random>
#include <vector>

#include "crandall/histogram.hpp"

namespace {

// The thread's CPU time: on a shared machine, wall time would count other processes' turns.
double cpu_seconds() {
  timespec t;
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
  return t.tv_sec + 1e-9 * t.tv_nsec;
}

double seconds_per_value(crandall::Histograms& h, const std::vector<double>& values, int repeats) {
  double best = 1e300;
  for (int r = 0; r < repeats; ++r) {
    h.clear();
    const double t0 = cpu_seconds();
    // Values cycle over many slots, as a kernel's output times would.
    const std::size_t slots = h.slots();
    std::size_t slot = 0;
    for (std::size_t i = 0; i < values.size(); ++i) {
      h.add(slot, values[i]);
      if (++slot == slots) slot = 0;
    }
    best = std::min(best, (cpu_seconds() - t0) / values.size());
  }
  return best;
}

}  // namespace

int main() {
  std::mt19937_64 gen(1);
  std::exponential_distribution<double> expo(2.0);  // the velocity's stationary law exp(-2|u|)
  std::vector<double> values(1 << 22);
  for (auto& v : values) v = (gen() & 1 ? 1.0 : -1.0) * expo(gen);
  std::printf("per_octave  bins  slots  automatic_ns  binary_search_ns\n");
  for (int m : {8, 16, 32, 64}) {
    for (std::size_t slots : {1, 300}) {
      const auto edges = crandall::BinEdges::log_linear(std::sqrt(0.5), m, 50.0, true);
      crandall::Histograms a(std::vector<crandall::BinEdges>(slots, edges));
      crandall::Histograms b(std::vector<crandall::BinEdges>(slots, crandall::BinEdges::from_edges(edges.edges())));
      const double ta = seconds_per_value(a, values, 5), tb = seconds_per_value(b, values, 5);
      if (a.counts() != b.counts()) {
        std::printf("the two lookups disagree\n");
        return 1;
      }
      std::printf("%10d %5zu %6zu %13.2f %17.2f\n", m, edges.bins(), slots, ta * 1e9, tb * 1e9);
    }
  }
  return 0;
}
