// The fast refit's loop (refit_fast.inc) at the x86-64 baseline, SSE2: what every x86-64 CPU runs
// when it has no AVX2 (refit_internal.h).
#include "refit/refit_internal.h"

#if defined(SKINSPHERES_X86_64)
#include <algorithm>
#include <cfloat>
#include <cmath>
#include <limits>
#include <type_traits>

#include "simd/float4.h"

namespace skinspheres::runtime::internal::sse2 {
constexpr SimdLevel kThisLevel = SimdLevel::kSse2;
namespace F = simd::sse;
#include "refit/refit_fast.inc"
}  // namespace skinspheres::runtime::internal::sse2
#endif  // SKINSPHERES_X86_64
