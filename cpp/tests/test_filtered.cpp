// The filtered excitation's path loop (filtered.hpp) against independent computations: the
// frictionless body's Gaussian velocity (Van Loan by Eigen's exponential), the record integrator
// newmark::exact on a finely sampled deterministic ring-down, the energy identity on single
// paths, bitwise reproducibility, and the coupling of run_samples' grids.
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <iterator>
#include <numeric>
#include <unsupported/Eigen/MatrixFunctions>
#include <vector>

#include "crandall/filter.hpp"
#include "crandall/filtered.hpp"
#include "crandall/levels.hpp"
#include "crandall/newmark.hpp"
#include "crandall/run.hpp"

namespace {

using Mat = Eigen::MatrixXd;

crandall::Options kt_options(double omega, double zeta) {
  const auto f = crandall::kanai_tajimi(omega, zeta);
  crandall::Options o;
  o.excitation = crandall::Excitation::filtered;
  o.filter_a = f.a;
  o.filter_b = f.b;
  o.filter_c = f.c;
  return o;
}

// Var G(t) from rest (z(0) = 0), unit intensity: Van Loan's block exponential by Eigen.
double ground_velocity_variance(const crandall::Options& o, double t) {
  const int n = static_cast<int>(o.filter_b.size()), m = n + 2;
  Mat abar = Mat::Zero(m, m), noise = Mat::Zero(m, m);
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) abar(i, j) = o.filter_a[i * n + j];
  for (int j = 0; j < n; ++j) abar(n, j) = o.filter_c[j];
  abar(n + 1, n) = 1.0;
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) noise(i, j) = o.filter_b[i] * o.filter_b[j];
  Mat big = Mat::Zero(2 * m, 2 * m);
  big.topLeftCorner(m, m) = -abar;
  big.topRightCorner(m, m) = noise;
  big.bottomRightCorner(m, m) = abar.transpose();
  const Mat e = (big * t).exp();
  const Mat q = e.bottomRightCorner(m, m).transpose() * e.topRightCorner(m, m);
  return q(n, n);
}

// (a) Without friction (drift 0, so static friction 0 too) the body's velocity is minus the
// ground's: V(t) = -G(t), Gaussian with mean 0 and variance sigma^2 Var G(t). 5 standard errors:
// the variance's is Var sqrt(2 / N), the mean's sqrt(Var / N).
TEST(FilteredRun, FrictionlessVelocityIsMinusTheGroundVelocity) {
  auto o = kt_options(15.6, 0.6);
  o.drift = 0.0;
  o.noise = 1.5;
  o.times = {0.25, 0.5, 1.0};
  o.switch_off = 1.0;
  o.dt = 0.01;
  o.seed = 7;
  o.paths = 20000;
  const crandall::Plan plan(o);
  const auto r = crandall::run_chunk(plan, 0, 0);
  const double n = static_cast<double>(o.paths);
  for (std::size_t k = 0; k < o.times.size(); ++k) {
    const double want = o.noise * o.noise * ground_velocity_variance(o, o.times[k]);
    const double var = r.times.central()[k * crandall::kMonomials + crandall::monomial_index(2, 0, 0)] / n;
    EXPECT_NEAR(var, want, 5 * want * std::sqrt(2 / n)) << o.times[k];
    EXPECT_NEAR(r.times.means()[k * 3], 0.0, 5 * std::sqrt(want / n)) << o.times[k];
  }
}

// Var a_g(t) = c Q_zz(t) c^T from rest (z(0) = 0), unit intensity (Van Loan by Eigen).
double ground_acceleration_variance(const crandall::Options& o, double t) {
  const int n = static_cast<int>(o.filter_b.size());
  Mat a(n, n), noise(n, n);
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) {
      a(i, j) = o.filter_a[i * n + j];
      noise(i, j) = o.filter_b[i] * o.filter_b[j];
    }
  Mat big = Mat::Zero(2 * n, 2 * n);
  big.topLeftCorner(n, n) = -a;
  big.topRightCorner(n, n) = noise;
  big.bottomRightCorner(n, n) = a.transpose();
  const Mat e = (big * t).exp();
  const Mat q = e.bottomRightCorner(n, n).transpose() * e.topRightCorner(n, n);
  Eigen::VectorXd c(n);
  for (int j = 0; j < n; ++j) c(j) = o.filter_c[j];
  return c.dot(q * c);
}

