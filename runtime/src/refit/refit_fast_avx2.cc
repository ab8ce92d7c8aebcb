// The fast refit's loop (refit_fast.inc) compiled for AVX2 whatever the build's flags, picked at run
// time when the CPU has it (refit_internal.h). The same source and float operations as the SSE2 level,
// so the same bits; the VEX encoding (three operands, no register copies) makes it faster.
#include "refit/refit_internal.h"

#if defined(SKINSPHERES_X86_64)
// Every header refit_fast.inc needs, before the target pragma (standard templates stay baseline).
#include <algorithm>
#include <cfloat>
#include <cmath>
#include <limits>
#include <type_traits>

#include "simd/float4.h"
#include "simd/target_begin_avx2.inc"

namespace skinspheres::runtime::internal::avx2 {
constexpr SimdLevel kThisLevel = SimdLevel::kAvx2;
namespace F = simd::sse;
#include "refit/refit_fast.inc"
}  // namespace skinspheres::runtime::internal::avx2

#include "simd/target_end.inc"
#endif  // x86
