// The filtered excitation's exact skeleton: transitions, the noise-space bisection tree's roots
// and splits, the ring-down's decay bound
// (filter.hpp; derivations in docs/filtered.md, "The skeleton"). Plan-time code: small dense
// algebra (matrices of at most 8 x 8, Lyapunov systems of at most 36 unknowns) written out here
// in double-double arithmetic (double_double.hpp) with a fixed order of every sum, so every CPU
// and compiler gets the same bits.
#include "crandall/filter.hpp"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cfloat>
#include <cmath>
#include <stdexcept>
#include <string>
#include <utility>

#include "crandall/double_double.hpp"
#include "crandall/plan.hpp"

namespace crandall {
namespace {

// The plan-time algebra runs in double-double (about 106 bits; double_double.hpp: built from
// correctly rounded double operations and fma only, so the same bits on every IEEE platform,
// unlike long double, whose format differs between x86-64, aarch64 and others) and is rounded to
// double at the end. The augmented state is nearly degenerate at small steps: for Kanai-Tajimi,
// G + 2 zeta omega x - (omega^2 / (2 zeta omega)) D is of relative size (omega h)^2, so Var Y(h)
// has an eigenvalue of relative size (omega h)^4 that rounding of Q's entries in double (1e-16)
// swamps below h ~ 1e-4; the factorisations need it, the stored results do not (rounding a
// square root or a gain to double changes the sampled law only at second order in the rounding).
using Real = DoubleDouble;

void require(bool ok, const std::string& message) {
  if (!ok) throw std::invalid_argument(message);
}

// A small dense row-major matrix of double-doubles. Products sum over the inner index in
// increasing order, one rounding per double-double operation: no blocking, no vectorisation,
// nothing that depends on the instruction set or on a library's version.
struct RMat {
  int rows = 0, cols = 0;
  std::vector<Real> v;
  RMat() = default;
  RMat(int r, int c) : rows(r), cols(c), v(static_cast<std::size_t>(r * c)) {}
  Real& operator()(int i, int j) { return v[static_cast<std::size_t>(i * cols + j)]; }
  const Real& operator()(int i, int j) const { return v[static_cast<std::size_t>(i * cols + j)]; }
  static RMat identity(int n) {
    RMat out(n, n);
    for (int i = 0; i < n; ++i) out(i, i) = 1.0;
    return out;
  }
};

// Every out(i, j) sums its terms in increasing k from +0. A term with a zero factor is skipped:
// it is a signed zero, and adding it to a sum that started at +0 changes no bit (the matrices
// here are sparse: Abar's structure, the tree's unit vectors).
RMat operator*(const RMat& a, const RMat& b) {
  RMat out(a.rows, b.cols);
  for (int i = 0; i < a.rows; ++i)
    for (int k = 0; k < a.cols; ++k) {
      const Real aik = a(i, k);
      if (aik.hi == 0.0) continue;
      for (int j = 0; j < b.cols; ++j)
        if (b(k, j).hi != 0.0) out(i, j) += aik * b(k, j);
    }
  return out;
}

RMat operator+(const RMat& a, const RMat& b) {
  RMat out(a.rows, a.cols);
  for (std::size_t i = 0; i < a.v.size(); ++i) out.v[i] = a.v[i] + b.v[i];
  return out;
}

RMat operator*(const RMat& a, const Real& s) {
  RMat out(a.rows, a.cols);
  for (std::size_t i = 0; i < a.v.size(); ++i) out.v[i] = a.v[i] * s;
  return out;
}

RMat transpose(const RMat& a) {
  RMat out(a.cols, a.rows);
  for (int i = 0; i < a.rows; ++i)
    for (int j = 0; j < a.cols; ++j) out(j, i) = a(i, j);
  return out;
}

RMat block(const RMat& a, int r0, int c0, int rows, int cols) {
  RMat out(rows, cols);
  for (int i = 0; i < rows; ++i)
    for (int j = 0; j < cols; ++j) out(i, j) = a(r0 + i, c0 + j);
  return out;
}

bool all_finite(const RMat& a) {
  for (const Real& x : a.v)
    if (!isfinite(x)) return false;
  return true;
}

RMat from_row_major(const std::vector<double>& v, int rows, int cols) {
  RMat out(rows, cols);
  for (std::size_t i = 0; i < out.v.size(); ++i) out.v[i] = v[i];
  return out;
}

// Rounded to nearest double.
std::vector<double> to_row_major(const RMat& a) {
  std::vector<double> out(a.v.size());
  for (std::size_t i = 0; i < a.v.size(); ++i) out[i] = static_cast<double>(a.v[i]);
  return out;
}

// The largest absolute row sum (the infinity norm).
Real norm_inf(const RMat& a) {
  Real best = 0.0;
  for (int i = 0; i < a.rows; ++i) {
    Real s = 0.0;
    for (int j = 0; j < a.cols; ++j) s += abs(a(i, j));
    best = std::max(best, s);
  }
  return best;
}

Real squared_norm(const RMat& a) {
  Real s = 0.0;
  for (const Real& x : a.v) s += x * x;
  return s;
}

// Abar = [[A, 0, 0], [c, 0, 0], [0, 1, 0]] and bbar bbar^T, bbar = (b, 0, 0).
void augmented(const LinearFilter& f, RMat& abar, RMat& noise) {
  const int n = f.n, m = n + 2;
  abar = RMat(m, m);
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) abar(i, j) = f.a[static_cast<std::size_t>(i * n + j)];
  for (int j = 0; j < n; ++j) abar(n, j) = f.c[static_cast<std::size_t>(j)];
  abar(n + 1, n) = 1.0;
  noise = RMat(m, m);
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j)
      noise(i, j) = Real(f.b[static_cast<std::size_t>(i)]) * f.b[static_cast<std::size_t>(j)];
}

