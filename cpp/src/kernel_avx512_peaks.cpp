// The avx512 variant of the kernel, its path loops with peaks (variant.hpp, kernel_variant.inc).
#define CRANDALL_VARIANT_LEVEL 4
#define CRANDALL_KERNEL_PEAKS 1
#include "kernel_variant.inc"
