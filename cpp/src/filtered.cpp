// The filtered excitation's path loop (filtered.hpp; docs/filtered.md).
//
// Per path, the filter's augmented state Y = (z, G, D) is walked on the plan's grid with its exact
// Gaussian transition (filter.hpp): every step gives z at its end and G = int a_g, D = int G over
// it, with no error. The body (V its velocity relative to the foundation, U its displacement,
// S = int |V|) follows:
//   sliding (V != 0): V' = -a_g - drift sgn V, U' = V, S' = |V|;
//   at rest (V = 0): stays while |a_g| <= static_drift, else slides the way -sgn a_g;
//   a slide reaching V = 0 where |a_g| > static_drift goes on the other way.
// Over an interval of length L on which no event (stop, onset) happens, a sliding body moves
// exactly by the skeleton's numbers: V1 = V0 - G - s drift L, dU = V0 L - D - s drift L^2 / 2,
// dS = s dU (s = sgn V0); a body at rest stays at rest. An interval where an event is possible
// (the test `possible_event`) is bisected by exact bridges in noise space (below), only its
// candidate halves again,
// down to event_depth bisections; on those finest substeps a_g is taken linear between its end
// values and the body is stepped exactly for that line by newmark::linear_step (the record
// integrator's own step).
//
// Bridges in noise space (filter.hpp, root_levels; docs/filtered.md): every interval carries
// its noise coordinates xi (Y_end = Phi(L) Y_start + sigma R(L) xi; the skeleton's are its
// normals), and its halves' are (xi_left; xi_right) = split (xi; eta) with eta ~ N(0, I_m) the
// node's normals: the midpoint is Y_mid = Phi(L/2) Y_start + sigma R(L/2) xi_left and the right
// half's (G, D) Phi(L/2) (z_mid, 0, 0) + sigma R(L/2) xi_right, both forward; the right half's
// end z is the interval's own (shared with the next interval). No state is conditioned on at run
// time, so nothing amplifies the rounding of the path's numbers.
//
// Coupled grids (run_samples, Richardson's methods): grid g's skeleton is every 2^g-th point of
// the walked grid, its (G, D) over a coarse step composed exactly from the fine steps'; its
// event search bisects a coarse step first at the fine grid's points, then inside a fine step
// with that step's own noise tree and random numbers (a composite interval is never split in
// noise space, so it needs no xi of its own: its first splits are at fine points, whose
// intervals carry the fine steps' xi). Every interval's numbers are a function of
// its place in that tree only, so the grids see one and the same path.
//
// Random numbers: Philox keyed by the seed; the counter is (index, path word), index = 2 k + j
// for the j-th block of 4 normals of fine step k, path word = path + ((2^22 + node) << 40) with
// node 0 for the skeleton's step and node >= 1 for the eta that splits node's interval of that
// step (node 1 the whole step, children 2 node and 2 node + 1). Paths are < 2^40 and nodes
// < 2^21, so these counters never meet each other nor the white-noise kernel's (path words below
// 2^40, or with bit 63 set).
#include "crandall/filtered.hpp"

#include <algorithm>
#include <array>
#include <atomic>
#include <functional>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>
#include <type_traits>

#include "crandall/branch.hpp"
#include "crandall/filter.hpp"
#include "crandall/kernel.hpp"
#include "crandall/kernel_controls.hpp"
#include "crandall/newmark.hpp"
#include "crandall/rng.hpp"
#include "crandall/run.hpp"

namespace crandall {
namespace {

std::atomic<double> event_margin{kEventMargin};

constexpr std::uint64_t kNodeTag = std::uint64_t{1} << 22;
constexpr int kPathBits = 40;

// The M <= 8 standard normals of one (path, step, node): Box-Muller on pairs of Philox words
// (radius from the first, angle from bits 2..31 of the second), with the project's
// deterministic log and sine/cosine (detmath.hpp), so the same bits on every CPU. A Philox block
// gives two pairs; the two go through the log and the sine/cosine side by side (one SSE2 vector:
// the same bits as one at a time, IEEE operations without contraction).
template <int M>
void normals(std::uint64_t seed, std::uint64_t path, std::uint64_t step, std::uint64_t node,
             double* out) {
  const std::uint64_t word = path + ((kNodeTag + node) << kPathBits);
  for (int j = 0; 4 * j < M; ++j) {
    std::uint64_t w[4];
    detail::philox_scalar(seed, word, 2 * step + static_cast<std::uint64_t>(j), w);
    double radius[2], sn[2], cs[2];
#pragma omp simd
    for (int p = 0; p < 2; ++p) {
      radius[p] = std::sqrt(-2.0 * detmath::log_positive(detmath::unit_of_word(w[2 * p])));
      detmath::sincos_turn30((w[2 * p + 1] & 0xFFFFFFFFull) >> 2, sn[p], cs[p]);
    }
    for (int p = 0; p < 2; ++p) {
      if (4 * j + 2 * p < M) out[4 * j + 2 * p] = radius[p] * cs[p];
      if (4 * j + 2 * p + 1 < M) out[4 * j + 2 * p + 1] = radius[p] * sn[p];
    }
  }
}

// The normals of node 0 (the skeleton's) of steps first .. first + count - 1, count <= kBatch:
// out[i * M + r] the r-th of step first + i, the same bits as normals<M> step by step; every
// pair of the batch goes through the log and the sine/cosine in one vectorised loop, so the
// steps' latencies overlap.
constexpr int kBatch = 16;
template <int M>
void skeleton_normals(std::uint64_t seed, std::uint64_t path, std::uint64_t first, int count,
                      double* out) {
  constexpr int kBlocks = (M + 3) / 4;
  const std::uint64_t word = path + (kNodeTag << kPathBits);
  std::uint64_t radial[2 * kBlocks * kBatch], angular[2 * kBlocks * kBatch];
  for (int i = 0; i < count; ++i)
    for (int j = 0; j < kBlocks; ++j) {
      std::uint64_t w[4];
      detail::philox_scalar(seed, word, 2 * (first + static_cast<std::uint64_t>(i)) + static_cast<std::uint64_t>(j), w);
      for (int p = 0; p < 2; ++p) {
        radial[(i * kBlocks + j) * 2 + p] = w[2 * p];
        angular[(i * kBlocks + j) * 2 + p] = w[2 * p + 1];
      }
    }
  double radius[2 * kBlocks * kBatch], sn[2 * kBlocks * kBatch], cs[2 * kBlocks * kBatch];
  const int pairs = 2 * kBlocks * count;
#pragma omp simd
  for (int q = 0; q < pairs; ++q) {
    radius[q] = std::sqrt(-2.0 * detmath::log_positive(detmath::unit_of_word(radial[q])));
    detmath::sincos_turn30((angular[q] & 0xFFFFFFFFull) >> 2, sn[q], cs[q]);
  }
  for (int i = 0; i < count; ++i)
    for (int j = 0; j < kBlocks; ++j)
      for (int p = 0; p < 2; ++p) {
        const int q = (i * kBlocks + j) * 2 + p;
        if (4 * j + 2 * p < M) out[i * M + 4 * j + 2 * p] = radius[q] * cs[q];
        if (4 * j + 2 * p + 1 < M) out[i * M + 4 * j + 2 * p + 1] = radius[q] * sn[q];
      }
}

// Whether the filter starts at rest (z(0) = 0): then every state of the shaking has mean 0, and
// the means of |a_g| and of the ground velocity's |vg| are sigma sqrt(2 / pi) (no exp or erf,
// whose last bit differs between CPUs). Otherwise those two features are left out (0).
bool zero_start(const FilterModel& fm) {
  for (double x : fm.start)
    if (x != 0.0) return false;
  return true;
}

constexpr double kRootTwoOverPi = 0.79788456080286535588;  // sqrt(2 / pi)

// A fine step of the walked grid: z at both ends, (G, D) over it, its index and start time.
template <int N>
struct FineStep {
  static constexpr int M = N + 2;
  double z0[N], z1[N];
  double xi[M];  // the skeleton's normals (noise coordinates in R(step))
  double g, d;
  std::uint64_t k;
  double t0;
};

// An interval the event search looks at: its start time and length, z at both ends, (G, D)
// over it, and where its midpoint comes from: `count` >= 2 fine steps of the group (fine points
// split it), or (count <= 1) inside fine step `k` as its bisection tree's `node` at relative
// depth `rel` (length step / 2^rel) with noise coordinates xi (count <= 1 only).
template <int N>
struct Interval {
  static constexpr int M = N + 2;
  double t0, len;
  double za[N], zb[N];
  double xi[M];
  double g, d;
  int first, count;
  std::uint64_t k;
  std::uint64_t node;
  int rel;
};

// One grid's body.
struct Body {
  double v = 0.0, u = 0.0, s = 0.0;
  double rest_since = 0.0;  // when it last came to rest
  bool done = false;        // at rest for good (after the switch-off, by the decay bound)
  // Options::peaks: the running maxima of |V| and |U| over the points the walk computed (the
  // grid's points, the ends of the event search's substeps, every arrival at rest).
  double pv = 0.0, pu = 0.0;
  void track_peaks() {
    const double av = std::abs(v), au = std::abs(u);
    pv = pv < av ? av : pv;
    pu = pu < au ? au : pu;
  }
};

// A grid's values at an output slot: (V, U, S, max |V|, max |U|); at the stop (the time of the
// stop, U, S, max |V|, max |U|). The maxima are 0 without Options::peaks.
using Values = std::array<double, 5>;

// The walker of a filter of dimension N (m = N + 2): fixed-size arrays and loops the compiler
// unrolls (Kanai-Tajimi N = 2, Clough-Penzien N = 4).
template <int N>
class Walker {
  static constexpr int M = N + 2;
  using Iv = Interval<N>;
  // A finest interval at rest (Touches at rest, last_touch).
  struct Rest {
    Iv iv;
    const StepTable* table;
    double sigma;
    double after;  // the rest's start when it began inside the interval, else iv.t0
  };

