// SimdLevel: the instruction set a runtime stage's kernels run at (the broad phase, the fast refit,
// the crowd's batches). The one enum of skinning/simd_level.h (the runtime depends on skinning),
// named here in the runtime's namespace: the same type, enumerators, ToString and
// SimdLevelSupported.
#pragma once

#include "skinspheres/skinning/simd_level.h"

namespace skinspheres::runtime {

using skinning::SimdLevel;
using skinning::SimdLevelSupported;
using skinning::ToString;

}  // namespace skinspheres::runtime
