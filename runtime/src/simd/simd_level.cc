// ToString(SimdLevel) (simd_level.h).
#include "skinspheres/runtime/simd_level.h"

namespace skinspheres::runtime {

const char* ToString(SimdLevel level) {
  switch (level) {
    case SimdLevel::kAuto: return "auto";
    case SimdLevel::kSse2: return "sse2";
    case SimdLevel::kAvx2: return "avx2";
    case SimdLevel::kAvx512: return "avx512";
    case SimdLevel::kPortable: return "portable";
  }
  return "unknown";
}

}  // namespace skinspheres::runtime
