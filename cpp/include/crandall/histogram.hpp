// Streaming histograms with fixed bins, one per slot (a slot is one quantity at one output time,
// or at the stop), with integer counts. Memory is fixed by the slots and their bins, never by
// the number of paths.
//
// Bins are half-open, [e_j, e_{j+1}), as in numpy.histogram (but for its closed last bin) and
// boost-histogram. Every value is counted somewhere: below e_0 (including -inf) in the
// underflow, at or above the last edge (including +inf) in the overflow, NaN in its own count.
// -0.0 compares equal to 0.0 and is binned with it.
//
// Counts are unsigned integers, so merging (adding counts) is exact, associative and
// commutative: the counts of a run are the same bits whatever the number of threads, the
// chunking, a checkpoint or a Dask cluster, in whatever order the parts are merged.
//
// The bin of a value is decided by comparisons with the stored edges only: a value x is in
// bin j iff e_j <= x < e_{j+1}. A closed form gives a first guess (no search per value for the
// automatic edges), and the guess is then corrected by those comparisons, so no rounding in
// the formula can misplace a value, and the result is the same on every CPU.
// The scheme and its numbers: docs/methods/histograms.md.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <vector>

namespace crandall {

// The most bins one axis may have: 32 MiB of counts for one slot.
constexpr std::size_t kMaxHistogramBins = std::size_t(1) << 22;

// The edges of one histogram axis and the lookup of a value's bin.
//
// Automatic edges ("log-linear", as in HdrHistogram): a power of two b near the quantity's
// scale, m = 2^M bins per octave. Outward from the origin, [0, b) is cut into m bins of width
// b / m (linear near 0), then every octave [b 2^k, b 2^(k+1)) into m bins of width b 2^k / m
// (geometric beyond b: the relative width of a bin is between 1/(2m) and 1/m), up to
// top = b 2^K, the first such power at or above max_scales * scale. The first bin above 0 is
// split at the least positive double, 2^-1074: the cell [0, 2^-1074) holds exact zeros only
// (an atom at 0, which many quantities have), apart from the values near 0. Symmetric axes
// mirror the rest at 0 (no atom cell below 0: -0.0 is binned with 0); one-sided axes start at 0. Every edge is a dyadic rational computed exactly
// (no library function, no rounding), so the edges are the same bits on every machine, and
// the bin of |x| follows from its exponent and its leading M mantissa bits.
class BinEdges {
 public:
  BinEdges() = default;

  // Edges from the scale of the quantity (its standard deviation, or a typical value: > 0,
  // finite, >= 2^-900). per_octave: a power of two, 1 to 2^20. max_scales: the axis covers
  // at least max_scales * scale on each side used (>= 1). Throws std::invalid_argument.
  static BinEdges log_linear(double scale, int per_octave, double max_scales, bool symmetric);
  // Any strictly increasing finite edges (at least two). The lookup is a binary search.
  static BinEdges from_edges(std::vector<double> edges);

  const std::vector<double>& edges() const { return edges_; }
  std::size_t bins() const { return edges_.empty() ? 0 : edges_.size() - 1; }
  // The slots of a histogram's counts: underflow, bins() in-range bins, overflow, NaN.
  std::size_t cells() const { return bins() + 3; }
  // The cell of x: 0 underflow, 1 + j for bin j, bins() + 1 overflow, bins() + 2 NaN.
  std::size_t cell(double x) const {
    const std::size_t n = bins();
    if (x != x) return n + 2;
    if (x < edges_.front()) return 0;
    if (!(x < edges_.back())) return n + 1;
    if (per_octave_ == 0)
      return static_cast<std::size_t>(std::upper_bound(edges_.begin(), edges_.end(), x) -
                                      edges_.begin());
    // Written without branches on the value (selects), as the sign and the side of b are
    // unpredictable for a symmetric law. |x| <= top here; -top itself maps to o = half_.
    const std::size_t o = std::min(outward(std::fabs(x)), half_ - 1);
    // Above 0 the atom cell [0, 2^-1074) comes first: one more bin on that side.
    std::size_t j = !symmetric_ ? o + 1 : (x < 0.0 ? half_ - 1 - o : half_ + 1 + o);
    // The comparisons decide; the formula only saves the search. A mirrored value exactly on
    // an edge needs one step up (bins are half-open upwards on both sides).
    while (x < edges_[j]) --j;
    while (!(x < edges_[j + 1])) ++j;
    return j + 1;
  }
  // The automatic scheme's constants, for a lookup of many values at once written elsewhere
  // (the kernel's, vectorised over its lanes); outward() and cell() show their use.
  struct Scheme {
    double base, inv_width;
    std::int64_t per_octave, half;
    int shift;
    std::uint64_t base_key;
    bool symmetric;
  };
  Scheme scheme() const {
    return {base_, inv_width_, per_octave_, static_cast<std::int64_t>(half_), shift_, base_key_,
            symmetric_};
  }
  // Parameters of the automatic scheme (0 for user-given edges).
  bool automatic() const { return per_octave_ != 0; }
  double base() const { return base_; }
  int per_octave() const { return per_octave_; }
  bool symmetric() const { return symmetric_; }

