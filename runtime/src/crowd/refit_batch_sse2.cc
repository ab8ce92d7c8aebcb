// The crowd's fast refit of 4 instances of one set at once, one per SSE lane (crowd/refit_batch.inc
// over simd/float4.h's SSE body): x86-64's baseline, used by the crowd calls on a CPU without AVX2.
#include "refit/refit_internal.h"

#if defined(SKINSPHERES_X86_64)
#include <cfloat>
#include <cstdint>
#include <limits>
#include <type_traits>

#include "simd/float4.h"

namespace skinspheres::runtime::internal::sse2 {
namespace F = simd::sse;
#include "simd/lanes_float4.inc"
constexpr SimdLevel kThisLevel = SimdLevel::kSse2;
#include "crowd/refit_batch.inc"
}  // namespace skinspheres::runtime::internal::sse2
#endif  // x86
