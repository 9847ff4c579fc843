// Counter-based random numbers: every draw is a pure function of (seed, path, step), so a
// result does not depend on the number of threads, on how paths are split into chunks, or on
// the machine that simulates them.
#pragma once

#include <Random123/philox.h>

#include <cmath>
#include <cstdint>

#include "crandall/detmath.hpp"
#include "crandall/variant.hpp"

namespace crandall {

// Version of the random stream: which numbers a (seed, path, step) gives. Changed whenever the
// layout below, the generator or the math that turns words into numbers changes; recorded with
// results so that numbers of different streams are never mixed. 1: libmvec/libm math (numbers
// depended on the build); 2: the deterministic math of detmath.hpp (the same on every CPU).
constexpr int kRandomStream = 2;

// Noise consumed by one time step of one path: a standard normal, a standard exponential
// (-log of a uniform) and a fair coin.
struct StepNoise {
  double normal;
  double exponential;
  bool coin;
};

// Bounds of every draw, from the uniforms' range [2^-33, 1 - 2^-33] (draw_pairs): exponentials
// lie in [-log(1 - 2^-33), 33 log 2] = [1.16e-10, 22.88], normals in
// [-sqrt(66 log 2), sqrt(66 log 2)] = +-6.77. The kernel relies on them to know a segment's
// steps need no range check (exact_step.hpp); cpp/tests/test_rng.cpp checks them.
constexpr double kMinExponential = 1.1e-10;
constexpr double kMaxExponential = 22.9;
constexpr double kMaxAbsNormal = 6.8;

// Noise of two consecutive steps for N paths (path0, ..., path0 + N - 1), structure of arrays:
// normal[j][l] is the normal of step 2*pair + j of path path0 + l.
template <int N>
struct PairNoise {
  alignas(64) double normal[2][N];
  alignas(64) double exponential[2][N];
  alignas(64) double coin[2][N];  // 1.0 or 0.0
};

}  // namespace crandall

// Everything below is compiled once per instruction-set variant (variant.hpp).
CRANDALL_BEGIN_VARIANT

