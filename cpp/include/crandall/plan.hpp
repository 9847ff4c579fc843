// What a run simulates: the model, the observables, the output times, and the time grid the
// kernel walks. Options are validated here once; the kernel trusts them.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include "crandall/histogram.hpp"

namespace crandall {

// exact: exact skeleton, trapezoid integrals (docs/integrals.md).
// euler: Euler-Maruyama, the baseline.
// richardson: exact skeleton, trapezoid integrals on the grid and on the grids of every 2nd
//   and every 4th point (the same path), moments extrapolated to a zero step assuming a
//   bias c1 dt^1.5 + c2 dt^2 (docs/methods/richardson.md).
// richardson2: the same with the grid and every 2nd point only, assuming c dt^1.5.
// refine: exact skeleton; a step that starts near 0 is taken as kRefineSubsteps exact substeps
//   (docs/methods/refine.md).
// Each value has its row in kMethodTable below (name, grids, skeleton, order), in the same
// order. The values stay an enum rather than the rows' indices: the plan's checks, the levels,
// the filtered core and the tests name a method by its value (Method::exact), which an index
// would need as a named constant per method all the same.
enum class Method { exact, euler, richardson, richardson2, refine };

// The exponents of the exact skeleton's trapezoid bias, c1 h^1.5 + c2 h^2 + ...
// (docs/methods/richardson.md): the sqrt(t) start of E|X(t)| gives h^1.5 (Navot's expansion of
// the trapezoid rule), the h^2 term follows; the second moments are assumed to expand with the
// same two. What follows them is not known: after both are removed the variance of the distance
// still has a term of unknown exponent (measured to fall about 4 per halving of h,
// richardson.md, "What limits the variance of the distance"). richardson_weights cancels these.
constexpr double kSkeletonExponents[] = {1.5, 2.0};
constexpr std::size_t kSkeletonExponentCount = sizeof(kSkeletonExponents) / sizeof(kSkeletonExponents[0]);
// A method's order where no document states it and none is derived.
constexpr double kUnknownOrder = std::numeric_limits<double>::quiet_NaN();

// The methods' table, one row per method in the order of the enum: its name as the Python layer
// spells it (method_name, parse_method), the number of coupled grids it walks on one path
// (steps dt, 2 dt, 4 dt, ...: the grid of step 2^j dt is every 2^j-th point of the finest; 1 for
// a method without extrapolation), whether its steps are the exact skeleton's with the
// trapezoid integrals on its grids (the quadratic variation is integrated on those only, and
// the bias estimate's coupled grids reproduce them) and its order: the exponent p of the leading term
// c dt^p of the bias of the moments it reports (the time integrals'; the velocity's and the
// stop's are exact in law with every method but euler), kUnknownOrder (NaN) where it is not
// known. The one place these are decided: the plan, the kernel's method types (methods/*.hpp),
// the run and Python (_core.METHOD_TABLE, _core.METHOD_GRIDS) ask here.
//   exact        1.5: the trapezoid rule's leading exponent on the skeleton (kSkeletonExponents).
//   euler        1: Euler-Maruyama's weak order (docs/methods/richardson.md), also of its
//                velocity and stop time; measured, the biases of the mean distance, the
//                velocity's variance and the mean stop time fall in proportion to dt
//                (bench/results/work_precision.json, dt = 0.1 to 0.01).
//   richardson   unknown: both exponents removed, the means would be left with Navot's h^2.5,
//                but the second moments keep a term whose exponent is not known (above).
//   richardson2  2: h^1.5 removed, the h^2 term is left.
//   refine       unknown: docs/methods/refine.md states none, and none follows from the
//                exact method's: its threshold 2 sigma sqrt(h) chooses the refined steps by the
//                path, so its mean is no longer the trapezoid rule of E|X(t)| whose expansion
//                gives 1.5; bench/results/work_precision.json has no step below 0.2 for it.
struct MethodRow {
  Method method;
  const char* name;
  int grids;
  bool skeleton;
  double order;
};
constexpr MethodRow kMethodTable[] = {
    {Method::exact, "exact", 1, true, kSkeletonExponents[0]},
    {Method::euler, "euler", 1, false, 1.0},
    {Method::richardson, "richardson", 3, true, kUnknownOrder},
    {Method::richardson2, "richardson2", 2, true, kSkeletonExponents[1]},
    {Method::refine, "refine", 1, false, kUnknownOrder},
};
constexpr std::size_t kMethodCount = sizeof(kMethodTable) / sizeof(kMethodTable[0]);

// A row for every value of the enum, in its order (so that a method is its value and one row).
constexpr bool table_follows_enum() {
  for (std::size_t i = 0; i < kMethodCount; ++i)
    if (static_cast<std::size_t>(kMethodTable[i].method) != i) return false;
  return true;
}
static_assert(table_follows_enum(), "kMethodTable: one row per Method, in the enum's order");

constexpr const MethodRow& method_row(Method m) {
  for (const MethodRow& r : kMethodTable)
    if (r.method == m) return r;
  return kMethodTable[0];
}

// Every method, in the order of the table (parse_method's list; the tests loop over it).
constexpr std::array<Method, kMethodCount> method_list() {
  std::array<Method, kMethodCount> a{};
  for (std::size_t i = 0; i < kMethodCount; ++i) a[i] = kMethodTable[i].method;
  return a;
}
constexpr std::array<Method, kMethodCount> kMethods = method_list();

constexpr int grids(Method m) { return method_row(m).grids; }
constexpr bool skeleton(Method m) { return method_row(m).skeleton; }
// The method's order (the row's; NaN: unknown).
constexpr double method_order(Method m) { return method_row(m).order; }

// The grids a run keeps: with no time integral observed there is nothing to extrapolate (the
// velocity step is exact at any length, and the plan does not even refine the grid), so one.
constexpr int grids(Method m, bool integrals) { return integrals ? grids(m) : 1; }

// The weights that combine the moments of the grids(m) grids; weights[j] belongs to the grid of
// step 2^j dt.
std::vector<double> richardson_weights(Method m);

// Name of a method as the Python layer spells it; parse_method throws std::invalid_argument.
const char* method_name(Method m);
Method parse_method(const std::string& name);

// The model's two constants: finite and >= 0 (throws std::invalid_argument naming the one that
// is not). Options::validate and every entry point that takes them on their own check here.
void validate_model(double drift, double noise);

// The ground motion. white: the foundation's acceleration is white noise (the paper's model;
// the vectorised kernels). filtered: it is a_g = c . z of a linear filter of white noise
// (Kanai-Tajimi, Clough-Penzien, ...: Options::filter_a, filter_b, filter_c; filter.hpp),
// simulated on the filter's exact Gaussian skeleton (filtered.cpp, docs/filtered.md).
enum class Excitation { white, filtered };
const char* excitation_name(Excitation e);
Excitation parse_excitation(const std::string& name);

// Default of Options::event_depth: bisections of a step in which an event may happen.
constexpr int kDefaultEventDepth = 8;
constexpr int kMaxEventDepth = 20;

// Values binned per slot (Options::histogram_axes).
constexpr int kHistogramVariables = 5;

struct Options {
  // dX = -drift sign(X) dt + noise dW for t < switch_off; no noise afterwards.
  double drift = 2.0;        // friction deceleration (mu g; 2 in the paper's scaled units)
  double noise = 1.4142135623730951;  // white-noise intensity (the paper's h; sqrt 2 in scaled units)
  double switch_off = std::numeric_limits<double>::infinity();  // t0; may be +inf
  // A piecewise intensity: piece i acts on [piece_ends[i - 1], piece_ends[i]) (from 0 for
  // i = 0) with noise piece_noise[i] (0: a pause); the last end is switch_off. Empty: one
  // piece, `noise` until switch_off.
  std::vector<double> piece_ends;
  std::vector<double> piece_noise;
  // With stop and displacement: the stop's moments get a second slot, (|U(t_s)|, 0, 0), the
  // magnitude of the residual displacement (its moments are not functions of U's).
  bool residual = false;
  // Runs to an accuracy (levels.hpp): with the stop and an integral observed, no peaks, and the
  // exact or a Richardson method, run_samples' samples get one more slot after the stop's, (Q, 0, 0) on
  // each grid, with Q = int_0^t0 noise(t)^2 X(t)^2 dt by the trapezoid rule on that grid: the
  // quadratic variation of the noise's work int noise X dW, whose mean is drift^2 times the
  // variance of the distance at the stop (Ito's isometry). run_chunk's sums do not use it.
  bool quadratic_variation = false;
  // The state at t = 0: velocity X(0) and displacement U(0) (the distance starts at 0).
  double start_velocity = 0.0;
  double start_displacement = 0.0;
  std::vector<double> times;  // output times, strictly increasing, >= 0
  double dt = 0.01;           // longest internal step where integrals are observed
  // Graded grid: in the segment that ends at time t (an output time or the switch-off) the step
  // is also at most t / min_steps, so every output time and the switch-off are reached in at
  // least min_steps steps, whatever dt, while a tiny first output time does not force tiny
  // steps on the rest of the path. 0: off (steps of at most dt only).
  std::uint64_t min_steps = 0;
  // Multilevel runs (python/crandall/adaptive/): every segment's step count, as dt and
  // min_steps give it, is multiplied by 2^refinement, so the grid of refinement r is every
  // second point of the grid of refinement r + 1, segment by segment (nested grids). 0: off.
  int refinement = 0;
  Method method = Method::exact;
  bool velocity = true;
  bool displacement = false;
  bool distance = false;
  bool stop = false;  // stop time, and displacement/distance at the stop if observed
  // Running maxima over [0, t] of |velocity| (and of |displacement| when it is observed) at
  // every output time and at the stop. They are maxima over the points the path is computed
  // at, so a peak needs the fine grid: with peaks on, even a velocity-only scene takes steps
  // of at most dt (and min_steps), where it would otherwise jump one exact step per segment.
  bool peaks = false;
  // The moments of the squared velocity V^2 at every output time (ChunkResult::energy), so
  // that the kinetic energy's variance has a standard error: it needs E V^8, beyond the order
  // 4 the velocity's own moments keep. Only a scene observing the kinetic energy sets it.
  bool energy = false;
  // Distributions: empty (none; the kernel does no binning at all), or one axis per
  // (slot, variable) at index slot * kHistogramVariables + variable, where slot is the index of
  // an output time, or times.size() for the stop. An axis with no bins is not recorded.
  // Variables at an output time: velocity, displacement, distance, peak speed, peak
  // |displacement|; at the stop: the time from the switch-off to the stop, displacement,
  // distance, and the two peaks over the whole path.
  std::vector<BinEdges> histogram_axes;
  std::uint64_t seed = 0;
  std::uint64_t paths = 1;

