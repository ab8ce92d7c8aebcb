// The crowd's broad phase of 4 instances at once in portable C++ (crowd_query.inc over
// simd/float4.h's portable body): what the crowd calls run off x86-64, and on x86-64 for tests.
#include <limits>

#include "crowd/crowd_query.h"
#include "simd/float4.h"

namespace skinspheres::runtime::internal::portable {
namespace F = simd::portable;
#include "simd/lanes_float4.inc"
static_assert(Lanes::kWidth <= kBatchDepthStride);  // a hit's depths fit its row
#include "crowd/crowd_query.inc"
}  // namespace skinspheres::runtime::internal::portable
