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

#include <array>
#include <cstddef>
#include <vector>

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

}  // namespace crandall
