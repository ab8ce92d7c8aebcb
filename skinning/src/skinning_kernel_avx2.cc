// Linear blend skinning kernels, avx2 level (see skinning_kernels.h).

#include <algorithm>
#include <cstddef>
#include <cstdint>

#include "skinning_kernels.h"

#if defined(SKINSPHERES_X86_64)
#include <immintrin.h>
#define SKS_NS avx2
#define SKS_LEVEL 2
// GCC and Clang compile the copy for AVX2 by a function attribute, inside a default build; MSVC
// emits any intrinsic anywhere and needs none.
#if defined(_MSC_VER) && !defined(__clang__)
#define SKS_TARGET
#else
#define SKS_TARGET __attribute__((target("avx2")))
#endif
#include "skinning_kernel_body.inc"
#endif