// The path loop's bridge points have the exact process's marginal law. Kanai-Tajimi omega = 0.5,
// zeta = 0.6, dt = 0.02, depth 8 (omega L from 1e-2 at the skeleton to 4e-5 at the finest
// substeps: the old bridges' a_g had sd ~ 1e3 there instead of ~ 0.1). With an event margin of
// 1e6 and a static friction of 1e3 the body never moves and every step is bisected to the full
// depth, so the trajectory holds a_g at every point t = i dt / 256. At the last step's midpoints
// of depths 1, 2, 3, 8 (and its end, a skeleton point) a_g over the paths must have mean 0 within
// 5 sqrt(Var / N) and variance Var a_g(t) within 5 standard errors Var sqrt(2 / N).
TEST(FilteredRun, BridgePointsHaveTheExactMarginalLaw) {
  auto o = kt_options(0.5, 0.6);
  o.drift = 1.0;
  o.static_drift = 1e3;
  o.noise = 1.0;
  o.times = {0.2};
  o.switch_off = 0.2;
  o.dt = 0.02;
  o.event_depth = 8;
  o.seed = 5;
  o.paths = 4000;
  const double margin = crandall::set_event_margin(1e6);
  const crandall::Plan plan(o);
  const std::size_t fine = 256, last = 10 * fine;
  const std::size_t at[] = {last - 128, last - 64, last - 32, last - 1, last - 85, last};
  std::vector<double> s1(std::size(at)), s2(std::size(at));
  for (std::uint64_t p = 0; p < o.paths; ++p) {
    const auto t = crandall::filtered_trajectory(plan, p);
    ASSERT_EQ(t.time.size(), last + 1) << p;
    for (std::size_t j = 0; j < std::size(at); ++j) {
      const double x = t.ground[at[j]];
      s1[j] += x;
      s2[j] += x * x;
    }
  }
  crandall::set_event_margin(margin);
  const double n = static_cast<double>(o.paths);
  for (std::size_t j = 0; j < std::size(at); ++j) {
    const double time = o.dt * static_cast<double>(at[j]) / static_cast<double>(fine);
    const double want = ground_acceleration_variance(o, time);
    const double mean = s1[j] / n, var = s2[j] / n - mean * mean;
    EXPECT_NEAR(mean, 0.0, 5 * std::sqrt(want / n)) << time;
    EXPECT_NEAR(var, want, 5 * want * std::sqrt(2 / n)) << time;
  }
}

crandall::Options stop_scene() {
  auto o = kt_options(15.6, 0.6);
  o.drift = 2.0;
  o.static_drift = 2.5;
  o.noise = 0.6;
  o.times = {0.5, 1.0, 1.5, 2.5};
  o.switch_off = 1.0;
  o.dt = 0.01;
  o.displacement = o.distance = o.stop = o.residual = true;
  o.seed = 11;
  o.paths = 1500;
  return o;
}

// (b) The same bits for any thread count, and path by path whatever the split into calls.
TEST(FilteredRun, BitwiseForThreadsAndChunking) {
  const crandall::Plan plan(stop_scene());
  const auto one = crandall::run_chunk(plan, 0, 1);
  const auto two = crandall::run_chunk(plan, 0, 2);
  EXPECT_EQ(one.times.central(), two.times.central());
  EXPECT_EQ(one.times.means(), two.times.means());
  EXPECT_EQ(one.stop.central(), two.stop.central());
  EXPECT_EQ(one.stop.means(), two.stop.means());
  const std::size_t size = crandall::sample_size(plan);
  std::vector<double> whole(300 * size), parts(300 * size);
  crandall::run_samples(plan, 0, 300, 2, whole.data());
  crandall::run_samples(plan, 0, 17, 1, parts.data());
  crandall::run_samples(plan, 17, 283, 2, parts.data() + 17 * size);
  EXPECT_EQ(whole, parts);
  // And the stop is where the body last came to rest: at or after its last output time's
  // state is frozen, and the stop time comes out finite.
  for (std::size_t p = 0; p < 300; ++p) EXPECT_TRUE(std::isfinite(whole[p * size + 4 * 3]));
}

