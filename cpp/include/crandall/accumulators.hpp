// Streaming moments of three variables (velocity, displacement, distance; or the stop-time
// triple) up to total order 4, for a number of slots (output times). Memory is fixed by the
// number of slots, never by the number of paths.
//
// A slot holds the count n, the mean vector and the central sums
//   C[a,b,c] = sum_i (x_i - mean_x)^a (y_i - mean_y)^b (z_i - mean_z)^c,  a + b + c <= 4.
// Two sets merge by re-centring both on the pooled mean with the binomial theorem (an exact
// identity; docs/accumulators.md). Floating-point addition is not associative, so callers merge
// in a fixed order (block index, then chunk index) to get bitwise-reproducible results.
#pragma once

#include <algorithm>
#include <array>
#include <cstddef>
#include <vector>

#include "crandall/plan.hpp"  // kLanes

namespace crandall {

constexpr int kMomentOrder = 4;
constexpr int kMonomials = 35;  // exponent triples with a + b + c <= 4
constexpr int kVariables = 3;

// The exponent triples in graded order: (0,0,0), (1,0,0), (0,1,0), (0,0,1), (2,0,0), ...
const std::array<std::array<int, 3>, kMonomials>& monomial_exponents();
// Index of the triple (a, b, c) in monomial_exponents(), or -1 if a + b + c > 4.
int monomial_index(int a, int b, int c);

class Moments {
 public:
  Moments() = default;
  explicit Moments(std::size_t slots);

  std::size_t slots() const { return counts_.size(); }
  // this := this (+) other, slot by slot. The result depends on the order of merges only
  // through rounding.
  void merge(const Moments& other);
  // Merge a group of points given by raw sums about an arbitrary centre `centre` (one per
  // variable): raw[k] = sum_i prod_v (x_iv - centre_v)^e_kv. Centring near the data keeps the
  // sums free of cancellation.
  void merge_raw(std::size_t slot, double count, const double* centre, const double* raw);

  const std::vector<double>& counts() const { return counts_; }
  const std::vector<double>& means() const { return means_; }      // slots x 3
  const std::vector<double>& central() const { return central_; }  // slots x 35
  std::vector<double>& counts() { return counts_; }
  std::vector<double>& means() { return means_; }
  std::vector<double>& central() { return central_; }

 private:
  void merge_slot(std::size_t slot, double count, const double* mean, const double* central);
  std::vector<double> counts_;
  std::vector<double> means_;
  std::vector<double> central_;
};

// Moments of the signed combination sum_j w_j law(parts_j) (sum_j w_j = 1), slot by slot:
// every raw moment is sum_j w_j E_j[.]. All parts must hold the same counts. This is how
// Richardson extrapolation is applied to all moments at once (docs/methods/richardson.md).
Moments combine(const std::vector<const Moments*>& parts, const std::vector<double>& weights);

// Re-centre sums: out[t] = sum over s <= t of binom(t, s) in[s] delta^(t - s), i.e. sums about a
// centre c become sums about c - delta. Exposed for the tests.
void recentre(const double* in, const double* delta, double* out);

// Raw sums of one block of paths about a centre per slot (the first path's values), fed by the
// kernel kLanes paths at a time, then merged into a Moments in block order by the caller.
struct BlockSums {
  explicit BlockSums(std::size_t slots)
      : centre(slots * kVariables), raw(slots * kMonomials), counts(slots) {}
  void reset() {
    std::fill(raw.begin(), raw.end(), 0.0);
    std::fill(counts.begin(), counts.end(), 0.0);
  }
  void add(std::size_t slot, const double* a, const double* b, const double* c, int lanes,
           const std::vector<int>& active);
  void merge_into(Moments& out) const {
    for (std::size_t s = 0; s < counts.size(); ++s)
      out.merge_raw(s, counts[s], &centre[s * kVariables], &raw[s * kMonomials]);
  }
  std::vector<double> centre, raw, counts;
};

inline void BlockSums::add(std::size_t slot, const double* a, const double* b, const double* c,
                           int lanes, const std::vector<int>& active) {
  double* cen = &centre[slot * kVariables];
  if (counts[slot] == 0.0) {
    cen[0] = a[0];
    cen[1] = b[0];
    cen[2] = c[0];
  }
  const auto& exps = monomial_exponents();
  double* r = &raw[slot * kMonomials];
  // active is in graded order, so the first powers of the 2nd and 3rd variables (monomials 2
  // and 3) come right after (0,0,0) and (1,0,0) when they are observed.
  const bool only_first = active.size() < 3 || active[2] > 3;
  if (only_first) {
    // A velocity-only (or stop-time-only) slot: powers of the first variable alone; the
    // products below would multiply by 1.0 exactly, so the sums are the same bits.
    double pa[kMomentOrder + 1][kLanes];
    for (int l = 0; l < lanes; ++l) {
      pa[0][l] = 1.0;
      pa[1][l] = a[l] - cen[0];
    }
    for (int p = 2; p <= kMomentOrder; ++p)
      for (int l = 0; l < lanes; ++l) pa[p][l] = pa[p - 1][l] * pa[1][l];
    for (int k : active) {
      const int e = exps[k][0];
      double sum = 0.0;
      for (int l = 0; l < lanes; ++l) sum += pa[e][l];
      r[k] += sum;
    }
    counts[slot] += lanes;
    return;
  }
  double pa[kMomentOrder + 1][kLanes], pb[kMomentOrder + 1][kLanes], pc[kMomentOrder + 1][kLanes];
  for (int l = 0; l < lanes; ++l) {
    pa[0][l] = pb[0][l] = pc[0][l] = 1.0;
    pa[1][l] = a[l] - cen[0];
    pb[1][l] = b[l] - cen[1];
    pc[1][l] = c[l] - cen[2];
  }
  for (int p = 2; p <= kMomentOrder; ++p)
    for (int l = 0; l < lanes; ++l) {
      pa[p][l] = pa[p - 1][l] * pa[1][l];
      pb[p][l] = pb[p - 1][l] * pb[1][l];
      pc[p][l] = pc[p - 1][l] * pc[1][l];
    }
  for (int k : active) {
    const auto& e = exps[k];
    double sum = 0.0;
    for (int l = 0; l < lanes; ++l) sum += pa[e[0]][l] * pb[e[1]][l] * pc[e[2]][l];
    r[k] += sum;
  }
  counts[slot] += lanes;
}

// Monomials whose exponents vanish on the variables that are not simulated.
inline std::vector<int> active_monomials(bool second, bool third) {
  std::vector<int> out;
  const auto& exps = monomial_exponents();
  for (int k = 0; k < kMonomials; ++k)
    if ((second || exps[k][1] == 0) && (third || exps[k][2] == 0)) out.push_back(k);
  return out;
}

}  // namespace crandall