  bool operator==(const BinEdges& other) const;
  bool operator!=(const BinEdges& other) const { return !(*this == other); }

 private:
  // The bin of the automatic scheme's formula for 0 <= a < top, counted outward from 0.
  std::size_t outward(double a) const {
    // Below b: a m / b, exact (m / b is a power of two). From b on: the exponent and the
    // leading M mantissa bits of a, i.e. its bits shifted right, counted from those of b.
    // Both are computed and one is selected by a mask: a branch on a < b would be mispredicted
    // about as often as taken for values of the order of the scale.
    const auto linear = static_cast<std::uint64_t>(
        static_cast<std::int64_t>(std::min(a, base_) * inv_width_));
    std::uint64_t key;
    std::memcpy(&key, &a, sizeof key);
    const std::uint64_t geometric = static_cast<std::uint64_t>(per_octave_) + ((key >> shift_) - base_key_);
    const std::uint64_t below = 0 - static_cast<std::uint64_t>(a < base_);
    return static_cast<std::size_t>((linear & below) | (geometric & ~below));
  }

  std::vector<double> edges_;
  double base_ = 0.0;       // b
  double inv_width_ = 0.0;  // m / b, a power of two: a * inv_width_ is exact
  int per_octave_ = 0;      // m (0: user-given edges)
  int shift_ = 0;           // 52 - M: the bits of a >> shift_ are exponent * m + leading bits
  std::uint64_t base_key_ = 0;
  std::size_t half_ = 0;    // bins of the formula on each side (symmetric) or in all (one-sided);
                            // the positive side has one more, the atom cell
  bool symmetric_ = false;
};

// Histograms of any number of slots, each with its own edges.
class Histograms {
 public:
  Histograms() = default;
  explicit Histograms(std::vector<BinEdges> axes);

  std::size_t slots() const { return axes_.size(); }
  const BinEdges& axis(std::size_t slot) const { return axes_[slot]; }

  void add(std::size_t slot, double x) { ++counts_[offsets_[slot] + axes_[slot].cell(x)]; }
  void add(std::size_t slot, const double* x, std::size_t n) {
    const BinEdges& axis = axes_[slot];
    std::uint64_t* c = counts_.data() + offsets_[slot];
    for (std::size_t i = 0; i < n; ++i) ++c[axis.cell(x[i])];
  }
  // this += other, cell by cell; the edges must be identical (throws std::invalid_argument).
  void merge(const Histograms& other);
  // Zero every count, keeping the edges (a per-thread buffer reused between blocks).
  void clear();

  // All counts, slot after slot; slot s occupies [offset(s), offset(s) + axis(s).cells()).
  const std::vector<std::uint64_t>& counts() const { return counts_; }
  std::vector<std::uint64_t>& counts() { return counts_; }
  std::size_t offset(std::size_t slot) const { return offsets_[slot]; }
  const std::uint64_t* slot_counts(std::size_t slot) const { return counts_.data() + offsets_[slot]; }
  std::uint64_t underflow(std::size_t slot) const { return slot_counts(slot)[0]; }
  std::uint64_t overflow(std::size_t slot) const { return slot_counts(slot)[axes_[slot].bins() + 1]; }
  std::uint64_t nan(std::size_t slot) const { return slot_counts(slot)[axes_[slot].bins() + 2]; }
  // Every value added to the slot, NaN included.
  std::uint64_t total(std::size_t slot) const;

 private:
  std::vector<BinEdges> axes_;
  std::vector<std::size_t> offsets_;
  std::vector<std::uint64_t> counts_;
};

}  // namespace crandall
