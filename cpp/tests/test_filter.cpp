// The filtered excitation's skeleton (filter.hpp) against independent computations: Eigen's
// matrix exponential of Van Loan's block matrix, closed forms of Kanai-Tajimi's stationary
// variances and of the small-step variances, and the noise-space bisection tree's identities and law.
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <memory>
#include <stdexcept>
#include <random>
#include <string>
#include <vector>
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

// The noise-space tree (root_levels, docs/filtered.md "Bridges in noise space") against the
// Taylor/doubling Q (reliable entry by entry relative to sqrt(Q_ii Q_jj), TransitionMatches... and
// TinyStep... above). Kanai-Tajimi with omega = 1 from L = 1 down to L = 2^-20 (omega L from 1 to
// 1e-6, where the old conditioning's gains reached 1 / (omega L)^4), and Clough-Penzien (Q of rank
// n < m: exact degeneracies).
const LinearFilter kt1 = crandall::kanai_tajimi(1.0, 0.6);

TEST(FilterRoots, QuadratureRootReproducesQ) {
  for (const LinearFilter* f : {&kt1, &kt, &cp})
    for (double length : {1e-6, 1e-4, 1e-2, 0.3, 2.0}) {
      const int m = f->n + 2;
      const Mat r = mat(crandall::quadrature_root(*f, length), m, m);
      const Mat q = mat(crandall::transition(*f, length).q, m, m);
      expect_close_scaled(r * r.transpose(), q, q, 1e-12, "quadrature root at " + std::to_string(length));
      for (int i = 0; i < m; ++i)
        for (int j = i + 1; j < m; ++j) EXPECT_EQ(r(i, j), 0.0);  // lower triangular
    }
}

struct TreeCase {
  const LinearFilter* f;
  double longest;
  int count;
};

TEST(FilterRoots, LevelsReproduceQComposeAndSplitOrthonormally) {
  const TreeCase cases[] = {{&kt1, 1.0, 21}, {&kt, 0.08, 12}, {&cp, 0.08, 12}, {&cp, 4.0, 24}};
  for (const TreeCase& tc : cases) {
    const int n = tc.f->n, m = n + 2;
    const auto levels = crandall::root_levels(*tc.f, tc.longest, tc.count);
    ASSERT_EQ(levels.size(), static_cast<std::size_t>(tc.count));
    for (int i = 0; i < tc.count; ++i) {
      const auto& lv = levels[static_cast<std::size_t>(i)];
      const std::string where = "n " + std::to_string(n) + " L " + std::to_string(lv.length);
      EXPECT_EQ(lv.length, std::ldexp(tc.longest, -i));
      const auto t = crandall::transition(*tc.f, lv.length);
      EXPECT_EQ(lv.phi, t.phi);
      const Mat q = mat(t.q, m, m), r = mat(lv.root, m, m);
      expect_close_scaled(r * r.transpose(), q, q, 1e-10, "R R^T = Q, " + where);
      if (i + 1 == tc.count) {
        EXPECT_TRUE(lv.split.empty());
        continue;
      }
      // The split is orthogonal (its first m columns orthonormal, the rest their complement).
      const Mat s = mat(lv.split, 2 * m, 2 * m);
      EXPECT_LE((s.transpose() * s - Mat::Identity(2 * m, 2 * m)).cwiseAbs().maxCoeff(), 1e-14) << where;
      // Composition: [Phi(L/2) R(L/2), R(L/2)] split = [R(L), 0], each row to 1e-12 of its
      // scale sqrt(Q_rr(L)) (the rows of W have that norm, the columns of split are unit).
      const auto& below = levels[static_cast<std::size_t>(i + 1)];
      const Mat rh = mat(below.root, m, m);
      Mat w(m, 2 * m);
      w << mat(below.phi, m, m) * rh, rh;
      Mat want = Mat::Zero(m, 2 * m);
      want.leftCols(m) = r;
      const Mat got = w * s;
      for (int a = 0; a < m; ++a)
        for (int b = 0; b < 2 * m; ++b)
          EXPECT_LE(std::abs(got(a, b) - want(a, b)), 1e-12 * std::sqrt(q(a, a)))
              << "composition, " << where << " (" << a << ", " << b << ")";
      // The a_g spread: positive, below a_g's unconditional variance over L/2.
      Eigen::VectorXd c = Eigen::VectorXd::Zero(m);
      for (int j = 0; j < n; ++j) c(j) = tc.f->c[j];
      const Mat qh = mat(crandall::transition(*tc.f, below.length).q, m, m);
      EXPECT_GT(lv.spread, 0.0) << where;
      EXPECT_LT(lv.spread * lv.spread, c.dot(qh * c)) << where;
    }
  }
}

