// ToString(SimdLevel) and SimdLevelSupported (simd_level.h).
#include "skinspheres/skinning/simd_level.h"

#include "skinspheres/skinning/platform.h"

namespace skinspheres::skinning {

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

bool SimdLevelSupported(SimdLevel level) {
  switch (level) {
    case SimdLevel::kAuto:
    case SimdLevel::kPortable: return true;
#if defined(SKINSPHERES_X86_64)
    case SimdLevel::kSse2: return true;
    case SimdLevel::kAvx2: return HostCpu().avx2 && HostCpu().bmi1 && HostCpu().popcnt;  // simd/target_begin_avx2.inc
    case SimdLevel::kAvx512: return SimdLevelSupported(SimdLevel::kAvx2) && HostCpu().avx512f;
#endif
    default: return false;
  }
}

}  // namespace skinspheres::skinning
