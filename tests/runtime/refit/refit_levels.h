// The fast refit's levels (refit/refit_internal.h) as a GoogleTest parameter: every level, widest
// first, and a test name for each. A test pins its level (internal::PinRefitSimd) and skips, saying
// so, where the CPU lacks it.
#pragma once

#include <gtest/gtest.h>

#include <string>

#include "refit/refit_internal.h"

namespace skinspheres::test {

inline auto AllRefitLevels() {
  using runtime::internal::RefitSimd;
  return ::testing::Values(RefitSimd::kAvx512, RefitSimd::kAvx2, RefitSimd::kSse2, RefitSimd::kPortable);
}

inline std::string RefitLevelName(const ::testing::TestParamInfo<runtime::internal::RefitSimd>& level) {
  switch (level.param) {
    case runtime::internal::RefitSimd::kAvx512: return "Avx512";
    case runtime::internal::RefitSimd::kAvx2: return "Avx2";
    case runtime::internal::RefitSimd::kSse2: return "Sse2";
    case runtime::internal::RefitSimd::kPortable: return "Portable";
    default: return "Auto";
  }
}

}  // namespace skinspheres::test
