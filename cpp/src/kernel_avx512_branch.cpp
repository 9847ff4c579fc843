// The avx512 variant of the kernel, its rows continued in vector lanes (variant.hpp,
// kernel_variant.inc, branch_lanes.inc).
#define CRANDALL_VARIANT_LEVEL 4
#define CRANDALL_KERNEL_BRANCH 1
#include "kernel_variant.inc"
