// The baseline variant of the kernel, its path loops with peaks (variant.hpp, kernel_variant.inc).
#define CRANDALL_VARIANT_LEVEL 0
#define CRANDALL_KERNEL_PEAKS 1
#include "kernel_variant.inc"