// Phi(tau) and Q(tau) by their Taylor series, for ||Abar tau|| <= 1/2:
//   Phi = sum_k (Abar tau)^k / k!,
//   Q = sum_k tau^(k+1) / (k+1)! L^k(B),  L(X) = Abar X + X Abar^T,  B = bbar bbar^T
// (Q' = Abar Q + Q Abar^T + B, Q(0) = 0). Each entry of Phi and Q starts at its own power of tau
// (the variance of D is O(tau^5) where that of x' is O(tau)), and every later term of its series
// is smaller than the one before by a factor below 1/2: so each entry is accurate relative to
// itself, not only to the matrix's norm (which a Pade approximant of Van Loan's block matrix
// would give, losing the small entries at small steps). Terms are summed smallest first.
void taylor(const RMat& abar, const RMat& noise, const Real& tau, RMat& phi, RMat& q) {
  constexpr int kTerms = 30;  // (1/2)^30 / 30! = 4e-42, far below a double-double's 2^-104
  const int m = abar.rows;
  std::vector<RMat> terms;
  terms.reserve(kTerms + 1);
  RMat t = RMat::identity(m);
  terms.push_back(t);
  for (int k = 1; k <= kTerms; ++k) {
    t = (t * abar) * (tau / Real(k));
    terms.push_back(t);
  }
  phi = RMat(m, m);
  for (int k = kTerms; k >= 0; --k) phi = phi + terms[static_cast<std::size_t>(k)];
  terms.clear();
  // Every term is symmetric (B is), so L(X) = M + M^T with M = Abar X: one product a term, and
  // the sum is exactly symmetric (double-double addition is commutative).
  RMat r = noise * tau;
  terms.push_back(r);
  for (int k = 0; k < kTerms; ++k) {
    const RMat product = abar * r;
    r = (product + transpose(product)) * (tau / Real(k + 2));
    terms.push_back(r);
  }
  q = RMat(m, m);
  for (int k = kTerms; k >= 0; --k) q = q + terms[static_cast<std::size_t>(k)];
}

// Phi(h), Q(h) (Van Loan's integral): the Taylor series on h / 2^s with ||Abar h|| / 2^s <= 1/2,
// then s doublings Q(2t) = Phi(t) Q(t) Phi(t)^T + Q(t), Phi(2t) = Phi(t)^2 (the composition of
// two steps: a sum of two positive semidefinite terms, so the diagonal never cancels).
// The halvings s of phi_q's Taylor step for a length h: the fewest with ||Abar|| h / 2^s <= 1/2.
int halvings(const RMat& abar, double h) {
  const Real norm = norm_inf(abar);
  int s = 0;
  Real tau = h;
  while (norm * tau > Real(0.5) && s < 2000) tau = ldexp(Real(h), -(++s));
  return s;
}

void double_step(RMat& phi, RMat& q) {
  q = phi * q * transpose(phi) + q;
  q = (q + transpose(q)) * Real(0.5);
  phi = phi * phi;
}

void require_finite_transition(const RMat& phi, const RMat& q, double h) {
  require(all_finite(phi) && all_finite(q),
          "filter_a, filter_b, filter_c: the filter's transition over a step of " +
              std::to_string(h) + " overflows (the filter grows too fast for the horizon)");
}

void phi_q(const LinearFilter& f, double h, RMat& phi, RMat& q) {
  require(std::isfinite(h) && h > 0.0, "filter transition: the step must be finite and > 0");
  RMat abar, noise;
  augmented(f, abar, noise);
  const int s = halvings(abar, h);
  taylor(abar, noise, ldexp(Real(h), -s), phi, q);
  for (int i = 0; i < s; ++i) double_step(phi, q);
  require_finite_transition(phi, q, h);
}

// Phi(longest / 2^i) for i < count, bitwise phi_q's for each length: a length that phi_q halves
// s > 0 times is the next shorter length's Taylor step (halved s - 1 times) and doublings, so it
// is one doubling of that length's (Phi, Q); only the lengths with s = 0 need their own series.
std::vector<RMat> phi_ladder(const LinearFilter& f, double longest, int count) {
  RMat abar, noise;
  augmented(f, abar, noise);
  std::vector<RMat> phis(static_cast<std::size_t>(count));
  RMat phi, q;
  for (int i = count - 1; i >= 0; --i) {
    const double h = std::ldexp(longest, -i);
    if (i + 1 < count && halvings(abar, h) > 0) {
      double_step(phi, q);
      require_finite_transition(phi, q, h);
    } else {
      phi_q(f, h, phi, q);
    }
    phis[static_cast<std::size_t>(i)] = phi;
  }
  return phis;
}

