// The filtered excitation's exact Gaussian skeleton (docs/filtered.md, "The skeleton").
//
// The ground acceleration is a_g(t) = c . z(t), z the state of a linear filter driven by white
// noise: dz = A z dt + b sigma(t) dW, with sigma(t) the plan's piecewise-constant intensity (0
// after the switch-off, when the filter rings down deterministically). Kanai-Tajimi and
// Clough-Penzien are two such filters (kanai_tajimi, clough_penzien).
//
// Over a step the body needs, besides the filter's state at both ends, the ground velocity
// change G = int a_g and its integral D = int G, both from the start of the step. So the filter
// is augmented to Y = (z, G, D) (dimension m = n + 2), dY = Abar Y dt + bbar sigma dW with
//   Abar = [[A, 0, 0], [c, 0, 0], [0, 1, 0]],  bbar = (b, 0, 0),
// a linear SDE whose transition over a step h is exactly Gaussian:
//   Y(h) = Phi(h) Y(0) + sigma L(h) xi,  xi ~ N(0, I_m),  Phi = exp(Abar h),
//   Q(h) = L L^T = int_0^h exp(Abar s) bbar bbar^T exp(Abar^T s) ds.
// The event search bisects steps by carrying the standard normals, not the states, down a tree
// (docs/filtered.md, "Bridges in noise space"): every interval holds its noise coordinates xi in
// a square root R(L) of Q(L), and an interval's xi is split into its halves' by an orthogonal
// 2m x 2m matrix, with no inversion at run time (root_levels).
// Everything here is computed once per plan (per distinct step length), never per path.
#pragma once

#include <cstdint>
#include <memory>
#include <vector>

