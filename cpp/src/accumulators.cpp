#include "crandall/accumulators.hpp"

#include <cmath>
#include <stdexcept>

namespace crandall {
namespace {

struct Tables {
  std::array<std::array<int, 3>, kMonomials> exps{};
  int index[5][5][5];
  // For each target t: the sources s <= t with coefficient binom(t, s) (product over variables).
  struct Term {
    int source;
    int da, db, dc;
    double coefficient;
  };
  std::vector<Term> terms[kMonomials];

  Tables() {
    int k = 0;
    for (int total = 0; total <= kMomentOrder; ++total)
      for (int a = total; a >= 0; --a)
        for (int b = total - a; b >= 0; --b) exps[k++] = {a, b, total - a - b};
    for (auto& p : index)
      for (auto& q : p)
        for (auto& r : q) r = -1;
    for (int i = 0; i < kMonomials; ++i) index[exps[i][0]][exps[i][1]][exps[i][2]] = i;
    const double binom[5][5] = {{1, 0, 0, 0, 0},
                                {1, 1, 0, 0, 0},
                                {1, 2, 1, 0, 0},
                                {1, 3, 3, 1, 0},
                                {1, 4, 6, 4, 1}};
    for (int t = 0; t < kMonomials; ++t) {
      const auto& e = exps[t];
      for (int a = 0; a <= e[0]; ++a)
        for (int b = 0; b <= e[1]; ++b)
          for (int c = 0; c <= e[2]; ++c)
            terms[t].push_back({index[a][b][c], e[0] - a, e[1] - b, e[2] - c,
                                binom[e[0]][a] * binom[e[1]][b] * binom[e[2]][c]});
    }
  }
};

const Tables& tables() {
  static const Tables t;
  return t;
}

}  // namespace

const std::array<std::array<int, 3>, kMonomials>& monomial_exponents() { return tables().exps; }

int monomial_index(int a, int b, int c) {
  if (a < 0 || b < 0 || c < 0 || a + b + c > kMomentOrder) return -1;
  return tables().index[a][b][c];
}

void recentre(const double* in, const double* delta, double* out) {
  const Tables& tb = tables();
  double pw[kVariables][kMomentOrder + 1];
  for (int v = 0; v < kVariables; ++v) {
    pw[v][0] = 1.0;
    for (int p = 1; p <= kMomentOrder; ++p) pw[v][p] = pw[v][p - 1] * delta[v];
  }
  // A term whose source sum is 0 adds a signed zero, which leaves the sum's bits as they are (a
  // round-to-nearest sum that starts at +0 is never -0), so it is skipped when the shifts are
  // finite (0 times inf would be NaN). A velocity-only slot has 5 non-zero sums of 35: this
  // skips most of the work of merging its many slots.
  const bool finite = std::isfinite(delta[0]) && std::isfinite(delta[1]) && std::isfinite(delta[2]);
  for (int t = 0; t < kMonomials; ++t) {
    double acc = 0.0;
    for (const auto& term : tb.terms[t]) {
      const double source = in[term.source];
      if (finite && source == 0.0) continue;
      acc += term.coefficient * source * pw[0][term.da] * pw[1][term.db] * pw[2][term.dc];
    }
    out[t] = acc;
  }
}

Moments::Moments(std::size_t slots)
    : counts_(slots, 0.0), means_(slots * kVariables, 0.0), central_(slots * kMonomials, 0.0) {}

void Moments::merge(const Moments& other) {
  if (other.slots() != slots())
    throw std::invalid_argument("Moments.merge: the two accumulators have different slots");
  for (std::size_t s = 0; s < slots(); ++s)
    merge_slot(s, other.counts_[s], &other.means_[s * kVariables],
               &other.central_[s * kMonomials]);
}

void Moments::merge_raw(std::size_t slot, double count, const double* centre, const double* raw) {
  if (count <= 0.0) return;
  double mean[kVariables], delta[kVariables], central[kMonomials];
  // Monomials 1..3 are the first powers of each variable.
  for (int v = 0; v < kVariables; ++v) {
    const double offset = raw[1 + v] / count;
    mean[v] = centre[v] + offset;
    delta[v] = -offset;
  }
  recentre(raw, delta, central);
  merge_slot(slot, count, mean, central);
}

void Moments::merge_slot(std::size_t slot, double count, const double* mean,
                         const double* central) {
  if (count <= 0.0) return;
  double* my_mean = &means_[slot * kVariables];
  double* my_central = &central_[slot * kMonomials];
  const double n_a = counts_[slot];
  if (n_a == 0.0) {
    counts_[slot] = count;
    for (int v = 0; v < kVariables; ++v) my_mean[v] = mean[v];
    for (int k = 0; k < kMonomials; ++k) my_central[k] = central[k];
    return;
  }
  const double n = n_a + count;
  double pooled[kVariables], delta_a[kVariables], delta_b[kVariables];
  for (int v = 0; v < kVariables; ++v) {
    pooled[v] = my_mean[v] + (mean[v] - my_mean[v]) * (count / n);
    delta_a[v] = my_mean[v] - pooled[v];
    delta_b[v] = mean[v] - pooled[v];
  }
  double a[kMonomials], b[kMonomials];
  recentre(my_central, delta_a, a);
  recentre(central, delta_b, b);
  for (int k = 0; k < kMonomials; ++k) my_central[k] = a[k] + b[k];
  // The first-order central sums are zero by definition; keep them exactly so.
  for (int v = 0; v < kVariables; ++v) my_central[1 + v] = 0.0;
  my_central[0] = n;
  counts_[slot] = n;
  for (int v = 0; v < kVariables; ++v) my_mean[v] = pooled[v];
}

Moments combine(const std::vector<const Moments*>& parts, const std::vector<double>& weights) {
  if (parts.empty() || parts.size() != weights.size())
    throw std::invalid_argument("combine: one weight per part is needed");
  const Moments& a = *parts[0];
  for (const Moments* p : parts)
    if (p->slots() != a.slots() || p->counts() != a.counts())
      throw std::invalid_argument("combine: the accumulators have different slots or counts");
  Moments out(a.slots());
  for (std::size_t s = 0; s < a.slots(); ++s) {
    const double n = a.counts()[s];
    if (n <= 0.0) continue;
    const double* centre = &a.means()[s * kVariables];
    double raw[kMonomials] = {};
    for (std::size_t j = 0; j < parts.size(); ++j) {
      // Part j's sums about the first part's mean, weighted.
      const double* mj = &parts[j]->means()[s * kVariables];
      double delta[kVariables], moved[kMonomials];
      for (int v = 0; v < kVariables; ++v) delta[v] = mj[v] - centre[v];
      recentre(&parts[j]->central()[s * kMonomials], delta, moved);
      for (int k = 0; k < kMonomials; ++k) raw[k] += weights[j] * moved[k];
    }
    raw[0] = n;
    out.merge_raw(s, n, centre, raw);
  }
  return out;
}

}  // namespace crandall