  // The filtered excitation (Excitation::filtered; the fields below must keep their defaults
  // with white noise). Model, with V the body's velocity relative to the foundation:
  //   dz = A z dt + b sigma(t) dW, z(0) = filter_start; a_g = c . z;
  //   sliding: V' = -a_g - drift sgn V; at rest: stays while |a_g| <= static_drift, else
  //   slides in the direction -sgn a_g; a slide reaching V = 0 at a time where
  //   |a_g| > static_drift goes on the other way.
  // sigma(t) is `noise` (or the pieces' piece_noise) before switch_off and 0 after it; then
  // a_g = 0 (the shaking ends), or with ring_down the filter rings down. The stop is the last time the body comes to rest (it may be before the
  // switch-off, when the body is at rest there and the ring-down never moves it again; 0 for a
  // body that never slides).
  Excitation excitation = Excitation::white;
  std::vector<double> filter_a;      // A, n x n row-major (1 <= n <= 6)
  std::vector<double> filter_b;      // b, n
  std::vector<double> filter_c;      // c, n
  std::vector<double> filter_start;  // z(0), n; empty: zeros
  // Static friction deceleration mu_static g, >= drift. NaN (the default): equal to drift.
  double static_drift = std::numeric_limits<double>::quiet_NaN();
  // Bisections by exact bridges of a step where an event (a stop, an onset) may happen; the
  // finest substeps (step / 2^event_depth) take a_g linear between their ends. 1 to 20, and at
  // least grids() - 1.
  int event_depth = kDefaultEventDepth;
  // What the switch-off ends. false (the default): the shaking, a_g = 0 from switch_off on (the
  // filter's state is dropped there), as under white noise, and the body slides to rest at the
  // deceleration `drift`. true: only the driving noise; the filter rings down freely and the
  // stop is the last time the body comes to rest, located with the decay bound.
  bool ring_down = false;
  bool filtered() const { return excitation == Excitation::filtered; }
  // static_drift as the model uses it.
  double resolved_static_drift() const { return static_drift == static_drift ? static_drift : drift; }

