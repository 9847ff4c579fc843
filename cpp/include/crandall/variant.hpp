// Instruction-set variants of the kernel. The code that turns random words into paths (the
// generator, the deterministic math, the path loop) is compiled once per variant, each in its own
// translation unit (cpp/src/kernel_*.cpp), and the best one the CPU supports is chosen at run
// time (cpp/src/dispatch.cpp). Everything else is compiled for the baseline instruction set.
//
// Two traps are avoided here:
// - The linker merges same-named inline functions from different translation units (the one
//   definition rule lets it keep any copy). Had the variants shared names, an AVX-512 copy could
//   end up called from the baseline path and crash a CPU without AVX-512. So each variant's code
//   lives in its own inline namespace (crandall::baseline, crandall::avx2, crandall::avx512);
//   inline, so that code including these headers outside a variant translation unit (tests,
//   run.cpp) sees the baseline variant under the plain crandall:: names.
// - Template code from the standard library that a variant instantiates (std::vector, std::min)
//   must not be compiled above the baseline either, for the same reason. So the variant's
//   instruction set is switched on with `#pragma GCC target` around the variant's own code only
//   (CRANDALL_BEGIN_VARIANT ... CRANDALL_END_VARIANT), after every other header is included: the
//   standard library's functions keep the baseline target (and can still be inlined into the
//   variant's functions, whose instruction set includes the baseline's). The pragma lists
//   features rather than an -march level, since GCC refuses to inline across different -march
//   values.
//
// The three variants compute bitwise the same numbers: the project is compiled with
// -ffp-contract=off (no fused multiply-add is formed from a * b + c), without -ffast-math (no
// reassociation, no approximate reciprocals), and its math on the random path uses only
// correctly rounded operations (detmath.hpp). Vector width changes how many lanes run at once,
// never what each lane computes.
#pragma once

#if defined(__x86_64__) || defined(__i386__)
// GCC's immintrin.h declares every intrinsic whatever the command-line target; the variants
// use those of their own instruction set inside their target region.
#include <immintrin.h>
#define CRANDALL_X86 1
#else
#define CRANDALL_X86 0
#endif

// 0: baseline (x86-64 with SSE2, or any other architecture), 3: x86-64-v3 (AVX2, FMA, BMI2),
// 4: x86-64-v4 (AVX-512 F/BW/CD/DQ/VL; loops vectorised with 512-bit registers, measured
// faster than 256-bit ones for the deterministic math). Set by the variant translation units
// only.
#ifndef CRANDALL_VARIANT_LEVEL
#define CRANDALL_VARIANT_LEVEL 0
#endif

#if CRANDALL_VARIANT_LEVEL == 0
#define CRANDALL_VARIANT_NS baseline
#define CRANDALL_TARGET_PUSH
#define CRANDALL_TARGET_POP
#elif CRANDALL_VARIANT_LEVEL == 3 && CRANDALL_X86
#define CRANDALL_VARIANT_NS avx2
#define CRANDALL_TARGET_PUSH                                                                  \
  _Pragma("GCC push_options")                                                                 \
  _Pragma("GCC target(\"sse3,ssse3,sse4.1,sse4.2,popcnt,avx,avx2,bmi,bmi2,f16c,fma,lzcnt,movbe\")")
#define CRANDALL_TARGET_POP _Pragma("GCC pop_options")
#elif CRANDALL_VARIANT_LEVEL == 4 && CRANDALL_X86
#define CRANDALL_VARIANT_NS avx512
#define CRANDALL_TARGET_PUSH                                                                  \
  _Pragma("GCC push_options")                                                                 \
  _Pragma("GCC target(\"sse3,ssse3,sse4.1,sse4.2,popcnt,avx,avx2,bmi,bmi2,f16c,fma,lzcnt,movbe,avx512f,avx512bw,avx512cd,avx512dq,avx512vl,prefer-vector-width=512\")")
#define CRANDALL_TARGET_POP _Pragma("GCC pop_options")
#else
#error "CRANDALL_VARIANT_LEVEL must be 0, or 3 or 4 on x86"
#endif

// Open and close a stretch of variant code (at global scope).
#define CRANDALL_BEGIN_VARIANT \
  CRANDALL_TARGET_PUSH namespace crandall { inline namespace CRANDALL_VARIANT_NS {
#define CRANDALL_END_VARIANT \
  }                          \
  }                          \
  CRANDALL_TARGET_POP