namespace crandall {

class Plan;
struct Options;

// The largest filter dimension n (the augmented state has n + 2 <= kMaxAugmented components).
constexpr int kMaxFilter = 6;
constexpr int kMaxAugmented = kMaxFilter + 2;

// A linear filter: dz = A z dt + b dW, a_g = c . z. a is n x n row-major.
struct LinearFilter {
  int n = 0;
  std::vector<double> a, b, c;
};

// Kanai-Tajimi: z = (x, x'), x'' + 2 zeta omega x' + omega^2 x = -w (white noise),
// a_g = -(omega^2 x + 2 zeta omega x'), the absolute acceleration of the soil column.
LinearFilter kanai_tajimi(double omega, double zeta);
// Clough-Penzien: Kanai-Tajimi's acceleration through a second (high-pass) oscillator,
// y'' + 2 zeta_f omega_f y' + omega_f^2 y = a_KT, a_g = y''; z = (x, x', y, y').
LinearFilter clough_penzien(double omega, double zeta, double omega_f, double zeta_f);

// Row-major m x m matrices, m = filter.n + 2 (the augmented state (z, G, D)).
struct Transition {
  double step = 0.0;
  std::vector<double> phi;   // Phi(step)
  std::vector<double> q;     // Q(step), unit intensity
  std::vector<double> root;  // a square root of q: q = root root^T
};

// Phi(h) and Q(h) of the augmented system (unit intensity), and a square root of Q. Throws
// std::invalid_argument for h not finite and > 0 or a filter whose numbers are not finite.
Transition transition(const LinearFilter& f, double h);

// The noise-space bisection tree (docs/filtered.md, "Bridges in noise space"). levels[i] is an
// interval of length L_i = longest / 2^i (i = 0 .. count - 1), built from the deepest level up:
//   R_{count-1}: from a Gauss-Legendre quadrature of Q's integral (quadrature_root);
//   i < count - 1: the Householder QR [Phi(L_{i+1}) R_{i+1}, R_{i+1}]^T = U T (U 2m x 2m
//     orthogonal, T m x m upper triangular in its top rows), R_i = T^T, split = U.
// So Q(L_i) = R_i R_i^T, and for an interval of level i with noise coordinates xi (Y_end =
// Phi(L_i) Y_start + sigma R_i xi) and eta ~ N(0, I_m) independent of it, its halves' noise
// coordinates (xi_left; xi_right) = split (xi; eta) are iid N(0, I_m) and
//   Phi(L_{i+1}) R_{i+1} xi_left + R_{i+1} xi_right = R_i xi
// (the first m columns of split are U's thin factor: (xi; 0) -> the part fixed by xi). The
// midpoint is then Y_mid = Phi(L_{i+1}) Y_start + sigma R_{i+1} xi_left, forward only.
struct RootLevel {
  double length = 0.0;
  std::vector<double> phi;    // Phi(length), m x m row-major
  std::vector<double> root;   // R(length), m x m row-major (lower triangular), Q = R R^T
  std::vector<double> split;  // 2m x 2m row-major orthogonal; empty at the deepest level
  // The standard deviation of a_g at the midpoint given the interval's start and its xi (unit
  // intensity): |N_top^T R_{i+1}^T c|, N_top = split's top-right m x m block. 0 at the deepest.
  double spread = 0.0;
};
std::vector<RootLevel> root_levels(const LinearFilter& f, double longest, int count);

// The widest a_g spread of levels[level]'s interval: the largest standard deviation of a_g
// (unit intensity, a_g = c . z) at the points j / 2^k of the interval (k = 1 .. sub, as far as
// the levels reach) given its start and its noise coordinates xi, through the tree's splits.
// At k = 1 it is RootLevel::spread; the bridge of the augmented state is pinned by G and D as
// well as by its end, so a_g's conditional deviation is smallest near the midpoint (for
// Kanai-Tajimi at small omega L the widest is about 1.4 times the midpoint's), and the event
// search's band takes the widest (docs/filtered.md, "Events").
double widest_spread(const std::vector<RootLevel>& levels, const std::vector<double>& c,
                     std::size_t level, int sub);

// A square root R (m x m, lower triangular) of Q(length) from the columns exp(Abar s_j) bbar
// sqrt(w_j) at k = m + 4 Gauss-Legendre nodes on [0, length] (for ||Abar length|| <= 1/2; a
// longer interval is halved until it is, and the roots composed back up by the QR above),
// reduced to m x m by a Householder QR of their transpose. Double-double inside
// (double_double.hpp), as everywhere in the plan-time algebra: the same bits on every CPU.
std::vector<double> quadrature_root(const LinearFilter& f, double length);

// Solves A X + X A^T = -rhs for X (n x n row-major; rhs n x n, usually symmetric) by the
// Kronecker form (I (x) A + A (x) I) vec X = -vec rhs. With A Hurwitz and rhs = b b^T, X is the
// filter's stationary covariance; with A^T in place of A and rhs = I, the Lyapunov matrix P of
// A^T P + P A = -I. Throws std::invalid_argument when the system is singular.
std::vector<double> lyapunov(const std::vector<double>& a, int n, const std::vector<double>& rhs);

// Whether every eigenvalue of the n x n matrix a has a negative real part.
bool hurwitz(const std::vector<double>& a, int n);

// The decay bound of the ring-down (no noise): with P from A^T P + P A = -I (positive definite
// for a Hurwitz A), d/dt (z^T P z) = -|z|^2 <= 0, so ||z(s)||_P <= ||z(t)||_P for s >= t, and by
// Cauchy-Schwarz in P's inner product |c . z(s)| <= sqrt(c^T P^-1 c) ||z(t)||_P.
struct DecayBound {
  std::vector<double> p;  // n x n
  double gain = 0.0;      // sqrt(c^T P^-1 c)
  double rate = 0.0;      // ||z||_P decays at least like exp(-rate t): rate = 1 / (2 lambda_max(P))
  // The bound on |a_g| from the filter state z, for every later time.
  double bound(const double* z, int n) const;
};
DecayBound decay_bound(const LinearFilter& f);

// The filter of a plan's Options (filter_a, filter_b, filter_c), unvalidated.
LinearFilter options_filter(const Options& o);
// Checks the filtered excitation's options (Options::validate calls it for excitation
// filtered); throws std::invalid_argument naming the field.
void validate_filter_options(const Options& o);

// What a filtered plan precomputes for every distinct step length h: the skeleton's transition
// (its root the tree's R(h)) and the noise-space tree over the lengths h 2^(kLevelsUp - i), i = 0
// .. event_depth + kLevelsUp + 1: the coarse grids' steps 4h and 2h (their spreads), h, and the
// event search's intervals h / 2^d down to d = event_depth + 1 (the spread of the finest
// intervals needs their split).
constexpr int kLevelsUp = 2;
// The dyadic depth over which the event search's spreads take the widest (widest_spread).
constexpr int kSpreadDepth = 3;
struct StepTable {
  double step = 0.0;
  Transition skeleton;              // phi, q by Taylor; root = levels[kLevelsUp].root
  std::vector<RootLevel> levels;    // levels[kLevelsUp + d]: an interval of length step / 2^d
  // The event search's a_g spreads (widest_spread over kSpreadDepth):
  std::vector<double> spread_fine;  // [d]: the a_g spread of an interval of length step / 2^d
  std::vector<double> spread_coarse;  // [g]: of an interval of length step 2^g (g = 0 .. 2)
  // The mean of a_g at the midpoint of an interval of length step / 2^d given its start z and
  // its xi (unit intensity): mid_z[d n ..] . z + sigma mid_xi[d m ..] . xi.
  std::vector<double> mid_z, mid_xi;
  // The same at the points j / 8 of the interval, j = 1 .. 7 (kRestPoints; j = 4 is the
  // midpoint): rows [(d 7 + j - 1) n ..] and [(d 7 + j - 1) m ..]. The test for an onset at
  // rest looks at all of them (filtered.cpp, possible_event).
  std::vector<double> pts_z, pts_xi;
  // [d (kRestPoints + 1) + j]: the widest spread of a_g (unit intensity) over the segment
  // between the points j / 8 and (j + 1) / 8 (at its ends and middle) given the start and xi.
  std::vector<double> seg_spread;
};
constexpr int kRestPoints = 7;

// The depth below a fine step (step / 2^kGrazeDepth) that the search of the last rest's missed
// touches reaches (filtered.cpp, "Touches at rest"): the deepest the node numbering allows
// (plan.hpp's kMaxEventDepth), whatever the event depth. A touch shorter than its intervals is
// still missed; what that leaves falls like the square root of their length
// (docs/filtered.md, "Events and the stop").
constexpr int kGrazeDepth = 20;

struct FilterModel {
  LinearFilter filter;
  int m = 0;                        // n + 2
  std::vector<double> c_a2;         // the row c A^2 (the curvature of a_g's mean)
  std::vector<double> start;        // z(0)
  double static_drift = 0.0;        // the resolved static friction deceleration
  int depth = 0;                    // Options::event_depth
  std::vector<StepTable> tables;
  // With the stop observed: tables[i]'s step with its tree down to graze_depth(depth), for the
  // search of the last rest's missed touches (filtered.cpp, "Touches at rest"). The same roots
  // as tables[i]'s up to rounding (canonical_signs), so a finest interval goes on in it.
  std::vector<StepTable> deep_tables;
  std::vector<int> segment_table;   // the table of each plan segment (-1: no steps)
  int tail_table = -1;              // the ring-down's steps after the plan's segments
  double tail_step = 0.0;
  bool has_bound = false;
  DecayBound bound;
  // The table of a step length (throws std::logic_error if it was not precomputed).
  int table_of(double step) const;
};

// Built by Plan for excitation filtered: segment_steps holds each plan segment's step length
// (0 for a segment without steps), tail_step the ring-down's.
std::shared_ptr<const FilterModel> make_filter_model(const Options& o,
                                                     const std::vector<double>& segment_steps,
                                                     double tail_step);

}  // namespace crandall