  // Throws std::invalid_argument naming the offending field.
  void validate() const;
  // Slots of the stop's moments: none, the stop, and with residual |U(t_s)|.
  std::size_t stop_slots() const { return stop ? (residual ? 2 : 1) : 0; }
  bool integrals() const { return displacement || distance; }
  // Slots of run_samples' per-path values: the output times, the stop, the quadratic variation;
  // with peaks under the filtered excitation then (max |V|, max |U|, 0) per output time and at
  // the stop (the white-noise kernel records no peaks per path).
  std::size_t sample_slots() const {
    return times.size() + (stop ? 1 : 0) + (quadratic_variation ? 1 : 0) +
           (peaks && filtered() ? times.size() + (stop ? 1 : 0) : 0);
  }
  // The filtered excitation's velocity has a bias too (its events): its grids follow the method.
  int grids() const {
    return filtered() ? crandall::grids(method) : crandall::grids(method, integrals());
  }
  // Output slots that carry histograms: the output times, and the stop if observed.
  std::size_t histogram_slots() const { return times.size() + (stop ? 1 : 0); }
};


// A stretch of the grid: `steps` equal steps of length `step`, then (if slot >= 0) an output.
struct Segment {
  double step;
  std::uint64_t steps;
  long slot;
  // The intensity on the segment: a segment never straddles a piece boundary.
  double noise;
};

// Canonical partition of the paths: chunk c holds paths [c * kChunkPaths, ...), and block b of
// a chunk holds kBlockPaths of them. Moments are summed per block, blocks are merged in order
// into their chunk, and chunks in order into the result, so the result is the same bitwise
// whatever the thread count, the machine, or a resume from a checkpoint.
constexpr std::uint64_t kBlockPaths = 256;
constexpr std::uint64_t kChunkPaths = 65536;
constexpr int kLanes = 16;  // paths stepped together in the kernel

struct FilterModel;

class Plan {
 public:
  explicit Plan(Options options);

