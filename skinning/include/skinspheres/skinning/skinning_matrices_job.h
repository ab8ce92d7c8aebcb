// SkinningMatricesJob: model-space joint matrices -> one skinning matrix per bind entry.
//
// M_b = G_joint(b) · IBM_b (skinned_mesh.h: a bind entry pairs a joint with an inverse bind
// matrix). The result is what SkinningJob reads as joint_matrices. joint_model may come from
// LocalToModelJob or straight from an engine's animation system; no clip is involved.
// Sizes: joint_model >= 1 + the largest bind joint, output >= binds.size().
// Run() validates, never allocates, never throws.
#pragma once

#include <Eigen/Core>
#include <span>

#include "skinspheres/skinning/math_types.h"
#include "skinspheres/skinning/skinned_mesh.h"

namespace skinspheres::skinning {

struct SkinningMatricesJob {
  std::span<const BindEntry> binds;    // e.g. SkinnedMesh::binds
  std::span<const Mat4f> joint_model;  // G_j per skeleton joint
  std::span<Mat4f> output;             // >= binds.size(): M_b

  bool Validate() const;
  bool Run() const;
};

}  // namespace skinspheres::skinning
