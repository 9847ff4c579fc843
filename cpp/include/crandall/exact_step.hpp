// The exact-in-law step of the velocity. Derivation and numerics: docs/exact-step.md.
//
// The velocity X obeys dX = -c sign(X) dt + sigma dW (the paper's eq3 has c = 2, sigma = sqrt 2).
// |X| is the Skorokhod reflection at 0 of Y(s) = |x| + sigma B(s) - c s, and the sign of each
// excursion away from 0 is an independent fair coin. A step of any length h (`step` in the
// code; the noise intensity is sigma, Options::noise) from X = x:
//   D = -c h + sigma sqrt(h) Z                         (increment of Y)
//   m = (D - sqrt(D^2 + 2 sigma^2 h E)) / 2, E ~ Exp(1) (exact minimum of the bridge of Y - |x|)
//   |X(h)| = max(|x| + D, D - m)                       (Skorokhod map)
//   a touch of 0 (|x| + m <= 0) draws a fresh sign; otherwise the sign is kept.
// Every quantity is evaluated in a form free of cancellation for any D, h and draws. The step is
// written once: exact_step below is made of the functions the kernel's lanes call
// (step_constants, step_increment, step_spread, step_root_square, regular_step), and the kernel
// calls exact_step itself outside the regular range, so the two give the same bits
// (Kernel.LanesEqualTheScalarExactStep).
#pragma once

#include <algorithm>
#include <cmath>
#include <limits>

#include "crandall/rng.hpp"

