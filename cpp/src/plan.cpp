#include "crandall/plan.hpp"

#include <cmath>
#include <cstdio>
#include <stdexcept>

#include "crandall/exact_step.hpp"
#include "crandall/filter.hpp"

namespace crandall {
namespace {

void require(bool ok, const std::string& message) {
  if (!ok) throw std::invalid_argument(message);
}

// Far above any useful resolution; keeps gap / until * min_steps exact in a double.
constexpr std::uint64_t kMaxMinSteps = std::uint64_t{1} << 30;

}  // namespace

const char* method_name(Method m) { return method_row(m).name; }

const char* excitation_name(Excitation e) {
  return e == Excitation::filtered ? "filtered" : "white";
}

Excitation parse_excitation(const std::string& name) {
  if (name == "white") return Excitation::white;
  if (name == "filtered") return Excitation::filtered;
  throw std::invalid_argument("excitation must be 'white' or 'filtered', got '" + name + "'");
}

Method parse_method(const std::string& name) {
  std::string names;
  for (Method m : kMethods) {
    if (name == method_name(m)) return m;
    names += std::string(names.empty() ? "'" : ", '") + method_name(m) + "'";
  }
  throw std::invalid_argument("method must be one of " + names + ", got '" + name + "'");
}

std::vector<double> richardson_weights(Method m) {
  // Solve sum_j w_j = 1 and sum_j w_j (2^j)^p = 0 for each bias exponent p (Cramer's rule on
  // at most 3 unknowns); the bias exponents (kSkeletonExponents) are derived in
  // docs/methods/richardson.md.
  static_assert(kSkeletonExponentCount == 2, "richardson_weights solves for at most 3 grids");
  const int levels = grids(m);
  if (levels == 1) return {1.0};
  if (levels == 2) {
    const double r = std::pow(2.0, kSkeletonExponents[0]);
    return {r / (r - 1.0), -1.0 / (r - 1.0)};
  }
  const double* p = kSkeletonExponents;
  double a[3][3], b[3] = {1.0, 0.0, 0.0};
  for (int j = 0; j < 3; ++j) {
    a[0][j] = 1.0;
    for (int i = 0; i < 2; ++i) a[i + 1][j] = std::pow(std::pow(2.0, j), p[i]);
  }
  auto det = [](const double m3[3][3]) {
    return m3[0][0] * (m3[1][1] * m3[2][2] - m3[1][2] * m3[2][1]) -
           m3[0][1] * (m3[1][0] * m3[2][2] - m3[1][2] * m3[2][0]) +
           m3[0][2] * (m3[1][0] * m3[2][1] - m3[1][1] * m3[2][0]);
  };
  const double d = det(a);
  std::vector<double> w(3);
  for (int j = 0; j < 3; ++j) {
    double c[3][3];
    for (int r = 0; r < 3; ++r)
      for (int q = 0; q < 3; ++q) c[r][q] = q == j ? b[r] : a[r][q];
    w[j] = det(c) / d;
  }
  return w;
}

void validate_model(double drift, double noise) {
  require(std::isfinite(drift) && drift >= 0.0, "drift must be finite and >= 0");
  require(std::isfinite(noise) && noise >= 0.0, "noise must be finite and >= 0");
}

void Options::validate() const {
  validate_model(drift, noise);
  require(!std::isnan(switch_off) && switch_off >= 0.0,
          "switch_off must be >= 0 (or +inf for never)");
  require(piece_ends.size() == piece_noise.size(),
          "piece_ends and piece_noise must have the same length");
  for (std::size_t i = 0; i < piece_ends.size(); ++i) {
    require(std::isfinite(piece_ends[i]) && piece_ends[i] > (i == 0 ? 0.0 : piece_ends[i - 1]),
            "piece_ends must be finite, > 0 and strictly increasing");
    require(std::isfinite(piece_noise[i]) && piece_noise[i] >= 0.0,
            "piece_noise must be finite and >= 0");
  }
  require(piece_ends.empty() || piece_ends.back() == switch_off,
          "the last of piece_ends must be switch_off");
  require(!residual || (stop && displacement), "residual needs the stop and the displacement");
  require(!quadratic_variation ||
              (stop && integrals() && !peaks &&
               skeleton(method)),
          "quadratic_variation needs the stop, an observed integral, no peaks and the exact or a "
          "Richardson method");
  require(std::isfinite(start_velocity), "start_velocity must be finite");
  require(std::isfinite(start_displacement), "start_displacement must be finite");
  for (std::size_t i = 0; i < times.size(); ++i) {
    require(std::isfinite(times[i]) && times[i] >= 0.0, "times must be finite and >= 0");
    require(i == 0 || times[i] > times[i - 1], "times must be strictly increasing");
  }
  require(std::isfinite(dt) && dt > 0.0, "dt must be finite and > 0");
  require(min_steps <= kMaxMinSteps, "min_steps must be <= 2^30");
  require(refinement >= 0 && refinement <= 30, "refinement must be between 0 and 30");
  require(paths >= 1, "paths must be >= 1");
  require(velocity || displacement || distance || stop, "observe at least one quantity");
  require(!times.empty() || stop, "times must not be empty unless only the stop is observed");
  if (stop) {
    require(std::isfinite(switch_off), "the stop needs a finite switch_off (t0)");
    require(drift > 0.0 || (noise == 0.0 && start_velocity == 0.0),
            "without friction the body never stops");
  }
  if (filtered()) {
    validate_filter_options(*this);
  } else {
    require(filter_a.empty() && filter_b.empty() && filter_c.empty() && filter_start.empty(),
            "filter_a, filter_b, filter_c and filter_start need excitation 'filtered'");
    require(std::isnan(static_drift) || static_drift == drift,
            "static_drift needs excitation 'filtered' (white noise never lets the body rest)");
    require(event_depth == kDefaultEventDepth, "event_depth needs excitation 'filtered'");
    require(!ring_down, "ring_down needs excitation 'filtered'");
  }
  if (!histogram_axes.empty()) {
    const std::size_t slots = histogram_slots();
    require(histogram_axes.size() == slots * kHistogramVariables,
            "histogram_axes must be empty or hold (len(times) + (1 if stop else 0)) * " +
                std::to_string(kHistogramVariables) + " = " +
                std::to_string(slots * kHistogramVariables) + " axes, got " +
                std::to_string(histogram_axes.size()));
    static const char* const names[kHistogramVariables] = {
        "velocity (the time to stop at the stop slot)", "displacement", "distance",
        "peak speed", "peak displacement"};
    for (std::size_t i = 0; i < histogram_axes.size(); ++i) {
      if (histogram_axes[i].bins() == 0) continue;
      const int v = static_cast<int>(i % kHistogramVariables);
      const bool simulated = v == 0                   ? true
                             : v == 1                 ? displacement
                             : v == 2                 ? distance
                             : v == 3                 ? peaks
                                                      : peaks && displacement;
      require(simulated, "histogram_axes[" + std::to_string(i) + "] asks for the " + names[v] +
                             (v == 4   ? ", which needs peaks and displacement"
                              : v == 3 ? ", which needs peaks"
                                       : ", which is not observed"));
    }
  }
}

Plan::Plan(Options options) : options_(std::move(options)) {
  options_.validate();
  const Options& o = options_;
  const bool any_after = !o.times.empty() && o.times.back() > o.switch_off;
  const bool filtered = o.filtered();
  needs_switch_state_ = o.stop || any_after;
  // The filtered excitation has no closed form after the switch-off (the filter rings down):
  // its grid goes on to the last output time, and the kernel steps on from there to the stop.
  const double end = needs_switch_state_
                         ? (filtered && any_after ? o.times.back() : o.switch_off)
                         : o.times.back();
  // Boundaries of the noise's pieces (the filtered grid also needs one at the switch-off when
  // it goes past it).
  const std::vector<double> piece_ends =
      filtered && o.piece_ends.empty() && any_after ? std::vector<double>{o.switch_off} : o.piece_ends;
  // Internal steps are needed for the time integrals, and for Euler-Maruyama always; the
  // exact velocity step is exact for any length, so velocity-only scenes jump.
  // A peak is a maximum over the grid's points, so peaks need the fine grid too.
  // The filtered excitation's steps are the skeleton's: always the fine grid.
  const bool fine = o.integrals() || o.method == Method::euler || o.peaks || filtered;
  // The intensity of the piece that ends at or after `until` (one piece: noise; none after
  // the switch-off).
  std::size_t piece = 0;
  auto noise_until = [&](double until) {
    if (until > o.switch_off) return 0.0;
    if (o.piece_ends.empty()) return o.noise;
    while (piece + 1 < o.piece_ends.size() && o.piece_ends[piece] < until) ++piece;
    return o.piece_noise[piece];
  };
  double previous = 0.0;
  long slot = 0;
  auto add = [&](double until, long s) {
    const double gap = until - previous;
    std::uint64_t n = 0;
    if (gap > 0.0) {
      double want = fine ? std::ceil(gap / o.dt * (1.0 - 1e-12)) : 1.0;
      if (fine && o.min_steps > 0) {
        // gap <= until, so this is at most min_steps: no overflow even for subnormal times.
        const double graded = std::ceil(gap / until * static_cast<double>(o.min_steps) * (1.0 - 1e-12));
        if (graded > want) want = graded;
      }
      if (fine) want = std::ldexp(want < 1.0 ? 1.0 : want, o.refinement);
      require(want < 9.0e15, "dt is too small for the horizon: the grid would not fit in 2^53 steps");
      n = want < 1.0 ? 1 : static_cast<std::uint64_t>(want);
      // Richardson's coarse grids are every 2nd (4th) point of the fine one, segment by
      // segment, so the step count is a multiple of 2 (4).
      const std::uint64_t group = std::uint64_t{1} << (o.grids() - 1);
      n = (n + group - 1) / group * group;
    }
    segments_.push_back({n > 0 ? gap / static_cast<double>(n) : 0.0, n, s, noise_until(until)});
    segment_ends_.push_back(until);
    steps_per_path_ += n;
    previous = until;
  };
  // Segments end at the output times and at the pieces' ends (before `end`), in time order;
  // an output time at a piece's end ends one segment there.
  std::size_t next_piece = 0;
  for (;;) {
    const bool time_left = slot < static_cast<long>(o.times.size()) && o.times[slot] <= end;
    while (next_piece < piece_ends.size() && piece_ends[next_piece] <= previous) ++next_piece;
    const bool piece_left = next_piece < piece_ends.size() && piece_ends[next_piece] < end;
    if (piece_left && (!time_left || piece_ends[next_piece] < o.times[slot])) {
      add(piece_ends[next_piece], -1);
    } else if (time_left) {
      add(o.times[slot], slot);
      ++slot;
    } else {
      break;
    }
  }
  if (previous < end) add(end, -1);
  // The step's arithmetic has a range (exact_step.hpp); beyond it a step would overflow.
  if (!filtered)
    for (const Segment& seg : segments_)
      require(step_in_range(seg.step, o.drift, seg.noise),
              "times and switch_off are too long for this drift and noise: a step would exceed "
              "the range of doubles");
  if (filtered) {
    // The ring-down after the grid (to the stop) takes steps of dt / 2^refinement, in groups of
    // the coarse grids' steps like the segments.
    const double tail_step = std::ldexp(o.dt, -o.refinement);
    std::vector<double> steps;  // per segment, 0 for a segment without steps
    for (const Segment& seg : segments_) steps.push_back(seg.steps > 0 ? seg.step : 0.0);
    filter_ = make_filter_model(o, steps, tail_step);
    // The ring-down's steps are not known in advance: counted as the time the bound takes to
    // fall by e^5 (thread-count heuristics only).
    if (o.stop && filter_->has_bound) {
      const double ring = 5.0 / filter_->bound.rate / tail_step;
      steps_per_path_ += ring < 1e12 ? static_cast<std::uint64_t>(ring) : std::uint64_t{1000000000000};
    }
  }
  for (; slot < static_cast<long>(o.times.size()); ++slot) {
    coast_slots_.push_back(slot);
    coast_elapsed_.push_back(o.times[slot] - o.switch_off);
  }
  histogram_slot_.assign(o.histogram_axes.size(), -1);
  for (std::size_t i = 0; i < o.histogram_axes.size(); ++i)
    if (o.histogram_axes[i].bins() > 0) {
      histogram_slot_[i] = static_cast<long>(recorded_axes_.size());
      recorded_axes_.push_back(o.histogram_axes[i]);
    }
}

std::uint64_t Plan::chunk_paths(std::uint64_t chunk) const {
  require(chunk < chunks(), "chunk index out of range");
  const std::uint64_t first = chunk * kChunkPaths;
  const std::uint64_t left = options_.paths - first;
  return left < kChunkPaths ? left : kChunkPaths;
}

TailGrid tail_grid(const Plan& plan, double dt, bool coarse, double max_steps) {
  require(std::isfinite(dt) && dt > 0.0, "dt must be finite and > 0");
  TailGrid grid;
  double a = 0.0;
  for (std::size_t k = 0; k < plan.segments().size(); ++k) {
    const double b = plan.segment_ends()[k];
    const double sigma = plan.segments()[k].noise;
    if (b > a) {
      // The operations of tail/problem.py's former NumPy cut, in its order (no contraction:
      // -ffp-contract=off), so the same bits (tests/test_tail_grid.py).
      const double want = (sigma == 0.0 || coarse) ? 1.0 : std::ceil((b - a) / dt - 1e-9);
      if (!(want <= max_steps)) {
        char text[64];
        std::snprintf(text, sizeof text, "%.0f", want);
        throw std::invalid_argument(std::string("dt: ") + text +
                                    " steps over one piece of the excitation; the paths would "
                                    "not fit");
      }
      const auto n = static_cast<std::uint64_t>(want < 1.0 ? 1.0 : want);
      const double nd = static_cast<double>(n);
      double previous = a;
      for (std::uint64_t i = 1; i <= n; ++i) {
        const double edge = a + (b - a) * static_cast<double>(i) / nd;
        grid.lengths.push_back(edge - previous);
        grid.noises.push_back(sigma);
        grid.starts.push_back(previous);
        previous = edge;
      }
    }
    a = b;
  }
  return grid;
}

}  // namespace crandall
