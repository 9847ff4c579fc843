// The filtered excitation's exact skeleton: transitions, the noise-space bisection tree's roots
// and splits, the ring-down's decay bound
// (filter.hpp; derivations in docs/filtered.md, "The skeleton"). Plan-time code: Eigen's dense
// algebra on matrices of at most 8 x 8, compiled once for the baseline instruction set, so every
// CPU gets the same bits.
#include "crandall/filter.hpp"

#include <Eigen/Dense>
#include <Eigen/Eigenvalues>
#include <cmath>
#include <stdexcept>
#include <string>

#include "crandall/plan.hpp"

namespace crandall {
namespace {

using Mat = Eigen::MatrixXd;
using Vec = Eigen::VectorXd;
// The plan-time algebra of transitions and bridges runs in extended precision (x86's 80-bit long
// double: the same bits on every x86-64 CPU) and is rounded to double at the end. The augmented
// state is nearly degenerate at small steps: for Kanai-Tajimi, G + 2 zeta omega x - (omega^2 /
// (2 zeta omega)) D is of relative size (omega h)^2, so Var Y(h) has an eigenvalue of relative
// size (omega h)^4 that rounding of Q's entries in double (1e-16) swamps below h ~ 1e-4; the
// factorisations need it, the stored results do not (rounding a square root or a gain to double
// changes the sampled law only at second order in the rounding).
using Real = long double;
using RMat = Eigen::Matrix<Real, Eigen::Dynamic, Eigen::Dynamic>;
using RVec = Eigen::Matrix<Real, Eigen::Dynamic, 1>;

void require(bool ok, const std::string& message) {
  if (!ok) throw std::invalid_argument(message);
}

Mat from_row_major(const std::vector<double>& v, int rows, int cols) {
  Mat out(rows, cols);
  for (int i = 0; i < rows; ++i)
    for (int j = 0; j < cols; ++j) out(i, j) = v[static_cast<std::size_t>(i * cols + j)];
  return out;
}

std::vector<double> to_row_major(const Mat& a) {
  std::vector<double> out(static_cast<std::size_t>(a.rows() * a.cols()));
  for (Eigen::Index i = 0; i < a.rows(); ++i)
    for (Eigen::Index j = 0; j < a.cols(); ++j) out[static_cast<std::size_t>(i * a.cols() + j)] = a(i, j);
  return out;
}

// Abar = [[A, 0, 0], [c, 0, 0], [0, 1, 0]] and bbar bbar^T, bbar = (b, 0, 0).
void augmented(const LinearFilter& f, RMat& abar, RMat& noise) {
  const int n = f.n, m = n + 2;
  abar = RMat::Zero(m, m);
  abar.topLeftCorner(n, n) = from_row_major(f.a, n, n).cast<Real>();
  for (int j = 0; j < n; ++j) abar(n, j) = f.c[static_cast<std::size_t>(j)];
  abar(n + 1, n) = 1.0;
  RVec bbar = RVec::Zero(m);
  for (int j = 0; j < n; ++j) bbar(j) = f.b[static_cast<std::size_t>(j)];
  noise = bbar * bbar.transpose();
}

// Phi(tau) and Q(tau) by their Taylor series, for ||Abar tau|| <= 1/2:
//   Phi = sum_k (Abar tau)^k / k!,
//   Q = sum_k tau^(k+1) / (k+1)! L^k(B),  L(X) = Abar X + X Abar^T,  B = bbar bbar^T
// (Q' = Abar Q + Q Abar^T + B, Q(0) = 0). Each entry of Phi and Q starts at its own power of tau
// (the variance of D is O(tau^5) where that of x' is O(tau)), and every later term of its series
// is smaller than the one before by a factor below 1/2: so each entry is accurate relative to
// itself, not only to the matrix's norm (which a Pade approximant of Van Loan's block matrix
// would give, losing the small entries at small steps). Terms are summed smallest first.
void taylor(const RMat& abar, const RMat& noise, Real tau, RMat& phi, RMat& q) {
  constexpr int kTerms = 30;  // (1/2)^30 / 30! is far below a long double's precision
  const Eigen::Index m = abar.rows();
  std::vector<RMat> terms;
  terms.reserve(kTerms + 1);
  RMat t = RMat::Identity(m, m);
  terms.push_back(t);
  for (int k = 1; k <= kTerms; ++k) {
    t = (t * abar) * (tau / k);
    terms.push_back(t);
  }
  phi = RMat::Zero(m, m);
  for (int k = kTerms; k >= 0; --k) phi += terms[static_cast<std::size_t>(k)];
  terms.clear();
  RMat r = noise * tau;
  terms.push_back(r);
  for (int k = 0; k < kTerms; ++k) {
    r = (abar * r + r * abar.transpose()) * (tau / (k + 2));
    terms.push_back(r);
  }
  q = RMat::Zero(m, m);
  for (int k = kTerms; k >= 0; --k) q += terms[static_cast<std::size_t>(k)];
}

// Phi(h), Q(h) (Van Loan's integral): the Taylor series on h / 2^s with ||Abar h|| / 2^s <= 1/2,
// then s doublings Q(2t) = Phi(t) Q(t) Phi(t)^T + Q(t), Phi(2t) = Phi(t)^2 (the composition of
// two steps: a sum of two positive semidefinite terms, so the diagonal never cancels).
void phi_q(const LinearFilter& f, double h, RMat& phi, RMat& q) {
  require(std::isfinite(h) && h > 0.0, "filter transition: the step must be finite and > 0");
  RMat abar, noise;
  augmented(f, abar, noise);
  const Real norm = abar.cwiseAbs().rowwise().sum().maxCoeff();
  int s = 0;
  Real tau = h;
  while (norm * tau > 0.5L && s < 2000) {
    tau = std::ldexp(static_cast<Real>(h), -(++s));
  }
  taylor(abar, noise, tau, phi, q);
  for (int i = 0; i < s; ++i) {
    q = phi * q * phi.transpose() + q;
    q = 0.5 * (q + q.transpose());
    phi = phi * phi;
  }
  require(phi.allFinite() && q.allFinite(),
          "filter_a, filter_b, filter_c: the filter's transition over a step of " +
              std::to_string(h) + " overflows (the filter grows too fast for the horizon)");
}

// A square root of a positive semidefinite matrix q (q = R R^T), robust to its ill
// conditioning: the components' variances span many powers of the step (O(h) for x' to O(h^5)
// for D), so q is scaled to its correlation matrix first (diag(q)^(-1/2) q diag(q)^(-1/2),
// entries O(1)), factored by Eigen's pivoted LDL^T (a pivot that rounds below 0 is taken as 0),
// and scaled back: R = diag(q)^(1/2) P^T L D^(1/2). A component without variance gets a zero row.
RMat psd_root(const RMat& q) {
  const Eigen::Index m = q.rows();
  RVec d(m);
  for (Eigen::Index i = 0; i < m; ++i) d(i) = q(i, i) > 0.0 ? std::sqrt(q(i, i)) : 0.0L;
  RMat r = RMat::Zero(m, m);
  for (Eigen::Index i = 0; i < m; ++i)
    for (Eigen::Index j = 0; j < m; ++j)
      r(i, j) = d(i) > 0.0 && d(j) > 0.0 ? q(i, j) / (d(i) * d(j)) : (i == j ? 1.0 : 0.0);
  Eigen::LDLT<RMat> ldlt(r);
  RVec pivots = ldlt.vectorD();
  for (Eigen::Index i = 0; i < m; ++i) pivots(i) = pivots(i) > 0.0 ? std::sqrt(pivots(i)) : 0.0L;
  const RMat lower = ldlt.matrixL();
  RMat root = ldlt.transpositionsP().transpose() * (lower * pivots.asDiagonal());
  return d.asDiagonal() * root;
}

}  // namespace

LinearFilter kanai_tajimi(double omega, double zeta) {
  LinearFilter f;
  f.n = 2;
  f.a = {0.0, 1.0, -omega * omega, -2.0 * zeta * omega};
  f.b = {0.0, -1.0};
  f.c = {-omega * omega, -2.0 * zeta * omega};
  return f;
}

LinearFilter clough_penzien(double omega, double zeta, double omega_f, double zeta_f) {
  LinearFilter f;
  f.n = 4;
  const double w2 = omega * omega, k = 2.0 * zeta * omega;
  const double f2 = omega_f * omega_f, kf = 2.0 * zeta_f * omega_f;
  f.a = {0.0, 1.0, 0.0, 0.0,  //
         -w2, -k,  0.0, 0.0,  //
         0.0, 0.0, 0.0, 1.0,  //
         -w2, -k,  -f2, -kf};
  f.b = {0.0, -1.0, 0.0, 0.0};
  f.c = {-w2, -k, -f2, -kf};
  return f;
}

Transition transition(const LinearFilter& f, double h) {
  RMat phi, q;
  phi_q(f, h, phi, q);
  Transition t;
  t.step = h;
  t.phi = to_row_major(phi.cast<double>());
  t.q = to_row_major(q.cast<double>());
  t.root = to_row_major(psd_root(q).cast<double>());
  return t;
}

namespace {

// The k Gauss-Legendre nodes and weights on [-1, 1]: Newton on P_k from Chebyshev-like starts
// (long double; k <= 12 here).
void gauss_legendre(int k, std::vector<Real>& nodes, std::vector<Real>& weights) {
  nodes.assign(static_cast<std::size_t>(k), 0.0L);
  weights.assign(static_cast<std::size_t>(k), 0.0L);
  const Real pi = 3.141592653589793238462643383279502884L;
  for (int i = 0; i < k; ++i) {
    Real x = std::cos(pi * (i + 0.75L) / (k + 0.5L)), dp = 0.0L;
    for (int it = 0; it < 100; ++it) {
      Real p0 = 1.0L, p1 = x;
      for (int j = 2; j <= k; ++j) {
        const Real p2 = ((2 * j - 1) * x * p1 - (j - 1) * p0) / j;
        p0 = p1;
        p1 = p2;
      }
      dp = k * (x * p1 - p0) / (x * x - 1.0L);
      const Real dx = p1 / dp;
      x -= dx;
      if (std::abs(dx) <= 1e-21L) break;
    }
    Real p0 = 1.0L, p1 = x;
    for (int j = 2; j <= k; ++j) {
      const Real p2 = ((2 * j - 1) * x * p1 - (j - 1) * p0) / j;
      p0 = p1;
      p1 = p2;
    }
    dp = k * (x * p1 - p0) / (x * x - 1.0L);
    nodes[static_cast<std::size_t>(i)] = x;
    weights[static_cast<std::size_t>(i)] = 2.0L / ((1.0L - x * x) * dp * dp);
  }
}

// The thin-to-full composition of two consecutive intervals of length t: with W = [Phi(t) R(t),
// R(t)] (m x 2m, W W^T = Q(2t)), the Householder QR W^T = U T; returns R(2t) = T^T (its top m
// rows) and, if asked, U (2m x 2m orthogonal). Householder QR is backward stable column by
// column (each column of W^T, a component of Y, keeps its own scale), and nothing is inverted:
// a rank-deficient W (Clough-Penzien) just gives zeros on T's diagonal.
RMat compose_roots(const RMat& phi_half, const RMat& root_half, RMat* split) {
  const Eigen::Index m = root_half.rows();
  RMat wt(2 * m, m);
  wt.topRows(m) = (phi_half * root_half).transpose();
  wt.bottomRows(m) = root_half.transpose();
  const Eigen::HouseholderQR<RMat> qr(wt);
  const RMat t = qr.matrixQR().topRows(m).triangularView<Eigen::Upper>();
  if (split != nullptr) *split = qr.householderQ() * RMat::Identity(2 * m, 2 * m);
  return t.transpose();
}

// exp(Abar s) bbar by its Taylor series (||Abar s|| <= 1/2: every component accurate relative
// to itself, as in taylor above).
RVec flow_of_noise(const RMat& abar, const RVec& bbar, Real s) {
  constexpr int kTerms = 30;
  std::vector<RVec> terms;
  RVec t = bbar;
  terms.push_back(t);
  for (int k = 1; k <= kTerms; ++k) {
    t = (abar * t) * (s / k);
    terms.push_back(t);
  }
  RVec out = RVec::Zero(bbar.size());
  for (int k = kTerms; k >= 0; --k) out += terms[static_cast<std::size_t>(k)];
  return out;
}

// The quadrature root at a length with ||Abar length|| <= 1/2 (the Gauss-Legendre rule on k
// nodes is exact for polynomials of degree 2k - 1; the integrand is entire, so its error is
// about (||Abar|| length)^(2k) / (2k)! relative to each entry).
RMat quadrature_root_short(const RMat& abar, const RVec& bbar, Real length) {
  const Eigen::Index m = abar.rows();
  const int k = static_cast<int>(m) + 4;
  std::vector<Real> x, w;
  gauss_legendre(k, x, w);
  RMat cols(k, m);  // the transpose of [exp(Abar s_j) bbar sqrt(w_j)]
  for (int j = 0; j < k; ++j) {
    const Real s = 0.5L * length * (1.0L + x[static_cast<std::size_t>(j)]);
    cols.row(j) = (flow_of_noise(abar, bbar, s) * std::sqrt(0.5L * length * w[static_cast<std::size_t>(j)])).transpose();
  }
  const Eigen::HouseholderQR<RMat> qr(cols);
  const RMat t = qr.matrixQR().topRows(m).triangularView<Eigen::Upper>();
  return t.transpose();
}

RMat quadrature_root_long(const LinearFilter& f, double length) {
  require(std::isfinite(length) && length > 0.0, "filter root: the length must be finite and > 0");
  RMat abar, noise;
  augmented(f, abar, noise);
  const Eigen::Index m = abar.rows();
  RVec bbar = RVec::Zero(m);
  for (int j = 0; j < f.n; ++j) bbar(j) = f.b[static_cast<std::size_t>(j)];
  const Real norm = abar.cwiseAbs().rowwise().sum().maxCoeff();
  int s = 0;
  Real tau = length;
  while (norm * tau > 0.5L && s < 2000) tau = std::ldexp(static_cast<Real>(length), -(++s));
  RMat root = quadrature_root_short(abar, bbar, tau);
  for (int i = s; i > 0; --i) {
    RMat phi, q;
    phi_q(f, static_cast<double>(std::ldexp(static_cast<Real>(length), -i)), phi, q);
    root = compose_roots(phi, root, nullptr);
  }
  return root;
}

}  // namespace

std::vector<double> quadrature_root(const LinearFilter& f, double length) {
  return to_row_major(quadrature_root_long(f, length).cast<double>());
}

std::vector<RootLevel> root_levels(const LinearFilter& f, double longest, int count) {
  require(count >= 1, "filter root levels: count must be >= 1");
  const int n = f.n, m = n + 2;
  std::vector<RMat> phis(static_cast<std::size_t>(count)), roots(static_cast<std::size_t>(count)),
      splits(static_cast<std::size_t>(count));
  for (int i = 0; i < count; ++i) {
    RMat q;
    phi_q(f, std::ldexp(longest, -i), phis[static_cast<std::size_t>(i)], q);
  }
  roots[static_cast<std::size_t>(count - 1)] = quadrature_root_long(f, std::ldexp(longest, -(count - 1)));
  for (int i = count - 2; i >= 0; --i)
    roots[static_cast<std::size_t>(i)] = compose_roots(phis[static_cast<std::size_t>(i + 1)],
                                                       roots[static_cast<std::size_t>(i + 1)],
                                                       &splits[static_cast<std::size_t>(i)]);
  RVec c = RVec::Zero(m);
  for (int j = 0; j < n; ++j) c(j) = f.c[static_cast<std::size_t>(j)];
  std::vector<RootLevel> out(static_cast<std::size_t>(count));
  for (int i = 0; i < count; ++i) {
    RootLevel& level = out[static_cast<std::size_t>(i)];
    const auto u = static_cast<std::size_t>(i);
    level.length = std::ldexp(longest, -i);
    level.phi = to_row_major(phis[u].cast<double>());
    level.root = to_row_major(roots[u].cast<double>());
    require(phis[u].allFinite() && roots[u].allFinite(),
            "filter_a, filter_b, filter_c: the filter's noise roots over an interval of " +
                std::to_string(level.length) + " are not finite");
    if (i + 1 < count) {
      level.split = to_row_major(splits[u].cast<double>());
      const RMat null_top = splits[u].topRightCorner(m, m);
      level.spread = static_cast<double>((null_top.transpose() * (roots[u + 1].transpose() * c)).norm());
    }
  }
  return out;
}

namespace {

// widest_spread's recursion: zs (n x E) and xi (m x E) are the start state's and the noise
// coordinates' coefficients on the E normals of the nodes below the interval (its own xi and
// start are given: they carry no variance).
void widest_below(const std::vector<RootLevel>& levels, const Vec& c, std::size_t level, int sub,
                  const Mat& zs, const Mat& xi, int& node, double& widest) {
  if (sub == 0 || level + 1 >= levels.size() || levels[level].split.empty()) return;
  const Eigen::Index n = c.size(), m = xi.rows(), e = xi.cols();
  const Mat split = from_row_major(levels[level].split, static_cast<int>(2 * m), static_cast<int>(2 * m));
  const Mat phi = from_row_major(levels[level + 1].phi, static_cast<int>(m), static_cast<int>(m));
  const Mat root = from_row_major(levels[level + 1].root, static_cast<int>(m), static_cast<int>(m));
  Mat eta = Mat::Zero(m, e);
  for (Eigen::Index i = 0; i < m; ++i) eta(i, node * m + i) = 1.0;
  ++node;
  const Mat left = split.topLeftCorner(m, m) * xi + split.topRightCorner(m, m) * eta;
  const Mat right = split.bottomLeftCorner(m, m) * xi + split.bottomRightCorner(m, m) * eta;
  const Mat mid = phi.topLeftCorner(n, n) * zs + root.topRows(n) * left;
  widest = std::max(widest, (c.transpose() * mid).norm());
  widest_below(levels, c, level + 1, sub - 1, zs, left, node, widest);
  widest_below(levels, c, level + 1, sub - 1, mid, right, node, widest);
}

}  // namespace

double widest_spread(const std::vector<RootLevel>& levels, const std::vector<double>& c,
                     std::size_t level, int sub) {
  const auto n = static_cast<Eigen::Index>(c.size()), m = n + 2;
  Vec cv(n);
  for (Eigen::Index j = 0; j < n; ++j) cv(j) = c[static_cast<std::size_t>(j)];
  const Eigen::Index e = m * ((Eigen::Index{1} << sub) - 1);
  int node = 0;
  double widest = 0.0;
  widest_below(levels, cv, level, sub, Mat::Zero(n, e), Mat::Zero(m, e), node, widest);
  return widest;
}

std::vector<double> lyapunov(const std::vector<double>& a, int n, const std::vector<double>& rhs) {
  const Mat am = from_row_major(a, n, n);
  const int nn = n * n;
  Mat k = Mat::Zero(nn, nn);
  Vec v(nn);
  // Column-major vec: index i + j n. (A X)_ij = sum_k A_ik X_kj; (X A^T)_ij = sum_k X_ik A_jk.
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) {
      const int row = i + j * n;
      for (int q = 0; q < n; ++q) {
        k(row, q + j * n) += am(i, q);
        k(row, i + q * n) += am(j, q);
      }
      v(row) = -rhs[static_cast<std::size_t>(i * n + j)];
    }
  Eigen::FullPivLU<Mat> lu(k);
  require(lu.isInvertible(),
          "filter_a: the Lyapunov equation A X + X A^T = -B has no unique solution (A has "
          "eigenvalues lambda_i + lambda_j = 0)");
  const Vec x = lu.solve(v);
  Mat out(n, n);
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) out(i, j) = x(i + j * n);
  return to_row_major(out);
}

