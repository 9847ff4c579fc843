// The baseline variant of the kernel (variant.hpp, kernel_variant.inc).
#define CRANDALL_VARIANT_LEVEL 0
#include "kernel_variant.inc"
