// Distributions and peaks in the kernel (Options::histogram_axes, Options::peaks): the counts are
// a direct binning of every path's values as a scalar reference walk of the same grid and draws
// computes them; the peaks are that walk's running maxima; counts and peaks are bitwise the same
// for any thread count and kernel variant; asking for them changes no moment; bad axes are
// refused with a message naming histogram_axes.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

#include "crandall/coast.hpp"
#include "crandall/dispatch.hpp"
#include "crandall/exact_step.hpp"
#include "crandall/histogram.hpp"
#include "crandall/kernel.hpp"
#include "crandall/rng.hpp"
#include "crandall/run.hpp"
#include "support.hpp"

namespace {

using crandall::BinEdges;
using crandall::kHistogramVariables;
using Values = std::array<double, kHistogramVariables>;

bool same_bits(const std::vector<double>& a, const std::vector<double>& b) {
  return a.size() == b.size() &&
         (a.empty() || std::memcmp(a.data(), b.data(), a.size() * sizeof(double)) == 0);
}

// Every observable, peaks and the stop; output times before and after the switch-off.
crandall::Options peak_scene() {
  auto o = scene();
  o.peaks = true;
  o.paths = 700;  // partial blocks and lane groups
  return o;
}

// An axis for every (slot, variable) of the scene, of several kinds: automatic symmetric and
// one-sided axes at scales that put values in every part of the axis (and in the underflow and
// overflow: max_scales 4 at the velocity's scale), user edges, and some not recorded.
std::vector<BinEdges> axes_for(const crandall::Options& o) {
  std::vector<BinEdges> axes;
  const std::size_t slots = o.histogram_slots();
  for (std::size_t s = 0; s < slots; ++s)
    for (int v = 0; v < kHistogramVariables; ++v) {
      const bool simulated = v == 0 || (v == 1 && o.displacement) || (v == 2 && o.distance) ||
                             (v == 3 && o.peaks) || (v == 4 && o.peaks && o.displacement);
      if (!simulated || (s == 1 && v == 2)) {
        axes.emplace_back();  // not recorded
      } else if (v == 2) {
        axes.push_back(BinEdges::from_edges({0.0, 0.01, 0.05, 0.1, 0.2, 0.3, 0.5, 1.0}));
      } else if (v >= 3 || (s + 1 == slots && o.stop)) {
        axes.push_back(BinEdges::log_linear(0.3, 4, 4.0, false));  // peaks, stop time: >= 0
      } else {
        axes.push_back(BinEdges::log_linear(v == 0 ? 0.6 : 0.1, 8, 4.0, true));
      }
    }
  return axes;
}

// The values of path p at every slot (output times, then the stop), walked by hand on the
// plan's grid with the kernel's draws (step k uses half k & 1 of pair k >> 1 of the path's
// stream) and the scalar steps: exact_step for the exact method, euler_step for Euler, the
// trapezoid rule (exact) or the left-point rule (Euler) for the integrals, the running maxima
// of |x| and |u| over the grid's points, and the closed-form coast after the switch-off.
std::vector<Values> reference_path(const crandall::Plan& plan, std::uint64_t p) {
  const crandall::Options& o = plan.options();
  std::vector<Values> out(o.histogram_slots());
  double x = 0.0, u = 0.0, s = 0.0, pv = 0.0, pu = 0.0;
  crandall::StepNoise z[2];
  std::uint64_t k = 0;
  for (const crandall::Segment& seg : plan.segments()) {
    for (std::uint64_t i = 0; i < seg.steps; ++i, ++k) {
      if ((k & 1u) == 0) crandall::draw_pair(o.seed, p, k >> 1, z);
      const crandall::StepNoise& n = z[k & 1u];
      const double x0 = x;
      if (o.method == crandall::Method::euler) {
        u += seg.step * x0;
        s += seg.step * std::abs(x0);
        x = crandall::euler_step(x0, seg.step, o.drift, o.noise, n.normal);
      } else {
        x = crandall::exact_step(x0, seg.step, o.drift, o.noise, n.normal, n.exponential, n.coin)
                .velocity;
        u += crandall::trapezoid(seg.step, x0, x);
        s += crandall::trapezoid(seg.step, std::abs(x0), std::abs(x));
      }
      pv = std::max(pv, std::abs(x));
      pu = std::max(pu, std::abs(u));
    }
    if (seg.slot >= 0) out[static_cast<std::size_t>(seg.slot)] = {x, u, s, pv, pu};
  }
  for (std::size_t j = 0; j < plan.coast_slots().size(); ++j) {
    const crandall::State st = crandall::coast({x, u, s}, o.drift, plan.coast_elapsed()[j]);
    // The peak speed cannot grow after the switch-off; |u| is monotone on the coast.
    out[static_cast<std::size_t>(plan.coast_slots()[j])] = {
        st.velocity, st.displacement, st.distance, pv, std::max(pu, std::abs(st.displacement))};
  }
  if (o.stop) {
    const double to_stop = crandall::time_to_stop(x, o.drift);
    const crandall::State st = crandall::coast({x, u, s}, o.drift, to_stop);
    out.back() = {to_stop, st.displacement, st.distance, pv, std::max(pu, std::abs(st.displacement))};
  }
  return out;
}

// The counts a direct binning of the reference values gives, axis by axis (empty when not
// recorded), with the axes' own cell().
std::vector<std::vector<std::uint64_t>> reference_counts(const crandall::Plan& plan) {
  const crandall::Options& o = plan.options();
  std::vector<std::vector<std::uint64_t>> counts(o.histogram_axes.size());
  for (std::size_t i = 0; i < counts.size(); ++i)
    if (o.histogram_axes[i].bins() > 0) counts[i].assign(o.histogram_axes[i].cells(), 0);
  for (std::uint64_t p = 0; p < o.paths; ++p) {
    const auto values = reference_path(plan, p);
    for (std::size_t s = 0; s < values.size(); ++s)
      for (int v = 0; v < kHistogramVariables; ++v) {
        const std::size_t i = s * kHistogramVariables + static_cast<std::size_t>(v);
        if (!counts[i].empty()) ++counts[i][o.histogram_axes[i].cell(values[s][static_cast<std::size_t>(v)])];
      }
  }
  return counts;
}

TEST(Distributions, CountsAreADirectBinningOfTheReferencePaths) {
  for (auto method : {crandall::Method::exact, crandall::Method::euler}) {
    auto o = peak_scene();
    o.method = method;
    o.histogram_axes = axes_for(o);
    const crandall::Plan plan(o);
    const auto got = crandall::run_chunk(plan, 0, 2).histogram_counts;
    const auto want = reference_counts(plan);
    ASSERT_EQ(got.size(), want.size());
    std::size_t recorded = 0, underflow = 0, overflow = 0;
    for (std::size_t i = 0; i < want.size(); ++i) {
      EXPECT_EQ(got[i], want[i]) << crandall::method_name(method) << " axis " << i;
      if (want[i].empty()) continue;
      ++recorded;
      underflow += want[i].front();
      overflow += want[i][want[i].size() - 2];
    }
    // The scene's axes exercise the underflow and overflow cells, not only the bins.
    EXPECT_GT(recorded, 20u);
    EXPECT_GT(underflow, 0u);
    EXPECT_GT(overflow, 0u);
  }
}

TEST(Distributions, EveryPathIsCountedOnceInEveryRecordedSlot) {
  auto o = peak_scene();
  o.paths = 70000;  // two chunks, the second partial
  o.times = {0.5, 1.5};
  o.histogram_axes = axes_for(o);
  const crandall::Plan plan(o);
  for (std::uint64_t chunk = 0; chunk < plan.chunks(); ++chunk) {
    const auto r = crandall::run_chunk(plan, chunk, 2);
    ASSERT_EQ(r.histogram_counts.size(), o.histogram_axes.size());
    for (std::size_t i = 0; i < o.histogram_axes.size(); ++i) {
      if (o.histogram_axes[i].bins() == 0) {
        EXPECT_TRUE(r.histogram_counts[i].empty()) << i;
        continue;
      }
      ASSERT_EQ(r.histogram_counts[i].size(), o.histogram_axes[i].cells()) << i;
      std::uint64_t total = 0;
      for (std::uint64_t c : r.histogram_counts[i]) total += c;
      EXPECT_EQ(total, plan.chunk_paths(chunk)) << "chunk " << chunk << " axis " << i;
      EXPECT_EQ(r.histogram_counts[i].back(), 0u) << "NaN count, axis " << i;
    }
  }
}

TEST(Distributions, BitwiseTheSameForAnyThreadCountAndVariant) {
  KeepKernel keep;
  for (auto method : crandall::kMethods) {
    auto o = peak_scene();
    o.method = method;
    o.histogram_axes = axes_for(o);
    const crandall::Plan plan(o);
    bool first = true;
    crandall::ChunkResult want;
    for (const crandall::KernelTable* kernel : crandall::compiled_kernels()) {
      if (!crandall::kernel_supported(*kernel)) continue;
      crandall::select_kernel(kernel->name);
      for (int threads : {1, 2, 3}) {
        const auto got = crandall::run_chunk(plan, 0, threads);
        if (first) {
          want = got;
          first = false;
          continue;
        }
        const std::string where = std::string(crandall::method_name(method)) + " " +
                                  kernel->name + " threads=" + std::to_string(threads);
        EXPECT_EQ(got.histogram_counts, want.histogram_counts) << where;
        EXPECT_TRUE(same_bits(got.peaks.means(), want.peaks.means())) << where;
        EXPECT_TRUE(same_bits(got.peaks.central(), want.peaks.central())) << where;
        EXPECT_TRUE(same_bits(got.peaks_stop.means(), want.peaks_stop.means())) << where;
        EXPECT_TRUE(same_bits(got.peaks_stop.central(), want.peaks_stop.central())) << where;
      }
    }
  }
}

TEST(Distributions, AskingForThemChangesNoMoment) {
  // With an integral observed the grid is fine already, so peaks and histograms change neither
  // the grid nor any moment's bits.
  for (auto method : crandall::kMethods) {
    auto o = scene();
    o.method = method;
    const auto plain = crandall::run_chunk(crandall::Plan(o), 0, 2);
    o.peaks = true;
    o.histogram_axes = axes_for(o);
    const auto both = crandall::run_chunk(crandall::Plan(o), 0, 2);
    const char* name = crandall::method_name(method);
    EXPECT_TRUE(same_bits(plain.times.means(), both.times.means())) << name;
    EXPECT_TRUE(same_bits(plain.times.central(), both.times.central())) << name;
    EXPECT_TRUE(same_bits(plain.stop.means(), both.stop.means())) << name;
    EXPECT_TRUE(same_bits(plain.stop.central(), both.stop.central())) << name;
    EXPECT_EQ(plain.peaks.slots(), 0u);
    EXPECT_EQ(plain.peaks_stop.slots(), 0u);
    EXPECT_TRUE(plain.histogram_counts.empty());
    EXPECT_EQ(both.peaks.slots(), o.times.size());
    EXPECT_EQ(both.peaks_stop.slots(), 1u);
  }
}

TEST(Distributions, RichardsonBinsTheFineGridWithoutExtrapolating) {
  // Segments of multiples of 4 steps: exact and richardson walk the same fine grid, so the
  // histograms and the peaks (never extrapolated) must be the same bits, while the moments of
  // the integrals differ (they are extrapolated).
  auto o = peak_scene();
  o.times = {0.2, 0.4, 0.8, 1.5};
  o.histogram_axes = axes_for(o);
  const auto exact = crandall::run_chunk(crandall::Plan(o), 0, 2);
  for (auto method : {crandall::Method::richardson, crandall::Method::richardson2}) {
    o.method = method;
    const auto rich = crandall::run_chunk(crandall::Plan(o), 0, 2);
    const char* name = crandall::method_name(method);
    EXPECT_EQ(rich.histogram_counts, exact.histogram_counts) << name;
    EXPECT_TRUE(same_bits(rich.peaks.means(), exact.peaks.means())) << name;
    EXPECT_TRUE(same_bits(rich.peaks.central(), exact.peaks.central())) << name;
    EXPECT_TRUE(same_bits(rich.peaks_stop.central(), exact.peaks_stop.central())) << name;
    EXPECT_FALSE(same_bits(rich.times.means(), exact.times.means())) << name;
  }
}

TEST(Peaks, OnePathEqualsTheHandLoop) {
  // With one path a slot's mean is that path's value, bit for bit (the block sums are centred on
  // the first path's values): the kernel's peaks must be the reference walk's running maxima.
  for (auto method : {crandall::Method::exact, crandall::Method::euler}) {
    for (bool displacement : {false, true}) {
      for (std::uint64_t seed = 0; seed < 24; ++seed) {
        auto o = peak_scene();
        o.method = method;
        o.displacement = displacement;
        o.distance = false;
        o.paths = 1;
        o.seed = seed;
        const crandall::Plan plan(o);
        const auto r = crandall::run_chunk(plan, 0, 1);
        const auto want = reference_path(plan, 0);
        const std::string where = std::string(crandall::method_name(method)) +
                                  " displacement=" + std::to_string(displacement) +
                                  " seed=" + std::to_string(seed);
        double previous_speed = 0.0, previous_disp = 0.0;
        for (std::size_t s = 0; s < o.times.size(); ++s) {
          const double speed = r.peaks.means()[s * crandall::kVariables];
          const double disp = r.peaks.means()[s * crandall::kVariables + 1];
          EXPECT_EQ(speed, want[s][3]) << where << " slot " << s;
          EXPECT_EQ(disp, displacement ? want[s][4] : 0.0) << where << " slot " << s;
          EXPECT_GE(speed, std::abs(r.times.means()[s * crandall::kVariables])) << where;
          if (displacement) {
            EXPECT_GE(disp, std::abs(r.times.means()[s * crandall::kVariables + 1])) << where;
          }
          EXPECT_GE(speed, previous_speed) << where << " slot " << s;
          EXPECT_GE(disp, previous_disp) << where << " slot " << s;
          previous_speed = speed;
          previous_disp = disp;
        }
        EXPECT_EQ(r.peaks_stop.means()[0], want.back()[3]) << where;
        EXPECT_EQ(r.peaks_stop.means()[1], displacement ? want.back()[4] : 0.0) << where;
        EXPECT_GE(r.peaks_stop.means()[0], previous_speed) << where;
        EXPECT_GE(r.peaks_stop.means()[1], previous_disp) << where;
        if (displacement) {
          EXPECT_GE(r.peaks_stop.means()[1], std::abs(r.stop.means()[1])) << where;
        }
      }
    }
  }
}

TEST(Peaks, RefineCountsItsSubstepsAndStaysAboveTheGridPeak) {
  // refine adds points (its substeps) to the path near 0 but walks the exact method's grid
  // otherwise: its peaks are maxima over more points of different paths, so they are only
  // checked to be consistent (above the slot's own |value|, non-decreasing).
  auto o = peak_scene();
  o.method = crandall::Method::refine;
  o.paths = 1;
  for (std::uint64_t seed = 0; seed < 16; ++seed) {
    o.seed = seed;
    const auto r = crandall::run_chunk(crandall::Plan(o), 0, 1);
    double previous = 0.0;
    for (std::size_t s = 0; s < o.times.size(); ++s) {
      const double speed = r.peaks.means()[s * crandall::kVariables];
      EXPECT_GE(speed, std::abs(r.times.means()[s * crandall::kVariables]));
      EXPECT_GE(r.peaks.means()[s * crandall::kVariables + 1],
                std::abs(r.times.means()[s * crandall::kVariables + 1]));
      EXPECT_GE(speed, previous);
      previous = speed;
    }
  }
}

TEST(Peaks, AVelocityOnlySceneWalksTheFineGrid) {
  crandall::Options o;
  o.times = {0.5, 1.0};
  o.dt = 0.01;
  o.paths = 100;
  EXPECT_EQ(crandall::Plan(o).steps_per_path(), 2u);  // one exact step per segment
  o.peaks = true;
  EXPECT_EQ(crandall::Plan(o).steps_per_path(), 100u);
  o.min_steps = 200;
  EXPECT_EQ(crandall::Plan(o).steps_per_path(), 300u);  // 200 to 0.5, then 100 more to 1.0
  const auto r = crandall::run_chunk(crandall::Plan(o), 0, 1);
  EXPECT_EQ(r.peaks.slots(), 2u);
  EXPECT_EQ(r.peaks.means()[1], 0.0);  // no displacement observed
  EXPECT_GT(r.peaks.means()[0], 0.0);
}

TEST(Distributions, BadAxesAreRefusedNamingHistogramAxes) {
  auto expect_refused = [](const crandall::Options& o, const std::string& part) {
    try {
      crandall::Plan plan(o);
      ADD_FAILURE() << "accepted: " << part;
    } catch (const std::invalid_argument& e) {
      const std::string what = e.what();
      EXPECT_NE(what.find("histogram_axes"), std::string::npos) << what;
      EXPECT_NE(what.find(part), std::string::npos) << what;
    }
  };
  const BinEdges some = BinEdges::log_linear(1.0, 4, 8.0, true);
  auto o = scene();  // 4 times and the stop: 25 axes; no peaks
  o.histogram_axes.assign(24, BinEdges());
  expect_refused(o, "25");
  o.histogram_axes.assign(26, BinEdges());
  expect_refused(o, "got 26");
  o.histogram_axes.assign(25, BinEdges());
  EXPECT_NO_THROW(crandall::Plan{o});  // all unrecorded: allowed, nothing binned
  o.histogram_axes[3] = some;  // peak speed without peaks
  expect_refused(o, "peak speed");
  o.histogram_axes[3] = BinEdges();
  o.histogram_axes[5 * 4 + 4] = some;  // peak displacement at the stop without peaks
  expect_refused(o, "histogram_axes[24]");
  o.peaks = true;
  EXPECT_NO_THROW(crandall::Plan{o});
  o.displacement = false;
  expect_refused(o, "peak displacement");
  o.histogram_axes[5 * 4 + 4] = BinEdges();
  o.histogram_axes[6] = some;  // displacement at time 1, not observed
  expect_refused(o, "histogram_axes[6]");
  o.displacement = true;
  o.distance = false;
  o.histogram_axes[6] = BinEdges();
  o.histogram_axes[7] = some;  // distance, not observed
  expect_refused(o, "distance");
  o.distance = true;
  o.stop = false;  // the stop slot goes: 20 axes needed
  expect_refused(o, "20");
}

TEST(Distributions, TheKernelsLookupEqualsCellInEveryVariant) {
  // The kernel bins with count_lanes (a vectorised first guess, then the edge comparisons);
  // every variant must put every value where BinEdges::cell does: on every edge and its
  // mirror, one ulp either side, the midpoints, the ends of the axis, +-0, +-inf, NaN,
  // subnormals, huge values, and random values at the axis's scale.
  KeepKernel keep;
  std::vector<BinEdges> axes;
  for (double scale : {1e-3, 0.3, 0.7, 1.0, 5.5})
    for (int m : {1, 2, 16, 256})
      for (double reach : {1.0, 4.5, 50.0})
        for (bool symmetric : {false, true}) axes.push_back(BinEdges::log_linear(scale, m, reach, symmetric));
  axes.push_back(BinEdges::from_edges({-3.0, -0.5, 0.0, 0.1, 2.0}));
  const double inf = std::numeric_limits<double>::infinity();
  std::uint64_t state = 12345;
  auto uniform = [&state] {  // a fixed LCG: the values need no statistical quality
    state = state * 6364136223846793005ull + 1442695040888963407ull;
    return static_cast<double>(state >> 11) * 0x1.0p-53;
  };
  for (const BinEdges& axis : axes) {
    std::vector<double> x = {0.0, -0.0, inf, -inf, std::numeric_limits<double>::quiet_NaN(),
                             5e-324, -5e-324, 1e300, -1e300};
    const auto& e = axis.edges();
    for (std::size_t i = 0; i < e.size(); ++i)
      for (double v : {e[i], -e[i]}) {
        x.push_back(v);
        x.push_back(std::nextafter(v, inf));
        x.push_back(std::nextafter(v, -inf));
        if (i + 1 < e.size()) x.push_back(0.5 * (v + (v == e[i] ? e[i + 1] : -e[i + 1])));
      }
    for (int i = 0; i < 1000; ++i) x.push_back((uniform() - 0.5) * 4.0 * e.back());
    x.push_back(1.0);  // an odd count: a partial lane group at the end
    std::vector<std::uint64_t> want(axis.cells(), 0);
    for (double v : x) ++want[axis.cell(v)];
    for (const crandall::KernelTable* kernel : crandall::compiled_kernels()) {
      if (!crandall::kernel_supported(*kernel)) continue;
      std::vector<std::uint64_t> got(axis.cells(), 0);
      kernel->count_values(axis, x.data(), x.size(), got.data());
      EXPECT_EQ(got, want) << kernel->name << " bins=" << axis.bins() << " base=" << axis.base()
                           << " m=" << axis.per_octave() << " symmetric=" << axis.symmetric();
    }
  }
}

TEST(Distributions, ASceneWithoutThemHasNoHistogramsInItsWorkspace) {
  // Memory is set by the axes, never by the paths: a scene without axes holds no counts at all.
  const crandall::Plan plan(scene());
  EXPECT_FALSE(plan.histograms());
  const crandall::Workspace ws(plan);
  EXPECT_EQ(ws.histograms.slots(), 0u);
  EXPECT_TRUE(ws.histograms.counts().empty());
  auto o = scene();
  o.histogram_axes = axes_for(o);
  const crandall::Plan with(o);
  const crandall::Workspace ws2(with);
  std::size_t cells = 0;
  for (const BinEdges& a : o.histogram_axes) cells += a.bins() > 0 ? a.cells() : 0;
  EXPECT_EQ(ws2.histograms.counts().size(), cells);
}

}  // namespace
