// The avx2 variant of the kernel, its path loops that integrate the quadratic variation
// (variant.hpp, kernel_variant.inc).
#define CRANDALL_VARIANT_LEVEL 3
#define CRANDALL_KERNEL_QUADRATIC 1
#include "kernel_variant.inc"
