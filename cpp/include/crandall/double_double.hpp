// Double-double arithmetic: a number is the unevaluated sum hi + lo of two doubles with
// |lo| <= ulp(hi) / 2, about 106 bits of significand. The filtered excitation's plan-time
// algebra (filter.cpp) runs in it and rounds to double at the end.
//
// Why not long double: it is x87's 80-bit format on x86-64, IEEE quad (in software) on aarch64
// and plain double elsewhere, so the same plan would give other doubles on another machine.
// Every operation here is built from IEEE double's correctly rounded +, -, *, / and std::fma
// (Dekker's and Knuth's error-free transformations: two_sum, two_prod), which give the same bits
// on every IEEE platform; no libm function (exp, cos, ...) and no long double is used, and every
// product that is added is an explicit std::fma, so the result does not depend on whether the
// compiler contracts a * b + c either. The algorithms are the QD library's (Hida, Li and Bailey,
// "Library for double-double and quad-double arithmetic", 2007): the accurate ("IEEE") addition,
// relative error about 2^-104 for each operation.
#pragma once

#include <cmath>

namespace crandall {

struct DoubleDouble {
  double hi = 0.0, lo = 0.0;
  DoubleDouble() = default;
  // NOLINTNEXTLINE(google-explicit-constructor): a double is exactly a double-double
  DoubleDouble(double x) : hi(x) {}
  DoubleDouble(double h, double l) : hi(h), lo(l) {}
  // hi is hi + lo rounded to nearest (the pair is normalised: hi = fl(hi + lo)).
  explicit operator double() const { return hi; }
};

namespace dd_detail {

// s + e = a + b exactly (Knuth).
inline DoubleDouble two_sum(double a, double b) {
  const double s = a + b;
  const double bb = s - a;
  return {s, (a - (s - bb)) + (b - bb)};
}

// s + e = a + b exactly for |a| >= |b| (Dekker).
inline DoubleDouble quick_two_sum(double a, double b) {
  const double s = a + b;
  return {s, b - (s - a)};
}

// p + e = a b exactly (fma is correctly rounded on every IEEE platform).
inline DoubleDouble two_prod(double a, double b) {
  const double p = a * b;
  return {p, std::fma(a, b, -p)};
}

}  // namespace dd_detail

inline DoubleDouble operator-(const DoubleDouble& a) { return {-a.hi, -a.lo}; }

inline DoubleDouble operator+(const DoubleDouble& a, const DoubleDouble& b) {
  using namespace dd_detail;
  DoubleDouble s = two_sum(a.hi, b.hi);
  const DoubleDouble t = two_sum(a.lo, b.lo);
  s.lo += t.hi;
  s = quick_two_sum(s.hi, s.lo);
  s.lo += t.lo;
  return quick_two_sum(s.hi, s.lo);
}

inline DoubleDouble operator-(const DoubleDouble& a, const DoubleDouble& b) { return a + (-b); }

inline DoubleDouble operator*(const DoubleDouble& a, const DoubleDouble& b) {
  using namespace dd_detail;
  DoubleDouble p = two_prod(a.hi, b.hi);
  p.lo = std::fma(a.hi, b.lo, std::fma(a.lo, b.hi, p.lo));
  return quick_two_sum(p.hi, p.lo);
}

inline DoubleDouble operator*(const DoubleDouble& a, double b) {
  using namespace dd_detail;
  DoubleDouble p = two_prod(a.hi, b);
  p.lo = std::fma(a.lo, b, p.lo);
  return quick_two_sum(p.hi, p.lo);
}

inline DoubleDouble operator/(const DoubleDouble& a, const DoubleDouble& b) {
  using namespace dd_detail;
  const double q1 = a.hi / b.hi;
  DoubleDouble r = a - b * q1;
  const double q2 = r.hi / b.hi;
  r = r - b * q2;
  const double q3 = r.hi / b.hi;
  return quick_two_sum(q1, q2) + DoubleDouble(q3);
}

inline DoubleDouble& operator+=(DoubleDouble& a, const DoubleDouble& b) { return a = a + b; }
inline DoubleDouble& operator-=(DoubleDouble& a, const DoubleDouble& b) { return a = a - b; }

inline bool operator<(const DoubleDouble& a, const DoubleDouble& b) {
  return a.hi < b.hi || (a.hi == b.hi && a.lo < b.lo);
}
inline bool operator>(const DoubleDouble& a, const DoubleDouble& b) { return b < a; }
inline bool operator<=(const DoubleDouble& a, const DoubleDouble& b) { return !(b < a); }
inline bool operator>=(const DoubleDouble& a, const DoubleDouble& b) { return !(a < b); }
inline bool operator==(const DoubleDouble& a, const DoubleDouble& b) { return a.hi == b.hi && a.lo == b.lo; }

inline DoubleDouble abs(const DoubleDouble& a) { return a.hi < 0.0 ? -a : a; }

// The square root (one Newton step from the double root, whose residual a - x^2 is formed
// exactly); 0 for a <= 0.
inline DoubleDouble sqrt(const DoubleDouble& a) {
  if (!(a.hi > 0.0)) return DoubleDouble(0.0);
  const double x = std::sqrt(a.hi);
  const DoubleDouble r = a - dd_detail::two_prod(x, x);
  return dd_detail::quick_two_sum(x, r.hi / (2.0 * x));
}

// a 2^e, exactly (barring overflow and underflow).
inline DoubleDouble ldexp(const DoubleDouble& a, int e) { return {std::ldexp(a.hi, e), std::ldexp(a.lo, e)}; }

inline bool isfinite(const DoubleDouble& a) { return std::isfinite(a.hi) && std::isfinite(a.lo); }

}  // namespace crandall