// (b'') The peaks (Options::peaks): run_samples' values get (max |V|, max |U|, 0) per output time
// and at the stop, after the stop's slot, and they are the maxima over every point of the
// path's trajectory up to each of them; the other values are the same bits as without peaks.
TEST(FilteredRun, PeaksAreTheTrajectorysMaxima) {
  auto o = stop_scene();
  o.paths = 20;
  const crandall::Plan plain(o);
  o.peaks = true;
  const crandall::Plan plan(o);
  const std::size_t slots = o.times.size() + 1, size = crandall::sample_size(plan);
  ASSERT_EQ(size, 2 * slots * 3);
  ASSERT_EQ(crandall::sample_size(plain), slots * 3);
  std::vector<double> with(20 * size), without(20 * slots * 3);
  crandall::run_samples(plan, 0, 20, 1, with.data());
  crandall::run_samples(plain, 0, 20, 1, without.data());
  for (std::size_t p = 0; p < 20; ++p) {
    for (std::size_t j = 0; j < slots * 3; ++j)
      EXPECT_EQ(with[p * size + j], without[p * slots * 3 + j]) << p << " " << j;
    const auto tr = crandall::filtered_trajectory(plan, p);
    for (std::size_t k = 0; k < slots; ++k) {
      const double until = k < o.times.size() ? o.times[k] : INFINITY;
      double pv = 0.0, pu = 0.0;
      for (std::size_t i = 0; i < tr.time.size() && tr.time[i] <= until; ++i) {
        pv = std::max(pv, std::abs(tr.velocity[i]));
        pu = std::max(pu, std::abs(tr.displacement[i]));
      }
      const double* x = with.data() + p * size + (slots + k) * 3;
      EXPECT_EQ(x[0], pv) << p << " " << k;
      EXPECT_EQ(x[1], pu) << p << " " << k;
      EXPECT_EQ(x[2], 0.0);
    }
  }
}

// (b') Paths continued from stored states (extend_filtered_paths, crandall.tail's splitting):
// from point 0 with the plan's seed, the walked grid's path of run_samples at every output time
// (before and after the switch-off, static friction), bit for bit; from a middle point of a
// stored path, the rest of that path; the same bits for any thread count.
TEST(FilteredRun, ContinuedPathsAreTheBlocksPaths) {
  const crandall::Plan plan(stop_scene());
  const std::size_t points = crandall::filtered_grid_points(plan);
  const std::size_t cols = crandall::filtered_state_columns(plan);
  ASSERT_EQ(cols, 6u);
  std::vector<std::size_t> at;  // the grid point of every output slot
  std::size_t k = 0;
  for (const auto& seg : plan.segments()) {
    k += static_cast<std::size_t>(seg.steps);
    if (seg.slot >= 0) at.push_back(k);
  }
  ASSERT_EQ(at.size(), 4u);
  ASSERT_EQ(at.back() + 1, points);
  const std::size_t n = 64, size = crandall::sample_size(plan);
  std::vector<double> samples(n * size);
  crandall::run_samples(plan, 0, n, 2, samples.data());
  std::vector<double> states(n * points * cols, 0.0);
  std::vector<std::int64_t> rows(n), starts(n, 0);
  std::vector<std::uint64_t> streams(n);
  std::iota(rows.begin(), rows.end(), 0);
  std::iota(streams.begin(), streams.end(), 0);
  crandall::extend_filtered_paths(plan, states.data(), n, rows.data(), starts.data(),
                                  streams.data(), n, plan.options().seed, 1);
  int moved = 0, rested = 0;
  for (std::size_t p = 0; p < n; ++p)
    for (std::size_t slot = 0; slot < at.size(); ++slot) {
      const double* s = &states[(p * points + at[slot]) * cols];
      for (int v = 0; v < 3; ++v) EXPECT_EQ(s[v], samples[p * size + slot * 3 + v]) << p << " " << slot;
      moved += s[2] > 0.0;
      rested += s[0] == 0.0;
    }
  EXPECT_GT(moved, 0);
  EXPECT_GT(rested, 0);
  // From a point before the switch-off (1.0 s) and one after it.
  for (const std::size_t from : {at[0] - 7, at[1] + 3}) {
    std::vector<double> again = states;
    for (std::size_t p = 0; p < n; ++p)
      for (std::size_t q = from + 1; q < points; ++q)
        for (std::size_t c = 0; c < cols; ++c) again[(p * points + q) * cols + c] = -1.0;
    std::vector<std::int64_t> mid(n, static_cast<std::int64_t>(from));
    crandall::extend_filtered_paths(plan, again.data(), n, rows.data(), mid.data(),
                                    streams.data(), n, plan.options().seed, 2);
    EXPECT_EQ(again, states) << from;
  }
  std::vector<std::uint64_t> far(n, std::uint64_t{1} << 40);
  EXPECT_THROW(crandall::extend_filtered_paths(plan, states.data(), n, rows.data(),
                                               starts.data(), far.data(), n, 0, 1),
               std::invalid_argument);
}

