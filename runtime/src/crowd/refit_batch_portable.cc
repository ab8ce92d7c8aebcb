// The crowd's fast refit of 4 instances of one set at once in portable C++ (crowd/refit_batch.inc
// over simd/float4.h's portable body, which the compiler may vectorise): what the crowd calls run
// off x86-64 (aarch64: four floats, one NEON register), and on x86-64 for tests.
#include <cfloat>
#include <cstdint>
#include <limits>
#include <type_traits>

#include "refit/refit_internal.h"
#include "simd/float4.h"

namespace skinspheres::runtime::internal::portable {
namespace F = simd::portable;
#include "simd/lanes_float4.inc"
constexpr SimdLevel kThisLevel = SimdLevel::kPortable;
#include "crowd/refit_batch.inc"
}  // namespace skinspheres::runtime::internal::portable