bool hurwitz(const std::vector<double>& a, int n) {
  Eigen::EigenSolver<Mat> es(from_row_major(a, n, n), false);
  return es.info() == Eigen::Success && es.eigenvalues().real().maxCoeff() < 0.0;
}

double DecayBound::bound(const double* z, int n) const {
  double quad = 0.0;
  for (int i = 0; i < n; ++i) {
    double row = 0.0;
    for (int j = 0; j < n; ++j) row += p[static_cast<std::size_t>(i * n + j)] * z[j];
    quad += z[i] * row;
  }
  return gain * std::sqrt(quad > 0.0 ? quad : 0.0);
}

DecayBound decay_bound(const LinearFilter& f) {
  const int n = f.n;
  require(hurwitz(f.a, n),
          "filter_a must be Hurwitz (every eigenvalue with a negative real part) when the stop "
          "is observed: the ring-down after the switch-off must die out");
  const Mat at = from_row_major(f.a, n, n).transpose();
  std::vector<double> identity(static_cast<std::size_t>(n * n), 0.0);
  for (int i = 0; i < n; ++i) identity[static_cast<std::size_t>(i * n + i)] = 1.0;
  Mat p = from_row_major(lyapunov(to_row_major(at), n, identity), n, n);
  p = 0.5 * (p + p.transpose());
  Eigen::SelfAdjointEigenSolver<Mat> es(p);
  require(es.info() == Eigen::Success && es.eigenvalues().minCoeff() > 0.0,
          "filter_a: the Lyapunov matrix of the ring-down is not positive definite");
  Vec c(n);
  for (int j = 0; j < n; ++j) c(j) = f.c[static_cast<std::size_t>(j)];
  DecayBound d;
  d.p = to_row_major(p);
  d.gain = std::sqrt(c.dot(p.ldlt().solve(c)));
  d.rate = 0.5 / es.eigenvalues().maxCoeff();
  return d;
}

