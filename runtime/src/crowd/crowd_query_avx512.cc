// The crowd's broad phase of 16 instances at once, one per AVX-512 lane (crowd_query.inc), compiled for AVX512F
// whatever the build's flags; called only when the CPU has it (the batched refit decides).
#include "crowd/crowd_query.h"

#if defined(SKINSPHERES_X86_64)
#include <immintrin.h>

#include <limits>

#include "simd/target_begin_avx512.inc"

namespace skinspheres::runtime::internal::avx512 {
#include "simd/lanes_avx512.inc"
static_assert(Lanes::kWidth <= kBatchDepthStride);  // a hit's depths fit its row
#include "crowd/crowd_query.inc"
}  // namespace skinspheres::runtime::internal::avx512

#include "simd/target_end.inc"
#endif  // x86
