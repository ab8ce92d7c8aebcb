// The fast refit's bind-pose reference stored unconditionally (refit_job.h, "Reference frame"), for
// tests that weigh it against the rest pose. Kept apart from refit_internal.h, which the AVX2 and
// AVX-512 copies include: nothing with inline library code belongs there.
#pragma once

#include "skinspheres/runtime/error.h"
#include "skinspheres/runtime/format/sphere_set.h"

namespace skinspheres::runtime::internal {

// The bind pose stored as the fast refit's reference whether or not it bounds tighter
// (ChooseFastReference stores it only where it does); clears the reach groups. false (nothing
// stored) where the set has no mesh, is fast-only, or a transform cannot be inverted; an error when
// the set does not pass Validate() without a reference.
Result<bool> StoreBindFastReference(SphereSet* set);

}  // namespace skinspheres::runtime::internal
