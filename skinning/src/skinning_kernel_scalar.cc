// Linear blend skinning kernels, portable level (see skinning_kernels.h).

#include <algorithm>
#include <cstddef>
#include <cstdint>

#include "skinning_kernels.h"

#define SKS_NS scalar
#define SKS_LEVEL 0
#include "skinning_kernel_body.inc"
