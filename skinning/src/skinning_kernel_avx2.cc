// Linear blend skinning kernels, avx2 level (see skinning_kernels.h).

#include <algorithm>
#include <cstddef>
#include <cstdint>

#include "skinning_kernels.h"

#if defined(__x86_64__) || defined(__i386__)
#include <immintrin.h>
#define SKS_NS avx2
#define SKS_LEVEL 2
#define SKS_TARGET __attribute__((target("avx2,fma")))
#include "skinning_kernel_body.inc"
#endif
