// Writes the C library's exp, log1p and hypot (the libm functions the core called, nm -u:
// split.cpp's splitting weights, exact_step.hpp's scaled step; now replaced by the core's own,
// bench/detfunc_bits.cpp and exact_step.hpp's scaled_root) at a million arguments each, as
// raw doubles: (exp, log1p, hypot) per argument, to stdout. The arguments are exact doubles made
// from integers (the same as bench/core_bits.cpp's hashes), so that bench/core_bits.sh can count
// the results whose bits differ between platforms, function by function.
#include <cmath>
#include <cstdint>
#include <cstdio>

int main() {
  std::uint64_t x = 0x9e3779b97f4a7c15ull;
  const auto next = [&x] {
    x ^= x << 13;
    x ^= x >> 7;
    x ^= x << 17;
    return x;
  };
  for (int i = 0; i < 1000000; ++i) {
    const double e = static_cast<double>(next() % (1454ull << 40)) / 1099511627776.0 - 745.0;
    const double l = static_cast<double>(next() % (2ull << 52)) / 4503599627370496.0 - 1.0 + 0x1p-52;
    const double a = static_cast<double>(next() % (128ull << 40)) / 1099511627776.0 - 64.0;
    const double b = static_cast<double>(next() % (64ull << 46)) / 70368744177664.0;
    const double out[3] = {std::exp(e), std::log1p(l), std::hypot(a, b)};
    std::fwrite(out, sizeof out, 1, stdout);
  }
  return 0;
}