// A square root of a positive semidefinite matrix q (q = R R^T), robust to its ill
// conditioning: the components' variances span many powers of the step (O(h) for x' to O(h^5)
// for D), so q is scaled to its correlation matrix first (diag(q)^(-1/2) q diag(q)^(-1/2),
// entries O(1), unit diagonal), factored by LDL^T with diagonal pivoting (at each step the
// largest remaining pivot of the Schur complement; a pivot that rounds to <= 0 is taken as 0),
// and scaled back: R = diag(q)^(1/2) P^T L D^(1/2). A component without variance gets a zero row.
RMat psd_root(const RMat& q) {
  const int m = q.rows;
  std::vector<Real> d(static_cast<std::size_t>(m));
  for (int i = 0; i < m; ++i) d[static_cast<std::size_t>(i)] = q(i, i) > Real(0.0) ? sqrt(q(i, i)) : Real(0.0);
  RMat a(m, m);
  for (int i = 0; i < m; ++i)
    for (int j = 0; j < m; ++j) {
      const Real di = d[static_cast<std::size_t>(i)], dj = d[static_cast<std::size_t>(j)];
      a(i, j) = i == j ? Real(1.0) : (di > Real(0.0) && dj > Real(0.0) ? q(i, j) / (di * dj) : Real(0.0));
    }
  std::vector<int> perm(static_cast<std::size_t>(m));
  for (int i = 0; i < m; ++i) perm[static_cast<std::size_t>(i)] = i;
  RMat l(m, m);
  std::vector<Real> pivots(static_cast<std::size_t>(m));
  for (int k = 0; k < m; ++k) {
    int p = k;
    for (int i = k + 1; i < m; ++i)
      if (a(i, i) > a(p, p)) p = i;
    if (p != k) {
      std::swap(perm[static_cast<std::size_t>(k)], perm[static_cast<std::size_t>(p)]);
      for (int j = 0; j < m; ++j) std::swap(a(k, j), a(p, j));
      for (int i = 0; i < m; ++i) std::swap(a(i, k), a(i, p));
      for (int j = 0; j < k; ++j) std::swap(l(k, j), l(p, j));
    }
    const Real pivot = a(k, k);
    pivots[static_cast<std::size_t>(k)] = pivot > Real(0.0) ? sqrt(pivot) : Real(0.0);
    l(k, k) = 1.0;
    for (int i = k + 1; i < m; ++i) l(i, k) = pivot > Real(0.0) ? a(i, k) / pivot : Real(0.0);
    for (int i = k + 1; i < m; ++i)
      for (int j = k + 1; j <= i; ++j) {
        a(i, j) -= l(i, k) * a(k, j);
        a(j, i) = a(i, j);
      }
  }
  RMat root(m, m);
  for (int i = 0; i < m; ++i) {
    const int row = perm[static_cast<std::size_t>(i)];
    for (int j = 0; j < m; ++j)
      root(row, j) = d[static_cast<std::size_t>(row)] * (l(i, j) * pivots[static_cast<std::size_t>(j)]);
  }
  return root;
}

// The Householder QR a = U [T; 0] of a (rows >= cols), LAPACK's and Eigen's convention: the
// reflector of column k is I - tau v v^T with v = (1, essential), T's diagonal beta = -sign(a_kk)
// times the column's norm (beta = a_kk, tau = 0, when the column has nothing below the
// diagonal). Returns T (cols x cols, upper triangular) and, if asked, U (rows x rows,
// orthogonal), accumulated from the last reflector to the first.
RMat householder_qr(RMat a, RMat* u) {
  const int rows = a.rows, cols = a.cols;
  std::vector<Real> taus(static_cast<std::size_t>(cols));
  for (int k = 0; k < cols; ++k) {
    const Real c0 = a(k, k);
    Real tail = 0.0;
    for (int i = k + 1; i < rows; ++i) tail += a(i, k) * a(i, k);
    Real tau = 0.0, beta = c0;
    if (tail.hi > DBL_MIN) {
      beta = sqrt(c0 * c0 + tail);
      if (c0.hi >= 0.0) beta = -beta;
      const Real denominator = c0 - beta;
      for (int i = k + 1; i < rows; ++i) a(i, k) = a(i, k) / denominator;
      tau = (beta - c0) / beta;
    } else {
      for (int i = k + 1; i < rows; ++i) a(i, k) = 0.0;
    }
    a(k, k) = beta;
    taus[static_cast<std::size_t>(k)] = tau;
    for (int j = k + 1; j < cols; ++j) {
      Real w = a(k, j);
      for (int i = k + 1; i < rows; ++i) w += a(i, k) * a(i, j);
      w = w * tau;
      a(k, j) -= w;
      for (int i = k + 1; i < rows; ++i) a(i, j) -= a(i, k) * w;
    }
  }
  if (u != nullptr) {
    *u = RMat::identity(rows);
    for (int k = cols - 1; k >= 0; --k) {
      const Real tau = taus[static_cast<std::size_t>(k)];
      for (int j = 0; j < rows; ++j) {
        Real w = (*u)(k, j);
        for (int i = k + 1; i < rows; ++i) w += a(i, k) * (*u)(i, j);
        w = w * tau;
        (*u)(k, j) -= w;
        for (int i = k + 1; i < rows; ++i) (*u)(i, j) -= a(i, k) * w;
      }
    }
  }
  RMat t(cols, cols);
  for (int i = 0; i < cols; ++i)
    for (int j = i; j < cols; ++j) t(i, j) = a(i, j);
  return t;
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
  t.phi = to_row_major(phi);
  t.q = to_row_major(q);
  t.root = to_row_major(psd_root(q));
  return t;
}

