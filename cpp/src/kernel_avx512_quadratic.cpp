// The avx512 variant of the kernel, its path loops that integrate the quadratic variation
// (variant.hpp, kernel_variant.inc).
#define CRANDALL_VARIANT_LEVEL 4
#define CRANDALL_KERNEL_QUADRATIC 1
#include "kernel_variant.inc"
