// Linear blend skinning kernels, sse2 level (see skinning_kernels.h).

#include <algorithm>
#include <cstddef>
#include <cstdint>

#include "skinning_kernels.h"

#if defined(SKINSPHERES_X86_64)
#include <immintrin.h>
#define SKS_NS sse2
#define SKS_LEVEL 1
#include "skinning_kernel_body.inc"
#endif
