// The crowd's broad phase of 4 instances at once, one per SSE lane (crowd_query.inc over
// simd/float4.h's SSE body): x86-64's baseline.
#include "crowd/crowd_query.h"

#if defined(SKINSPHERES_X86_64)
#include <limits>

#include "simd/float4.h"

namespace skinspheres::runtime::internal::sse2 {
namespace F = simd::sse;
#include "simd/lanes_float4.inc"
static_assert(Lanes::kWidth <= kBatchDepthStride);  // a hit's depths fit its row
#include "crowd/crowd_query.inc"
}  // namespace skinspheres::runtime::internal::sse2
#endif  // x86
