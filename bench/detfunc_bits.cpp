// Writes the core's own exp, log1p, log and log erfc (cpp/src/detfunc.cpp, the tail
// estimators' weights) at a million arguments each, as raw doubles per argument, to stdout:
// bench/core_bits.sh compares the bits between x86-64 (baseline and -march=native builds, and
// under qemu's Nehalem without AVX or FMA) and aarch64. The arguments are libm_bits.cpp's
// (exact doubles made from integers), with log's spread over the whole positive range.
#include <cstdint>
#include <cstdio>
#include <cstring>

#include "crandall/detfunc.hpp"

int main() {
  namespace df = crandall::detfunc;
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
    std::uint64_t bits = next() % 0x7FF0000000000000ull;  // any positive finite double
    double g;
    std::memcpy(&g, &bits, sizeof g);
    const double z = static_cast<double>(next() % (60ull << 40)) / 1099511627776.0 - 10.0;
    const double out[4] = {df::exp(e), df::log1p(l), df::log(g), df::log_erfc(z)};
    std::fwrite(out, sizeof out, 1, stdout);
  }
  return 0;
}