// Philox4x32-10 (Random123's rounds and key schedule) for `count` consecutive paths at once:
// word j of the block of path path0 + l, counter (pair, path0 + l), goes to the low 32 bits of
// w[j][l] (the high bits are garbage). With AVX-512 or AVX2, 8 or 4 paths per register, one
// path per 64-bit lane, since the 32x32->64 multiply (vpmuludq) works on 64-bit lanes;
// otherwise Random123's scalar generator. The three give bitwise the same words (checked in
// cpp/tests/test_rng.cpp against Random123, and across variants in cpp/tests/test_dispatch.cpp).
namespace detail {
constexpr std::uint32_t kPhiloxM0 = 0xD2511F53u, kPhiloxM1 = 0xCD9E8D57u;
constexpr std::uint32_t kPhiloxW0 = 0x9E3779B9u, kPhiloxW1 = 0xBB67AE85u;

CRANDALL_HOT void philox_scalar(std::uint64_t seed, std::uint64_t path, std::uint64_t pair,
                          std::uint64_t out[4]) {
  using Philox = r123::Philox4x32;
  const Philox::key_type key = {{static_cast<std::uint32_t>(seed),
                                 static_cast<std::uint32_t>(seed >> 32)}};
  const Philox::ctr_type ctr = {{static_cast<std::uint32_t>(pair),
                                 static_cast<std::uint32_t>(pair >> 32),
                                 static_cast<std::uint32_t>(path),
                                 static_cast<std::uint32_t>(path >> 32)}};
  const Philox::ctr_type r = Philox()(ctr, key);
  for (int j = 0; j < 4; ++j) out[j] = r[j];
}

#if CRANDALL_VARIANT_LEVEL >= 4
// One path per 64-bit lane. vpmuludq reads the low 32 bits of each lane, so the high garbage
// that the rounds leave in c0, c2 is harmless. (The zero-masked forms with an all-ones mask are
// the plain instructions; GCC 12's plain intrinsics trip its own -Wuninitialized through
// _mm512_undefined_epi32.)
struct PhiloxOps {
  using V = __m512i;
  static constexpr int kWidth = 8;
  static V set1(std::uint64_t x) { return _mm512_set1_epi64(static_cast<long long>(x)); }
  static V lanes() { return _mm512_setr_epi64(0, 1, 2, 3, 4, 5, 6, 7); }
  static V add(V a, V b) { return _mm512_add_epi64(a, b); }
  static V mul32(V a, V b) { return _mm512_maskz_mul_epu32(0xFF, a, b); }
  static V high32(V a) { return _mm512_maskz_srli_epi64(0xFF, a, 32); }
  static V bitxor(V a, V b) { return _mm512_xor_si512(a, b); }
  static void store(std::uint64_t* p, V a) { _mm512_storeu_si512(p, a); }
};
#elif CRANDALL_VARIANT_LEVEL >= 3
struct PhiloxOps {
  using V = __m256i;
  static constexpr int kWidth = 4;
  static V set1(std::uint64_t x) { return _mm256_set1_epi64x(static_cast<long long>(x)); }
  static V lanes() { return _mm256_setr_epi64x(0, 1, 2, 3); }
  static V add(V a, V b) { return _mm256_add_epi64(a, b); }
  static V mul32(V a, V b) { return _mm256_mul_epu32(a, b); }
  static V high32(V a) { return _mm256_srli_epi64(a, 32); }
  static V bitxor(V a, V b) { return _mm256_xor_si256(a, b); }
  static void store(std::uint64_t* p, V a) { _mm256_storeu_si256(reinterpret_cast<V*>(p), a); }
};
#endif

#if CRANDALL_VARIANT_LEVEL >= 3
constexpr int kPhiloxWidth = PhiloxOps::kWidth;
// Philox4x32-10's ten rounds on a vector of counters (c0, c1, c2, c3: word j in the low 32
// bits of each lane; c0's and c2's high halves are ignored by mul32), the words stored to o_j.
inline void philox_rounds(std::uint64_t seed, PhiloxOps::V c0, PhiloxOps::V c1, PhiloxOps::V c2,
                          PhiloxOps::V c3, std::uint64_t* o0, std::uint64_t* o1,
                          std::uint64_t* o2, std::uint64_t* o3) {
  using O = PhiloxOps;
  const O::V m0 = O::set1(kPhiloxM0), m1 = O::set1(kPhiloxM1);
  std::uint32_t k0 = static_cast<std::uint32_t>(seed), k1 = static_cast<std::uint32_t>(seed >> 32);
  for (int r = 0; r < 10; ++r) {
    if (r > 0) {
      k0 += kPhiloxW0;
      k1 += kPhiloxW1;
    }
    const O::V p0 = O::mul32(c0, m0), p1 = O::mul32(c2, m1);
    const O::V n0 = O::bitxor(O::bitxor(O::high32(p1), c1), O::set1(k0));
    const O::V n2 = O::bitxor(O::bitxor(O::high32(p0), c3), O::set1(k1));
    c1 = p1;  // lo1 in the low half
    c3 = p0;  // lo0 in the low half
    c0 = n0;
    c2 = n2;
  }
  O::store(o0, c0);
  O::store(o1, c1);
  O::store(o2, c2);
  O::store(o3, c3);
}

// Random123's Philox4x32-10 for paths path0 .. path0 + kPhiloxWidth - 1 at once; word j of
// lane l goes to the low 32 bits of o_j[l].
inline void philox_vector(std::uint64_t seed, std::uint64_t path0, std::uint64_t pair,
                          std::uint64_t* o0, std::uint64_t* o1, std::uint64_t* o2,
                          std::uint64_t* o3) {
  using O = PhiloxOps;
  const O::V path = O::add(O::set1(path0), O::lanes());
  O::V c0 = O::set1(pair & 0xFFFFFFFFu), c1 = O::set1(pair >> 32);
  O::V c2 = path, c3 = O::high32(path);  // c2's high half is ignored by mul32
  philox_rounds(seed, c0, c1, c2, c3, o0, o1, o2, o3);
}
#else
constexpr int kPhiloxWidth = 1;
#endif
}  // namespace detail

// Words of the blocks of paths path0 .. path0 + count - 1 (count a multiple of the vector width
// or smaller than it), word j of path l in w[j][l].
template <int N>
inline void philox_paths(std::uint64_t seed, std::uint64_t path0, std::uint64_t pair, int count,
                         std::uint64_t (&w)[4][N]) {
  count = count < N ? count : N;
  int l = 0;
#if CRANDALL_VARIANT_LEVEL >= 3
  constexpr int V = detail::kPhiloxWidth;
  if constexpr (N >= V)
    for (; l + V <= count; l += V)
      detail::philox_vector(seed, path0 + static_cast<std::uint64_t>(l), pair, &w[0][l],
                            &w[1][l], &w[2][l], &w[3][l]);
#endif
  for (; l < count; ++l) {
    std::uint64_t o[4];
    detail::philox_scalar(seed, path0 + static_cast<std::uint64_t>(l), pair, o);
    for (int j = 0; j < 4; ++j) w[j][l] = o[j];
  }
}

#if CRANDALL_VARIANT_LEVEL >= 3
namespace detail {
// philox_vector with a counter of its own in every lane: (pairs[l], paths[l]).
inline void philox_vector_lanes(std::uint64_t seed, const std::uint64_t* paths,
                                const std::uint64_t* pairs, std::uint64_t* o0,
                                std::uint64_t* o1, std::uint64_t* o2, std::uint64_t* o3) {
  using O = PhiloxOps;
#if CRANDALL_VARIANT_LEVEL >= 4
  const O::V path = _mm512_loadu_si512(paths), pair = _mm512_loadu_si512(pairs);
#else
  const O::V path = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(paths));
  const O::V pair = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(pairs));
