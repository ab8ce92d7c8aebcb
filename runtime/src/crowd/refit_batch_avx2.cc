// The crowd's fast refit of 8 instances of one set at once, one per AVX lane (crowd/refit_batch.inc), compiled for AVX2
// whatever the build's flags and used by the crowd calls when the CPU has it (refit_internal.h).
#include "refit/refit_internal.h"

#if defined(SKINSPHERES_X86_64)
#include <immintrin.h>

#include <cfloat>
#include <cstdint>
#include <limits>
#include <type_traits>

#include "simd/target_begin_avx2.inc"

namespace skinspheres::runtime::internal::avx2 {
#include "simd/lanes_avx2.inc"
constexpr SimdLevel kThisLevel = SimdLevel::kAvx2;
#include "crowd/refit_batch.inc"
}  // namespace skinspheres::runtime::internal::avx2

#include "simd/target_end.inc"
#endif  // x86