namespace crandall {

struct StepResult {
  double velocity;  // X at the end of the step
  bool touched;     // whether X reached 0 during the step
};

// Largest c h and sigma sqrt(h) a step accepts. Every intermediate value of a step then stays
// below about 32 times it (|Z| < 7 and E < 23 for the project's draws, rng.hpp, and |x| of the
// same order), far from overflow; in scaled units this allows steps up to 5e300.
constexpr double kStepScaleLimit = 1e301;

inline bool step_in_range(double step, double drift, double noise) {
  return step >= 0.0 && drift * step <= kStepScaleLimit &&
         noise * std::sqrt(step) <= kStepScaleLimit;
}

// sigma^2 h, the variance of D. (noise * noise) * h is kept where noise^2 is a normal number
// (every realistic intensity; these bits are the kernel's); below that, noise^2 alone would lose
// precision to underflow while sigma^2 h itself may well be representable.
inline double step_variance(double noise, double step) {
  if (noise >= 0x1p-500) return noise * noise * step;
  const double s = noise * std::sqrt(step);
  return s * s;
}

// root = sqrt(D^2 + q) is a normal number far from both ends of the range: then neither D^2
// nor q overflows, and whichever of them underflows is negligible against the other (below
// 2^-170 of it), so the regular formulas below hold to a few ulps. Fails for NaN.
inline bool step_regular(double root) {
  return (root >= 0x1p-450) & (root <= std::numeric_limits<double>::max());
}

// a * b + c, rounded twice: the build compiles with -ffp-contract=off (CMakeLists.txt), so the
// compiler never fuses it, in the vectorised kernel or in the scalar step, in any instruction-set
// variant; that is what makes the kernel's lanes, exact_step and every variant give the same
// bits. (A fused form where the CPU has FMA would make the variants differ.)
inline double mul_add(double a, double b, double c) { return a * b + c; }

// The constants of every step of one length: the mean -c h and the standard deviation
// sigma sqrt(h) of the increment D, and 2 sigma^2 h (q = 2 sigma^2 h E). Computed once per
// segment by the kernel and once per step by exact_step, by this one function, so the two round
// them alike.
struct StepConstants {
  double mean;
  double scale;
  double twice_variance;
};

inline StepConstants step_constants(double step, double drift, double noise) {
  return {-drift * step, noise * std::sqrt(step), 2.0 * step_variance(noise, step)};
}

// D = sigma sqrt(h) Z - c h, and q = 2 sigma^2 h E; root = sqrt(D^2 + q) is step_root_square's
// square root (a separate step, so that the kernel takes the square roots of all its lanes at
// once).
inline double step_increment(double mean, double scale, double normal) {
  return mul_add(scale, normal, mean);
}
inline double step_spread(double twice_variance, double exponential) {
  return twice_variance * exponential;
}
inline double step_root_square(double d, double q) { return mul_add(d, d, q); }

// Whether every step of a segment is regular whatever the draws (rng.hpp bounds them), from the
// step's constants: then the kernel skips the per-lane range check.
inline bool segment_regular(const StepConstants& c) {
  const double lowest =
      c.twice_variance > 0.0 ? std::sqrt(c.twice_variance * kMinExponential) : std::abs(c.mean);
  const double d = std::abs(c.mean) + kMaxAbsNormal * c.scale;
  const double highest = std::sqrt(d * d + c.twice_variance * kMaxExponential);
  return lowest >= 0x1p-449 && highest <= 1e300;
}

// The step's regular case, from a = |x|, the increment d, q = 2 sigma^2 h E and
// root = sqrt(d^2 + q), for step_regular(root). With r = q / (2 (root + |d|)):
// - for d > 0, the bridge minimum m = (d - root)/2 cancels; it equals -r (multiply by
//   d + root). For d <= 0, d - m = (d + root)/2 cancels when d^2 >> q (a long step, where d is
//   near -c h and sqrt(q) only of order sqrt(h): it lost about log2(4 d^2 / q) bits); it
//   equals r, since root^2 - d^2 = q. So m = min(d, 0) - r and d - m = max(d, 0) + r, sums of
//   terms of one sign for either sign of d, and one quotient of positive terms;
// - |X(h)| = max(|x| + d, d - m): |x| + d is the state plus the increment, rounded once;
// - the touch |x| + m <= 0 is tested as |x| <= -m, the same predicate (a rounded sum is <= 0
//   exactly when the exact one is).
// The forms are branch-free so that the kernel's loop over them vectorises, and they return
// plain doubles (a struct local in an OpenMP simd loop becomes an array in memory).
inline double step_regular_quotient(double d, double q, double root) {
  return 0.5 * q / (root + std::abs(d));
}

inline double step_regular_minimum(double d, double q, double root) {
  return std::min(d, 0.0) - step_regular_quotient(d, q, root);
}

inline double step_regular_magnitude(double a, double d, double q, double root) {
  return std::max(a + d, std::max(d, 0.0) + step_regular_quotient(d, q, root));
}

inline bool step_touched(double a, double minimum) { return a <= -minimum; }

// The velocity at the end of a step of magnitude |X(h)| from x: a touch of 0 takes the coin's
// sign, otherwise the sign is kept. Branch-free, for the kernel's loop.
inline double step_signed(double x, double magnitude, bool touched, bool coin) {
  const bool positive = (touched & coin) | (!touched & (x > 0.0));
  return positive ? magnitude : -magnitude;
}

// The regular step (step_regular(root)) from x, given d, q and root: what the kernel's lanes
// compute, and what exact_step computes in the regular case.
inline double regular_step(double x, double d, double q, double root, bool coin) {
  const double a = std::abs(x);
  return step_signed(x, step_regular_magnitude(a, d, q, root),
                     step_touched(a, step_regular_minimum(d, q, root)), coin);
}

struct StepParts {
  double magnitude;  // |X(h)|
  double minimum;    // m (<= 0)
};

// Any step in range (step_in_range), regular or not: used where step_regular fails, i.e. when
// D^2 + q overflows (steps beyond about 1e150 in scaled units), underflows (steps below about
// 1e-270), or noise and drift both vanish. Everything is computed in units of
// s = sigma sqrt(h), the standard deviation of D: delta = D / s = Z - c h / s and, with q / s^2
// = 2E, rho = sqrt(delta^2 + 2E) (scaled_root: no overflow), m / s and (D - m) / s in the
// quotient forms above.
// a * a as the exact sum hi + lo (Dekker's product with Veltkamp's split; |a| <= 2^500).
inline void exact_square(double a, double& hi, double& lo) {
  const double c = 134217729.0 * a;  // 2^27 + 1
  const double ah = c - (c - a), al = a - ah;
  hi = a * a;
  lo = ((ah * ah - hi) + 2.0 * ah * al) + al * al;
}

// sqrt(x^2 + y^2) without overflow or underflow, within about half an ulp, with +, -, *, / and
// sqrt only (all correctly rounded): the same bits on every CPU. Not std::hypot, whose last bit
// is the C library's (glibc 2.36 on aarch64 differs from x86-64 for 13 % of arguments:
// docs/filtered.md, "What rests on the C library"). x and y are scaled by a power of 2 (exact)
// when the larger is above 2^500 or below 2^-500; the squares and their sum are kept as exact
// double-doubles, and the square root of the sum's head gets one Newton correction from the
// exact residual.
inline double scaled_root(double x, double y) {
  const double abs_x = std::abs(x), abs_y = std::abs(y);
  const double big = abs_x < abs_y ? abs_y : abs_x;
  if (abs_x != abs_x || abs_y != abs_y) return abs_x + abs_y;  // NaN
  if (big == std::numeric_limits<double>::infinity()) return big;
  double ax = big, ay = abs_x < abs_y ? abs_x : abs_y;  // ax >= ay
  if (big == 0.0) return 0.0;
  double scale = 1.0;
  if (big > 0x1p500) {
    ax *= 0x1p-600;
    ay *= 0x1p-600;
    scale = 0x1p600;
  } else if (big < 0x1p-500) {
    ax *= 0x1p600;
    ay *= 0x1p600;
    scale = 0x1p-600;
  }
  double xh, xl, yh, yl;
  exact_square(ax, xh, xl);
  exact_square(ay, yh, yl);
  const double s = xh + yh;
  const double t = ((xh - s) + yh) + xl + yl;  // xh >= yh: Fast2Sum's error of s, exact
  const double h = std::sqrt(s);
  double hh, hl;
  exact_square(h, hh, hl);
  const double r = ((s - hh) - hl) + t;  // s - hh is exact (Sterbenz)
  return (h + r / (2.0 * h)) * scale;
}

inline StepParts step_scaled_parts(double a, const StepConstants& c, double d, double normal,
                                   double exponential) {
  const double s = c.scale;
  if (!(s > 0.0)) {
    // No noise (or noise below the smallest double): the deterministic Skorokhod map.
    const double m = std::min(0.0, d);
    return {std::max(a + d, d - m), m};
  }
  // c h / s may overflow to +inf when s is tiny; delta = -inf then gives m = -inf (a certain
  // touch) and D - m = 0, both right to the last representable digit.
  const double delta = normal - -c.mean / s;
  const double rho = scaled_root(delta, std::sqrt(2.0 * exponential));
  const double e = exponential;
  double m_s, down_s;
  if (delta <= 0.0) {
    m_s = -0.5 * (rho - delta);
    down_s = e / (rho - delta);
  } else {
    const double r = e / (delta + rho);
    m_s = -r;
    down_s = delta + r;
  }
  const double m = s * m_s, down = s * down_s;
  const double up = a + d;
  return {up < down ? down : up, m};
}

// The textbook bridge minimum, the reference the tests check the law against (exact_step uses
// step_regular_minimum, the same number without overflow). Minimum over [0, h] of a Brownian
// bridge from 0 to d with variance `variance` = sigma^2 h at time h: P(min <= m) = exp(-2 m (m - d) / variance) for m <= min(0, d). Inverting at
// exp(-exponential) gives m = (d - sqrt(d^2 + 2 variance exponential)) / 2.
inline double bridge_minimum(double d, double variance, double exponential) {
  const double q = 2.0 * variance * exponential;
  const double root = std::sqrt(d * d + q);
  // For d > 0 the textbook form (d - root)/2 cancels catastrophically; the product form is
  // the same number computed without cancellation.
  return d <= 0.0 ? 0.5 * (d - root) : -0.5 * q / (d + root);
}

// One exact step of length `step` from x, with the step's draws. The kernel computes the same
// number with the same functions (step_constants, step_increment, step_spread,
// step_root_square, regular_step) lane by lane, and calls this function where a lane's step is
// not regular.
inline StepResult exact_step(double x, double step, double drift, double noise, double normal,
                             double exponential, bool coin) {
  const StepConstants c = step_constants(step, drift, noise);
  const double d = step_increment(c.mean, c.scale, normal);
  const double q = step_spread(c.twice_variance, exponential);
  const double root = std::sqrt(step_root_square(d, q));
  if (step_regular(root)) {
    const double a = std::abs(x);
    return {regular_step(x, d, q, root, coin), step_touched(a, step_regular_minimum(d, q, root))};
  }
  const double a = std::abs(x);
  const StepParts p = step_scaled_parts(a, c, d, normal, exponential);
  const bool touched = step_touched(a, p.minimum);
  return {step_signed(x, p.magnitude, touched, coin), touched};
}

// Euler-Maruyama, the baseline: weak order 1, kept for comparison (sign(0) = 0).
inline double euler_step(double x, double step, double drift, double noise, double normal) {
  const double s = x > 0.0 ? 1.0 : (x < 0.0 ? -1.0 : 0.0);
  return x - drift * s * step + noise * std::sqrt(step) * normal;
}

}  // namespace crandall