// For a full-rank Q the noise-space spread is the textbook bridge's: Var[c.Y(L/2) | Y(0), Y(L)] =
// c (Q_h - Q_h Phi_h^T Q_L^-1 Phi_h Q_h) c, Q_h = Q(L/2). Checked in double at moderate omega L
// only (0.3 to 0.6), where that formula (the old construction's) is still accurate to 1e-6.
TEST(FilterRoots, SpreadIsTheConditionalSpreadOfTheClassicBridge) {
  for (double length : {0.02, 0.04}) {
    const auto levels = crandall::root_levels(kt, length, 2);
    const Mat qh = mat(crandall::transition(kt, 0.5 * length).q, 4, 4);
    const Mat ph = mat(levels[1].phi, 4, 4);
    const Mat ql = mat(crandall::transition(kt, length).q, 4, 4);
    const Mat cond = qh - qh * ph.transpose() * ql.ldlt().solve(ph * qh);
    Eigen::Vector4d c(kt.c[0], kt.c[1], 0.0, 0.0);
    EXPECT_NEAR(levels[0].spread, std::sqrt(c.dot(cond * c)), 1e-6 * levels[0].spread) << length;
  }
}

// The filter model of the Kanai-Tajimi filter kt at event depth `depth`, one step length.
std::shared_ptr<const crandall::FilterModel> kt_model(int depth, double step) {
  crandall::Options o;
  o.excitation = crandall::Excitation::filtered;
  o.filter_a = kt.a;
  o.filter_b = kt.b;
  o.filter_c = kt.c;
  o.event_depth = depth;
  return crandall::make_filter_model(o, {step}, step);
}

// The event search's widest spread and midpoint mean against the textbook bridge (full-rank Q,
// moderate omega L as above): Var[c.Y(t) | Y(0), Y(L)] = c (Q_t - Q_t Phi_{L-t}^T Q_L^-1
// Phi_{L-t} Q_t) c, its widest over t = L/4, L/2, 3L/4 is widest_spread(.., 2); and
// E[Y(L/2) | Y(0), Y(L)] = Phi_h Y0 + Q_h Phi_h^T Q_L^-1 (Y(L) - Phi_L Y0), whose a_g is the
// table's mid_z . z0 + mid_xi . xi for Y(L) = Phi_L Y0 + R_L xi.
TEST(FilterRoots, WidestSpreadAndMidpointMeanAreTheClassicBridges) {
  const double length = 0.04;
  const auto levels = crandall::root_levels(kt, length, 3);
  const Mat ql = mat(crandall::transition(kt, length).q, 4, 4);
  const Eigen::Vector4d c(kt.c[0], kt.c[1], 0.0, 0.0);
  double widest = 0.0;
  for (double t : {0.25, 0.5, 0.75}) {
    const Mat qt = mat(crandall::transition(kt, t * length).q, 4, 4);
    const Mat pr = mat(crandall::transition(kt, (1 - t) * length).phi, 4, 4);
    const Mat cond = qt - qt * pr.transpose() * ql.ldlt().solve(pr * qt);
    widest = std::max(widest, std::sqrt(c.dot(cond * c)));
  }
  EXPECT_NEAR(crandall::widest_spread(levels, kt.c, 0, 1), levels[0].spread, 1e-12 * levels[0].spread);
  EXPECT_NEAR(crandall::widest_spread(levels, kt.c, 0, 2), widest, 1e-6 * widest);
  EXPECT_GT(widest, levels[0].spread);

  const auto fm = kt_model(1, length);
  const auto& table = fm->tables[0];
  const Mat ph = mat(crandall::transition(kt, 0.5 * length).phi, 4, 4);
  const Mat qh = mat(crandall::transition(kt, 0.5 * length).q, 4, 4);
  const Mat pl = mat(crandall::transition(kt, length).phi, 4, 4);
  const Mat rl = mat(table.levels[crandall::kLevelsUp].root, 4, 4);
  const Eigen::Vector4d y0(0.3, -1.2, 0.0, 0.0), xi(0.7, -0.4, 1.1, 0.2);
  const Eigen::Vector4d yl = pl * y0 + rl * xi;
  const Eigen::Vector4d mean = ph * y0 + qh * ph.transpose() * ql.ldlt().solve(yl - pl * y0);
  const double got = table.mid_z[0] * y0(0) + table.mid_z[1] * y0(1) + table.mid_xi[0] * xi(0) +
                     table.mid_xi[1] * xi(1) + table.mid_xi[2] * xi(2) + table.mid_xi[3] * xi(3);
  EXPECT_NEAR(got, c.dot(mean), 1e-6 * std::abs(c.dot(mean)));
}

