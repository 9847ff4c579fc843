// The filtered excitation's skeleton (filter.hpp) against independent computations: Eigen's
// matrix exponential of Van Loan's block matrix, closed forms of Kanai-Tajimi's stationary
// variances and of the small-step variances, and the Gaussian bridge's identities.
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <cmath>
#include <stdexcept>
#include <string>
#include <unsupported/Eigen/MatrixFunctions>

#include "crandall/filter.hpp"
#include "crandall/plan.hpp"

namespace {

using crandall::LinearFilter;
using Mat = Eigen::MatrixXd;

Mat mat(const std::vector<double>& v, int r, int c) {
  Mat out(r, c);
  for (int i = 0; i < r; ++i)
    for (int j = 0; j < c; ++j) out(i, j) = v[static_cast<std::size_t>(i * c + j)];
  return out;
}

void augmented(const LinearFilter& f, Mat& abar, Mat& noise) {
  const int n = f.n, m = n + 2;
  abar = Mat::Zero(m, m);
  abar.topLeftCorner(n, n) = mat(f.a, n, n);
  for (int j = 0; j < n; ++j) abar(n, j) = f.c[j];
  abar(n + 1, n) = 1.0;
  Eigen::VectorXd b = Eigen::VectorXd::Zero(m);
  for (int j = 0; j < n; ++j) b(j) = f.b[j];
  noise = b * b.transpose();
}

// Van Loan: exp([[-Abar, B], [0, Abar^T]] h) = [[., F12], [0, F22]], Phi = F22^T, Q = F22^T F12
// (Eigen's Pade exponential: accurate relative to the matrix's norm).
void van_loan(const LinearFilter& f, double h, Mat& phi, Mat& q) {
  Mat abar, noise;
  augmented(f, abar, noise);
  const Eigen::Index m = abar.rows();
  Mat big = Mat::Zero(2 * m, 2 * m);
  big.topLeftCorner(m, m) = -abar;
  big.topRightCorner(m, m) = noise;
  big.bottomRightCorner(m, m) = abar.transpose();
  const Mat e = (big * h).exp();
  phi = e.bottomRightCorner(m, m).transpose();
  q = phi * e.topRightCorner(m, m);
}

// |a_ij - b_ij| <= tol sqrt(s_ii s_jj) for a covariance-like scale s.
void expect_close_scaled(const Mat& a, const Mat& b, const Mat& s, double tol, const std::string& what) {
  for (Eigen::Index i = 0; i < a.rows(); ++i)
    for (Eigen::Index j = 0; j < a.cols(); ++j)
      EXPECT_LE(std::abs(a(i, j) - b(i, j)), tol * std::sqrt(s(i, i) * s(j, j)))
          << what << " (" << i << ", " << j << "): " << a(i, j) << " vs " << b(i, j);
}

const LinearFilter kt = crandall::kanai_tajimi(15.6, 0.6);
const LinearFilter cp = crandall::clough_penzien(15.6, 0.6, 1.6, 0.6);

TEST(FilterSkeleton, TransitionMatchesVanLoanBlockExponential) {
  for (const LinearFilter* f : {&kt, &cp})
    for (double h : {0.05, 0.3}) {
      const auto t = crandall::transition(*f, h);
      const int m = f->n + 2;
      Mat phi, q;
      van_loan(*f, h, phi, q);
      const double pn = phi.cwiseAbs().maxCoeff(), qn = q.cwiseAbs().maxCoeff();
      EXPECT_LE((mat(t.phi, m, m) - phi).cwiseAbs().maxCoeff(), 1e-12 * pn) << h;
      EXPECT_LE((mat(t.q, m, m) - q).cwiseAbs().maxCoeff(), 1e-10 * qn) << h;
      // The square root reproduces Q.
      const Mat root = mat(t.root, m, m);
      expect_close_scaled(root * root.transpose(), mat(t.q, m, m), mat(t.q, m, m), 1e-12, "root");
    }
}

TEST(FilterSkeleton, CompositionOfTwoStepsToRoundoff) {
  for (const LinearFilter* f : {&kt, &cp})
    for (double scale : {1e-4, 1e-2, 1.0}) {
      const double h1 = 1.23 * scale, h2 = 3.71 * scale;
      const int m = f->n + 2;
      const auto a = crandall::transition(*f, h1), b = crandall::transition(*f, h2),
                 ab = crandall::transition(*f, h1 + h2);
      const Mat p2 = mat(b.phi, m, m);
      // Y(h1 + h2) = Phi(h2) Y(h1) + noise, with G and D carried on from the start of the
      // first step: the augmented system's flow composes as it is.
      const Mat q = p2 * mat(a.q, m, m) * p2.transpose() + mat(b.q, m, m);
      expect_close_scaled(mat(ab.q, m, m), q, mat(ab.q, m, m), 1e-12, "Q(h1 + h2)");
      const Mat phi = p2 * mat(a.phi, m, m);
      const Mat mag = p2.cwiseAbs() * mat(a.phi, m, m).cwiseAbs();
      for (int i = 0; i < m; ++i)
        for (int j = 0; j < m; ++j)
          EXPECT_LE(std::abs(mat(ab.phi, m, m)(i, j) - phi(i, j)), 1e-12 * mag(i, j) + 1e-15 * std::sqrt(ab.q[i * m + i] / ab.q[j * m + j]));
    }
}

// Kanai-Tajimi x'' + 2 zeta omega x' + omega^2 x = -w: Var x = 1 / (4 zeta omega^3),
// Var x' = 1 / (4 zeta omega), Cov = 0 (unit intensity).
TEST(FilterSkeleton, LongStepReachesTheStationaryCovariance) {
  const double w = 15.6, z = 0.6;
  const auto t = crandall::transition(kt, 40.0 / (z * w));
  const Mat q = mat(t.q, 4, 4);
  EXPECT_NEAR(q(0, 0), 1.0 / (4 * z * w * w * w), 1e-12 / (4 * z * w * w * w));
  EXPECT_NEAR(q(1, 1), 1.0 / (4 * z * w), 1e-12 / (4 * z * w));
  EXPECT_NEAR(q(0, 1), 0.0, 1e-12 * std::sqrt(q(0, 0) * q(1, 1)));
  // And the Lyapunov solver on its own, for Clough-Penzien too.
  for (const LinearFilter* f : {&kt, &cp}) {
    const int n = f->n;
    std::vector<double> bb(static_cast<std::size_t>(n * n));
    for (int i = 0; i < n; ++i)
      for (int j = 0; j < n; ++j) bb[i * n + j] = f->b[i] * f->b[j];
    const Mat sigma = mat(crandall::lyapunov(f->a, n, bb), n, n);
    const auto far = crandall::transition(*f, 400.0);
    expect_close_scaled(mat(far.q, n + 2, n + 2).topLeftCorner(n, n), sigma, sigma, 1e-10, "stationary");
    const Mat a = mat(f->a, n, n);
    const Mat residual = a * sigma + sigma * a.transpose() + mat(bb, n, n);
    EXPECT_LE(residual.cwiseAbs().maxCoeff(), 1e-12 * sigma.cwiseAbs().maxCoeff() * a.cwiseAbs().maxCoeff());
  }
}

// At a tiny step every variance has its leading power of h: Var x' = h, Var x = h^3 / 3,
// Var G = k^2 h^3 / 3, Var D = k^2 h^5 / 20 with k = c . b = 2 zeta omega (the white part of
// a_g), each to relative O(omega h). A Pade exponential of Van Loan's matrix would lose Var D
// (1e-31 beside entries of 1e-6) entirely.
TEST(FilterSkeleton, TinyStepResolvesEveryVariance) {
  const double h = 1e-6, k = 2 * 0.6 * 15.6;
  const auto t = crandall::transition(kt, h);
  const Mat q = mat(t.q, 4, 4);
  const double tol = 1e-4;
  EXPECT_NEAR(q(1, 1) / h, 1.0, tol);
  EXPECT_NEAR(q(0, 0) / (h * h * h / 3), 1.0, tol);
  EXPECT_NEAR(q(2, 2) / (k * k * h * h * h / 3), 1.0, tol);
  EXPECT_NEAR(q(3, 3) / (k * k * std::pow(h, 5) / 20), 1.0, tol);
  // Correlation of G and D: (k^2 h^4 / 8) / sqrt(h^3 / 3 h^5 / 20) k^2 = sqrt(15) / 4.
  EXPECT_NEAR(q(2, 3) / std::sqrt(q(2, 2) * q(3, 3)), std::sqrt(15.0) / 4, tol);
}

// Checked in double from the stored (double) matrices, so only where the gains are moderate: the
// gain K grows like 1 / (omega L)^2 (the augmented state's near-degenerate direction, filter.cpp),
// and the identities multiply the stored Q(L)'s rounding by K twice (2e-16 K^2 ~ 1e-6 at
// L = 2e-3, the tolerance).
TEST(FilterBridge, MeanAndCovarianceIdentities) {
  for (const LinearFilter* f : {&kt, &cp})
    for (double length : {2e-3, 0.02, 0.5}) {
      const int n = f->n, m = n + 2;
      const auto br = crandall::bridge(*f, length);
      const auto half = crandall::transition(*f, 0.5 * length);
      const auto whole = crandall::transition(*f, length);
      const Mat F = mat(br.from_start, m, n), K = mat(br.from_end, m, m), R = mat(br.root, m, m);
      const Mat qm = mat(half.q, m, m), qh = mat(whole.q, m, m), pm = mat(half.phi, m, m);
      // Tower property: E[E[Ym | Y0, Y1] | Y0] = Phi(L/2) Y0 for every z0.
      const Mat tower = F + K * mat(whole.phi, m, m).leftCols(n);
      for (int i = 0; i < m; ++i)
        for (int j = 0; j < n; ++j)
          EXPECT_LE(std::abs(tower(i, j) - pm(i, j)), 1e-6 * std::sqrt(qm(i, i) / qm(j, j)) + 1e-12 * std::abs(pm(i, j)))
              << length << " tower " << i << j;
      // Total covariance: Var Ym = E Var[Ym | Y1] + Var E[Ym | Y1] = R R^T + K Q(L) K^T.
      expect_close_scaled(R * R.transpose() + K * qh * K.transpose(), qm, qm, 1e-6, "total covariance");
      // Cov(Ym, Y1) = Q(L/2) Phi(L/2)^T = K Q(L) (the gain's defining equation).
      const Mat cross = qm * pm.transpose();
      for (int i = 0; i < m; ++i)
        for (int j = 0; j < m; ++j)
          EXPECT_LE(std::abs((K * qh)(i, j) - cross(i, j)), 1e-6 * std::sqrt(qm(i, i) * qh(j, j))) << "cross";
      // The conditional variance of a_g at the midpoint: positive, below its prior variance.
      Eigen::VectorXd c = Eigen::VectorXd::Zero(m);
      for (int j = 0; j < n; ++j) c(j) = f->c[j];
      EXPECT_GT(br.spread, 0.0);
      EXPECT_LT(br.spread * br.spread, c.dot(qm * c));
    }
}

// The ring-down's bound: |c . z(s)| <= gain ||z(t)||_P for s >= t, on sampled deterministic
// flows (z(s) = exp(A s) z0 by Eigen).
TEST(FilterDecay, BoundHoldsOnTheFlow) {
  for (const LinearFilter* f : {&kt, &cp}) {
    const int n = f->n;
    const auto d = crandall::decay_bound(*f);
    const Mat a = mat(f->a, n, n), p = mat(d.p, n, n);
    EXPECT_LE((a.transpose() * p + p * a + Mat::Identity(n, n)).cwiseAbs().maxCoeff(), 1e-12 * p.cwiseAbs().maxCoeff() * a.cwiseAbs().maxCoeff());
    for (int trial = 0; trial < 5; ++trial) {
      Eigen::VectorXd z0 = Eigen::VectorXd::Zero(n);
      z0(trial % n) = 1.0;
      z0(n - 1) += 0.5 * trial;
      const double bound = d.bound(z0.data(), n);
      for (double s = 0.0; s < 5.0; s += 0.001) {
        const Eigen::VectorXd z = (a * s).exp() * z0;
        double ag = 0.0;
        for (int j = 0; j < n; ++j) ag += f->c[j] * z(j);
        ASSERT_LE(std::abs(ag), bound * (1 + 1e-12)) << s;
      }
    }
  }
  const auto unstable = crandall::kanai_tajimi(2.0, -0.1);
  EXPECT_FALSE(crandall::hurwitz(unstable.a, 2));
  EXPECT_THROW(crandall::decay_bound(unstable), std::invalid_argument);
}

crandall::Options filtered_options() {
  crandall::Options o;
  o.excitation = crandall::Excitation::filtered;
  o.filter_a = kt.a;
  o.filter_b = kt.b;
  o.filter_c = kt.c;
  o.times = {1.0};
  o.switch_off = 1.0;
  return o;
}

void expect_refused(const crandall::Options& o, const std::string& field) {
  try {
    o.validate();
    ADD_FAILURE() << "accepted; expected an error naming " << field;
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find(field), std::string::npos) << e.what();
  }
}

