// pySLAMMER 0.2.2's rigid-block recursion (RigidAnalysis.run_rigid_analysis), re-derived from
// its description and written here operation for operation, in its order, so that the same
// doubles come out: the trapezoid rule on the samples for the velocity and the displacement,
// the rest threshold 1e-5 m/s, and at rest the "normalised" ground acceleration
// n = a / ky (or its sign above the yield) whose product n * ky is subtracted (not a
// subtraction of a itself, so a small residue remains). CMakeLists.txt compiles this file with
// -ffp-contract=off and no instruction-set flags: a fused multiply-add would round once where
// Python rounds twice.
#include <cmath>
#include <stdexcept>
#include <string>

#include "crandall/newmark.hpp"

namespace crandall {
namespace newmark {

Summary slammer(const double* a, std::size_t n, double dt, double sign, double ky_g,
                const History& history) {
  if (n < 2) throw std::invalid_argument("acceleration: a record needs at least 2 samples");
  if (!(std::isfinite(dt) && dt > 0.0))
    throw std::invalid_argument("dt: must be finite and > 0, got " + std::to_string(dt));
  if (!(std::isfinite(ky_g) && ky_g > 0.0))
    throw std::invalid_argument("ky: must be finite and > 0 for the slammer method");
  for (std::size_t i = 0; i < n; ++i)
    if (!std::isfinite(a[i]))
      throw std::invalid_argument("acceleration: sample " + std::to_string(i) +
                                  " is not finite");
  const double tol = 1e-5;
  const double ky = ky_g * kStandardGravity;
  Summary out;
  double acc_prev = 0.0, vel_prev = 0.0, pos_prev = 0.0;
  double acc = 0.0, vel = 0.0, pos = 0.0;
  double onset = 0.0;
  for (std::size_t i = 0; i < n; ++i) {
    const double ground = sign * a[i];
    double normal;
    if (vel < tol) {
      if (std::fabs(ground) > ky)
        normal = ground / std::fabs(ground);
      else
        normal = ground / ky;
    } else {
      normal = 1.0;
    }
    acc = ground - normal * ky;
    vel = vel_prev + (dt / 2.0) * (acc + acc_prev);
    if (vel > 0.0) {
      pos = pos_prev + (dt / 2.0) * (vel + vel_prev);
      if (vel_prev == 0.0) {
        ++out.slips;
        onset = i > 0 ? static_cast<double>(i - 1) * dt : 0.0;
      }
    } else {
      vel = 0.0;
      acc = 0.0;
      if (vel_prev > 0.0 && history.events)
        history.events->push_back({onset, static_cast<double>(i) * dt, 1, true});
    }
    pos_prev = pos;
    vel_prev = vel;
    acc_prev = acc;
    if (history.velocity) history.velocity[i] = vel;
    if (history.displacement) history.displacement[i] = pos;
    if (pos > out.max_displacement) out.max_displacement = pos;
  }
  out.displacement = pos;
  if (vel > 0.0 && history.events)
    history.events->push_back({onset, static_cast<double>(n - 1) * dt, 1, false});
  return out;
}

}  // namespace newmark
}  // namespace crandall