namespace {

// cos x for |x| <= 4 by its Taylor series (double-double; no libm function, so the same bits
// everywhere): only the Newton starts below use it.
Real cos_series(const Real& x) {
  const Real x2 = x * x;
  Real term = 1.0, sum = 1.0;
  for (int j = 1; j <= 40; ++j) {
    term = -(term * x2) / Real(static_cast<double>((2 * j - 1) * (2 * j)));
    sum += term;
  }
  return sum;
}

// The k Gauss-Legendre nodes and weights on [-1, 1]: Newton on P_k from Chebyshev-like starts
// (double-double; k <= 12 here).
void gauss_legendre(int k, std::vector<Real>& nodes, std::vector<Real>& weights) {
  nodes.assign(static_cast<std::size_t>(k), Real(0.0));
  weights.assign(static_cast<std::size_t>(k), Real(0.0));
  const Real pi(3.141592653589793116, 1.2246467991473532e-16);
  const auto legendre = [k](const Real& x, Real& p1, Real& p0) {
    p0 = 1.0;
    p1 = x;
    for (int j = 2; j <= k; ++j) {
      const Real p2 = (x * p1 * static_cast<double>(2 * j - 1) - p0 * static_cast<double>(j - 1)) /
                      Real(static_cast<double>(j));
      p0 = p1;
      p1 = p2;
    }
  };
  for (int i = 0; i < k; ++i) {
    Real x = cos_series(pi * (Real(i) + Real(0.75)) / (Real(k) + Real(0.5)));
    Real p1, p0, dp;
    for (int it = 0; it < 100; ++it) {
      legendre(x, p1, p0);
      dp = (x * p1 - p0) * static_cast<double>(k) / (x * x - Real(1.0));
      const Real dx = p1 / dp;
      x -= dx;
      if (abs(dx) <= Real(1e-30)) break;
    }
    legendre(x, p1, p0);
    dp = (x * p1 - p0) * static_cast<double>(k) / (x * x - Real(1.0));
    nodes[static_cast<std::size_t>(i)] = x;
    weights[static_cast<std::size_t>(i)] = Real(2.0) / ((Real(1.0) - x * x) * dp * dp);
  }
}

// The thin-to-full composition of two consecutive intervals of length t: with W = [Phi(t) R(t),
// R(t)] (m x 2m, W W^T = Q(2t)), the Householder QR W^T = U T; returns R(2t) = T^T (its top m
// rows) and, if asked, U (2m x 2m orthogonal). Householder QR is backward stable column by
// column (each column of W^T, a component of Y, keeps its own scale), and nothing is inverted:
// a rank-deficient W (Clough-Penzien) just gives zeros on T's diagonal.
RMat compose_roots(const RMat& phi_half, const RMat& root_half, RMat* split) {
  const int m = root_half.rows;
  const RMat top = transpose(phi_half * root_half), bottom = transpose(root_half);
  RMat wt(2 * m, m);
  for (int i = 0; i < m; ++i)
    for (int j = 0; j < m; ++j) {
      wt(i, j) = top(i, j);
      wt(m + i, j) = bottom(i, j);
    }
  return transpose(householder_qr(wt, split));
}

// exp(Abar s) bbar by its Taylor series (||Abar s|| <= 1/2: every component accurate relative
// to itself, as in taylor above).
RMat flow_of_noise(const RMat& abar, const RMat& bbar, const Real& s) {
  constexpr int kTerms = 30;
  std::vector<RMat> terms;
  RMat t = bbar;
  terms.push_back(t);
  for (int k = 1; k <= kTerms; ++k) {
    t = (abar * t) * (s / Real(k));
    terms.push_back(t);
  }
  RMat out(bbar.rows, 1);
  for (int k = kTerms; k >= 0; --k) out = out + terms[static_cast<std::size_t>(k)];
  return out;
}

// The quadrature root at a length with ||Abar length|| <= 1/2 (the Gauss-Legendre rule on k
// nodes is exact for polynomials of degree 2k - 1; the integrand is entire, so its error is
// about (||Abar|| length)^(2k) / (2k)! relative to each entry).
RMat quadrature_root_short(const RMat& abar, const RMat& bbar, const Real& length) {
  const int m = abar.rows;
  const int k = m + 4;
  std::vector<Real> x, w;
  gauss_legendre(k, x, w);
  RMat cols(k, m);  // the transpose of [exp(Abar s_j) bbar sqrt(w_j)]
  for (int j = 0; j < k; ++j) {
    const Real s = length * Real(0.5) * (Real(1.0) + x[static_cast<std::size_t>(j)]);
    const RMat flow = flow_of_noise(abar, bbar, s);
    const Real scale = sqrt(length * Real(0.5) * w[static_cast<std::size_t>(j)]);
    for (int i = 0; i < m; ++i) cols(j, i) = flow(i, 0) * scale;
  }
  return transpose(householder_qr(cols, nullptr));
}

RMat quadrature_root_long(const LinearFilter& f, double length) {
  require(std::isfinite(length) && length > 0.0, "filter root: the length must be finite and > 0");
  RMat abar, noise;
  augmented(f, abar, noise);
  const int m = abar.rows;
  RMat bbar(m, 1);
  for (int j = 0; j < f.n; ++j) bbar(j, 0) = f.b[static_cast<std::size_t>(j)];
  const Real norm = norm_inf(abar);
  int s = 0;
  Real tau = length;
  while (norm * tau > Real(0.5) && s < 2000) tau = ldexp(Real(length), -(++s));
  RMat root = quadrature_root_short(abar, bbar, tau);
  for (int i = s; i > 0; --i) {
    RMat phi, q;
    phi_q(f, std::ldexp(length, -i), phi, q);
    root = compose_roots(phi, root, nullptr);
  }
  return root;
}

// The noise tree's roots are unique only up to their columns' signs, and Householder's
// convention (T's diagonal opposite in sign to the column it reduces) flips every level's signs
// with each composition, so the sign of every level depended on how many compositions lie below
// it: on the event depth's parity (and on how often the deepest quadrature root was halved). A
// depth of the other parity then walked the mirror image of the path (-V and -U, the same
// distance and stop time). Negating every root keeps every identity of the tree
// ([Phi R_(d+1), R_(d+1)] U_d = [R_d, 0] holds for -R with the same U_d, and -R (-R)^T = Q), so
// the roots are negated when the longest level's first nonzero diagonal entry is positive: every
// depth then builds the same roots up to rounding, and the same seed walks the same path.
// (Negative is the sign the default depth had, so its paths keep their bits.) Zero entries stay
// +0.
void canonical_signs(std::vector<RMat>& roots) {
  const RMat& top = roots.front();
  for (int k = 0; k < top.rows && k < top.cols; ++k) {
    if (top(k, k).hi == 0.0) continue;
    if (top(k, k).hi < 0.0) return;
    for (RMat& r : roots)
      for (Real& x : r.v)
        if (x.hi != 0.0) x = -x;
    return;
  }
}

}  // namespace

