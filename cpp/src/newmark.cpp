// The exact Newmark block on a record joined by straight lines, and the sweep over records,
// yields and polarities (newmark.hpp; docs/records.md derives each formula).
#include "crandall/newmark.hpp"

#include <omp.h>

#include <algorithm>
#include <cmath>
#include <exception>
#include <limits>
#include <mutex>
#include <stdexcept>
#include <string>

#include "crandall/run.hpp"

namespace crandall {
namespace newmark {

namespace {

void check_record(const double* a, std::size_t n, double dt) {
  if (n < 2) throw std::invalid_argument("acceleration: a record needs at least 2 samples");
  if (!(std::isfinite(dt) && dt > 0.0))
    throw std::invalid_argument("dt: must be finite and > 0, got " + std::to_string(dt));
  for (std::size_t i = 0; i < n; ++i)
    if (!std::isfinite(a[i]))
      throw std::invalid_argument("acceleration: sample " + std::to_string(i) +
                                  " is not finite");
}

void check_yield(const Yield& y) {
  const auto ok = [](double v) { return v > 0.0; };  // +inf allowed, NaN not
  if (!ok(y.kd) || !ok(y.ku) || !ok(y.sd) || !ok(y.su) || std::isinf(y.kd))
    throw std::invalid_argument("yield: kd must be finite and > 0, ku, sd, su > 0");
  if (!(y.sd >= y.kd) || !(y.su >= y.ku))
    throw std::invalid_argument("yield: the static yields must be >= the kinetic ones");
}

}  // namespace

double stop_time(double w, double r, double c, double limit) {
  // w + r x + a x^2 = 0, a = c / 2, w >= 0. With r < 0 the first root is 2w / (-r + sqrt(d))
  // (d = r^2 - 4 a w; no cancellation: both terms positive); with r >= 0 only a < 0 has a
  // positive root, (r + sqrt(d)) / (-2a), again a sum of positive terms.
  const double a = 0.5 * c;
  double x;
  if (r < 0.0) {
    const double d = r * r - 4.0 * a * w;
    if (d < 0.0) return -1.0;
    x = 2.0 * w / (std::sqrt(d) - r);
  } else if (a < 0.0) {
    const double d = r * r - 4.0 * a * w;
    x = (r + std::sqrt(d)) / (-2.0 * a);
  } else {
    return -1.0;
  }
  return x <= limit ? x : -1.0;
}

Summary exact(const double* a, std::size_t n, double dt, double sign, const Yield& y,
              const History& history) {
  check_record(a, n, dt);
  check_yield(y);
  Summary out;
  Motion m;
  double onset = 0.0;
  const auto start = [&](double t, int) {
    onset = t;
    ++out.slips;
  };
  const auto stop = [&](double t) {
    if (history.events) history.events->push_back({onset, t, m.mode, true});
    out.max_displacement = std::max(out.max_displacement, m.d);
    out.min_displacement = std::min(out.min_displacement, m.d);
  };
  if (history.velocity) history.velocity[0] = 0.0;
  if (history.displacement) history.displacement[0] = 0.0;
  for (std::size_t i = 0; i + 1 < n; ++i) {
    const double a0 = sign * a[i], a1 = sign * a[i + 1];
    linear_step(m, a0, a1, dt, static_cast<double>(i) * dt, y, start, stop);
    if (history.velocity) history.velocity[i + 1] = m.w;
    if (history.displacement) history.displacement[i + 1] = m.d;
  }
  out.displacement = m.d;
  out.max_displacement = std::max(out.max_displacement, m.d);
  out.min_displacement = std::min(out.min_displacement, m.d);
  if (m.mode != 0 && history.events)
    history.events->push_back({onset, static_cast<double>(n - 1) * dt, m.mode, false});
  return out;
}

void sweep(const std::vector<RecordView>& records, const std::vector<Yield>& yields,
           const std::vector<double>& signs, Method method, int threads, Summary* out) {
  for (const auto& rec : records) check_record(rec.a, rec.n, rec.dt);
  if (method == Method::kExact)
    for (const auto& y : yields) check_yield(y);
  const std::size_t per_record = yields.size() * signs.size();
  const std::size_t cases = records.size() * per_record;
  double work = 0.0;
  for (const auto& rec : records) work += static_cast<double>(rec.n) * per_record;
  // A sample costs about what a path step of the kernel does (a few ns): a thread per
  // kThreadWork samples at most, so a small sweep stays on the calling thread.
  const int team = thread_count(threads, work);
  std::exception_ptr error;
  std::mutex error_mutex;
#pragma omp parallel for num_threads(team) schedule(dynamic, 1)
  for (long k = 0; k < static_cast<long>(cases); ++k) {
    try {
      const std::size_t idx = static_cast<std::size_t>(k);
      const RecordView& rec = records[idx / per_record];
      const Yield& y = yields[(idx % per_record) / signs.size()];
      const double s = signs[idx % signs.size()];
      out[idx] = method == Method::kExact ? exact(rec.a, rec.n, rec.dt, s, y)
                                          : slammer(rec.a, rec.n, rec.dt, s, y.kd);
    } catch (...) {
      std::lock_guard<std::mutex> lock(error_mutex);
      if (!error) error = std::current_exception();
    }
  }
  if (error) std::rethrow_exception(error);
}

}  // namespace newmark
}  // namespace crandall
