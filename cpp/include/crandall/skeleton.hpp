// The exact-in-law step of the velocity. Derivation: docs/exact-step.md.
//
// The velocity X obeys dX = -c sign(X) dt + sigma dW (the paper's eq3 has c = 2, sigma = sqrt 2).
// |X| is the Skorokhod reflection at 0 of Y(s) = |x| + sigma B(s) - c s, and the sign of each
// excursion away from 0 is an independent fair coin. A step of any length h from X = x:
//   D = -c h + sigma sqrt(h) Z                         (increment of Y)
//   m = (D - sqrt(D^2 + 2 sigma^2 h E)) / 2, E ~ Exp(1) (exact minimum of the bridge of Y - |x|)
//   |X(h)| = max(|x| + D, D - m)                       (Skorokhod map)
//   a touch of 0 (|x| + m <= 0) draws a fresh sign; otherwise the sign is kept.
#pragma once

#include <algorithm>
#include <cmath>

namespace crandall {

struct StepResult {
  double velocity;  // X at the end of the step
  bool touched;     // whether X reached 0 during the step
};

// Minimum over [0, h] of a Brownian bridge from 0 to d with variance `variance` = sigma^2 h
// at time h: P(min <= m) = exp(-2 m (m - d) / variance) for m <= min(0, d). Inverting at
// exp(-exponential) gives m = (d - sqrt(d^2 + 2 variance exponential)) / 2.
inline double bridge_minimum(double d, double variance, double exponential) {
  const double q = 2.0 * variance * exponential;
  const double root = std::sqrt(d * d + q);
  // For d > 0 the textbook form (d - root)/2 cancels catastrophically; the product form is
  // the same number computed without cancellation.
  return d <= 0.0 ? 0.5 * (d - root) : -0.5 * q / (d + root);
}

inline StepResult exact_step(double x, double h, double drift, double noise, double normal,
                             double exponential, bool coin) {
  const double a = std::abs(x);
  const double d = -drift * h + noise * std::sqrt(h) * normal;
  const double m = bridge_minimum(d, noise * noise * h, exponential);
  const double magnitude = std::max(a + d, d - m);
  const bool touched = a + m <= 0.0;
  const bool positive = touched ? coin : x > 0.0;
  return {positive ? magnitude : -magnitude, touched};
}

// Euler-Maruyama, the baseline: weak order 1, kept for comparison (sign(0) = 0).
inline double euler_step(double x, double h, double drift, double noise, double normal) {
  const double s = x > 0.0 ? 1.0 : (x < 0.0 ? -1.0 : 0.0);
  return x - drift * s * h + noise * std::sqrt(h) * normal;
}

}  // namespace crandall