 public:
  Walker(const Plan& plan, int grids, Trajectory* trace, bool features = false)
      : plan_(plan), o_(plan.options()), fm_(*plan.filter()),
        grids_(grids), group_(1 << (grids - 1)), drift_(o_.drift), static_(fm_.static_drift),
        margin_(event_margin.load()), peaks_(o_.peaks), features_(features), trace_(trace),
        graze_depth_(fm_.deep_tables.empty() ? 0 : kGrazeDepth) {
    if (features_) {
      feature_slots_.assign((o_.times.size() + 1) * kFilteredControls, 0.0);
      folded_ = zero_start(fm_);
    }
    yield_ = {drift_, drift_, static_, static_};
    for (int i = 0; i < N; ++i) {
      c_[i] = fm_.filter.c[static_cast<std::size_t>(i)];
      ca2_[i] = fm_.c_a2[static_cast<std::size_t>(i)];
    }
  }

  // Walks one path; outputs[g][slot] = (V, U, S, max |V|, max |U|) at output slot `slot` of
  // grid g, and stops[g] = (time of the stop, U, S, max |V|, max |U|) (Values). Returns false
  // when cancelled.
  bool walk(std::uint64_t path, std::vector<std::vector<Values>>& outputs,
            std::vector<Values>& stops, const std::function<bool()>& cancelled,
            std::uint64_t& poll) {
    begin(path, o_.seed);
    for (int g = 0; g < grids_; ++g) {
      bodies_[g] = Body{};
      rests_[g].clear();
      bodies_[g].v = o_.start_velocity;
      bodies_[g].u = o_.start_displacement;
      if (peaks_) bodies_[g].track_peaks();
    }
    for (int i = 0; i < N; ++i) z_[i] = fm_.start[static_cast<std::size_t>(i)];
    if (features_) {
      vg_ = dg_ = 0.0;
      for (double& x : sums_) x = 0.0;
      for (double& x : martingale_) x = 0.0;
      for (double& x : covariation_) x = 0.0;
      for (double& x : second_) x = 0.0;
    }
    if (trace_) point(0.0, ground(z_), bodies_[0]);
    std::uint64_t k = 0;
    double start = 0.0;
    bool all_done = false;
    const auto at_slot = [&](long slot) {
      for (int g = 0; g < grids_; ++g)
        outputs[static_cast<std::size_t>(g)][static_cast<std::size_t>(slot)] = {
            bodies_[g].v, bodies_[g].u, bodies_[g].s, bodies_[g].pv, bodies_[g].pu};
      if (features_) snapshot(static_cast<std::size_t>(slot));
    };
    if (!segments(0, true, cancelled, poll, at_slot, [](std::uint64_t) {}, k, start, all_done))
      return false;
    if (!o_.stop) return true;
    if (features_) snapshot(o_.times.size());  // (frozen since the switch-off)
    if (start < o_.switch_off) start = o_.switch_off;  // (the grid always reaches it)
    end_shaking();
    const StepTable& tail = fm_.tables[static_cast<std::size_t>(fm_.tail_table)];
    // The ring-down: noise-free steps until every grid's body is at rest for good.
    shaking_ = false;
    all_done = all_done || check_done(k);
    for (std::uint64_t j = 0; !all_done; ++j, ++k) {
      if ((++poll & (kPollSteps - 1)) == 0 && cancelled && cancelled()) return false;
      step(tail, 0.0, k, start + static_cast<double>(j) * tail.step);
      all_done = check_done(k + 1);
    }
    if (graze_depth_ > 0)
      for (int g = 0; g < grids_; ++g) {
        Body& b = bodies_[g];
        if (b.v != 0.0) continue;
        const double t = last_touch(rests_[g]);
        if (t > b.rest_since) b.rest_since = t;
      }
    for (int g = 0; g < grids_; ++g)
      stops[static_cast<std::size_t>(g)] = {bodies_[g].rest_since, bodies_[g].u, bodies_[g].s,
                                            bodies_[g].pv, bodies_[g].pu};
    return true;
  }

