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

}  // namespace newmark
}  // namespace crandall
