// Newmark's sliding block on a recorded ground motion (docs/records.md).
//
// A record is a ground acceleration a_i (m/s^2) at the samples t_i = i dt. The block's sliding
// velocity W is SLAMMER's: the ground's velocity minus the block's, positive downslope, so
// that a positive ground acceleration drives downslope sliding. While W > 0 it obeys
// dW/dt = a(t) - kd; while W < 0, dW/dt = a(t) + ku; at rest it stays at rest while
// -su <= a(t) <= sd (the static yields, >= the kinetic ones). One-way sliding (SLAMMER's
// rigid block) is ku = su = +infinity; a flat surface is kd = ku = mu g, sd = su = mu_s g
// (whose body velocity relative to the foundation is -W).
//
// Two integrators:
// - exact: the record is linear between samples, and everything else follows exactly:
//   onsets are roots of linear functions, stops roots of quadratics (a form that does not
//   cancel), the displacement a cubic. At an onset located by a root the relative
//   acceleration is set to exactly sd - kd (or su - ku): computed from the record it could
//   round below 0 and stop the block at once.
// - slammer: pySLAMMER 0.2.2's rigid-block recursion (trapezoid velocity and displacement
//   on the samples, its 1e-5 m/s rest threshold), operation for operation, so that its
//   numbers come out bit for bit (newmark_slammer.cpp is compiled without contraction).
#pragma once

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <vector>

