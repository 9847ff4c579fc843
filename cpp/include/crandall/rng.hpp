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

// One Philox4x32-10 block yields the noise of two consecutive steps (k = 2*pair, 2*pair+1).
//   key     = seed (64 bits)
//   counter = (pair index, 64 bits; path index, 64 bits)
//   word 0       -> radius uniform of Box-Muller
//   word 1 >> 2  -> angle uniform of Box-Muller (30 bits); bits 0 and 1 -> the two coins
//   words 2, 3   -> the two exponentials
// Disjoint bits of a uniform word are independent, so the coins are independent of the angle.
// Box-Muller's cosine and sine outputs are independent normals, one per step.
// Layout documented in docs/random-numbers.md; changing it changes every result.
inline void draw_pair(std::uint64_t seed, std::uint64_t path, std::uint64_t pair,
                      StepNoise out[2]) {
  using Philox = r123::Philox4x32;
  const Philox::key_type key = {{static_cast<std::uint32_t>(seed),
                                 static_cast<std::uint32_t>(seed >> 32)}};
  const Philox::ctr_type ctr = {{static_cast<std::uint32_t>(pair),
                                 static_cast<std::uint32_t>(pair >> 32),
                                 static_cast<std::uint32_t>(path),
                                 static_cast<std::uint32_t>(path >> 32)}};
  const Philox::ctr_type w = Philox()(ctr, key);
  constexpr double k2m32 = 2.3283064365386962890625e-10;  // 2^-32
  constexpr double k2m30 = 9.31322574615478515625e-10;    // 2^-30
  constexpr double kTwoPi = 6.283185307179586476925286766559;
  // (w + 1/2) 2^-32 lies strictly inside (0, 1): log never sees 0 and never returns 0 exactly.
  const double u_radius = (static_cast<double>(w[0]) + 0.5) * k2m32;
  const double u_angle = (static_cast<double>(w[1] >> 2) + 0.5) * k2m30;
  const double radius = std::sqrt(-2.0 * std::log(u_radius));
  const double angle = kTwoPi * u_angle;
  out[0].normal = radius * std::cos(angle);
  out[1].normal = radius * std::sin(angle);
  out[0].exponential = -std::log((static_cast<double>(w[2]) + 0.5) * k2m32);
  out[1].exponential = -std::log((static_cast<double>(w[3]) + 0.5) * k2m32);
  out[0].coin = (w[1] & 1u) != 0;
  out[1].coin = (w[1] & 2u) != 0;
}

}  // namespace crandall