// The onset test's points (kRestPoints) and segments: the table's pts_z . z0 + pts_xi . xi at
// the points j/8 of an interval is the textbook bridge's E[c.Y(t) | Y(0), Y(L)] = c (Phi_t Y0 +
// Q_t Phi_(L-t)^T Q_L^-1 (Y(L) - Phi_L Y0)), t = j L / 8, and seg_spread[j] the largest of
// sqrt(c Var[Y(t) | Y(0), Y(L)] c) = sqrt(c (Q_t - Q_t Phi_(L-t)^T Q_L^-1 Phi_(L-t) Q_t) c) over
// t = j L / 8, (2 j + 1) L / 16, (j + 1) L / 8 (0 at the interval's ends), at the step's level
// and one below; j = 4 is the midpoint's row (mid_z, mid_xi, from the table's own tree: the
// same up to rounding).
TEST(FilterRoots, TheRestTestsPointsAndSegmentsAreTheClassicBridges) {
  const double step = 0.08;
  const auto fm = kt_model(2, step);
  const auto& table = fm->tables[0];
  constexpr int kPts = crandall::kRestPoints;
  ASSERT_EQ(table.pts_z.size(), static_cast<std::size_t>(3 * kPts * 2));
  ASSERT_EQ(table.seg_spread.size(), static_cast<std::size_t>(3 * (kPts + 1)));
  const Eigen::Vector4d c(kt.c[0], kt.c[1], 0.0, 0.0);
  const Eigen::Vector4d y0(0.3, -1.2, 0.0, 0.0), xi(0.7, -0.4, 1.1, 0.2);
  for (int d = 0; d <= 1; ++d) {
    const double length = std::ldexp(step, -d);
    const Mat ql = mat(crandall::transition(kt, length).q, 4, 4);
    const Mat pl = mat(crandall::transition(kt, length).phi, 4, 4);
    const Mat rl = mat(table.levels[static_cast<std::size_t>(crandall::kLevelsUp + d)].root, 4, 4);
    const Eigen::Vector4d yl = pl * y0 + rl * xi;
    std::vector<double> spread(17, 0.0);
    for (int k = 1; k < 16; ++k) {
      const double t = length * k / 16.0;
      const Mat qt = mat(crandall::transition(kt, t).q, 4, 4);
      const Mat pr = mat(crandall::transition(kt, length - t).phi, 4, 4);
      const Mat cond = qt - qt * pr.transpose() * ql.ldlt().solve(pr * qt);
      spread[static_cast<std::size_t>(k)] = std::sqrt(c.dot(cond * c));
    }
    for (int j = 0; j <= kPts; ++j) {
      const std::size_t k = static_cast<std::size_t>(2 * j);
      const double want = std::max({spread[k], spread[k + 1], spread[k + 2]});
      EXPECT_NEAR(table.seg_spread[static_cast<std::size_t>(d * (kPts + 1) + j)], want,
                  1e-6 * want) << d << " " << j;
    }
    for (int j = 1; j <= kPts; ++j) {
      const double t = length * j / 8.0;
      const Mat pt = mat(crandall::transition(kt, t).phi, 4, 4);
      const Mat qt = mat(crandall::transition(kt, t).q, 4, 4);
      const Mat pr = mat(crandall::transition(kt, length - t).phi, 4, 4);
      const Eigen::Vector4d mean = pt * y0 + qt * pr.transpose() * ql.ldlt().solve(yl - pl * y0);
      const std::size_t row = static_cast<std::size_t>(d * kPts + j - 1);
      double got = 0.0;
      for (int i = 0; i < 2; ++i) got += table.pts_z[row * 2 + static_cast<std::size_t>(i)] * y0(i);
      for (int i = 0; i < 4; ++i) got += table.pts_xi[row * 4 + static_cast<std::size_t>(i)] * xi(i);
      EXPECT_NEAR(got, c.dot(mean), 1e-6 * std::abs(c.dot(mean)) + 1e-12) << d << " " << j;
      if (j == 4) {
        for (int i = 0; i < 2; ++i)
          EXPECT_NEAR(table.pts_z[row * 2 + static_cast<std::size_t>(i)],
                      table.mid_z[static_cast<std::size_t>(d * 2 + i)], 1e-14);
        for (int i = 0; i < 4; ++i)
          EXPECT_NEAR(table.pts_xi[row * 4 + static_cast<std::size_t>(i)],
                      table.mid_xi[static_cast<std::size_t>(d * 4 + i)], 1e-14);
      }
    }
  }
}

