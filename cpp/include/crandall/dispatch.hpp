// Run-time choice among the instruction-set variants of the kernel (variant.hpp): the best one
// the CPU and the operating system support, or a lower one forced with the CRANDALL_ISA
// environment variable (baseline | avx2 | avx512). All variants give bitwise the same numbers;
// only the speed differs.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "crandall/plan.hpp"

namespace crandall {

struct Workspace;
class BinEdges;
struct LaneGrid;
struct SplitScore;

using BlockFn = void (*)(const Plan&, std::uint64_t, std::uint64_t, Workspace&);

// The entry points of one variant (cpp/src/kernel_variant.inc).
struct KernelTable {
  const char* name;                // "baseline", "avx2" or "avx512"
  int philox_paths_per_register;   // 1 (Random123's scalar code), 4 or 8
  int doubles_per_register;        // widest vector the variant targets: 2, 4 or 8
  // simulate_block instantiation for a method, the observed integrals, the peaks and the
  // quadratic variation (Options::quadratic_variation).
  BlockFn (*block_fn)(Method method, bool displacement, bool distance, bool peaks,
                      bool quadratic);
  // The exact method's loop with control variates (kernel_controls.hpp).
  BlockFn (*controls_fn)(bool displacement, bool distance, bool quadratic);
  // The noise of paths [path0, path0 + kLanes) for `steps` steps, summed (random_floor).
  double (*noise_checksum)(std::uint64_t seed, std::uint64_t path0, std::uint64_t steps);
  // Draws of pair `pair` for paths path0 .. path0 + count - 1, as 6 arrays of `count` doubles:
  // normal of step 2 pair, normal of step 2 pair + 1, the two exponentials, the two coins.
  void (*draw)(std::uint64_t seed, std::uint64_t path0, std::uint64_t pair, std::uint64_t count,
               double* out);
  // Philox words of paths path0 .. path0 + count - 1 (count <= kLanes): word j of path l in the
  // low 32 bits of out[j * kLanes + l] (tests of the vector Philox against Random123).
  void (*philox_words)(std::uint64_t seed, std::uint64_t path0, std::uint64_t pair, int count,
                       std::uint64_t* out);
  // Adds the counts of x[0, n) on axis `edges` to counts (edges.cells() of them) with the
  // kernel's own lookup (count_lanes, kernel.hpp), for the tests that check it against
  // BinEdges::cell in every variant.
  void (*count_values)(const BinEdges& edges, const double* x, std::size_t n,
                       std::uint64_t* counts);
  // Rows continued in vector lanes (branch_lanes.inc): entries [0, count) of rows, starts
  // (even) and streams, to the last even grid point (branch.hpp's extend_rows_in_lanes calls
  // it and takes an odd grid's last step).
  void (*extend_lanes)(double* states, std::size_t points, const LaneGrid& grid,
                       const std::int64_t* rows, const std::int64_t* starts,
                       const std::uint64_t* streams, int count, std::uint64_t key);
  // Splitting's normalised rank at points [from, steps] of a row (split.hpp's
  // split_score_row, vectorised: the same bits).
  void (*normalised_rank)(const SplitScore& score, std::size_t steps, const double* row,
                          std::size_t from, const double* plain, double* rank);
};

// Variants compiled into this build, lowest first (baseline only on non-x86 hosts).
const std::vector<const KernelTable*>& compiled_kernels();
// Whether this CPU and OS can run the variant (CPUID and the OS-enabled register state).
bool kernel_supported(const KernelTable& k);
// Names of the variants compiled in and supported here, lowest first.
std::vector<std::string> available_kernels();
// The variant in use: chosen on first use from CRANDALL_ISA or the CPU (throws
// std::invalid_argument for an unknown or unsupported CRANDALL_ISA).
const KernelTable& active_kernel();
// Force a variant by name (throws std::invalid_argument if unknown or unsupported here); for
// tests and for CRANDALL_ISA. Not for use while a run is in progress.
void select_kernel(const std::string& name);
// The variant CRANDALL_ISA asks for, or the best supported one when it is unset or empty.
std::string kernel_from_environment();

}  // namespace crandall