std::vector<double> quadrature_root(const LinearFilter& f, double length) {
  return to_row_major(quadrature_root_long(f, length));
}

std::vector<RootLevel> root_levels(const LinearFilter& f, double longest, int count) {
  require(count >= 1, "filter root levels: count must be >= 1");
  const int n = f.n, m = n + 2;
  require(std::isfinite(longest) && longest > 0.0, "filter transition: the step must be finite and > 0");
  const std::vector<RMat> phis = phi_ladder(f, longest, count);
  std::vector<RMat> roots(static_cast<std::size_t>(count)), splits(static_cast<std::size_t>(count));
  roots[static_cast<std::size_t>(count - 1)] = quadrature_root_long(f, std::ldexp(longest, -(count - 1)));
  for (int i = count - 2; i >= 0; --i)
    roots[static_cast<std::size_t>(i)] = compose_roots(phis[static_cast<std::size_t>(i + 1)],
                                                       roots[static_cast<std::size_t>(i + 1)],
                                                       &splits[static_cast<std::size_t>(i)]);
  canonical_signs(roots);
  RMat c(m, 1);
  for (int j = 0; j < n; ++j) c(j, 0) = f.c[static_cast<std::size_t>(j)];
  std::vector<RootLevel> out(static_cast<std::size_t>(count));
  for (int i = 0; i < count; ++i) {
    RootLevel& level = out[static_cast<std::size_t>(i)];
    const auto u = static_cast<std::size_t>(i);
    level.length = std::ldexp(longest, -i);
    level.phi = to_row_major(phis[u]);
    level.root = to_row_major(roots[u]);
    require(all_finite(phis[u]) && all_finite(roots[u]),
            "filter_a, filter_b, filter_c: the filter's noise roots over an interval of " +
                std::to_string(level.length) + " are not finite");
    if (i + 1 < count) {
      level.split = to_row_major(splits[u]);
      const RMat null_top = block(splits[u], 0, m, m, m);
      level.spread = static_cast<double>(sqrt(squared_norm(transpose(null_top) * (transpose(roots[u + 1]) * c))));
    }
  }
  return out;
}