// (c) No noise, a filter started away from 0: a deterministic ring-down. The body against
// newmark::exact fed a_g = c . exp(A t) z0 (Eigen) sampled every 1e-5 s (its linear
// interpolation is good to ~1e-10 there), with W = -V, its displacement -U, and S the sum of
// |dU| over the samples.
TEST(FilteredRun, RingDownMatchesNewmarkOnAFineRecord) {
  auto o = kt_options(10.0, 0.3);
  o.drift = 2.0;
  o.static_drift = 3.0;
  o.noise = 0.0;
  o.switch_off = 0.0;
  o.ring_down = true;  // the filter rings down from its start (else the shaking, a_g, ends at once)
  o.filter_start = {0.3, -2.0};  // a_g(0) = -18
  o.times = {0.1, 0.2, 0.35, 0.5, 1.0};
  o.dt = 0.01;
  o.displacement = o.distance = o.stop = true;
  o.paths = 1;
  const crandall::Plan plan(o);
  const auto r = crandall::run_chunk(plan, 0, 1);
  const double fine = 1e-5, horizon = 3.0;
  const auto count = static_cast<std::size_t>(horizon / fine) + 1;
  Eigen::Matrix2d a;
  a << o.filter_a[0], o.filter_a[1], o.filter_a[2], o.filter_a[3];
  const Eigen::Matrix2d step = (a * fine).exp();
  Eigen::Vector2d z(o.filter_start[0], o.filter_start[1]);
  std::vector<double> acc(count), w(count), d(count);
  for (std::size_t i = 0; i < count; ++i) {
    acc[i] = o.filter_c[0] * z(0) + o.filter_c[1] * z(1);
    z = step * z;
  }
  std::vector<crandall::newmark::Event> events;
  crandall::newmark::History h{w.data(), d.data(), &events};
  crandall::newmark::exact(acc.data(), count, fine, 1.0, {2.0, 2.0, 3.0, 3.0}, h);
  double scale = 0.0;
  for (double x : d) scale = std::max(scale, std::abs(x));
  for (std::size_t k = 0; k < o.times.size(); ++k) {
    const auto i = static_cast<std::size_t>(std::llround(o.times[k] / fine));
    double s = 0.0;
    for (std::size_t j = 0; j < i; ++j) s += std::abs(d[j + 1] - d[j]);
    EXPECT_NEAR(r.times.means()[k * 3 + 0], -w[i], 1e-6 * 18.0 * 0.1) << o.times[k];
    EXPECT_NEAR(r.times.means()[k * 3 + 1], -d[i], 1e-6 * scale) << o.times[k];
    EXPECT_NEAR(r.times.means()[k * 3 + 2], s, 1e-6 * scale) << o.times[k];
  }
  ASSERT_FALSE(events.empty());
  const double last = events.back().stop;
  EXPECT_TRUE(events.back().stopped);
  EXPECT_NEAR(r.stop.means()[0], last, 1e-6);
  EXPECT_NEAR(r.stop.means()[1], -d.back(), 1e-6 * scale);
}

