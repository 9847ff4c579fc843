// fdlibm's exp, log, log1p and erfc with only +, -, *, / and exact bit operations (detfunc.hpp).
// This file must be compiled with -ffp-contract=off (the core's PUBLIC option, CMakeLists.txt):
// every a * b + c below is two roundings.
#include "crandall/detfunc.hpp"

#include <cstdint>
#include <cstring>
#include <limits>

namespace crandall {
namespace detfunc {
namespace {

std::uint64_t bits_of(double x) {
  std::uint64_t b;
  std::memcpy(&b, &x, sizeof b);
  return b;
}

double from_bits(std::uint64_t b) {
  double x;
  std::memcpy(&x, &b, sizeof x);
  return x;
}

// The high 32 bits of x as fdlibm's signed high word.
std::int32_t high_word(double x) {
  return static_cast<std::int32_t>(static_cast<std::uint32_t>(bits_of(x) >> 32));
}

// x with its high word replaced.
double with_high_word(double x, std::uint32_t hi) {
  return from_bits((std::uint64_t{hi} << 32) | (bits_of(x) & 0xFFFFFFFFull));
}

// 2^k for a k in [-1022, 1023], exactly.
double pow2(int k) { return from_bits(static_cast<std::uint64_t>(1023 + k) << 52); }

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

constexpr double kLn2Hi = 0x1.62e42feep-1;        // 6.93147180369123816490e-01
constexpr double kLn2Lo = 0x1.a39ef35793c76p-33;  // 1.90821492927058770002e-10
constexpr double kLn2 = 0x1.62e42fefa39efp-1;     // ln 2 rounded

// e_exp.c
constexpr double kInvLn2 = 0x1.71547652b82fep+0;        // 1.44269504088896338700e+00
constexpr double kExpOver = 0x1.62e42fefa39efp+9;       // 7.09782712893383973096e+02
constexpr double kExpUnder = -0x1.74910d52d3051p+9;     // -7.45133219101941108420e+02
constexpr double kP1 = 0x1.555555555553ep-3;            // 1.66666666666666019037e-01
constexpr double kP2 = -0x1.6c16c16bebd93p-9;           // -2.77777777770155933842e-03
constexpr double kP3 = 0x1.1566aaf25de2cp-14;           // 6.61375632143793436117e-05
constexpr double kP4 = -0x1.bbd41c5d26bf1p-20;          // -1.65339022054652515390e-06
constexpr double kP5 = 0x1.6376972bea4d0p-25;           // 4.13813679705723846039e-08

// e_log.c and s_log1p.c (the same coefficients)
constexpr double kLg1 = 0x1.5555555555593p-1;  // 6.666666666666735130e-01
constexpr double kLg2 = 0x1.999999997fa04p-2;  // 3.999999999940941908e-01
constexpr double kLg3 = 0x1.2492494229359p-2;  // 2.857142874366239149e-01
constexpr double kLg4 = 0x1.c71c51d8e78afp-3;  // 2.222219843214978396e-01
constexpr double kLg5 = 0x1.7466496cb03dep-3;  // 1.818357216161805012e-01
constexpr double kLg6 = 0x1.39a09d078c69fp-3;  // 1.531383769920937332e-01
constexpr double kLg7 = 0x1.2f112df3e5244p-3;  // 1.479819860511658591e-01

// log(1 + f) - f for the reduced f = m - 1, m in [sqrt(2)/2, sqrt(2)), as fdlibm's kernel
// evaluates it: with s = f / (2 + f), log(1 + f) = f - (hfsq - s (hfsq + R(s^2))).
double log_poly(double s) {
  const double z = s * s;
  const double w = z * z;
  const double t1 = w * (kLg2 + w * (kLg4 + w * kLg6));
  const double t2 = z * (kLg1 + w * (kLg3 + w * (kLg5 + w * kLg7)));
  return t2 + t1;
}

// s_erf.c
constexpr double kErx = 0x1.b0ac16p-1;  // 8.45062911510467529297e-01
constexpr double kPp0 = 0x1.06eba8214db68p-3;
constexpr double kPp1 = -0x1.4cd7d691cb913p-2;
constexpr double kPp2 = -0x1.d2a51dbd7194fp-6;
constexpr double kPp3 = -0x1.7a291236668e4p-8;
constexpr double kPp4 = -0x1.8ead6120016acp-16;
constexpr double kQq1 = 0x1.97779cddadc09p-2;
constexpr double kQq2 = 0x1.0a54c5536cebap-4;
constexpr double kQq3 = 0x1.4d022c4d36b0fp-8;
constexpr double kQq4 = 0x1.15dc9221c1a10p-13;
constexpr double kQq5 = -0x1.09c4342a26120p-18;
constexpr double kPa0 = -0x1.359b8bef77538p-9;
constexpr double kPa1 = 0x1.a8d00ad92b34dp-2;
constexpr double kPa2 = -0x1.7d240fbb8c3f1p-2;
constexpr double kPa3 = 0x1.45fca805120e4p-2;
constexpr double kPa4 = -0x1.c63983d3e28ecp-4;
constexpr double kPa5 = 0x1.22a36599795ebp-5;
constexpr double kPa6 = -0x1.1bf380a96073fp-9;
constexpr double kQa1 = 0x1.b3e6618eee323p-4;
constexpr double kQa2 = 0x1.14af092eb6f33p-1;
constexpr double kQa3 = 0x1.2635cd99fe9a7p-4;
constexpr double kQa4 = 0x1.02660e763351fp-3;
constexpr double kQa5 = 0x1.bedc26b51dd1cp-7;
constexpr double kQa6 = 0x1.88b545735151dp-7;
constexpr double kRa0 = -0x1.43412600d6435p-7;
constexpr double kRa1 = -0x1.63416e4ba736p-1;
constexpr double kRa2 = -0x1.51e0441b0e726p+3;
constexpr double kRa3 = -0x1.f300ae4cba38dp+5;
constexpr double kRa4 = -0x1.44cb184282266p+7;
constexpr double kRa5 = -0x1.7135cebccabb2p+7;
constexpr double kRa6 = -0x1.4526557e4d2f2p+6;
constexpr double kRa7 = -0x1.3a0efc69ac25cp+3;
constexpr double kSa1 = 0x1.3a6b9bd707687p+4;
constexpr double kSa2 = 0x1.1350c526ae721p+7;
constexpr double kSa3 = 0x1.b290dd58a1a71p+8;
constexpr double kSa4 = 0x1.42b1921ec2868p+9;
constexpr double kSa5 = 0x1.ad02157700314p+8;
constexpr double kSa6 = 0x1.b28a3ee48ae2cp+6;
constexpr double kSa7 = 0x1.a47ef8e484a93p+2;
constexpr double kSa8 = -0x1.eeff2ee749a62p-5;
constexpr double kRb0 = -0x1.4341239e86f4ap-7;
constexpr double kRb1 = -0x1.993ba70c285dep-1;
constexpr double kRb2 = -0x1.1c209555f995ap+4;
constexpr double kRb3 = -0x1.4145d43c5ed98p+7;
constexpr double kRb4 = -0x1.3ec881375f228p+9;
constexpr double kRb5 = -0x1.004616a2e5992p+10;
constexpr double kRb6 = -0x1.e384e9bdc383fp+8;
constexpr double kSb1 = 0x1.e568b261d519p+4;
constexpr double kSb2 = 0x1.45cae221b9f0ap+8;
constexpr double kSb3 = 0x1.802eb189d5118p+10;
constexpr double kSb4 = 0x1.8ffb7688c246ap+11;
constexpr double kSb5 = 0x1.3f219cedf3be6p+11;
constexpr double kSb6 = 0x1.da874e79fe763p+8;
constexpr double kSb7 = -0x1.670e242712d62p+4;

// erfc(x) for 0 <= x < 1.25 (s_erf.c's first two intervals).
double erfc_near(double x) {
  const std::int32_t ix = high_word(x) & 0x7fffffff;
  if (ix < 0x3feb0000) {  // x < 0.84375
    if (ix < 0x3c700000) return 1.0 - x;  // x < 2^-56
    const double z = x * x;
    const double r = kPp0 + z * (kPp1 + z * (kPp2 + z * (kPp3 + z * kPp4)));
    const double s = 1.0 + z * (kQq1 + z * (kQq2 + z * (kQq3 + z * (kQq4 + z * kQq5))));
    const double y = r / s;
    if (ix < 0x3fd00000) return 1.0 - (x + x * y);  // x < 1/4
    return 0.5 - (x * y + (x - 0.5));
  }
  const double s = x - 1.0;
  const double p = kPa0 + s * (kPa1 + s * (kPa2 + s * (kPa3 + s * (kPa4 + s * (kPa5 + s * kPa6)))));
  const double q = 1.0 + s * (kQa1 + s * (kQa2 + s * (kQa3 + s * (kQa4 + s * (kQa5 + s * kQa6)))));
  return (1.0 - kErx) - p / q;
}

// For x >= 1.25: the two parts of log(erfc(x) x) + x^2, fdlibm's -s^2 - 0.5625 (s: x with its
// low word cleared, so s^2 is exact) and (s - x)(s + x) + R/S, so that
// erfc(x) = exp(head) exp(tail) / x.
void erfc_far(double x, double& head, double& tail) {
  const std::int32_t ix = high_word(x) & 0x7fffffff;
  const double s = 1.0 / (x * x);
  double r, q;
  if (ix < 0x4006DB6D) {  // x < 1/0.35
    r = kRa0 + s * (kRa1 + s * (kRa2 + s * (kRa3 + s * (kRa4 + s * (kRa5 + s * (kRa6 + s * kRa7))))));
    q = 1.0 + s * (kSa1 + s * (kSa2 + s * (kSa3 + s * (kSa4 + s * (kSa5 + s * (kSa6 + s * (kSa7 + s * kSa8)))))));
  } else {
    r = kRb0 + s * (kRb1 + s * (kRb2 + s * (kRb3 + s * (kRb4 + s * (kRb5 + s * kRb6)))));
    q = 1.0 + s * (kSb1 + s * (kSb2 + s * (kSb3 + s * (kSb4 + s * (kSb5 + s * (kSb6 + s * kSb7))))));
  }
  const double z = from_bits(bits_of(x) & 0xFFFFFFFF00000000ull);
  head = -z * z - 0.5625;
  tail = (z - x) * (z + x) + r / q;
}

// erfc(x) for x >= 0 (0 from 28 on, where it is below 1e-341).
double erfc_positive(double x) {
  if (x < 1.25) return erfc_near(x);
  if (x >= 28.0) return 0.0;
  double head, tail;
  erfc_far(x, head, tail);
  return exp(head) * exp(tail) / x;
}

}  // namespace

double exp(double x) {
  if (x != x) return x + x;
  if (x > kExpOver) return kInf;
  if (x < kExpUnder) return 0.0;
  if (x == 1.0) return 0x1.5bf0a8b145769p+1;  // e rounded (fdlibm's choice)
  const std::int32_t hx = high_word(x) & 0x7fffffff;
  const bool negative = x < 0.0;
  double hi = 0.0, lo = 0.0;
  int k = 0;
  if (hx > 0x3fd62e42) {  // |x| > ln2 / 2
    if (hx < 0x3FF0A2B2) {  // and |x| < 1.5 ln2
      hi = negative ? x + kLn2Hi : x - kLn2Hi;
      lo = negative ? -kLn2Lo : kLn2Lo;
      k = negative ? -1 : 1;
    } else {
      k = static_cast<int>(kInvLn2 * x + (negative ? -0.5 : 0.5));
      const double t = k;
      hi = x - t * kLn2Hi;  // exact
      lo = t * kLn2Lo;
    }
    x = hi - lo;
  } else if (hx < 0x3e300000) {  // |x| < 2^-28
    return 1.0 + x;
  }
  const double t = x * x;
  const double c = x - t * (kP1 + t * (kP2 + t * (kP3 + t * (kP4 + t * kP5))));
  if (k == 0) return 1.0 - ((x * c) / (c - 2.0) - x);
  const double y = 1.0 - ((lo - (x * c) / (2.0 - c)) - hi);
  if (k == 1024) return y * 2.0 * 0x1p1023;
  if (k >= -1021) return y * pow2(k);
  return y * pow2(k + 1000) * 0x1p-1000;
}

double log(double x) {
  if (x != x) return x + x;
  if (x < 0.0) return kNaN;
  if (x == 0.0) return -kInf;
  if (x == kInf) return x;
  int k = 0;
  if (x < 0x1p-1022) {  // subnormal: scale up exactly
    x *= 0x1p54;
    k = -54;
  }
  const std::uint64_t b = bits_of(x);
  const std::uint64_t mantissa = b & 0x000FFFFFFFFFFFFFull;
  // Carries into bit 52 when 1 + mantissa is at least about sqrt(2): then m = x / 2^(e+1).
  const std::uint64_t halve = (mantissa + (std::uint64_t{0x95f64} << 32)) & (std::uint64_t{1} << 52);
  const double m = from_bits(mantissa | (halve ^ 0x3FF0000000000000ull));
  k += static_cast<int>(b >> 52) - 1023 + static_cast<int>(halve >> 52);
  const double dk = k;
  const double f = m - 1.0;
  const double s = f / (2.0 + f);
  const double r = log_poly(s);
  const double hfsq = 0.5 * f * f;
  // One form for every x, as detmath::log_positive (which it equals on that function's inputs).
  return dk * kLn2Hi - ((hfsq - (s * (hfsq + r) + dk * kLn2Lo)) - f);
}

double log1p(double x) {
  if (x != x) return x + x;
  if (x < -1.0) return kNaN;
  if (x == -1.0) return -kInf;
  if (x == kInf) return x;
  const std::int32_t hx = high_word(x);
  const std::int32_t ax = hx & 0x7fffffff;
  int k = 1;
  double f = 0.0, c = 0.0;
  std::int32_t hu = 0;
  if (hx < 0x3FDA827A) {  // 1 + x < sqrt(2)+
    if (ax < 0x3e200000) {  // |x| < 2^-29
      if (ax < 0x3c900000) return x;  // |x| < 2^-54
      return x - x * x * 0.5;
    }
    if (hx > 0 || hx <= static_cast<std::int32_t>(0xbfd2bec4u)) {  // sqrt(2)/2- <= 1 + x < sqrt(2)+
      k = 0;
      f = x;
      hu = 1;
    }
  }
  if (k != 0) {
    double u;
    if (hx < 0x43400000) {  // x < 2^53
      u = 1.0 + x;
      hu = high_word(u);
      k = (hu >> 20) - 1023;
      c = (k > 0) ? 1.0 - (u - x) : x - (u - 1.0);  // the rounding error of 1 + x
      c /= u;
    } else {
      u = x;
      hu = high_word(u);
      k = (hu >> 20) - 1023;
      c = 0.0;
    }
    hu &= 0x000fffff;
    if (hu < 0x6a09e) {  // u below about sqrt(2) times a power of 2
      u = with_high_word(u, static_cast<std::uint32_t>(hu) | 0x3ff00000u);
    } else {
      k += 1;
      u = with_high_word(u, static_cast<std::uint32_t>(hu) | 0x3fe00000u);
      hu = (0x00100000 - hu) >> 2;
    }
    f = u - 1.0;
  }
  const double hfsq = 0.5 * f * f;
  const double dk = k;
  if (hu == 0) {  // |f| < 2^-20
    if (f == 0.0) {
      if (k == 0) return 0.0;
      c += dk * kLn2Lo;
      return dk * kLn2Hi + c;
    }
    const double r = hfsq * (1.0 - 0.66666666666666666 * f);
    if (k == 0) return f - r;
    return dk * kLn2Hi - ((r - (dk * kLn2Lo + c)) - f);
  }
  const double s = f / (2.0 + f);
  const double r = log_poly(s);
  if (k == 0) return f - (hfsq - s * (hfsq + r));
  return dk * kLn2Hi - ((hfsq - (s * (hfsq + r) + (dk * kLn2Lo + c))) - f);
}

double log_erfc(double x) {
  if (x != x) return x + x;
  if (x < 0.0) {
    // erfc(x) = 2 - erfc(-x), erfc(-x) in (0, 1].
    return kLn2 + log1p(-0.5 * erfc_positive(-x));
  }
  if (x < 1.25) return log(erfc_near(x));
  if (x == kInf) return -kInf;
  double head, tail;
  erfc_far(x, head, tail);
  return (head + tail) - log(x);
}

}  // namespace detfunc
}  // namespace crandall