LinearFilter options_filter(const Options& o) {
  LinearFilter f;
  f.n = static_cast<int>(o.filter_b.size());
  f.a = o.filter_a;
  f.b = o.filter_b;
  f.c = o.filter_c;
  return f;
}

void validate_filter_options(const Options& o) {
  const std::size_t n = o.filter_b.size();
  require(n >= 1 && n <= static_cast<std::size_t>(kMaxFilter),
          "filter_b must hold the filter's n = 1 to 6 numbers, got " + std::to_string(n));
  require(o.filter_a.size() == n * n, "filter_a must hold n * n = " + std::to_string(n * n) +
                                          " numbers (A row-major), got " +
                                          std::to_string(o.filter_a.size()));
  require(o.filter_c.size() == n,
          "filter_c must hold n = " + std::to_string(n) + " numbers, got " + std::to_string(o.filter_c.size()));
  require(o.filter_start.empty() || o.filter_start.size() == n,
          "filter_start must be empty (zeros) or hold n = " + std::to_string(n) + " numbers, got " +
              std::to_string(o.filter_start.size()));
  const auto finite = [](const std::vector<double>& v) {
    for (double x : v)
      if (!std::isfinite(x)) return false;
    return true;
  };
  require(finite(o.filter_a), "filter_a must be finite");
  require(finite(o.filter_b), "filter_b must be finite");
  require(finite(o.filter_c), "filter_c must be finite");
  require(finite(o.filter_start), "filter_start must be finite");
  require(std::isnan(o.static_drift) || (std::isfinite(o.static_drift) && o.static_drift >= o.drift),
          "static_drift must be finite and >= drift (NaN: equal to drift)");
  require(o.method == Method::exact || o.method == Method::richardson || o.method == Method::richardson2,
          std::string("method must be 'exact' with excitation 'filtered' ('richardson' and "
                      "'richardson2' only for run_samples' coupled grids), got '") +
              method_name(o.method) + "'");
  require(o.event_depth >= 1 && o.event_depth <= kMaxEventDepth,
          "event_depth must be between 1 and " + std::to_string(kMaxEventDepth));
  require(o.event_depth >= o.grids() - 1,
          "event_depth must be at least " + std::to_string(o.grids() - 1) + " for method '" +
              method_name(o.method) + "' (its coarsest grid's steps are bisected at the finer grids' points first)");
  require(!o.quadratic_variation, "quadratic_variation is not available with excitation 'filtered'");
  require(o.paths <= (std::uint64_t{1} << 40), "paths must be <= 2^40 with excitation 'filtered'");
  if (o.stop) {
    require(o.drift > 0.0, "the stop needs drift > 0 with excitation 'filtered' (without friction "
                           "the ring-down never lets the body rest for good)");
    require(hurwitz(o.filter_a, static_cast<int>(n)),
            "filter_a must be Hurwitz (every eigenvalue with a negative real part) when the stop "
            "is observed: the ring-down after the switch-off must die out");
  }
}

