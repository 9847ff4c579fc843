// The random streams: distinct per seed, path and step; the vector Philox of every variant
// against Random123 and its known answers; batched draws equal single ones; the draws' moments
// and their documented bounds.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <set>

#include "crandall/dispatch.hpp"
#include "crandall/plan.hpp"
#include "crandall/rng.hpp"

namespace {

TEST(Rng, StreamsDependOnSeedPathAndStep) {
  std::set<double> seen;
  for (std::uint64_t seed : {0ull, 1ull})
    for (std::uint64_t path : {0ull, 1ull, 1ull << 40})
      for (std::uint64_t pair : {0ull, 1ull, 1ull << 33}) {
        crandall::StepNoise z[2];
        crandall::draw_pair(seed, path, pair, z);
        seen.insert(z[0].normal);
        seen.insert(z[1].normal);
      }
  EXPECT_EQ(seen.size(), 2u * 2 * 3 * 3);
}

// The vectorised Philox (the AVX-512 and AVX2 variants) against Random123's scalar generator,
// over counters whose words cross 32-bit boundaries, and a group of paths that is not a
// multiple of the vector width; every variant this host supports.
TEST(Rng, VectorPhiloxMatchesRandom123) {
  for (const crandall::KernelTable* kernel : crandall::compiled_kernels()) {
    if (!crandall::kernel_supported(*kernel)) continue;
    for (std::uint64_t seed : {0ull, 42ull, 0xFFFFFFFFFFFFFFFFull, 0x0123456789ABCDEFull})
      for (std::uint64_t path0 : {0ull, 1000ull, 0xFFFFFFF8ull, (1ull << 63) - 5})
        for (std::uint64_t pair : {0ull, 7ull, 0xFFFFFFFFull, 1ull << 40}) {
          std::uint64_t w[4 * crandall::kLanes];
          kernel->philox_words(seed, path0, pair, 13, w);
          for (int l = 0; l < 13; ++l) {
            using Philox = r123::Philox4x32;
            const Philox::key_type key = {{static_cast<std::uint32_t>(seed),
                                           static_cast<std::uint32_t>(seed >> 32)}};
            const std::uint64_t path = path0 + static_cast<std::uint64_t>(l);
            const Philox::ctr_type ctr = {{static_cast<std::uint32_t>(pair),
                                           static_cast<std::uint32_t>(pair >> 32),
                                           static_cast<std::uint32_t>(path),
                                           static_cast<std::uint32_t>(path >> 32)}};
            const Philox::ctr_type want = Philox()(ctr, key);
            for (int j = 0; j < 4; ++j)
              ASSERT_EQ(static_cast<std::uint32_t>(w[j * crandall::kLanes + l]), want[j])
                  << kernel->name << " seed " << seed << " path " << path << " pair " << pair
                  << " word " << j;
          }
        }
  }
}

// A host with AVX2 or AVX-512 runs (and the test above checks) the vector Philox by default.
TEST(Rng, VectorPhiloxIsChosenWhereTheHostHasIt) {
  if (std::getenv("CRANDALL_ISA")) GTEST_SKIP() << "CRANDALL_ISA forces a variant";
  const auto& k = crandall::active_kernel();
#if defined(__x86_64__)
  if (__builtin_cpu_supports("avx2")) {
    EXPECT_GT(k.philox_paths_per_register, 1);
  }
  if (__builtin_cpu_supports("avx512f")) {
    EXPECT_EQ(k.philox_paths_per_register, 8);
    EXPECT_STREQ(k.name, "avx512");
  }
#else
  EXPECT_STREQ(k.name, "baseline");
#endif
}

// Random123's published known-answer vectors for Philox4x32-10 (kat_vectors), so the scalar
// reference above is itself pinned.
TEST(Rng, PhiloxKnownAnswers) {
  using Philox = r123::Philox4x32;
  struct Kat {
    Philox::ctr_type ctr;
    Philox::key_type key;
    Philox::ctr_type want;
  };
  const Kat kats[] = {
      {{{0u, 0u, 0u, 0u}}, {{0u, 0u}}, {{0x6627e8d5u, 0xe169c58du, 0xbc57ac4cu, 0x9b00dbd8u}}},
      {{{0xffffffffu, 0xffffffffu, 0xffffffffu, 0xffffffffu}},
       {{0xffffffffu, 0xffffffffu}},
       {{0x408f276du, 0x41c83b0eu, 0xa20bc7c6u, 0x6d5451fdu}}},
      {{{0x243f6a88u, 0x85a308d3u, 0x13198a2eu, 0x03707344u}},
       {{0xa4093822u, 0x299f31d0u}},
       {{0xd16cfe09u, 0x94fdccebu, 0x5001e420u, 0x24126ea1u}}},
  };
  for (const Kat& k : kats) {
    const Philox::ctr_type got = Philox()(k.ctr, k.key);
    for (int j = 0; j < 4; ++j) EXPECT_EQ(got[j], k.want[j]);
    // And through the vector path: counter (pair = words 0-1, path = words 2-3).
    alignas(64) std::uint64_t w[4][8];
    const std::uint64_t pair = k.ctr[0] | (std::uint64_t{k.ctr[1]} << 32);
    const std::uint64_t path = k.ctr[2] | (std::uint64_t{k.ctr[3]} << 32);
    const std::uint64_t seed = k.key[0] | (std::uint64_t{k.key[1]} << 32);
    crandall::philox_paths<8>(seed, path - 3, pair, 8, w);
    for (int j = 0; j < 4; ++j) EXPECT_EQ(static_cast<std::uint32_t>(w[j][3]), k.want[j]);
  }
}

// A path's draws do not depend on the group it is drawn in.
TEST(Rng, BatchedDrawsEqualSingleDraws) {
  crandall::PairNoise<16> z;
  crandall::draw_pairs<16>(5, 1234, 77, z);
  for (int l = 0; l < 16; ++l) {
    crandall::StepNoise one[2];
    crandall::draw_pair(5, 1234 + static_cast<std::uint64_t>(l), 77, one);
    for (int j = 0; j < 2; ++j) {
      EXPECT_EQ(z.normal[j][l], one[j].normal);
      EXPECT_EQ(z.exponential[j][l], one[j].exponential);
      EXPECT_EQ(z.coin[j][l] != 0.0, one[j].coin);
    }
  }
}

TEST(Rng, MomentsOfTheDraws) {
  const int n = 400000;
  double sz = 0, szz = 0, se = 0, coins = 0;
  for (int i = 0; i < n / 2; ++i) {
    crandall::StepNoise z[2];
    crandall::draw_pair(9, 3, static_cast<std::uint64_t>(i), z);
    for (const auto& s : z) {
      sz += s.normal;
      szz += s.normal * s.normal;
      se += s.exponential;
      coins += s.coin;
    }
  }
  // 5 standard errors each: normal mean (1/sqrt n), normal second moment (sqrt(2/n)),
  // exponential mean (1/sqrt n), coin (0.5/sqrt n).
  EXPECT_NEAR(sz / n, 0.0, 5.0 / std::sqrt(n));
  EXPECT_NEAR(szz / n, 1.0, 5.0 * std::sqrt(2.0 / n));
  EXPECT_NEAR(se / n, 1.0, 5.0 / std::sqrt(n));
  EXPECT_NEAR(coins / n, 0.5, 2.5 / std::sqrt(n));
}

TEST(Rng, DrawsStayWithinTheirDocumentedBounds) {
  // The extreme uniforms (w = 0 and w = 2^32 - 1) give the extreme draws; the kernel's
  // segment_regular relies on these bounds.
  const double k2m32 = std::ldexp(1.0, -32);
  const double u_min = 0.5 * k2m32, u_max = (4294967295.0 + 0.5) * k2m32;
  EXPECT_GE(-std::log(u_max), crandall::kMinExponential);
  EXPECT_LE(-std::log(u_min), crandall::kMaxExponential);
  EXPECT_LE(std::sqrt(-2.0 * std::log(u_min)), crandall::kMaxAbsNormal);
  double lo = 1.0, hi = 0.0, z = 0.0;
  for (std::uint64_t pair = 0; pair < 200000; ++pair) {
    crandall::StepNoise w[2];
    crandall::draw_pair(9, 3, pair, w);
    for (const auto& v : w) {
      lo = std::min(lo, v.exponential);
      hi = std::max(hi, v.exponential);
      z = std::max(z, std::abs(v.normal));
    }
  }
  EXPECT_GE(lo, crandall::kMinExponential);
  EXPECT_LE(hi, crandall::kMaxExponential);
  EXPECT_LE(z, crandall::kMaxAbsNormal);
}

}  // namespace
