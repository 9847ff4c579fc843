// The avx2 variant of the kernel (variant.hpp, kernel_variant.inc).
#define CRANDALL_VARIANT_LEVEL 3
#include "kernel_variant.inc"