TEST(FilterOptions, RefusedWithTheFieldNamed) {
  filtered_options().validate();
  auto o = filtered_options();
  o.filter_b = {};
  expect_refused(o, "filter_b");
  o = filtered_options();
  o.filter_a.pop_back();
  expect_refused(o, "filter_a");
  o = filtered_options();
  o.filter_c = {1.0};
  expect_refused(o, "filter_c");
  o = filtered_options();
  o.filter_start = {1.0, 2.0, 3.0};
  expect_refused(o, "filter_start");
  o = filtered_options();
  o.filter_a[0] = std::nan("");
  expect_refused(o, "filter_a");
  o = filtered_options();
  o.static_drift = 1.0;  // below drift 2
  expect_refused(o, "static_drift");
  o = filtered_options();
  o.event_depth = 0;
  expect_refused(o, "event_depth");
  o = filtered_options();
  o.method = crandall::Method::euler;
  expect_refused(o, "method");
  o = filtered_options();
  o.method = crandall::Method::richardson;
  o.event_depth = 1;
  expect_refused(o, "event_depth");
  o = filtered_options();
  o.stop = true;
  o.displacement = o.distance = true;
  o.quadratic_variation = true;
  expect_refused(o, "quadratic_variation");
  o = filtered_options();
  o.peaks = true;
  expect_refused(o, "peaks");
  o = filtered_options();
  o.stop = true;
  o.filter_a = crandall::kanai_tajimi(2.0, -0.1).a;
  expect_refused(o, "filter_a");
  o = filtered_options();
  o.stop = true;
  o.drift = 0.0;
  expect_refused(o, "friction");
  // White noise takes none of the filter's fields.
  crandall::Options w;
  w.times = {1.0};
  w.filter_b = {1.0};
  expect_refused(w, "filter_b");
  w = crandall::Options{};
  w.times = {1.0};
  w.static_drift = 3.0;
  expect_refused(w, "static_drift");
  EXPECT_THROW(crandall::parse_excitation("pink"), std::invalid_argument);
}

}  // namespace
