// Histograms: the automatic edges follow their documented formula (docs/methods/histograms.md),
// every value lands in the bin its comparisons with the edges say (on an edge, one ulp either
// side, infinities, NaN, -0.0), and merging is exact for any split and order.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <fstream>
#include <limits>
#include <sstream>
#include <string>
#include <numeric>
#include <random>
#include <stdexcept>
#include <vector>

#include "crandall/histogram.hpp"

namespace {

using crandall::BinEdges;
using crandall::Histograms;

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// The cell by definition, written independently of the library: count the edges <= x.
std::size_t reference_cell(const std::vector<double>& e, double x) {
  const std::size_t n = e.size() - 1;
  if (std::isnan(x)) return n + 2;
  std::size_t at_or_below = 0;
  for (double edge : e) at_or_below += edge <= x ? 1 : 0;
  return at_or_below;  // 0: underflow, j + 1: bin j, n + 1: overflow
}

// The documented edges of the automatic scheme, from the formula alone: b the power of two
// with b <= scale < 2b; 0, b/m, ..., (m-1) b/m; (m + j) b 2^k / m for k < K, j < m; b 2^K with
// K the least such that b 2^K >= max_scales * scale; mirrored at 0 if symmetric; and the atom
// edge 2^-1074 just above 0 (not mirrored: exact zeros have a cell of their own).
std::vector<double> documented_edges(double scale, int m, double max_scales, bool symmetric) {
  double b = 1.0;
  while (b > scale) b /= 2.0;
  while (2.0 * b <= scale) b *= 2.0;
  std::vector<double> out;
  for (int j = 0; j < m; ++j) out.push_back(j * b / m);
  double octave = b;
  while (octave < scale * max_scales) {
    for (int j = 0; j < m; ++j) out.push_back(octave + j * octave / m);
    octave *= 2.0;
  }
  out.push_back(octave);
  std::vector<double> atom(out);
  atom.insert(atom.begin() + 1, std::numeric_limits<double>::denorm_min());
  if (!symmetric) return atom;
  std::vector<double> all;
  for (std::size_t i = out.size() - 1; i > 0; --i) all.push_back(-out[i]);
  all.insert(all.end(), atom.begin(), atom.end());
  return all;
}

struct Case {
  double scale;
  int per_octave;
  double max_scales;
  bool symmetric;
};

const std::vector<Case>& cases() {
  static const std::vector<Case> c = {
      {std::sqrt(0.5), 16, 50.0, true},   // the velocity's stationary scale
      {1.0, 16, 50.0, true},              // the scale exactly a power of two
      {0.3, 32, 50.0, false},             // a stop time after the switch-off
      {1234.5, 8, 50.0, false},           // a distance at a late time
      {1e-7, 4, 1.0, true},               // max_scales 1: one octave at most
      {3.0, 1, 2.0, false},               // one bin per octave
      {std::ldexp(1.0, -900), 64, 10.0, true},  // the smallest scale allowed
  };
  return c;
}

TEST(Histogram, EdgesFollowTheDocumentedFormula) {
  for (const Case& c : cases()) {
    const BinEdges e = BinEdges::log_linear(c.scale, c.per_octave, c.max_scales, c.symmetric);
    const std::vector<double> want = documented_edges(c.scale, c.per_octave, c.max_scales, c.symmetric);
    ASSERT_EQ(e.edges().size(), want.size()) << "scale " << c.scale;
    for (std::size_t i = 0; i < want.size(); ++i)
      EXPECT_EQ(e.edges()[i], want[i]) << "scale " << c.scale << " edge " << i;
    EXPECT_TRUE(e.automatic());
    EXPECT_LE(e.base(), c.scale);
    EXPECT_GT(2.0 * e.base(), c.scale);
    EXPECT_GE(e.edges().back(), c.scale * c.max_scales);
    if (c.symmetric) {
      EXPECT_EQ(e.edges().front(), -e.edges().back());
    } else {
      EXPECT_EQ(e.edges().front(), 0.0);
    }
  }
}

TEST(Histogram, EdgesStrictlyIncreasingAndMirrored) {
  for (const Case& c : cases()) {
    const BinEdges e = BinEdges::log_linear(c.scale, c.per_octave, c.max_scales, c.symmetric);
    const auto& x = e.edges();
    for (std::size_t i = 1; i < x.size(); ++i) ASSERT_LT(x[i - 1], x[i]) << "edge " << i;
    if (c.symmetric) {
      // Mirrored but for the atom edge 2^-1074 just above the centre edge, +0.0.
      const std::size_t centre = (x.size() - 2) / 2;
      EXPECT_EQ(x[centre], 0.0);
      EXPECT_FALSE(std::signbit(x[centre]));
      EXPECT_EQ(x[centre + 1], std::numeric_limits<double>::denorm_min());
      for (std::size_t i = 0; i < centre; ++i) EXPECT_EQ(x[i], -x[x.size() - 1 - i]);
    } else {
      EXPECT_EQ(x[1], std::numeric_limits<double>::denorm_min());
    }
    // Relative width beyond b within [1/(2m), 1/m]: the geometric part resolves the tail
    // with a fixed relative precision.
    for (std::size_t i = 1; i < x.size(); ++i) {
      if (x[i - 1] < e.base()) continue;
      const double rel = (x[i] - x[i - 1]) / x[i - 1];
      EXPECT_LE(rel, 1.0 / c.per_octave);
      EXPECT_GE(rel, 0.5 / c.per_octave);
    }
  }
}

// Every edge, one ulp below and above it, and the midpoints: the library agrees with the
// definition, for the automatic edges and the same edges given by hand (the binary search).
TEST(Histogram, EdgePlacement) {
  for (const Case& c : cases()) {
    const BinEdges automatic = BinEdges::log_linear(c.scale, c.per_octave, c.max_scales, c.symmetric);
    const BinEdges given = BinEdges::from_edges(automatic.edges());
    EXPECT_FALSE(given.automatic());
    EXPECT_EQ(given, automatic);
    const auto& x = automatic.edges();
    const std::size_t n = automatic.bins();
    for (std::size_t i = 0; i < x.size(); ++i) {
      const double below = std::nextafter(x[i], -kInf), above = std::nextafter(x[i], kInf);
      // On an edge: the bin above it (overflow for the last edge); one ulp below: the bin
      // below it (underflow for the first).
      const std::size_t on = i + 1, under = i;
      for (const BinEdges* e : {&automatic, &given}) {
        ASSERT_EQ(e->cell(x[i]), on) << "edge " << i << " = " << x[i];
        ASSERT_EQ(e->cell(below), under) << "below edge " << i;
        // One ulp above 0 is the atom edge itself: the bin above it.
        const std::size_t next = i + 1 < x.size() && above == x[i + 1] ? on + 1 : on;
        ASSERT_EQ(e->cell(above), std::min(next, n + 1)) << "above edge " << i;
        if (i + 1 < x.size()) {
          ASSERT_EQ(e->cell(0.5 * (x[i] + x[i + 1])), on) << "mid " << i;
        }
      }
    }
    for (const BinEdges* e : {&automatic, &given}) {
      EXPECT_EQ(e->cell(-kInf), 0u);
      EXPECT_EQ(e->cell(kInf), n + 1);
      EXPECT_EQ(e->cell(kNaN), n + 2);
      EXPECT_EQ(e->cell(-kNaN), n + 2);
      EXPECT_EQ(e->cell(std::numeric_limits<double>::max()), n + 1);
      EXPECT_EQ(e->cell(std::numeric_limits<double>::lowest()), 0u);
      // -0.0 equals 0.0: the bin starting at 0 (or, symmetric, the same as +0.0).
      EXPECT_EQ(e->cell(-0.0), e->cell(0.0));
      EXPECT_EQ(e->cell(0.0), reference_cell(x, 0.0));
      const double tiny = std::numeric_limits<double>::denorm_min();
      EXPECT_EQ(e->cell(tiny), reference_cell(x, tiny));
      EXPECT_EQ(e->cell(-tiny), reference_cell(x, -tiny));
    }
  }
}

// Random values of every magnitude around the axis (log-uniform, both signs, and values
// snapped to edges): the formula-guided lookup agrees with the definition everywhere.
TEST(Histogram, LookupAgreesWithDefinition) {
  std::mt19937_64 gen(20261121);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  for (const Case& c : cases()) {
    const BinEdges e = BinEdges::log_linear(c.scale, c.per_octave, c.max_scales, c.symmetric);
    const auto& x = e.edges();
    for (int i = 0; i < 200000; ++i) {
      double v;
      switch (i % 3) {
        case 0:  // log-uniform over 2^-60 .. 2^10 times the scale, either sign
          v = c.scale * std::exp2(-60.0 + 70.0 * u(gen)) * (u(gen) < 0.5 ? -1.0 : 1.0);
          break;
        case 1:  // uniform over the axis and a little beyond
          v = x.front() - 0.1 * (x.back() - x.front()) + 1.2 * (x.back() - x.front()) * u(gen);
          break;
        default: {  // an edge, nudged by up to 3 ulps
          double w = x[static_cast<std::size_t>(u(gen) * x.size()) % x.size()];
          const int steps = static_cast<int>(u(gen) * 7) - 3;
          for (int s = 0; s < std::abs(steps); ++s) w = std::nextafter(w, steps < 0 ? -kInf : kInf);
          v = w;
        }
      }
      ASSERT_EQ(e.cell(v), reference_cell(x, v)) << "value " << v << " scale " << c.scale;
    }
  }
}

TEST(Histogram, UserEdges) {
  const BinEdges e = BinEdges::from_edges({-1.0, -0.0, 1e-300, 2.5, 1e300});
  EXPECT_EQ(e.bins(), 4u);
  EXPECT_FALSE(std::signbit(e.edges()[1]));
  EXPECT_EQ(e.cell(-1.0), 1u);
  EXPECT_EQ(e.cell(-0.0), 2u);
  EXPECT_EQ(e.cell(0.0), 2u);
  EXPECT_EQ(e.cell(1e-300), 3u);
  EXPECT_EQ(e.cell(2.5), 4u);
  EXPECT_EQ(e.cell(1e300), 5u);
  EXPECT_EQ(e.cell(kNaN), 6u);
  EXPECT_THROW(BinEdges::from_edges({1.0}), std::invalid_argument);
  EXPECT_THROW(BinEdges::from_edges({1.0, 1.0}), std::invalid_argument);
  EXPECT_THROW(BinEdges::from_edges({2.0, 1.0}), std::invalid_argument);
  EXPECT_THROW(BinEdges::from_edges({0.0, kInf}), std::invalid_argument);
  EXPECT_THROW(BinEdges::from_edges({kNaN, 1.0}), std::invalid_argument);
}

TEST(Histogram, BadParameters) {
  EXPECT_THROW(BinEdges::log_linear(0.0, 16, 50, true), std::invalid_argument);
  EXPECT_THROW(BinEdges::log_linear(-1.0, 16, 50, true), std::invalid_argument);
  EXPECT_THROW(BinEdges::log_linear(kNaN, 16, 50, true), std::invalid_argument);
  EXPECT_THROW(BinEdges::log_linear(kInf, 16, 50, true), std::invalid_argument);
  EXPECT_THROW(BinEdges::log_linear(std::ldexp(1.0, -901), 16, 50, true), std::invalid_argument);
  EXPECT_THROW(BinEdges::log_linear(1.0, 12, 50, true), std::invalid_argument);
  EXPECT_THROW(BinEdges::log_linear(1.0, 0, 50, true), std::invalid_argument);
  EXPECT_THROW(BinEdges::log_linear(1.0, 1 << 21, 50, true), std::invalid_argument);
  EXPECT_THROW(BinEdges::log_linear(1.0, 16, 0.5, true), std::invalid_argument);
  EXPECT_THROW(BinEdges::log_linear(1.0, 16, kNaN, true), std::invalid_argument);
  EXPECT_THROW(BinEdges::log_linear(1e300, 16, 1e10, true), std::invalid_argument);
  EXPECT_THROW(BinEdges::log_linear(1.0, 1 << 20, 1e6, true), std::invalid_argument);  // too many bins
  EXPECT_THROW(Histograms({BinEdges()}), std::invalid_argument);
}

std::vector<BinEdges> three_axes() {
  return {BinEdges::log_linear(std::sqrt(0.5), 16, 50.0, true),
          BinEdges::log_linear(0.3, 32, 50.0, false),
          BinEdges::from_edges({-2.0, -1.0, 0.0, 1.0, 2.0})};
}

// Values with every kind of cell: heavy tails past the top, NaN, infinities, exact edges.
std::vector<double> nasty_values(std::size_t n, std::uint64_t seed) {
  std::mt19937_64 gen(seed);
  std::cauchy_distribution<double> cauchy(0.0, 1.0);
  std::uniform_int_distribution<int> kind(0, 19);
  std::vector<double> v(n);
  for (auto& x : v) {
    switch (kind(gen)) {
      case 0: x = kNaN; break;
      case 1: x = kInf; break;
      case 2: x = -kInf; break;
      case 3: x = -0.0; break;
      case 4: x = 1.0; break;
      default: x = cauchy(gen);
    }
  }
  return v;
}

TEST(Histogram, MergeIsExactForAnySplitAndOrder) {
  const std::size_t n = 60000;
  const std::vector<double> values = nasty_values(n, 7);
  const auto axes = three_axes();
  Histograms whole(axes);
  for (std::size_t s = 0; s < axes.size(); ++s) whole.add(s, values.data(), values.size());
  for (std::size_t s = 0; s < axes.size(); ++s) EXPECT_EQ(whole.total(s), n);
  // The counts against the definition, cell by cell.
  for (std::size_t s = 0; s < axes.size(); ++s) {
    std::vector<std::uint64_t> want(axes[s].cells(), 0);
    for (double x : values) ++want[reference_cell(axes[s].edges(), x)];
    for (std::size_t c = 0; c < want.size(); ++c) EXPECT_EQ(whole.slot_counts(s)[c], want[c]);
  }
  std::mt19937_64 gen(11);
  for (int trial = 0; trial < 20; ++trial) {
    // A random split into parts (as threads, chunks or workers would make), each filled one
    // value at a time, then merged in a random order and as a random tree.
    std::vector<std::size_t> cuts = {0, n};
    const int parts = 1 + static_cast<int>(gen() % 40);
    for (int p = 1; p < parts; ++p) cuts.push_back(gen() % (n + 1));
    std::sort(cuts.begin(), cuts.end());
    std::vector<Histograms> pieces;
    for (std::size_t p = 0; p + 1 < cuts.size(); ++p) {
      Histograms h(axes);
      for (std::size_t i = cuts[p]; i < cuts[p + 1]; ++i)
        for (std::size_t s = 0; s < axes.size(); ++s) h.add(s, values[i]);
      pieces.push_back(std::move(h));
    }
    std::shuffle(pieces.begin(), pieces.end(), gen);
    while (pieces.size() > 1) {
      const std::size_t a = gen() % pieces.size();
      std::size_t b = gen() % (pieces.size() - 1);
      if (b >= a) ++b;
      pieces[a].merge(pieces[b]);
      pieces.erase(pieces.begin() + static_cast<std::ptrdiff_t>(b));
    }
    EXPECT_EQ(pieces[0].counts(), whole.counts()) << "trial " << trial;
  }
}

// Real threads: per-thread histograms over a dynamic schedule, merged in whatever order the
// threads finish (a critical section), equal the serial counts for every thread count.
TEST(Histogram, ThreadsMergeInAnyOrder) {
  const std::vector<double> values = nasty_values(200000, 13);
  const auto axes = three_axes();
  Histograms serial(axes);
  for (std::size_t s = 0; s < axes.size(); ++s) serial.add(s, values.data(), values.size());
  for (int threads : {1, 2, 3, 8}) {
    Histograms total(axes);
#pragma omp parallel num_threads(threads)
    {
      Histograms mine(axes);
#pragma omp for schedule(dynamic, 997)
      for (std::ptrdiff_t i = 0; i < static_cast<std::ptrdiff_t>(values.size()); ++i)
        for (std::size_t s = 0; s < axes.size(); ++s) mine.add(s, values[static_cast<std::size_t>(i)]);
#pragma omp critical
      total.merge(mine);
    }
    EXPECT_EQ(total.counts(), serial.counts()) << threads << " threads";
  }
}

TEST(Histogram, MergeRefusesOtherEdgesAndClearKeepsThem) {
  Histograms a(three_axes());
  auto other = three_axes();
  other[1] = BinEdges::log_linear(0.3, 16, 50.0, false);
  Histograms b(other);
  EXPECT_THROW(a.merge(b), std::invalid_argument);
  auto two = three_axes();
  two.pop_back();
  Histograms c(two);
  EXPECT_THROW(a.merge(c), std::invalid_argument);
  a.add(0, 0.25);
  a.add(2, kNaN);
  EXPECT_EQ(a.total(0), 1u);
  EXPECT_EQ(a.nan(2), 1u);
  a.clear();
  EXPECT_EQ(a.total(0) + a.total(1) + a.total(2), 0u);
  EXPECT_EQ(a.axis(1), three_axes()[1]);
}

// Memory is slots x cells x 8 bytes, fixed at construction, whatever is added.
TEST(Histogram, MemoryDoesNotGrow) {
  const auto axes = three_axes();
  Histograms h(axes);
  std::size_t cells = 0;
  for (const auto& a : axes) cells += a.cells();
  EXPECT_EQ(h.counts().size(), cells);
  EXPECT_EQ(h.offset(1), axes[0].cells());
  const std::uint64_t* before = h.counts().data();
  const std::vector<double> values = nasty_values(100000, 3);
  for (std::size_t s = 0; s < axes.size(); ++s) h.add(s, values.data(), values.size());
  EXPECT_EQ(h.counts().size(), cells);
  EXPECT_EQ(h.counts().data(), before);
  EXPECT_EQ(h.underflow(2) + h.overflow(2) + h.nan(2) > 0, true);
}

// tests/data/histogram_cells.txt holds edges and cells computed by the NumPy reference
// (tests/histogram_reference.py, itself checked against the file and against numpy.histogram
// by tests/test_histogram_reference.py): the core agrees with it on every value.
TEST(Histogram, AgreesWithTheNumpyReference) {
  std::string root = __FILE__;
  root = root.substr(0, root.rfind("cpp/tests/"));
  std::ifstream in(root + "tests/data/histogram_cells.txt");
  ASSERT_TRUE(in.good()) << "cannot read " << root << "tests/data/histogram_cells.txt";
  auto number = [](const std::string& text) { return std::strtod(text.c_str(), nullptr); };
  std::string line;
  int axes = 0;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#') continue;
    std::istringstream head(line);
    std::string word, scale, reach;
    int per_octave = 0, symmetric = 0;
    std::size_t n_edges = 0, n_values = 0;
    head >> word >> scale >> per_octave >> reach >> symmetric >> n_edges >> n_values;
    ASSERT_EQ(word, "axis");
    const BinEdges e = BinEdges::log_linear(number(scale), per_octave, number(reach), symmetric != 0);
    ASSERT_EQ(e.edges().size(), n_edges);
    for (std::size_t i = 0; i < n_edges; ++i) {
      ASSERT_TRUE(std::getline(in, line));
      ASSERT_EQ(e.edges()[i], number(line)) << "edge " << i << " of axis " << axes;
    }
    for (std::size_t i = 0; i < n_values; ++i) {
      ASSERT_TRUE(std::getline(in, line));
      std::istringstream row(line);
      std::string value;
      std::size_t cell = 0;
      row >> value >> cell;
      EXPECT_EQ(e.cell(number(value)), cell) << "value " << value << " of axis " << axes;
    }
    ++axes;
  }
  EXPECT_EQ(axes, 4);
}

}  // namespace
