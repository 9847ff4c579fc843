// Counter-based random numbers: every draw is a pure function of (seed, path, step), so a
// result does not depend on the number of threads, on how paths are split into chunks, or on
// the machine that simulates them.
#pragma once

#include <Random123/philox.h>

#include <cmath>
#include <cstdint>

namespace crandall {

// Noise consumed by one time step of one path: a standard normal, a standard exponential
// (-log of a uniform) and a fair coin.
struct StepNoise {
  double normal;
  double exponential;
  bool coin;
};

// Elementwise natural log and (sin, cos) of n doubles. On x86-64 glibc with AVX, 4 at a time
// through libmvec (linked with libm); otherwise the scalar library functions. Every draw of the
// project goes through these two functions, so the scalar and the batched generators below
// give bitwise the same numbers on a given build.
void log_n(const double* in, double* out, int n);
void sincos_n(const double* in, double* sin_out, double* cos_out, int n);

// Noise of two consecutive steps for N paths (path0, ..., path0 + N - 1), structure of arrays:
// normal[j][l] is the normal of step 2*pair + j of path path0 + l.
template <int N>
struct PairNoise {
  alignas(32) double normal[2][N];
  alignas(32) double exponential[2][N];
  alignas(32) double coin[2][N];  // 1.0 or 0.0
};

// One Philox4x32-10 block yields// One Philox4x32-10 block yields the noise of two consecutive steps (k = 2*pair, 2*pair+1).
//   key     = seed (64 bits)
//   counter = (pair index, 64 bits; path index, 64 bits)
//   word 0       -> radius uniform of Box-Muller
//   word 1 >> 2  -> angle uniform of Box-Muller (30 bits); bits 0 and 1 -> the two coins
//   words 2, 3   -> the two exponentials
// Disjoint bits of a uniform word are independent, so the coins are independent of the angle.
// Box-Muller's cosine and sine outputs are independent normals, one per step.
// Layout documented in docs/random-numbers.md; changing it changes every result.
template <int N>
inline void draw_pairs(std::uint64_t seed, std::uint64_t path0, std::uint64_t pair, int lanes,
                       PairNoise<N>& out) {
  using Philox = r123::Philox4x32;
  const Philox::key_type key = {{static_cast<std::uint32_t>(seed),
                                 static_cast<std::uint32_t>(seed >> 32)}};
  constexpr double k2m32 = 2.3283064365386962890625e-10;  // 2^-32
  constexpr double k2m30 = 9.31322574615478515625e-10;    // 2^-30
  constexpr double kTwoPi = 6.283185307179586476925286766559;
  // Uniforms in (0, 1), then one batched log for radius and exponentials, one sincos.
  alignas(32) double u[3][N], angle[N], lg[3][N];
  for (int l = 0; l < N; ++l) {
    const std::uint64_t path = path0 + static_cast<std::uint64_t>(l < lanes ? l : 0);
    const Philox::ctr_type ctr = {{static_cast<std::uint32_t>(pair),
                                   static_cast<std::uint32_t>(pair >> 32),
                                   static_cast<std::uint32_t>(path),
                                   static_cast<std::uint32_t>(path >> 32)}};
    const Philox::ctr_type w = Philox()(ctr, key);
    // (w + 1/2) 2^-32 lies strictly inside (0, 1): log never sees 0 and never returns 0.
    u[0][l] = (static_cast<double>(w[0]) + 0.5) * k2m32;
    angle[l] = kTwoPi * ((static_cast<double>(w[1] >> 2) + 0.5) * k2m30);
    u[1][l] = (static_cast<double>(w[2]) + 0.5) * k2m32;
    u[2][l] = (static_cast<double>(w[3]) + 0.5) * k2m32;
    out.coin[0][l] = (w[1] & 1u) ? 1.0 : 0.0;
    out.coin[1][l] = (w[1] & 2u) ? 1.0 : 0.0;
  }
  log_n(&u[0][0], &lg[0][0], 3 * N);
  alignas(32) double sn[N], cs[N];
  sincos_n(angle, sn, cs, N);
  for (int l = 0; l < N; ++l) {
    const double radius = std::sqrt(-2.0 * lg[0][l]);
    out.normal[0][l] = radius * cs[l];
    out.normal[1][l] = radius * sn[l];
    out.exponential[0][l] = -lg[1][l];
    out.exponential[1][l] = -lg[2][l];
  }
}

// The same numbers for one path, as StepNoise (tests, the refinement stream).
inline void draw_pair(std::uint64_t seed, std::uint64_t path, std::uint64_t pair,
                      StepNoise out[2]) {
  PairNoise<1> z;
  draw_pairs<1>(seed, path, pair, 1, z);
  for (int j = 0; j < 2; ++j) out[j] = {z.normal[j][0], z.exponential[j][0], z.coin[j][0] != 0.0};
}

}  // namespace crandall