  // With features: the ground-motion features of the last walk at output slot `slot` (the
  // stop: times.size()), kGroundFeatures of them (filtered.hpp).
  const double* features(std::size_t slot) const {
    return feature_slots_.data() + slot * kFilteredControls;
  }

  // Continues a path of the walked grid (grids() == 1) from its state at grid point `from`,
  // row[from * cols ..] = (V, U, S, the time of its last arrival at rest, z), with the random
  // numbers of path `path` under `key`, to the plan's last grid point (the ring-down to the
  // stop is not walked), storing the state at every point after `from` (extend_filtered_paths).
  void extend(double* row, std::size_t cols, std::uint64_t from, std::uint64_t path,
              std::uint64_t key) {
    begin(path, key);
    Body& b = bodies_[0];
    const double* p = row + from * cols;
    b = Body{};
    b.v = p[0];
    b.u = p[1];
    b.s = p[2];
    b.rest_since = p[3];
    for (int i = 0; i < N; ++i) z_[i] = p[kStateColumns + i];
    std::uint64_t k = 0, poll = 0;
    double start = 0.0;
    bool all_done = false;
    segments(
        from, false, {}, poll, [](long) {},
        [&](std::uint64_t at) {
          double* q = row + at * cols;
          q[0] = b.v;
          q[1] = b.u;
          q[2] = b.s;
          q[3] = b.rest_since;
          for (int i = 0; i < N; ++i) q[kStateColumns + i] = z_[i];
        },
        k, start, all_done);
  }

 private:
  void begin(std::uint64_t path, std::uint64_t key) {
    path_ = path;
    seed_ = key;
    batch_first_ = ~std::uint64_t{0} - kBatch;  // (no step's)
  }

  // Steps the plan's segments from the walked grid's point `from` (z_ and bodies_ hold the
  // state there) to their end; k and start receive the fine step index and the time after
  // them, all_done whether every grid's body came to rest for good (only with `done_checks`,
  // after the switch-off, for a plan with the stop). at_slot(slot) after every segment that
  // ends at or after `from` with an output slot, at_point(k) after fine step k - 1 (at grid
  // point k). A segment's step times are its start plus j steps, whatever `from` (the same
  // bits from any point). Returns false when cancelled.
  template <class AtSlot, class AtPoint>
  bool segments(std::uint64_t from, bool done_checks, const std::function<bool()>& cancelled,
                std::uint64_t& poll, AtSlot&& at_slot, AtPoint&& at_point, std::uint64_t& k,
                double& start, bool& all_done) {
    k = 0;
    start = 0.0;
    all_done = false;
    const auto& segs = plan_.segments();
    for (std::size_t i = 0; i < segs.size(); ++i) {
      const Segment& seg = segs[i];
      if (k + seg.steps < from) {  // (wholly before the start point)
        k += seg.steps;
        start += static_cast<double>(seg.steps) * seg.step;
        continue;
      }
      const bool after = start >= o_.switch_off;
      if (after) end_shaking();
      shaking_ = !after;
      if (seg.steps > 0 && !all_done) {
        const StepTable& table = fm_.tables[static_cast<std::size_t>(fm_.segment_table[i])];
        std::uint64_t j = from > k ? from - k : 0;
        for (k += j; j < seg.steps && !all_done; ++j, ++k) {
          if ((++poll & (kPollSteps - 1)) == 0 && cancelled && cancelled()) return false;
          step(table, seg.noise, k, start + static_cast<double>(j) * seg.step);
          if (after && o_.stop && done_checks) all_done = check_done(k + 1);
          at_point(k + 1);
        }
      }
      start += static_cast<double>(seg.steps) * seg.step;
      if (seg.slot >= 0) at_slot(seg.slot);
    }
    return true;
  }

  // The ground-motion features' running sums after a shaking fine step of length h with
  // ground-velocity increment g = int a_g and d = int G over it (filtered.hpp, ground_features).
  void accumulate(double h, double g, double d) {
    dg_ = dg_ + vg_ * h + d;
    vg_ = vg_ + g;
    const double a = ground(z_);
    sums_[0] += h * (a * a);
    sums_[1] += h * (vg_ * vg_);
    sums_[2] += h * (dg_ * dg_);
    if (folded_) {
      sums_[3] += h * std::abs(a);
      sums_[4] += h * std::abs(vg_);
    }
  }
  // The body controls' sums (filtered.hpp): the walked grid's body at the step's start (a
  // function of the earlier steps only) times the innovation of the step's G, sigma R_G xi.
  // With var_e the innovation's variance, also the quadratic covariations of the products'
  // sums (filtered.hpp, kBodyProducts) and the second-order sums (kBodySecondOrder).
  void innovate(double e, double var_e, double t) {
    const Body& b = bodies_[0];
    const double sv = b.v > 0.0 ? 1.0 : (b.v < 0.0 ? -1.0 : 0.0);
    const double x[kBodyControls] = {b.v, b.s * b.v, sv, b.u, (o_.switch_off - t) * b.v, 1.0};
    for (int q = 0; q < kBodyControls; ++q) martingale_[q] += x[q] * e;
    covariation_[0] += (b.v * b.v) * var_e;
    covariation_[1] += (b.v * sv) * var_e;
    covariation_[2] += (sv * sv) * var_e;
    const double av = sv * b.v, excess = e * e - var_e;
    second_[0] += (b.v * av) * e;
    second_[1] += excess;
    second_[2] += (b.v * b.v) * excess;
    second_[3] += av * excess;
  }
  void snapshot(std::size_t slot) {
    double* f = feature_slots_.data() + slot * kFilteredControls;
    for (int q = 0; q < kBodyControls; ++q) f[kGroundFeatures + q] = martingale_[q];
    double* products = f + kGroundFeatures + kBodyControls;
    products[0] = martingale_[0] * martingale_[0] - covariation_[0];
    products[1] = martingale_[0] * martingale_[2] - covariation_[1];
    products[2] = martingale_[2] * martingale_[2] - covariation_[2];
    for (int q = 0; q < kBodySecondOrder; ++q) products[kBodyProducts + q] = second_[q];
    f[0] = sums_[0];
    f[1] = sums_[1];
    f[2] = vg_ * vg_;
    f[3] = sums_[3];
    f[4] = sums_[4];
    f[5] = vg_;
    f[6] = dg_;
    f[7] = dg_ * dg_;
    f[8] = sums_[2];
  }

  // At the switch-off, unless the filter rings down (Options::ring_down): the shaking ends,
  // a_g = 0 from here on. z = 0 is the filter's rest, where no noise leaves it at 0, so the
  // steps after it move the body by friction alone (exactly: a_g = 0 is a straight line).
  void end_shaking() {
    if (o_.ring_down) return;
    for (int i = 0; i < N; ++i) z_[i] = 0.0;
  }