namespace {

// widest_spread's recursion: zs (n x E) and xi (m x E) are the start state's and the noise
// coordinates' coefficients on the E normals of the nodes below the interval (its own xi and
// start are given: they carry no variance); widest is the largest squared spread.
void widest_below(const std::vector<RootLevel>& levels, const RMat& c_row, std::size_t level, int sub,
                  const RMat& zs, const RMat& xi, int& node, Real& widest) {
  if (sub == 0 || level + 1 >= levels.size() || levels[level].split.empty()) return;
  const int n = c_row.cols, m = xi.rows, e = xi.cols;
  const RMat split = from_row_major(levels[level].split, 2 * m, 2 * m);
  const RMat phi = from_row_major(levels[level + 1].phi, m, m);
  const RMat root = from_row_major(levels[level + 1].root, m, m);
  RMat eta(m, e);
  for (int i = 0; i < m; ++i) eta(i, node * m + i) = 1.0;
  ++node;
  const RMat left = block(split, 0, 0, m, m) * xi + block(split, 0, m, m, m) * eta;
  const RMat right = block(split, m, 0, m, m) * xi + block(split, m, m, m, m) * eta;
  const RMat mid = block(phi, 0, 0, n, n) * zs + block(root, 0, 0, n, m) * left;
  widest = std::max(widest, squared_norm(c_row * mid));
  widest_below(levels, c_row, level + 1, sub - 1, zs, left, node, widest);
  widest_below(levels, c_row, level + 1, sub - 1, mid, right, node, widest);
}

// The conditional law of a_g at the points below an interval, given its start z and its xi:
// zs (n x (n + m + E)) and xi (m x (n + m + E)) are the interval's start state's and noise
// coordinates' coefficients on (z_start; sigma xi; the E = m (2^sub - 1) normals eta of the
// nodes below, `node` the next unused node); out[j] receives c times the coefficients of the
// point j / 2^sub of the interval of points [lo, hi] (out's indices): its first n + m entries
// the mean's rows, the rest the spread's (unit intensity).
void points_below(const std::vector<RootLevel>& levels, const RMat& c_row, std::size_t level,
                  int sub, const RMat& zs, const RMat& xi, int lo, int hi, int& node,
                  std::vector<RMat>& out) {
  if (sub == 0) return;
  const int n = c_row.cols, m = xi.rows, e = xi.cols;
  const RMat split = from_row_major(levels[level].split, 2 * m, 2 * m);
  const RMat phi = from_row_major(levels[level + 1].phi, m, m);
  const RMat root = from_row_major(levels[level + 1].root, m, m);
  RMat eta(m, e);
  for (int i = 0; i < m; ++i) eta(i, n + m + node * m + i) = 1.0;
  ++node;
  const RMat left = block(split, 0, 0, m, m) * xi + block(split, 0, m, m, m) * eta;
  const RMat right = block(split, m, 0, m, m) * xi + block(split, m, m, m, m) * eta;
  const RMat mid = block(phi, 0, 0, n, n) * zs + block(root, 0, 0, n, m) * left;
  const int at = (lo + hi) / 2;
  out[static_cast<std::size_t>(at)] = c_row * mid;
  points_below(levels, c_row, level + 1, sub - 1, zs, left, lo, at, node, out);
  points_below(levels, c_row, level + 1, sub - 1, mid, right, at, hi, node, out);
}

}  // namespace

double widest_spread(const std::vector<RootLevel>& levels, const std::vector<double>& c,
                     std::size_t level, int sub) {
  const int n = static_cast<int>(c.size()), m = n + 2;
  const RMat c_row = from_row_major(c, 1, n);
  const int e = m * ((1 << sub) - 1);
  int node = 0;
  Real widest = 0.0;
  widest_below(levels, c_row, level, sub, RMat(n, e), RMat(m, e), node, widest);
  return static_cast<double>(sqrt(widest));
}

namespace {

// Solves A X + X A^T = -rhs by the Kronecker form (I (x) A + A (x) I) vec X = -vec rhs, Gaussian
// elimination with full pivoting; false when the system is singular (a pivot at or below
// n^2 2^-52 times the largest, the rank test of Eigen's FullPivLU in double).
bool lyapunov_solve(const RMat& a, const RMat& rhs, RMat& x) {
  const int n = a.rows, nn = n * n;
  RMat k(nn, nn), v(nn, 1);
  // Column-major vec: index i + j n. (A X)_ij = sum_k A_ik X_kj; (X A^T)_ij = sum_k X_ik A_jk.
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) {
      const int row = i + j * n;
      for (int q = 0; q < n; ++q) {
        k(row, q + j * n) += a(i, q);
        k(row, i + q * n) += a(j, q);
      }
      v(row, 0) = -rhs(i, j);
    }
  std::vector<int> col_of(static_cast<std::size_t>(nn));
  for (int i = 0; i < nn; ++i) col_of[static_cast<std::size_t>(i)] = i;
  Real first = 0.0;
  for (int s = 0; s < nn; ++s) {
    int pr = s, pc = s;
    for (int i = s; i < nn; ++i)
      for (int j = s; j < nn; ++j)
        if (abs(k(i, j)) > abs(k(pr, pc))) {
          pr = i;
          pc = j;
        }
    if (s == 0) first = abs(k(pr, pc));
    if (!(abs(k(pr, pc)) > first * (static_cast<double>(nn) * DBL_EPSILON))) return false;
    for (int j = 0; j < nn; ++j) std::swap(k(s, j), k(pr, j));
    std::swap(v(s, 0), v(pr, 0));
    for (int i = 0; i < nn; ++i) std::swap(k(i, s), k(i, pc));
    std::swap(col_of[static_cast<std::size_t>(s)], col_of[static_cast<std::size_t>(pc)]);
    for (int i = s + 1; i < nn; ++i) {
      const Real factor = k(i, s) / k(s, s);
      for (int j = s + 1; j < nn; ++j) k(i, j) -= factor * k(s, j);
      v(i, 0) -= factor * v(s, 0);
    }
  }
  RMat y(nn, 1);
  for (int s = nn - 1; s >= 0; --s) {
    Real sum = v(s, 0);
    for (int j = s + 1; j < nn; ++j) sum -= k(s, j) * y(j, 0);
    y(s, 0) = sum / k(s, s);
  }
  x = RMat(n, n);
  for (int s = 0; s < nn; ++s) {
    const int index = col_of[static_cast<std::size_t>(s)];
    x(index % n, index / n) = y(s, 0);
  }
  return true;
}

