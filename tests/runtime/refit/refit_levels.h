// The fast refit's levels (refit/refit_internal.h) as a GoogleTest parameter: every level, widest
// first, and a test name for each. A test pins its level (internal::PinRefitSimd) and skips, saying
// so, where the CPU lacks it.
#pragma once

#include <gtest/gtest.h>

#include <string>

#include "refit/refit_internal.h"

namespace skinspheres::test {

inline auto AllRefitLevels() {
  using runtime::SimdLevel;
  return ::testing::Values(SimdLevel::kAvx512, SimdLevel::kAvx2, SimdLevel::kSse2, SimdLevel::kPortable);
}

inline std::string RefitLevelName(const ::testing::TestParamInfo<runtime::SimdLevel>& level) {
  switch (level.param) {
    case runtime::SimdLevel::kAvx512: return "Avx512";
    case runtime::SimdLevel::kAvx2: return "Avx2";
    case runtime::SimdLevel::kSse2: return "Sse2";
    case runtime::SimdLevel::kPortable: return "Portable";
    default: return "Auto";
  }
}

}  // namespace skinspheres::test