// The tree's law, sampled as the path loop samples it: a step of h = 0.02 from Y(0) = (z0, 0, 0)
// (omega = 0.5, zeta = 0.6, depth 8), xi ~ N(0, I), descended by the splits along a fixed
// pattern of halves (right, left, right, ...): every midpoint Y_mid = Phi(L/2) S + R(L/2) xi_left
// (S the current interval's start, in the step's coordinates: G and D from the step's start).
// At offset t from the step's start, Y_mid must be N(Phi(t) Y(0), Q(t)) and Cov(Y_mid, Y(h)) =
// Q(t) Phi(h - t)^T. Scaled by sqrt(Q_ii(t)) (and sqrt(Q_jj(h))): variances 1 within 5 standard
// errors (sqrt(2 / N)), means 0 within 5 / sqrt(N), correlations within 5 / sqrt(N) (the variance
// of a product of unit normals is at most 2). The old construction's midpoints had sd ~ 1e3
// here.
TEST(FilterRoots, TreeMidpointsHaveTheExactJointLaw) {
  const LinearFilter f = crandall::kanai_tajimi(0.5, 0.6);
  const int m = 4, depth = 8, paths = 20000;
  const double h = 0.02;
  const auto levels = crandall::root_levels(f, h, depth + 1);
  std::mt19937_64 gen(20240611);
  std::normal_distribution<double> normal;
  Eigen::Vector4d y0(0.3, -0.2, 0.0, 0.0);
  std::vector<std::vector<Eigen::Vector4d>> mids(depth, std::vector<Eigen::Vector4d>(paths));
  std::vector<Eigen::Vector4d> ends(paths);
  std::vector<double> offsets(depth);
  for (int p = 0; p < paths; ++p) {
    Eigen::Vector4d xi;
    for (int i = 0; i < m; ++i) xi(i) = normal(gen);
    ends[p] = mat(levels[0].phi, m, m) * y0 + mat(levels[0].root, m, m) * xi;
    Eigen::Vector4d start = y0;
    double t = 0.0;
    for (int d = 0; d < depth; ++d) {
      const auto& below = levels[static_cast<std::size_t>(d + 1)];
      Eigen::Matrix<double, 8, 1> u, ch;
      u.head(4) = xi;
      for (int i = 0; i < m; ++i) u(4 + i) = normal(gen);
      ch = mat(levels[static_cast<std::size_t>(d)].split, 2 * m, 2 * m) * u;
      const Eigen::Vector4d mid = mat(below.phi, m, m) * start + mat(below.root, m, m) * ch.head(4);
      mids[d][p] = mid;
      offsets[d] = t + below.length;
      if (d % 2 == 0) {  // right half: it starts at the midpoint
        start = mid;
        t += below.length;
        xi = ch.tail(4);
      } else {
        xi = ch.head(4);
      }
    }
  }
  const double n = paths;
  const Mat qh = mat(crandall::transition(f, h).q, m, m);
  for (int d = 0; d < depth; ++d) {
    const double t = offsets[d];
    const auto tr = crandall::transition(f, t);
    const Mat q = mat(tr.q, m, m);
    const Eigen::Vector4d mean = mat(tr.phi, m, m) * y0;
    const Mat cross = q * mat(crandall::transition(f, h - t).phi, m, m).transpose();
    const Eigen::Vector4d end_mean = mat(levels[0].phi, m, m) * y0;
    for (int i = 0; i < m; ++i) {
      double s1 = 0.0, s2 = 0.0;
      for (int p = 0; p < paths; ++p) {
        const double x = (mids[d][p](i) - mean(i)) / std::sqrt(q(i, i));
        s1 += x;
        s2 += x * x;
      }
      EXPECT_NEAR(s1 / n, 0.0, 5 / std::sqrt(n)) << "mean, depth " << d << " component " << i;
      EXPECT_NEAR(s2 / n, 1.0, 5 * std::sqrt(2 / n)) << "variance, depth " << d << " component " << i;
      for (int j = 0; j < m; ++j) {
        double sc = 0.0;
        for (int p = 0; p < paths; ++p)
          sc += (mids[d][p](i) - mean(i)) * (ends[p](j) - end_mean(j));
        const double scale = std::sqrt(q(i, i) * qh(j, j));
        EXPECT_NEAR(sc / n / scale, cross(i, j) / scale, 5 * std::sqrt(2 / n))
            << "covariance with the end, depth " << d << " (" << i << ", " << j << ")";
      }
    }
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
  // A Clough-Penzien filter whose Lyapunov matrix (eigenvalues 0.14 to 8.9) was refused as
  // not definite: the eigenvalues' Jacobi sweeps ran on past convergence into NaN.
  LinearFilter near;
  near.n = 4;
  near.a = {0, 1, 0, 0, -9, -3.5999999999999996, 0, 0, 0, 0, 0, 1, -9, -3.5999999999999996, -0.25, -0.7};
  near.b = {0, -1, 0, 0};
  near.c = {-9, -3.5999999999999996, -0.25, -0.7};
  const auto dn = crandall::decay_bound(near);
  EXPECT_TRUE(std::isfinite(dn.gain) && dn.gain > 0.0);
  // rate = 1 / (2 max eigenvalue of P): 8.9145298 by SciPy's solve_continuous_lyapunov.
  EXPECT_NEAR(dn.rate, 0.5 / 8.91452984, 1e-8);
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