  double ground(const double* z) const {
    double a = 0.0;
    for (int i = 0; i < N; ++i) a += c_[i] * z[i];
    return a;
  }
  double curvature(const double* z) const {
    double a = 0.0;
    for (int i = 0; i < N; ++i) a += ca2_[i] * z[i];
    return std::abs(a);
  }
  void point(double t, double a, const Body& b) {
    trace_->time.push_back(t);
    trace_->ground.push_back(a);
    trace_->velocity.push_back(b.v);
    trace_->displacement.push_back(b.u);
    trace_->distance.push_back(b.s);
  }

  // After fine step `k_end` - 1 (the walked grid's point k_end), after the switch-off: grid g
  // (at its own points) is at rest for good once it is at rest and the decay bound keeps |a_g|
  // within the static friction for ever.
  bool check_done(std::uint64_t k_end) {
    bool all = true;
    double bound = -1.0;
    for (int g = 0; g < grids_; ++g) {
      Body& b = bodies_[g];
      if (!b.done && (k_end & ((std::uint64_t{1} << g) - 1)) == 0 && b.v == 0.0) {
        if (bound < 0.0) bound = fm_.bound.bound(z_, N);
        if (bound <= static_) b.done = true;
      }
      all = all && b.done;
    }
    return all;
  }

  // Fine step k from time t0: the skeleton's transition, then every grid whose step ends here.
  void step(const StepTable& table, double sigma, std::uint64_t k, double t0) {
    FineStep<N>& f = buffer_[k & static_cast<std::uint64_t>(group_ - 1)];
    const double* phi = table.skeleton.phi.data();
    const double* root = table.skeleton.root.data();
    double xi[M];
    if (sigma != 0.0) {
      // (drawn kBatch steps ahead: the path's stop may leave some unused)
      if (k < batch_first_ || k >= batch_first_ + kBatch) {
        batch_first_ = k;
        skeleton_normals<M>(seed_, path_, k, kBatch, batch_);
      }
      for (int i = 0; i < M; ++i) xi[i] = batch_[(k - batch_first_) * M + static_cast<std::uint64_t>(i)];
    } else {
      for (int i = 0; i < M; ++i) xi[i] = 0.0;
    }
    double y[M], g_noise = 0.0, g_var = 0.0;
    for (int r = 0; r < M; ++r) {
      double mean = 0.0, noise = 0.0;
      for (int c = 0; c < N; ++c) mean += phi[r * M + c] * z_[c];
      if (sigma != 0.0)  // (the tree's root: lower triangular)
        for (int c = 0; c <= r; ++c) noise += root[r * M + c] * xi[c];
      y[r] = mean + sigma * noise;
      if (r == N) g_noise = sigma * noise;
    }
    if (features_ && shaking_ && sigma != 0.0) {
      for (int c = 0; c <= N; ++c) g_var += root[N * M + c] * root[N * M + c];
      innovate(g_noise, (sigma * sigma) * g_var, t0);
    }
    for (int i = 0; i < N; ++i) {
      f.z0[i] = z_[i];
      f.z1[i] = z_[i] = y[i];
    }
    if (features_ && shaking_) accumulate(table.step, y[N], y[N + 1]);
    for (int i = 0; i < M; ++i) f.xi[i] = xi[i];
    f.g = y[N];
    f.d = y[N + 1];
    f.k = k;
    f.t0 = t0;
    table_ = &table;
    sigma_ = sigma;
    for (int g = 0; g < grids_; ++g) {
      const int span = 1 << g;
      if (((k + 1) & static_cast<std::uint64_t>(span - 1)) != 0 || bodies_[g].done) continue;
      const int first = static_cast<int>((k + 1 - static_cast<std::uint64_t>(span)) &
                                         static_cast<std::uint64_t>(group_ - 1));
      Iv iv;
      compose(first, span, iv);
      trace_grid_ = trace_ != nullptr && g == 0;
      search(iv, fm_.depth, bodies_[g]);
    }
  }

  // The interval of fine steps [first, first + count) of the group: its ends and the (G, D)
  // composed step by step (G = G1 + G2, D = D1 + D2 + G1 L2).
  void compose(int first, int count, Iv& iv) const {
    const FineStep<N>& a = buffer_[first];
    const FineStep<N>& b = buffer_[first + count - 1];
    const double h = table_->step;
    iv.t0 = a.t0;
    iv.len = h * static_cast<double>(count);
    for (int i = 0; i < N; ++i) {
      iv.za[i] = a.z0[i];
      iv.zb[i] = b.z1[i];
    }
    double g = 0.0, d = 0.0;
    for (int j = first; j < first + count; ++j) {
      d = d + buffer_[j].d + g * h;
      g = g + buffer_[j].g;
    }
    iv.g = g;
    iv.d = d;
    for (int i = 0; i < M; ++i) iv.xi[i] = count == 1 ? a.xi[i] : 0.0;
    iv.first = first;
    iv.count = count;
    iv.k = a.k;
    iv.node = 1;
    iv.rel = 0;
  }

  double spread(const Iv& iv) const {
    if (iv.count >= 2) return table_->spread_coarse[iv.count == 2 ? 1 : 2];
    return table_->spread_fine[static_cast<std::size_t>(iv.rel)];
  }

  // Whether an event (a stop, an onset, a reversal) may happen in the interval for a body with
  // velocity v at its start (docs/filtered.md, "Events"). a_g on the interval is taken to stay
  // within R = margin (sigma spread + L^2 / 8 max |c A^2 z| at the ends) of the line between its
  // end values: the bridge's deviation from that line (its standard deviation at the midpoint,
  // `spread`) and the curvature of its mean.
  // At rest: an onset needs a_g to cross +static_drift or -static_drift. For a Brownian bridge
  // from a to b with standard deviation s at its midpoint, P(max > K) = exp(-(K - a)(K - b) /
  // (2 s^2)), so the interval is searched when (K - a)(K - b) < R^2 for either sign (an end at
  // or beyond K included): a miss probability of at most exp(-margin^2 / 2), as for the worst
  // end alone, with the other end's distance counted too.
  // Sliding (s = sgn V0, V1 the no-event value): V1 on the other side of 0 is an event. Else V
  // cannot reach 0 when, within the band, V stays positive (times s) on both halves: on the
  // first V(t) >= s V0 - (L/2) max(0, max(s a) + R + drift), on the second (from the end)
  // V(t) >= s V1 - (L/2) max(0, R - drift - min(s a)), max and min over the ends.
  // The mean of a_g at the interval's midpoint given its start and xi (a composite interval's
  // midpoint is a fine point: its value).
  double middle(const Iv& iv) const {
    if (iv.count >= 2) return ground(buffer_[iv.first + iv.count / 2 - 1].z1);
    const double* wz = table_->mid_z.data() + iv.rel * N;
    const double* wx = table_->mid_xi.data() + iv.rel * M;
    double a = 0.0, x = 0.0;
    for (int i = 0; i < N; ++i) a += wz[i] * iv.za[i];
    for (int i = 0; i < M; ++i) x += wx[i] * iv.xi[i];
    return a + sigma_ * x;
  }

