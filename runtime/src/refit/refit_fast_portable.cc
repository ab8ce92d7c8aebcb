// The fast refit's loop (refit_fast.inc) in portable C++ (simd::portable: four floats as an
// array), on every platform: what aarch64 and every other target but x86-64 run, and on x86-64 the
// copy the tests compare with the SIMD ones (refit_internal.h). The same bits as every other level.
#include <algorithm>
#include <cfloat>
#include <cmath>
#include <limits>
#include <type_traits>

#include "refit/refit_internal.h"
#include "simd/float4.h"

namespace skinspheres::runtime::internal::portable {
constexpr SimdLevel kThisLevel = SimdLevel::kPortable;
namespace F = simd::portable;
#include "refit/refit_fast.inc"
}  // namespace skinspheres::runtime::internal::portable
