// The crowd's broad phase of 8 instances at once, one per AVX lane (crowd_query.inc), compiled for AVX2
// whatever the build's flags; called only when the CPU has it (the batched refit decides).
#include "crowd/crowd_query.h"

#if defined(SKINSPHERES_X86_64)
#include <immintrin.h>

#include <limits>

#include "simd/target_begin_avx2.inc"

namespace skinspheres::runtime::internal::avx2 {
#include "simd/lanes_avx2.inc"
static_assert(Lanes::kWidth <= kBatchDepthStride);  // a hit's depths fit its row
#include "crowd/crowd_query.inc"
}  // namespace skinspheres::runtime::internal::avx2

#include "simd/target_end.inc"
#endif  // x86