  bool possible_event(const Iv& iv, double v) const {
    const double aa = ground(iv.za), ab = ground(iv.zb), am = middle(iv);
    const double curve = 0.125 * iv.len * iv.len * std::max(curvature(iv.za), curvature(iv.zb));
    const double band = margin_ * (sigma_ * spread(iv) + curve);
    if (v == 0.0) {
      if (iv.count >= 2) {  // (each fine step: its own points' means)
        for (int j = iv.first; j < iv.first + iv.count; ++j) {
          Iv fine;
          compose(j, 1, fine);
          if (possible_event(fine, 0.0)) return true;
        }
        return false;
      }
      // The points j / 8 of the interval (its ends, and the conditional means given its start
      // and xi between them): on each segment between two of them a_g is taken within R_j =
      // margin (sigma spread_j + curve) of the segment's chord, spread_j the widest spread over
      // the segment (its ends and middle: seg_spread), so an onset is possible when an end of
      // a segment is within R_j of +-K. (A point's own value may lie its spread away from its
      // mean; an end of the interval is a known value, spread 0.)
      const double* wz = table_->pts_z.data() + iv.rel * kRestPoints * N;
      const double* wx = table_->pts_xi.data() + iv.rel * kRestPoints * M;
      const double* sp = table_->seg_spread.data() + iv.rel * (kRestPoints + 1);
      double prev = aa;
      for (int j = 0; j <= kRestPoints; ++j) {
        double p = ab;
        if (j < kRestPoints) {
          double a = 0.0, x = 0.0;
          for (int i = 0; i < N; ++i) a += wz[i] * iv.za[i];
          for (int i = 0; i < M; ++i) x += wx[i] * iv.xi[i];
          p = a + sigma_ * x;
          wz += N;
          wx += M;
        }
        const double r = margin_ * (sigma_ * sp[j] + curve);
        const double hi = prev > p ? prev : p, lo = prev < p ? prev : p;
        if (hi > static_ - r || lo < r - static_) return true;
        prev = p;
      }
      return false;
    }
    const double s = v > 0.0 ? 1.0 : -1.0;
    const double v1 = v - iv.g - s * drift_ * iv.len;
    if (s * v1 <= 0.0) return true;
    const double sa = s * aa, sb = s * ab, sm = s * am;
    const double half = 0.5 * iv.len;
    const double fall0 = std::max(std::max(sa, sm), sb) + band + drift_;  // the fastest fall of s V
    const double fall1 = band - drift_ - std::min(std::min(sa, sm), sb);  // the fastest fall towards the end
    return s * v <= half * std::max(0.0, fall0) || s * v1 <= half * std::max(0.0, fall1);
  }

  void search(const Iv& iv, int depth_left, Body& b) {
    if (!possible_event(iv, b.v)) {
      if (b.v != 0.0) {
        const double s = b.v > 0.0 ? 1.0 : -1.0;
        const double v1 = b.v - iv.g - s * drift_ * iv.len;
        const double du = b.v * iv.len - iv.d - s * drift_ * (0.5 * iv.len * iv.len);
        b.u += du;
        b.s += s * du;
        b.v = v1;
        if (peaks_) b.track_peaks();
      }
      if (trace_grid_) point(iv.t0 + iv.len, ground(iv.zb), b);
      return;
    }
    if (depth_left == 0) {
      finest(iv, b);
      return;
    }
    Iv left, right;
    bisect(iv, left, right);
    search(left, depth_left - 1, b);
    search(right, depth_left - 1, b);
  }

  // The two halves of an interval: at a fine point, or by the noise-space split of its node.
  void bisect(const Iv& iv, Iv& left, Iv& right) const {
    if (iv.count >= 2) {
      const int half = iv.count / 2;
      compose(iv.first, half, left);
      compose(iv.first + half, half, right);
      return;
    }
    const std::size_t level = static_cast<std::size_t>(kLevelsUp + iv.rel);
    const RootLevel& half = table_->levels[level + 1];  // Phi(len / 2), R(len / 2)
    const double* phi = half.phi.data();
    const double* root = half.root.data();
    double y[M], gd[2];
    double children[2 * M];  // (xi_left; xi_right)
    if (sigma_ != 0.0) {
      // (xi_left; xi_right) = split (xi; eta): iid N(0, I_m) with
      // Phi(L/2) R(L/2) xi_left + R(L/2) xi_right = R(L) xi.
      const double* split = table_->levels[level].split.data();
      double u[2 * M];
      for (int i = 0; i < M; ++i) u[i] = iv.xi[i];
      normals<M>(seed_, path_, iv.k, iv.node, u + M);
      constexpr int w = 2 * M;
      for (int r = 0; r < w; ++r) {
        double sum = 0.0;
        for (int c = 0; c < w; ++c) sum += split[r * w + c] * u[c];
        children[r] = sum;
      }
    } else {
      for (int i = 0; i < 2 * M; ++i) children[i] = 0.0;
    }
    // The midpoint, forward from the start: Phi(L/2) (za, 0, 0) + sigma R(L/2) xi_left (the
    // roots are lower triangular: root_levels).
    for (int r = 0; r < M; ++r) {
      double mean = 0.0, noise = 0.0;
      for (int c = 0; c < N; ++c) mean += phi[r * M + c] * iv.za[c];
      if (sigma_ != 0.0)
        for (int c = 0; c <= r; ++c) noise += root[r * M + c] * children[c];
      y[r] = mean + sigma_ * noise;
    }
    // The right half's own (G, D), forward from the midpoint: Phi(L/2) (z_mid, 0, 0) + sigma
    // R(L/2) xi_right; its end z is the interval's (the point it shares with the next one).
    for (int r = N; r < M; ++r) {
      double mean = 0.0, noise = 0.0;
      for (int c = 0; c < N; ++c) mean += phi[r * M + c] * y[c];
      if (sigma_ != 0.0)
        for (int c = 0; c <= r; ++c) noise += root[r * M + c] * children[M + c];
      gd[r - N] = mean + sigma_ * noise;
    }
    const double mid = 0.5 * iv.len;
    for (Iv* p : {&left, &right}) {
      p->len = mid;
      p->count = 1;
      p->first = iv.first;
      p->k = iv.k;
      p->rel = iv.rel + 1;
    }
    left.t0 = iv.t0;
    right.t0 = iv.t0 + mid;
    left.node = 2 * iv.node;
    right.node = 2 * iv.node + 1;
    for (int i = 0; i < N; ++i) {
      left.za[i] = iv.za[i];
      left.zb[i] = right.za[i] = y[i];
      right.zb[i] = iv.zb[i];
    }
    for (int i = 0; i < M; ++i) {
      left.xi[i] = children[i];
      right.xi[i] = children[M + i];
    }
    left.g = y[N];
    left.d = y[N + 1];
    right.g = gd[0];
    right.d = gd[1];
  }

