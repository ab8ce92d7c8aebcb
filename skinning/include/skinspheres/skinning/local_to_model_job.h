// LocalToModelJob: per-joint local transforms -> model-space (world) matrices.
//
// G_i = G_parent(i) · L_i, computed in one forward pass because the skeleton stores parents first
// (parents[i] < i). Roots are premultiplied by `root` (identity by default) so a character can be
// placed in the world. input holds the locals (e.g. SamplingJob's output, or an engine's own
// pose); output receives one matrix per joint. Both spans must hold >= skeleton->size() entries.
// Run() validates, never allocates, never throws.
#pragma once

#include <Eigen/Core>
#include <span>

#include "skinspheres/skinning/math_types.h"
#include "skinspheres/skinning/skeleton.h"

namespace skinspheres::skinning {

struct LocalToModelJob {
  const Skeleton* skeleton = nullptr;
  Mat4f root = Mat4f::Identity();    // applied to every root joint
  std::span<const Transform> input;  // >= skeleton->size(), joint-local TRS
  std::span<Mat4f> output;           // >= skeleton->size(), model space

  bool Validate() const;
  bool Run() const;
};

}  // namespace skinspheres::skinning