// Trapezoid rule for int a_g V dt over a trajectory's points.
double work(const crandall::Trajectory& t) {
  double sum = 0.0;
  for (std::size_t i = 0; i + 1 < t.time.size(); ++i)
    sum += 0.5 * (t.time[i + 1] - t.time[i]) *
           (t.ground[i] * t.velocity[i] + t.ground[i + 1] * t.velocity[i + 1]);
  return sum;
}

// (d) The energy identity of a path from V(0) = v0 to its stop (V = 0 there):
// drift S(t_s) = v0^2 / 2 - int_0^t_s a_g V dt. Without noise a_g is smooth and the
// trapezoid rule over the trajectory's points (steps h = 1e-3) is good to h^2 / 12 |(a V)''| t_s
// ~ 1e-6 / 12 omega^2 |a_g| |V| ~ 3e-5 relative: 1e-4; with noise a_g
// is rough (a Brownian part) and the rule's error is ~ sqrt(dt) relative at worst: 3 %.
TEST(FilteredRun, EnergyIdentityOnSinglePaths) {
  for (double noise : {0.0, 0.8}) {
    auto o = kt_options(15.6, 0.6);
    o.drift = 2.0;
    o.noise = noise;
    o.start_velocity = 1.5;
    o.filter_start = {0.05, -0.4};
    o.switch_off = 1.0;
    o.times = {0.5};
    o.dt = 1e-3;
    o.displacement = o.distance = o.stop = true;
    o.paths = 4;
    o.seed = 3;
    const crandall::Plan plan(o);
    for (std::uint64_t path = 0; path < o.paths; ++path) {
      const auto t = crandall::filtered_trajectory(plan, path);
      ASSERT_GT(t.time.size(), 10u);
      EXPECT_EQ(t.velocity.back(), 0.0);
      const double lhs = o.drift * t.distance.back();
      const double rhs = 0.5 * o.start_velocity * o.start_velocity - work(t);
      const double mag = 0.5 * o.start_velocity * o.start_velocity;
      EXPECT_NEAR(lhs, rhs, (noise == 0.0 ? 1e-4 : 3e-2) * (lhs + mag)) << noise << " " << path;
      for (std::size_t i = 0; i + 1 < t.time.size(); ++i) ASSERT_LE(t.time[i], t.time[i + 1]);
    }
  }
}

// Stage 3: run_samples' coupled grids (steps h, 2h, 4h) see one path: the difference between
// grids is far below either grid's spread, and it shrinks when the step halves.
TEST(FilteredRun, CoupledGridsDifferLittleAndLessWithTheStep) {
  double previous = -1.0;
  for (int refinement : {0, 1}) {
    auto o = stop_scene();
    o.method = crandall::Method::richardson;
    o.dt = 0.02;
    o.refinement = refinement;
    o.paths = 400;
    const crandall::Plan plan(o);
    const std::size_t size = crandall::sample_size(plan);
    std::vector<double> v(o.paths * size);
    crandall::run_samples(plan, 0, o.paths, 0, v.data());
    // The distance at the stop (slot times.size(), variable 2), grids 0 and 1.
    const std::size_t slot = o.times.size();
    std::vector<double> g0, diff;
    for (std::size_t p = 0; p < o.paths; ++p) {
      const double* x = v.data() + p * size + slot * 3 * 3;
      g0.push_back(x[2]);
      diff.push_back(x[0 * 3 + 2] - x[1 * 3 + 2]);
    }
    const auto var = [](const std::vector<double>& x) {
      const double mean = std::accumulate(x.begin(), x.end(), 0.0) / x.size();
      double s = 0.0;
      for (double y : x) s += (y - mean) * (y - mean);
      return s / (x.size() - 1);
    };
    const double vd = var(diff), v0 = var(g0);
    EXPECT_LT(vd, 1e-2 * v0) << refinement;
    if (previous >= 0.0) {
      EXPECT_LT(vd, previous) << refinement;
    }
    previous = vd;
  }
}

}  // namespace
