// The avx512 variant of the kernel (variant.hpp, kernel_variant.inc).
#define CRANDALL_VARIANT_LEVEL 4
#include "kernel_variant.inc"