  const Options& options() const { return options_; }
  const std::vector<Segment>& segments() const { return segments_; }
  // Where each segment ends (the output time, piece end or switch-off it was cut at), exactly.
  const std::vector<double>& segment_ends() const { return segment_ends_; }
  // Slots of output times after the switch-off (filled in closed form), with the time since it.
  const std::vector<long>& coast_slots() const { return coast_slots_; }
  const std::vector<double>& coast_elapsed() const { return coast_elapsed_; }
  bool needs_switch_state() const { return needs_switch_state_; }
  std::uint64_t steps_per_path() const { return steps_per_path_; }
  // The filtered excitation's precomputed transitions (null for white noise; filter.hpp).
  const FilterModel* filter() const { return filter_.get(); }
  std::uint64_t chunks() const { return (options_.paths + kChunkPaths - 1) / kChunkPaths; }
  std::uint64_t chunk_paths(std::uint64_t chunk) const;
  // Histograms: whether any axis is recorded; the recorded axes in index order (the slots of
  // a Histograms); and for every index of Options::histogram_axes its slot there, or -1.
  bool histograms() const { return !recorded_axes_.empty(); }
  const std::vector<BinEdges>& recorded_axes() const { return recorded_axes_; }
  long histogram_slot(std::size_t slot, int variable) const {
    return histograms() ? histogram_slot_[slot * kHistogramVariables + static_cast<std::size_t>(variable)] : -1;
  }

 private:
  Options options_;
  std::vector<Segment> segments_;
  std::vector<double> segment_ends_;
  std::vector<long> coast_slots_;
  std::vector<double> coast_elapsed_;
  bool needs_switch_state_ = false;
  std::uint64_t steps_per_path_ = 0;
  std::vector<BinEdges> recorded_axes_;
  std::vector<long> histogram_slot_;
  std::shared_ptr<const FilterModel> filter_;
};

// A tail run's grid (crandall.tail on a white-noise scene, tail/problem.py): the plan's
// segments (cut at its output times and pieces' ends) each split into n equal parts by the
// points a + (b - a) i / n, i = 0 .. n, with n = max(1, ceil((b - a) / dt - 1e-9)), or n = 1
// on a segment without noise or when `coarse` (the velocity's law does not depend on the
// grid). Per step: its length (the difference of its points), its intensity and its start.
// Throws std::invalid_argument, its message starting with "dt:", when a segment would take
// more than `max_steps` steps.
struct TailGrid {
  std::vector<double> lengths;
  std::vector<double> noises;
  std::vector<double> starts;
};
TailGrid tail_grid(const Plan& plan, double dt, bool coarse, double max_steps);

}  // namespace crandall