  // A finest substep: a_g linear between its ends, the body stepped exactly for that line
  // (newmark's sliding velocity W is -V, its displacement -U).
  void finest(const Iv& iv, Body& b) {
    const double aa = ground(iv.za), ab = ground(iv.zb);
    const bool resting = b.v == 0.0;
    bool arrived = false;
    double arrival = 0.0;
    newmark::Motion mo;
    mo.w = -b.v;
    mo.mode = b.v == 0.0 ? 0 : (b.v < 0.0 ? 1 : -1);
    double dist = 0.0;
    const double u0 = b.u, s0 = b.s;
    newmark::linear_step(
        mo, aa, ab, iv.len, iv.t0, yield_, [](double, int) {},
        [&](double t) {
          b.rest_since = t;
          arrived = true;
          arrival = t;
          if (peaks_) {  // (at rest: V = 0; U there counts)
            const double au = std::abs(u0 - mo.d);
            b.pu = b.pu < au ? au : b.pu;
          }
          if (trace_grid_) {
            Body at{0.0, u0 - mo.d, s0 + dist, t, false};
            point(t, aa + (ab - aa) * ((t - iv.t0) / iv.len), at);
          }
        },
        &dist);
    b.v = mo.mode == 0 ? 0.0 : -mo.w;
    b.u = u0 - mo.d;
    b.s = s0 + dist;
    if (peaks_) b.track_peaks();
    if (trace_grid_) point(iv.t0 + iv.len, ab, b);
    if (graze_depth_ > 0) {
      std::vector<Rest>& rests = rests_[&b - bodies_];
      if (arrived) rests.clear();
      if (b.v == 0.0 && (resting || arrived) && sigma_ != 0.0)
        rests.push_back({iv, table_, sigma_, arrived ? arrival : iv.t0});
    }
  }

  // Touches at rest (docs/filtered.md, "Touches at rest and the stop"). A finest substep takes a_g
  // linear, but a_g is rough: between two ends below K = static_drift it touches K with a
  // probability near exp(-(K - a)(K - b) / (2 s^2)) (s its midpoint's spread), and each touch
  // is a slide too short for the substep that moves the last time the body came to rest. Only
  // the stop time counts them (a micro-slide moves V, U and S by far less than the substep's
  // other errors), and only in the last rest: so the finest intervals at rest since the body
  // last came to rest are kept (rests_), and at the stop they are searched again, latest
  // first, by the same exact bridges down to graze_depth_ (in the deeper tables, the same tree
  // up to rounding), for the last time |a_g| reaches K. The first interval with a touch ends
  // the search. Returns -infinity when no touch is found.
  double last_touch(const std::vector<Rest>& rests) {
    const StepTable* table = table_;
    const double sigma = sigma_;
    double t = -std::numeric_limits<double>::infinity();
    for (auto r = rests.rbegin(); r != rests.rend() && t == -std::numeric_limits<double>::infinity(); ++r) {
      table_ = &fm_.deep_tables[static_cast<std::size_t>(r->table - fm_.tables.data())];
      sigma_ = r->sigma;
      t = touch(r->iv, graze_depth_ - r->iv.rel, r->after);
    }
    table_ = table;
    sigma_ = sigma;
    return t;
  }

  // The last time after `after` in the interval at which |a_g| reaches static_drift: bisected
  // (the right half first) while possible_event allows one; on the deepest intervals a_g is
  // the line between their ends.
  double touch(const Iv& iv, int depth_left, double after) {
    constexpr double none = -std::numeric_limits<double>::infinity();
    const double end = iv.t0 + iv.len;
    if (end <= after || !possible_event(iv, 0.0)) return none;
    const double ab = ground(iv.zb);
    if (std::abs(ab) >= static_) return end;
    if (depth_left == 0) {
      const double aa = ground(iv.za);
      if (std::abs(aa) < static_) return none;
      // (the line leaves the band |a| >= K where it crosses the side aa is on)
      const double k = aa > 0.0 ? static_ : -static_;
      const double t = iv.t0 + iv.len * ((k - aa) / (ab - aa));
      return t > after ? t : none;
    }
    Iv left, right;
    bisect(iv, left, right);
    const double t = touch(right, depth_left - 1, after);
    return t != none ? t : touch(left, depth_left - 1, after);
  }

