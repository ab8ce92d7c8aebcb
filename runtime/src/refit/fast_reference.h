// The fast refit's frame of reference (docs/REFIT.md#reference-frame): the reference a set stores,
// and the bind-pose reference stored unconditionally, for tests that weigh it against the rest
// pose. Kept apart from refit_internal.h, which the AVX2 and AVX-512 copies include: nothing with
// inline library code belongs there.
#pragma once

#include <vector>

#include "format/affine_inverse.h"
#include "skinspheres/runtime/error.h"
#include "skinspheres/runtime/format/sphere_set.h"

namespace skinspheres::runtime::internal {

// A frame of reference of the fast refit (docs/REFIT.md#reference-frame): per joint the inverse of
// its reference transform, per sphere its centre in reference space and its radius there (each
// source vertex's weighted mean reference copy distance, FastReferenceRadiiFromMesh).
struct Reference {
  std::vector<Mat4d> inverse;  // per joint: G_j(rest)^-1, or the stored R_j^-1
  std::vector<Vec4d> center;   // per sphere, homogeneous
  std::vector<float> radius;   // per sphere
};

// The reference the set stores (sphere_set.h), else its rest pose. An error names a joint whose
// rest transform cannot be inverted.
Result<Reference> StoredReference(const SphereSet& set);

// The bind pose stored as the fast refit's reference whether or not it bounds tighter
// (ChooseFastReference stores it only where it does); clears the reach groups. false (nothing
// stored) where the set has no mesh, is fast-only, or a transform cannot be inverted; an error when
// the set does not pass Validate() without a reference.
Result<bool> StoreBindFastReference(SphereSet* set);

}  // namespace skinspheres::runtime::internal