#endif
  O::V c0 = pair, c1 = O::high32(pair);  // c0's high half is ignored by mul32
  O::V c2 = path, c3 = O::high32(path);
  philox_rounds(seed, c0, c1, c2, c3, o0, o1, o2, o3);
}
}  // namespace detail
#endif

// The words of the blocks (pairs[l], paths[l]) of N lanes, word j of lane l in w[j][l] (low 32
// bits): philox_paths with a counter per lane.
template <int N>
inline void philox_lanes(std::uint64_t seed, const std::uint64_t* paths,
                         const std::uint64_t* pairs, std::uint64_t (&w)[4][N]) {
  int l = 0;
#if CRANDALL_VARIANT_LEVEL >= 3
  constexpr int V = detail::kPhiloxWidth;
  if constexpr (N >= V)
    for (; l + V <= N; l += V)
      detail::philox_vector_lanes(seed, paths + l, pairs + l, &w[0][l], &w[1][l], &w[2][l],
                                  &w[3][l]);
#endif
  for (; l < N; ++l) {
    std::uint64_t o[4];
    detail::philox_scalar(seed, paths[l], pairs[l], o);
    for (int j = 0; j < 4; ++j) w[j][l] = o[j];
  }
}

// One Philox4x32-10 block yields the noise of two consecutive steps (k = 2*pair, 2*pair+1).
//   key     = seed (64 bits)
//   counter = (pair index, 64 bits; path index, 64 bits)
//   word 0       -> radius uniform of Box-Muller
//   word 1 >> 2  -> angle uniform of Box-Muller (30 bits); bits 0 and 1 -> the two coins
//   words 2, 3   -> the two exponentials
// Disjoint bits of a uniform word are independent, so the coins are independent of the angle.
// Box-Muller's cosine and sine outputs are independent normals, one per step.
// Uniforms are (w + 1/2) 2^-32, strictly inside (0, 1) (log never sees 0 and never returns 0);
// the angle is 2 pi (k + 1/2) 2^-30. The log and the sine/cosine are the deterministic ones of
// detmath.hpp, so every variant and the NumPy reference (tests/reference_rng.py) give the same
// bits. Layout documented in docs/random-numbers.md; changing it changes every result (and
// kRandomStream above).
// All N lanes are drawn: in a partial group the lanes past its paths hold the draws of paths
// that are not simulated, and are never read.
template <int N>
inline void noise_of_words(const std::uint64_t (&w)[4][N], PairNoise<N>& out);

template <int N>
inline void draw_pairs(std::uint64_t seed, std::uint64_t path0, std::uint64_t pair,
                       PairNoise<N>& out) {
  alignas(64) std::uint64_t w[4][N];
  philox_paths<N>(seed, path0, pair, N, w);
  noise_of_words<N>(w, out);
}

// The noise of N Philox blocks (word j of lane l in the low 32 bits of w[j][l]), laid out as
// above: what draw_pairs makes of its words, and the lanes of branch_lanes.inc of theirs.
template <int N>
inline void noise_of_words(const std::uint64_t (&w)[4][N], PairNoise<N>& out) {
  alignas(64) double lg[3][N], sn[N], cs[N];
#pragma omp simd
  for (int l = 0; l < N; ++l) {
    lg[0][l] = detmath::log_positive(detmath::unit_of_word(w[0][l]));
    lg[1][l] = detmath::log_positive(detmath::unit_of_word(w[2][l]));
    lg[2][l] = detmath::log_positive(detmath::unit_of_word(w[3][l]));
  }
#pragma omp simd
  for (int l = 0; l < N; ++l) detmath::sincos_turn30((w[1][l] & 0xFFFFFFFFull) >> 2, sn[l], cs[l]);
#pragma omp simd
  for (int l = 0; l < N; ++l) {
    const double radius = std::sqrt(-2.0 * lg[0][l]);
    out.normal[0][l] = radius * cs[l];
    out.normal[1][l] = radius * sn[l];
    out.exponential[0][l] = -lg[1][l];
    out.exponential[1][l] = -lg[2][l];
    // 1.0 or 0.0 from the bit without a compare (none for 64-bit lanes in SSE2).
    out.coin[0][l] = detmath::from_bits((0 - (w[1][l] & 1u)) & 0x3FF0000000000000ull);
    out.coin[1][l] = detmath::from_bits((0 - ((w[1][l] >> 1) & 1u)) & 0x3FF0000000000000ull);
  }
}

// The same numbers for one path, as StepNoise (tests, the refinement stream).
inline void draw_pair(std::uint64_t seed, std::uint64_t path, std::uint64_t pair,
                      StepNoise out[2]) {
  PairNoise<1> z;
  draw_pairs<1>(seed, path, pair, z);
  for (int j = 0; j < 2; ++j) out[j] = {z.normal[j][0], z.exponential[j][0], z.coin[j][0] != 0.0};
}

CRANDALL_END_VARIANT