  const Plan& plan_;
  const Options& o_;
  const FilterModel& fm_;
  const int grids_, group_;
  const double drift_, static_, margin_;
  const bool peaks_;
  const bool features_;
  bool folded_ = false;   // the |a_g| and |ground velocity| features (a filter starting at 0)
  bool shaking_ = false;  // the current segment is before the switch-off
  double vg_ = 0.0, dg_ = 0.0;  // the ground's velocity and displacement (from 0)
  double sums_[5] = {};          // the running sums of h a^2, h vg^2, h dg^2, h |a|, h |vg|
  double martingale_[kBodyControls] = {};  // the body controls' sums (innovate)
  double covariation_[kBodyProducts] = {};  // their quadratic covariations (innovate)
  double second_[kBodySecondOrder] = {};     // the second-order sums (innovate)
  std::vector<double> feature_slots_;
  Trajectory* trace_;
  bool trace_grid_ = false;
  newmark::Yield yield_{};
  double c_[N] = {}, ca2_[N] = {};
  std::uint64_t path_ = 0;
  std::uint64_t seed_ = 0;  // the Philox key (the plan's seed, or a continuation's key)
  std::uint64_t batch_first_ = 0;  // the skeleton's normals of steps batch_first_ + [0, kBatch)
  double batch_[kBatch * M] = {};
  double z_[N] = {};
  Body bodies_[3];
  // Each grid's finest intervals at rest since its body last came to rest (rests_).
  std::vector<Rest> rests_[3];
  const int graze_depth_;  // the depth the touches' search reaches (0: not searched)
  FineStep<N> buffer_[4];
  const StepTable* table_ = nullptr;
  double sigma_ = 0.0;
};

// Calls fn(std::integral_constant<int, N>{}) for the plan's filter dimension N.
template <class Fn>
void with_dimension(const Plan& plan, Fn&& fn) {
  switch (plan.filter()->filter.n) {
    case 1: fn(std::integral_constant<int, 1>{}); break;
    case 2: fn(std::integral_constant<int, 2>{}); break;
    case 3: fn(std::integral_constant<int, 3>{}); break;
    case 4: fn(std::integral_constant<int, 4>{}); break;
    case 5: fn(std::integral_constant<int, 5>{}); break;
    case 6: fn(std::integral_constant<int, 6>{}); break;
    default: throw std::logic_error("filtered: filter dimension out of range");
  }
}
static_assert(kMaxFilter == 6, "with_dimension covers n = 1 .. kMaxFilter");

}  // namespace

double set_event_margin(double margin) {
  if (!(std::isfinite(margin) && margin > 0.0))
    throw std::invalid_argument("event margin must be finite and > 0");
  return event_margin.exchange(margin);
}

namespace {

template <int N>
void filtered_block(const Plan& plan, std::uint64_t first, std::uint64_t count, Workspace& ws) {
  const Options& o = plan.options();
  const int grids = o.grids();
  const std::size_t slots = o.times.size();
  const bool controls = ws.controls != nullptr;
  Walker<N> walker(plan, grids, nullptr, controls);
  const std::size_t chosen = ws.control_slots.size();
  static_assert(kFilteredControls <= kControls, "the controls fit the control sums' width");
  std::vector<std::vector<Values>> outputs(static_cast<std::size_t>(grids),
                                           std::vector<Values>(slots));
  std::vector<Values> stops(static_cast<std::size_t>(grids));
  // The walked grid's values of a group of kLanes paths, slot by slot (V, U, S, max |V|,
  // max |U|), summed as the white kernel sums its lanes.
  constexpr std::size_t kValues = 5;
  std::vector<double> lanes_out(slots * kValues * kLanes);
  double ts[kLanes], us[kLanes], ss[kLanes], au[kLanes], sv[kLanes], su[kLanes];
  const double zero[kLanes] = {};
  // run_samples' per-path peaks (Options::sample_slots): (max |V|, max |U|, 0) on every grid,
  // in the slots after the stop's, one per output time and one for the stop.
  const std::size_t peak_slot = slots + (o.stop ? 1 : 0);
  const auto record_peaks = [&](std::size_t k, std::uint64_t path) {  // k == slots: the stop
    for (int g = 0; g < grids; ++g) {
      const Values& y = k < slots ? outputs[static_cast<std::size_t>(g)][k]
                                  : stops[static_cast<std::size_t>(g)];
      const double pu = o.displacement ? y[4] : 0.0;
      ws.record(peak_slot + k, g, path, &y[3], &pu, &zero[0], 1);
    }
  };
  std::uint64_t poll = 0;
  for (std::uint64_t offset = 0; offset < count; offset += kLanes) {
    const int lanes = static_cast<int>(std::min<std::uint64_t>(kLanes, count - offset));
    const std::uint64_t path0 = first + offset;
    for (int l = 0; l < lanes; ++l) {
      const std::uint64_t path = path0 + static_cast<std::uint64_t>(l);
      if (!walker.walk(path, outputs, stops, ws.cancelled, poll)) return;
      if (controls) {  // the features minus their exact means (filtered.hpp)
        double* row = ws.controls + (path - ws.sample_first) * chosen * kControls;
        for (std::size_t a = 0; a < chosen; ++a) {
          const std::size_t slot = ws.control_slots[a];
          const double* f = walker.features(slot);
          const double* mu = ws.control_means.data() + slot * kGroundFeatures;
          for (int q = 0; q < kControls; ++q)
            row[a * kControls + q] = q < kGroundFeatures    ? f[q] - mu[q]
                                     : q < kFilteredControls ? f[q]
                                                             : 0.0;
        }
      }
      for (std::size_t k = 0; k < slots; ++k) {
        for (std::size_t v = 0; v < kValues; ++v)
          lanes_out[(k * kValues + v) * kLanes + static_cast<std::size_t>(l)] = outputs[0][k][v];
        for (int g = 0; g < grids; ++g) {
          const auto& x = outputs[static_cast<std::size_t>(g)][k];
          ws.record(k, g, path, &x[0], &x[1], &x[2], 1);
        }
        if (o.peaks) record_peaks(k, path);
      }
      if (o.stop) {
        ts[l] = stops[0][0] - o.switch_off;
        us[l] = stops[0][1];
        ss[l] = stops[0][2];
        au[l] = std::abs(us[l]);
        sv[l] = stops[0][3];
        su[l] = o.displacement ? stops[0][4] : 0.0;
        for (int g = 0; g < grids; ++g) {
          const double t = stops[static_cast<std::size_t>(g)][0] - o.switch_off;
          ws.record(slots, g, path, &t, &stops[static_cast<std::size_t>(g)][1],
                    &stops[static_cast<std::size_t>(g)][2], 1);
        }
        if (o.peaks) record_peaks(slots, path);
      }
    }
    for (std::size_t k = 0; k < slots; ++k) {
      const double* x = &lanes_out[(k * kValues + 0) * kLanes];
      const double* u = &lanes_out[(k * kValues + 1) * kLanes];
      const double* s = &lanes_out[(k * kValues + 2) * kLanes];
      const double* pv = &lanes_out[(k * kValues + 3) * kLanes];
      const double* pu = o.displacement ? &lanes_out[(k * kValues + 4) * kLanes] : zero;
      ws.times.add(k, x, u, s, lanes, ws.active);
      ws.add_energy(k, x, lanes);
      if (o.peaks) ws.peaks.add(k, pv, pu, zero, lanes, ws.peak_active);
      if (plan.histograms())
        bin_slot(plan, ws.histograms, k,
                 {x, o.displacement ? u : nullptr, o.distance ? s : nullptr,
                  o.peaks ? pv : nullptr, o.peaks && o.displacement ? pu : nullptr},
                 lanes);
    }
    if (o.stop) {
      ws.stop.add(0, ts, us, ss, lanes, ws.active);
      if (o.residual) ws.stop.add(1, au, zero, zero, lanes, ws.active);
      if (o.peaks) ws.peaks_stop.add(0, sv, su, zero, lanes, ws.peak_active);
      if (plan.histograms())
        bin_slot(plan, ws.histograms, slots,
                 {ts, o.displacement ? us : nullptr, o.distance ? ss : nullptr,
                  o.peaks ? sv : nullptr, o.peaks && o.displacement ? su : nullptr},
                 lanes);
    }
  }
}

template <int N>
void trace(const Plan& plan, std::uint64_t path, Trajectory& out) {
  const Options& o = plan.options();
  Walker<N> walker(plan, 1, &out);
  std::vector<std::vector<Values>> outputs(1, std::vector<Values>(o.times.size()));
  std::vector<Values> stops(1);
  std::uint64_t poll = 0;
  walker.walk(path, outputs, stops, {}, poll);
}

template <int N>
void extend_rows(const Plan& plan, double* states, std::size_t points, std::size_t cols,
                 const std::int64_t* rows, const std::int64_t* starts,
                 const std::uint64_t* streams, std::size_t count, std::uint64_t key, int team) {
  const long n = static_cast<long>(count);
#pragma omp parallel num_threads(team)
  {
    Walker<N> walker(plan, 1, nullptr);
#pragma omp for schedule(dynamic, 16)
    for (long i = 0; i < n; ++i)
      walker.extend(states + static_cast<std::size_t>(rows[i]) * points * cols, cols,
                    static_cast<std::uint64_t>(starts[i]), streams[i], key);
  }
}

}  // namespace

void simulate_filtered_block(const Plan& plan, std::uint64_t first, std::uint64_t count,
                             Workspace& ws) {
  with_dimension(plan, [&](auto n) { filtered_block<decltype(n)::value>(plan, first, count, ws); });
}

Trajectory filtered_trajectory(const Plan& plan, std::uint64_t path) {
  const Options& o = plan.options();
  if (!o.filtered()) throw std::invalid_argument("filtered_trajectory needs excitation 'filtered'");
  if (path >= o.paths) throw std::invalid_argument("filtered_trajectory: path must be < paths");
  Trajectory out;
  with_dimension(plan, [&](auto n) { trace<decltype(n)::value>(plan, path, out); });
  return out;
}

std::vector<double> ground_feature_means(const Plan& plan) {
  const Options& o = plan.options();
  if (plan.filter() == nullptr)
    throw std::invalid_argument("ground_feature_means needs a plan with excitation 'filtered'");
  const FilterModel& fm = *plan.filter();
  const int n = fm.filter.n, m = fm.m;
  const auto at = [m](int r, int c) { return static_cast<std::size_t>(r * m + c); };
  const bool folded = zero_start(fm);
  // The state (z, vg, dg): its mean and covariance, propagated exactly step by step.
  std::vector<double> mean(static_cast<std::size_t>(m), 0.0), cov(at(m, 0), 0.0);
  for (int i = 0; i < n; ++i) mean[static_cast<std::size_t>(i)] = fm.start[static_cast<std::size_t>(i)];
  std::vector<double> t(at(m, 0)), tp(at(m, 0)), next(at(m, 0)), mean_next(static_cast<std::size_t>(m));
  double sums[5] = {};
  std::vector<double> out((o.times.size() + 1) * kGroundFeatures, 0.0);
  const auto write = [&](std::size_t slot) {
    double* f = out.data() + slot * kGroundFeatures;
    const double mv = mean[static_cast<std::size_t>(n)], md = mean[static_cast<std::size_t>(n + 1)];
    f[0] = sums[0];
    f[1] = sums[1];
    f[2] = mv * mv + cov[at(n, n)];
    f[3] = sums[3];
    f[4] = sums[4];
    f[5] = mv;
    f[6] = md;
    f[7] = md * md + cov[at(n + 1, n + 1)];
    f[8] = sums[2];
  };
  const auto& segs = plan.segments();
  double start = 0.0;
  for (std::size_t i = 0; i < segs.size(); ++i) {
    const Segment& seg = segs[i];
    if (seg.steps > 0 && start < o.switch_off) {
      const StepTable& table = fm.tables[static_cast<std::size_t>(fm.segment_table[i])];
      const double h = table.step, var = seg.noise * seg.noise;
      const double* phi = table.skeleton.phi.data();
      const double* root = table.skeleton.root.data();
      // The transition of (z, vg, dg): z' = Phi_zz z, vg' = vg + Phi_gz z, dg' = dg + h vg +
      // Phi_dz z, plus the noise sigma R xi.
      std::fill(t.begin(), t.end(), 0.0);
      for (int r = 0; r < m; ++r)
        for (int c = 0; c < n; ++c) t[at(r, c)] = phi[at(r, c)];
      t[at(n, n)] = 1.0;
      t[at(n + 1, n)] = h;
      t[at(n + 1, n + 1)] = 1.0;
      for (std::uint64_t j = 0; j < seg.steps; ++j) {
        for (int r = 0; r < m; ++r) {
          double x = 0.0;
          for (int c = 0; c < m; ++c) x += t[at(r, c)] * mean[static_cast<std::size_t>(c)];
          mean_next[static_cast<std::size_t>(r)] = x;
        }
        mean.swap(mean_next);
        for (int r = 0; r < m; ++r)  // T P
          for (int c = 0; c < m; ++c) {
            double x = 0.0;
            for (int k = 0; k < m; ++k) x += t[at(r, k)] * cov[at(k, c)];
            tp[at(r, c)] = x;
          }
        for (int r = 0; r < m; ++r)  // T P T^T + var R R^T
          for (int c = 0; c < m; ++c) {
            double x = 0.0, q = 0.0;
            for (int k = 0; k < m; ++k) x += tp[at(r, k)] * t[at(c, k)];
            for (int k = 0; k < m; ++k) q += root[at(r, k)] * root[at(c, k)];
            next[at(r, c)] = x + var * q;
          }
        cov.swap(next);
        double ma = 0.0, va = 0.0;
        for (int r = 0; r < n; ++r) {
          const double cr = fm.filter.c[static_cast<std::size_t>(r)];
          ma += cr * mean[static_cast<std::size_t>(r)];
          double x = 0.0;
          for (int c = 0; c < n; ++c) x += cov[at(r, c)] * fm.filter.c[static_cast<std::size_t>(c)];
          va += cr * x;
        }
        const double mv = mean[static_cast<std::size_t>(n)], md = mean[static_cast<std::size_t>(n + 1)];
        const double vv = cov[at(n, n)], vd = cov[at(n + 1, n + 1)];
        sums[0] += h * (ma * ma + va);
        sums[1] += h * (mv * mv + vv);
        sums[2] += h * (md * md + vd);
        if (folded) {
          sums[3] += h * (std::sqrt(va) * kRootTwoOverPi);
          sums[4] += h * (std::sqrt(vv) * kRootTwoOverPi);
        }
      }
    }
    start += static_cast<double>(seg.steps) * seg.step;
    if (seg.slot >= 0) write(static_cast<std::size_t>(seg.slot));
  }
  write(o.times.size());
  return out;
}

std::size_t filtered_state_columns(const Plan& plan) {
  if (plan.filter() == nullptr)
    throw std::invalid_argument("a filtered state needs a plan with excitation 'filtered'");
  return kStateColumns + static_cast<std::size_t>(plan.filter()->filter.n);
}

std::size_t filtered_grid_points(const Plan& plan) {
  std::size_t steps = 0;
  for (const Segment& seg : plan.segments()) steps += static_cast<std::size_t>(seg.steps);
  return steps + 1;
}

void extend_filtered_paths(const Plan& plan, double* states, std::size_t rows_total,
                           const std::int64_t* rows, const std::int64_t* starts,
                           const std::uint64_t* streams, std::size_t count, std::uint64_t key,
                           int threads) {
  if (!plan.options().filtered())
    throw std::invalid_argument("extend_filtered_paths needs a plan with excitation 'filtered'");
  const std::size_t points = filtered_grid_points(plan);
  const std::size_t cols = filtered_state_columns(plan);
  validate_continued_rows(states, rows_total, points, cols, rows, starts, count);
  for (std::size_t i = 0; i < count; ++i)
    if (streams[i] >= (std::uint64_t{1} << kPathBits))
      throw std::invalid_argument("streams: " + std::to_string(streams[i]) +
                                  " is not below 2^40 (a filtered path's number)");
  double work = 0.0;  // the steps to take (each with its event search)
  for (std::size_t i = 0; i < count; ++i)
    work += double(points - 1 - static_cast<std::size_t>(starts[i]));
  const int team = thread_count(threads, work);
  with_dimension(plan, [&](auto n) {
    extend_rows<decltype(n)::value>(plan, states, points, cols, rows, starts, streams, count,
                                    key, team);
  });
}

}  // namespace crandall