int FilterModel::table_of(double step) const {
  for (std::size_t i = 0; i < tables.size(); ++i)
    if (tables[i].step == step) return static_cast<int>(i);
  throw std::logic_error("filtered: no transition was precomputed for a step");
}

std::shared_ptr<const FilterModel> make_filter_model(const Options& o,
                                                     const std::vector<double>& segment_steps,
                                                     double tail_step) {
  auto model = std::make_shared<FilterModel>();
  FilterModel& fm = *model;
  fm.filter = options_filter(o);
  const int n = fm.filter.n;
  fm.m = n + 2;
  const Mat a = from_row_major(fm.filter.a, n, n);
  Vec c(n);
  for (int j = 0; j < n; ++j) c(j) = fm.filter.c[static_cast<std::size_t>(j)];
  const Vec ca2 = (c.transpose() * a * a).transpose();
  fm.c_a2.assign(ca2.data(), ca2.data() + n);
  fm.start = o.filter_start.empty() ? std::vector<double>(static_cast<std::size_t>(n), 0.0) : o.filter_start;
  fm.static_drift = o.resolved_static_drift();
  fm.depth = o.event_depth;
  const auto table = [&](double h) {
    for (std::size_t i = 0; i < fm.tables.size(); ++i)
      if (fm.tables[i].step == h) return static_cast<int>(i);
    StepTable t;
    t.step = h;
    t.skeleton = transition(fm.filter, h);
    // (kSpreadDepth - 1 levels more than the search uses, for the widest spreads of its finest)
    t.levels = root_levels(fm.filter, std::ldexp(h, kLevelsUp), fm.depth + kLevelsUp + 1 + kSpreadDepth);
    const auto widest = [&](int level) {
      return widest_spread(t.levels, fm.filter.c, static_cast<std::size_t>(level), kSpreadDepth);
    };
    for (int d = 0; d <= fm.depth; ++d) t.spread_fine.push_back(widest(kLevelsUp + d));
    for (int g = 0; g <= kLevelsUp; ++g) t.spread_coarse.push_back(widest(kLevelsUp - g));
    t.levels.resize(static_cast<std::size_t>(fm.depth + kLevelsUp + 2));
    // The midpoint's mean a_g given the start and xi: c Phi(L/2) (z, 0, 0) + c R(L/2) Q_top xi.
    for (int d = 0; d <= fm.depth; ++d) {
      const RootLevel& whole = t.levels[static_cast<std::size_t>(kLevelsUp + d)];
      const RootLevel& half = t.levels[static_cast<std::size_t>(kLevelsUp + d + 1)];
      const int m = n + 2;
      const Mat phi = from_row_major(half.phi, m, m), root = from_row_major(half.root, m, m);
      const Mat q_top = from_row_major(whole.split, 2 * m, 2 * m).topLeftCorner(m, m);
      const Vec cz = (c.transpose() * phi.topLeftCorner(n, n)).transpose();
      const Vec cx = (c.transpose() * root.topRows(n) * q_top).transpose();
      for (int j = 0; j < n; ++j) t.mid_z.push_back(cz(j));
      for (int j = 0; j < m; ++j) t.mid_xi.push_back(cx(j));
    }
    t.skeleton.root = t.levels[kLevelsUp].root;
    fm.tables.push_back(std::move(t));
    return static_cast<int>(fm.tables.size() - 1);
  };
  for (double h : segment_steps) fm.segment_table.push_back(h > 0.0 ? table(h) : -1);
  fm.tail_step = tail_step;
  if (o.stop) {
    fm.tail_table = table(tail_step);
    fm.bound = decay_bound(fm.filter);
    fm.has_bound = true;
  }
  return model;
}

}  // namespace crandall
