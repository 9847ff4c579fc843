#include "crandall/histogram.hpp"

#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

namespace crandall {
namespace {

constexpr int kMaxPerOctaveLog2 = 20;            // keeps the shift of the mantissa key >= 32

}  // namespace

BinEdges BinEdges::log_linear(double scale, int per_octave, double max_scales, bool symmetric) {
  // scale >= 2^-900 keeps b / m (>= 2^-921) a normal number, so every edge is exact.
  if (!(std::isfinite(scale) && scale >= std::ldexp(1.0, -900)))
    throw std::invalid_argument("histogram scale must be finite and >= 2^-900");
  if (!(std::isfinite(max_scales) && max_scales >= 1.0))
    throw std::invalid_argument("histogram max_scales must be finite and >= 1");
  int log2m = 0;
  while (log2m <= kMaxPerOctaveLog2 && (1 << log2m) != per_octave) ++log2m;
  if (log2m > kMaxPerOctaveLog2)
    throw std::invalid_argument("histogram per_octave must be a power of two from 1 to 2^20");
  const double reach = scale * max_scales;
  if (!(reach < std::ldexp(1.0, 1000)))
    throw std::invalid_argument("histogram scale * max_scales must be < 2^1000");

  BinEdges e;
  int exponent;
  std::frexp(scale, &exponent);             // scale = f 2^exponent, f in [1/2, 1): exact
  e.base_ = std::ldexp(1.0, exponent - 1);  // the power of two b <= scale < 2b
  int octaves = 0;
  double top = e.base_;
  while (top < reach) {
    top *= 2.0;
    ++octaves;
  }
  const std::size_t m = static_cast<std::size_t>(per_octave);
  e.half_ = m * static_cast<std::size_t>(1 + octaves);
  if (e.half_ * (symmetric ? 2 : 1) + 1 > kMaxHistogramBins)  // + 1: the atom cell
    throw std::invalid_argument("histogram: more than 2^22 bins; lower per_octave or max_scales");
  e.per_octave_ = per_octave;
  e.symmetric_ = symmetric;
  e.inv_width_ = std::ldexp(1.0, log2m - (exponent - 1));
  e.shift_ = 52 - log2m;
  std::uint64_t key;
  std::memcpy(&key, &e.base_, sizeof key);
  e.base_key_ = key >> e.shift_;

  // Outward edges 0, b/m, ..., b, then (m + j) b 2^k / m: small integers times powers of two.
  std::vector<double> out;
  out.reserve(e.half_ + 2);
  for (std::size_t j = 0; j < m; ++j) out.push_back(std::ldexp(static_cast<double>(j), exponent - 1 - log2m));
  for (int k = 0; k < octaves; ++k)
    for (std::size_t j = 0; j < m; ++j)
      out.push_back(std::ldexp(static_cast<double>(m + j), exponent - 1 - log2m + k));
  out.push_back(top);
  // The atom cell [0, 2^-1074): the least positive double as an edge, so that exact zeros (a
  // body at rest, stopped, or never shaken) are counted apart from the values near 0
  // (docs/methods/histograms.md, "Atoms at zero").
  out.insert(out.begin() + 1, std::numeric_limits<double>::denorm_min());
  if (symmetric) {
    e.edges_.reserve(2 * e.half_ + 2);
    // The negative side mirrors the edges from b/m outward (no atom edge below 0).
    for (std::size_t i = e.half_ + 1; i > 1; --i) e.edges_.push_back(-out[i]);
    e.edges_.insert(e.edges_.end(), out.begin(), out.end());  // out[0] = 0 is the centre edge
  } else {
    e.edges_ = std::move(out);
  }
  return e;
}

BinEdges BinEdges::from_edges(std::vector<double> edges) {
  if (edges.size() < 2) throw std::invalid_argument("histogram edges: at least two are needed");
  if (edges.size() - 1 > kMaxHistogramBins) throw std::invalid_argument("histogram edges: more than 2^22 bins");
  for (std::size_t i = 0; i < edges.size(); ++i) {
    if (!std::isfinite(edges[i])) throw std::invalid_argument("histogram edges must be finite");
    if (i > 0 && !(edges[i - 1] < edges[i]))
      throw std::invalid_argument("histogram edges must be strictly increasing");
  }
  BinEdges e;
  // -0.0 and 0.0 are the same edge for the comparisons; store +0.0 so equal axes compare equal.
  for (double& x : edges)
    if (x == 0.0) x = 0.0;
  e.edges_ = std::move(edges);
  return e;
}

bool BinEdges::operator==(const BinEdges& other) const {
  // The edges decide every bin; the scheme's parameters follow from them.
  if (edges_.size() != other.edges_.size()) return false;
  return edges_.empty() ||
         std::memcmp(edges_.data(), other.edges_.data(), edges_.size() * sizeof(double)) == 0;
}

Histograms::Histograms(std::vector<BinEdges> axes) : axes_(std::move(axes)) {
  offsets_.reserve(axes_.size() + 1);
  std::size_t total = 0;
  for (const BinEdges& a : axes_) {
    if (a.bins() == 0) throw std::invalid_argument("Histograms: an axis has no edges");
    offsets_.push_back(total);
    total += a.cells();
  }
  offsets_.push_back(total);
  counts_.assign(total, 0);
}

void Histograms::merge(const Histograms& other) {
  if (other.axes_.size() != axes_.size())
    throw std::invalid_argument("Histograms.merge: the two histograms have different slots");
  for (std::size_t s = 0; s < axes_.size(); ++s)
    if (axes_[s] != other.axes_[s])
      throw std::invalid_argument("Histograms.merge: slot " + std::to_string(s) +
                                  " has different edges");
  for (std::size_t i = 0; i < counts_.size(); ++i) counts_[i] += other.counts_[i];
}

void Histograms::clear() { std::fill(counts_.begin(), counts_.end(), 0); }

std::uint64_t Histograms::total(std::size_t slot) const {
  const std::uint64_t* c = slot_counts(slot);
  std::uint64_t sum = 0;
  for (std::size_t i = 0; i < axes_[slot].cells(); ++i) sum += c[i];
  return sum;
}

}  // namespace crandall
