// The crowd's fast refit of 16 instances of one set at once, one per AVX-512 lane (crowd/refit_batch.inc), compiled for
// AVX-512F whatever the build's flags and used by the crowd calls when the CPU has it (refit_internal.h).
#include "refit/refit_internal.h"

#if defined(SKINSPHERES_X86_64)
#include <immintrin.h>

#include <cfloat>
#include <cstdint>
#include <limits>
#include <type_traits>

#include "simd/target_begin_avx512.inc"

namespace skinspheres::runtime::internal::avx512 {
#include "simd/lanes_avx512.inc"
constexpr SimdLevel kThisLevel = SimdLevel::kAvx512;
#include "crowd/refit_batch.inc"
}  // namespace skinspheres::runtime::internal::avx512

#include "simd/target_end.inc"
#endif  // x86
