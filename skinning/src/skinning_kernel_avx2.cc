// Linear blend skinning kernels, avx2 level (see skinning_kernels.h).

#include <algorithm>
#include <cstddef>
#include <cstdint>

#include "skinning_kernels.h"

#if defined(SKINSPHERES_X86_64)
#include <immintrin.h>
#define SKS_NS avx2
#define SKS_LEVEL 2
// The body compiled for AVX2 (one switch, simd/target_begin_avx2.inc, for every SIMD copy):
#include "simd/target_begin_avx2.inc"
// the body,
#include "skinning_kernel_body.inc"
// then the build's own target again.
#include "simd/target_end.inc"
#endif