// The eigenvalues of a symmetric matrix by cyclic Jacobi rotations (double-double; n <= 6).
// Converged when the upper triangle, which the rotations are chosen from, is negligible: the
// lower one's rounding residue (the rows' and columns' updates round apart) can stay near
// 1e-32 of the diagonal, and rotating on regardless drove the angles' tangents past the
// double-double split's range, to NaN (a Clough-Penzien filter whose damping 3.6 came as
// 3.5999999999999996 was refused as not definite).
std::vector<Real> symmetric_eigenvalues(RMat a) {
  const int n = a.rows;
  for (int sweep = 0; sweep < 60; ++sweep) {
    Real off = 0.0, diag = 0.0;
    for (int i = 0; i < n; ++i) {
      diag += a(i, i) * a(i, i);
      for (int j = i + 1; j < n; ++j) off += a(i, j) * a(i, j);
    }
    if (!(off * 2.0 > diag * Real(1e-64))) break;
    for (int p = 0; p < n; ++p)
      for (int q = p + 1; q < n; ++q) {
        if (a(p, q).hi == 0.0) continue;
        const Real theta = (a(q, q) - a(p, p)) / (a(p, q) * 2.0);
        Real t = abs(theta) > Real(1e100) ? Real(0.5) / theta
                                          : Real(1.0) / (abs(theta) + sqrt(theta * theta + Real(1.0)));
        if (theta < Real(0.0) && !(abs(theta) > Real(1e100))) t = -t;
        const Real cs = Real(1.0) / sqrt(t * t + Real(1.0)), sn = t * cs;
        for (int k = 0; k < n; ++k) {  // columns p, q
          const Real akp = a(k, p), akq = a(k, q);
          a(k, p) = cs * akp - sn * akq;
          a(k, q) = sn * akp + cs * akq;
        }
        for (int k = 0; k < n; ++k) {  // rows p, q
          const Real apk = a(p, k), aqk = a(q, k);
          a(p, k) = cs * apk - sn * aqk;
          a(q, k) = sn * apk + cs * aqk;
        }
      }
  }
  std::vector<Real> out(static_cast<std::size_t>(n));
  for (int i = 0; i < n; ++i) out[static_cast<std::size_t>(i)] = a(i, i);
  return out;
}

}  // namespace

std::vector<double> lyapunov(const std::vector<double>& a, int n, const std::vector<double>& rhs) {
  RMat x;
  require(lyapunov_solve(from_row_major(a, n, n), from_row_major(rhs, n, n), x),
          "filter_a: the Lyapunov equation A X + X A^T = -B has no unique solution (A has "
          "eigenvalues lambda_i + lambda_j = 0)");
  return to_row_major(x);
}

bool hurwitz(const std::vector<double>& a, int n) {
  Eigen::MatrixXd am(n, n);
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) am(i, j) = a[static_cast<std::size_t>(i * n + j)];
  Eigen::EigenSolver<Eigen::MatrixXd> es(am, false);
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
  const RMat at = transpose(from_row_major(f.a, n, n));
  RMat p;
  require(lyapunov_solve(at, RMat::identity(n), p),
          "filter_a: the Lyapunov equation A X + X A^T = -B has no unique solution (A has "
          "eigenvalues lambda_i + lambda_j = 0)");
  p = (p + transpose(p)) * Real(0.5);
  const std::vector<Real> eig = symmetric_eigenvalues(p);
  const Real smallest = *std::min_element(eig.begin(), eig.end());
  const Real largest = *std::max_element(eig.begin(), eig.end());
  // c^T P^-1 c by Cholesky (P positive definite): P = L L^T, |L^-1 c|^2.
  RMat l(n, n), y(n, 1);
  bool definite = smallest > Real(0.0);
  for (int j = 0; j < n && definite; ++j) {
    Real d = p(j, j);
    for (int k = 0; k < j; ++k) d -= l(j, k) * l(j, k);
    definite = d > Real(0.0);
    if (!definite) break;
    l(j, j) = sqrt(d);
    for (int i = j + 1; i < n; ++i) {
      Real s = p(i, j);
      for (int k = 0; k < j; ++k) s -= l(i, k) * l(j, k);
      l(i, j) = s / l(j, j);
    }
  }
  require(definite, "filter_a: the Lyapunov matrix of the ring-down is not positive definite");
  for (int i = 0; i < n; ++i) {
    Real s = f.c[static_cast<std::size_t>(i)];
    for (int k = 0; k < i; ++k) s -= l(i, k) * y(k, 0);
    y(i, 0) = s / l(i, i);
  }
  DecayBound d;
  d.p = to_row_major(p);
  d.gain = static_cast<double>(sqrt(squared_norm(y)));
  d.rate = static_cast<double>(Real(0.5) / largest);
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


static_assert(kRestPoints == 7, "the points j / 8: three levels below an interval");
static_assert(kGrazeDepth == kMaxEventDepth, "the touches' search reaches the node numbering's limit");