namespace crandall {
namespace newmark {

// Standard gravity, m/s^2 (the g of the PEER files, SLAMMER and pySLAMMER).
constexpr double kStandardGravity = 9.80665;

// Yield accelerations in m/s^2 (> 0 or +infinity; sd >= kd, su >= ku).
struct Yield {
  double kd;  // kinetic, downslope
  double ku;  // kinetic, upslope (+inf: one-way)
  double sd;  // static, downslope
  double su;  // static, upslope
};

// One slide: its start, its end (the record's end if it is still sliding there) and its
// direction (+1 downslope, -1 upslope).
struct Event {
  double onset;
  double stop;
  int direction;
  bool stopped;
};

struct Summary {
  double displacement = 0.0;      // at the record's end, m (W's sense)
  double max_displacement = 0.0;  // the largest over the record (>= 0: it starts at 0)
  double min_displacement = 0.0;  // the smallest (<= 0)
  std::int64_t slips = 0;         // slides started
};

// What a run records beyond its summary; null pointers record nothing. velocity and
// displacement have one slot per sample.
struct History {
  double* velocity = nullptr;
  double* displacement = nullptr;
  std::vector<Event>* events = nullptr;
};

// The record `a` (n samples, m/s^2) times `sign` (+1 or -1: the polarity), sampled every dt.
// Throws std::invalid_argument for n < 2, dt not finite and > 0, or a yield out of range.
Summary exact(const double* a, std::size_t n, double dt, double sign, const Yield& y,
              const History& history = {});

// pySLAMMER 0.2.2's RigidAnalysis for yield ky (in g): its ground acceleration is the record
// in m/s^2 (sign * a[i]), its yield ky * 9.80665. One-way only.
Summary slammer(const double* a, std::size_t n, double dt, double sign, double ky_g,
                const History& history = {});

enum class Method { kExact = 0, kSlammer = 1 };

struct RecordView {
  const double* a;
  std::size_t n;
  double dt;
};

// Every (record, yield, polarity) combination, on `threads` threads (0: OpenMP's default; at
// most one per kThreadWork samples of work): out[(r * yields + k) * signs + s]. Each case is
// computed alone, so the output does not depend on the thread count. For kSlammer the
// yields' kd is ky in g (the other fields are ignored).
void sweep(const std::vector<RecordView>& records, const std::vector<Yield>& yields,
           const std::vector<double>& signs, Method method, int threads, Summary* out);

// The stop of a slide within a step: the smallest x in (0, limit] with
// w + r x + (c / 2) x^2 = 0 for w >= 0 (W's sense; an upslope slide is passed negated), or a
// negative value if there is none. Exposed for the unit tests.
double stop_time(double w, double r, double c, double limit);

// Displacement gained over x from W = w with relative acceleration r and slope c: the
// integral of w + r s + c s^2 / 2.
inline double cubic(double w, double r, double c, double x) {
  return x * (w + x * (0.5 * r + x * (c / 6.0)));
}

// The block's state: sliding velocity w (W's sense), displacement d (W's), and the mode: 0 at
// rest, +1 sliding downslope (w > 0), -1 upslope (w < 0).
struct Motion {
  double w = 0.0;
  double d = 0.0;
  int mode = 0;
};

// One step of the exact integrator: the block from `m` over [t0, t0 + dt], on which the ground
// acceleration is the straight line from a0 to a1. Onsets are roots of the line, stops roots of
// quadratics (stop_time), the displacement a cubic; a stop whose acceleration is beyond the
// static yield starts the slide the other way at once (a reversal). on_start(t, direction) is
// called when a slide starts (m.mode already set), on_stop(t) when one ends (before m.mode and
// m.w are cleared). With `distance`, the length of every piece of slide (|its displacement|) is
// added to it. exact() runs every step of a record through this; so does the filtered
// excitation's kernel on its finest substeps (filtered.cpp).
template <class OnStart, class OnStop>
inline void linear_step(Motion& m, double a0, double a1, double dt, double t0, const Yield& y,
                        OnStart&& on_start, OnStop&& on_stop, double* distance = nullptr) {
  // At rest with both ends within the static yields (the line between them too): nothing
  // happens on this step (most steps of a record).
  if (m.mode == 0 && a0 <= y.sd && a1 <= y.sd && a0 >= -y.su && a1 >= -y.su) return;
  const auto start = [&](double t, int direction) {
    m.mode = direction;
    on_start(t, direction);
  };
  const auto stop = [&](double t) {
    on_stop(t);
    m.mode = 0;
    m.w = 0.0;
  };
  const double c = (a1 - a0) / dt;  // the record's slope on this step
  double tau = 0.0;                 // time into the step
  double r = 0.0;                   // relative acceleration dW/dt at tau
  bool fresh = false;               // r was set by an onset (not read off the record)
  // A straight line crosses each yield at most once: a step holds a few events at most.
  for (int events = 0; events < 8; ++events) {
    if (m.mode == 0) {
      const double at = tau == 0.0 ? a0 : a0 + (a1 - a0) * (tau / dt);
      if (at > y.sd) {
        start(t0 + tau, 1);
        r = at - y.kd;
      } else if (at < -y.su) {
        start(t0 + tau, -1);
        r = at + y.ku;
      } else if (a1 > y.sd || a1 < -y.su) {
        // The line crosses a static yield within the step: the onset is its root, where
        // the relative acceleration is exactly the static minus the kinetic yield.
        const int direction = a1 > y.sd ? 1 : -1;
        const double level = direction > 0 ? y.sd : -y.su;
        const double root = std::max((level - a0) / (a1 - a0) * dt, tau);
        if (!(root < dt)) break;  // rounds to the step's end: the next step's sample starts it
        tau = root;
        start(t0 + tau, direction);
        r = direction > 0 ? y.sd - y.kd : -(y.su - y.ku);
      } else {
        break;  // at rest to the step's end
      }
      fresh = true;
    } else if (!fresh) {
      r = m.mode > 0 ? a0 - y.kd : a0 + y.ku;
      fresh = true;
    }
    const double rest = dt - tau;
    const double x = m.mode > 0 ? stop_time(m.w, r, c, rest) : stop_time(-m.w, -r, -c, rest);
    if (x >= 0.0) {
      const double piece = cubic(m.w, r, c, x);
      m.d += piece;
      if (distance) *distance += std::abs(piece);
      tau += x;
      stop(t0 + tau);
      if (tau >= dt) break;
      continue;
    }
    const double piece = cubic(m.w, r, c, rest);
    m.d += piece;
    if (distance) *distance += std::abs(piece);
    m.w += rest * (r + 0.5 * c * rest);
    // Round-off can leave the step's end on the wrong side of 0 when the stop is at it.
    if (m.w * m.mode <= 0.0) stop(t0 + dt);
    break;
  }
}

}  // namespace newmark
}  // namespace crandall