namespace {

// The table of step length h with the noise tree down to the event search's depth `depth`.
StepTable step_table(const FilterModel& fm, double h, int depth) {
  const int n = fm.filter.n;
  const RMat c = from_row_major(fm.filter.c, 1, n);
  StepTable t;
  t.step = h;
  t.skeleton = transition(fm.filter, h);
  // (kSpreadDepth - 1 levels more than the search uses, for the widest spreads of its finest)
  t.levels = root_levels(fm.filter, std::ldexp(h, kLevelsUp), depth + kLevelsUp + 1 + kSpreadDepth);
  const auto widest = [&](int level) {
    return widest_spread(t.levels, fm.filter.c, static_cast<std::size_t>(level), kSpreadDepth);
  };
  for (int d = 0; d <= depth; ++d) t.spread_fine.push_back(widest(kLevelsUp + d));
  for (int g = 0; g <= kLevelsUp; ++g) t.spread_coarse.push_back(widest(kLevelsUp - g));
  t.levels.resize(static_cast<std::size_t>(depth + kLevelsUp + 2));
  // The midpoint's mean a_g given the start and xi: c Phi(L/2) (z, 0, 0) + c R(L/2) Q_top xi.
  for (int d = 0; d <= depth; ++d) {
    const RootLevel& whole = t.levels[static_cast<std::size_t>(kLevelsUp + d)];
    const RootLevel& half = t.levels[static_cast<std::size_t>(kLevelsUp + d + 1)];
    const int m = n + 2;
    const RMat phi = from_row_major(half.phi, m, m), root = from_row_major(half.root, m, m);
    const RMat q_top = block(from_row_major(whole.split, 2 * m, 2 * m), 0, 0, m, m);
    const std::vector<double> cz = to_row_major(c * block(phi, 0, 0, n, n));
    const std::vector<double> cx = to_row_major(c * block(root, 0, 0, n, m) * q_top);
    t.mid_z.insert(t.mid_z.end(), cz.begin(), cz.end());
    t.mid_xi.insert(t.mid_xi.end(), cx.begin(), cx.end());
  }
  // The onset test's points j / 8 and its segments' spreads (the widest of each segment's ends
  // and middle, the points j / 16), from a tree one level deeper than the table's (only these
  // rows come from it: the same roots up to rounding).
  const std::vector<RootLevel> deeper =
      root_levels(fm.filter, std::ldexp(h, kLevelsUp), depth + kLevelsUp + 2 + kSpreadDepth);
  constexpr int kSub = 4, kPoints = 1 << kSub;
  for (int d = 0; d <= depth; ++d) {
    const int m = n + 2, e = n + m + m * (kPoints - 1);
    RMat zs(n, e), xi(m, e);
    for (int i = 0; i < n; ++i) zs(i, i) = 1.0;
    for (int i = 0; i < m; ++i) xi(i, n + i) = 1.0;
    std::vector<RMat> rows(static_cast<std::size_t>(kPoints + 1));
    int node = 0;
    points_below(deeper, c, static_cast<std::size_t>(kLevelsUp + d), kSub, zs, xi, 0, kPoints,
                 node, rows);
    std::vector<double> spread(static_cast<std::size_t>(kPoints + 1), 0.0);
    for (int j = 1; j < kPoints; ++j) {
      const RMat& r = rows[static_cast<std::size_t>(j)];
      Real sum = 0.0;
      for (int k = n + m; k < e; ++k) sum += r(0, k) * r(0, k);
      spread[static_cast<std::size_t>(j)] = static_cast<double>(sqrt(sum));
    }
    for (int j = 1; j <= kRestPoints; ++j) {
      const RMat& r = rows[static_cast<std::size_t>(2 * j)];
      for (int k = 0; k < n; ++k) t.pts_z.push_back(static_cast<double>(r(0, k)));
      for (int k = n; k < n + m; ++k) t.pts_xi.push_back(static_cast<double>(r(0, k)));
    }
    for (int j = 0; j <= kRestPoints; ++j)
      t.seg_spread.push_back(std::max({spread[static_cast<std::size_t>(2 * j)],
                                       spread[static_cast<std::size_t>(2 * j + 1)],
                                       spread[static_cast<std::size_t>(2 * j + 2)]}));
  }
  t.skeleton.root = t.levels[kLevelsUp].root;
  return t;
}

}  // namespace

std::shared_ptr<const FilterModel> make_filter_model(const Options& o,
                                                     const std::vector<double>& segment_steps,
                                                     double tail_step) {
  auto model = std::make_shared<FilterModel>();
  FilterModel& fm = *model;
  fm.filter = options_filter(o);
  const int n = fm.filter.n;
  fm.m = n + 2;
  const RMat a = from_row_major(fm.filter.a, n, n);
  const RMat c = from_row_major(fm.filter.c, 1, n);
  fm.c_a2 = to_row_major(c * a * a);
  fm.start = o.filter_start.empty() ? std::vector<double>(static_cast<std::size_t>(n), 0.0) : o.filter_start;
  fm.static_drift = o.resolved_static_drift();
  fm.depth = o.event_depth;
  const auto table = [&](double h) {
    for (std::size_t i = 0; i < fm.tables.size(); ++i)
      if (fm.tables[i].step == h) return static_cast<int>(i);
    fm.tables.push_back(step_table(fm, h, fm.depth));
    if (o.stop) fm.deep_tables.push_back(step_table(fm, h, kGrazeDepth));
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
