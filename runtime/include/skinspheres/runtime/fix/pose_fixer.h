// PoseFixer: a pose corrected at run time so that no part pair penetrates deeper than a limit,
// turning as few joints as little as it can (PoseSolver on the exact triangle contacts, skinned from
// the joint matrices: CharacterInstance's mode (b)). For engines that blend or generate poses.
//
// What:    Fix() changes the local rotations of the set's joints in place; translations and
//          scales stay. One pose alone: no smoothing over time (`skinspheres fix` eases whole
//          clips; an engine calling this per frame should ease the corrections it applies).
// Inputs:  every joint's local transform, in the set's joint order (SphereSet::joint_names,
//          parents SphereSet::joint_parents), roots in model space.
// Outputs: the corrected pose, and a PoseFixResult (holds, steps, deepest before and after).
// Memory:  Create allocates the instance; Fix allocates per call (a few small vectors).
// Cost:    each step plays the pose once (refit, broad phase, narrow phase): bench BM_FixPose.
// Threads: one PoseFixer per thread over one shared asset.
// Errors:  kInvalidArgument for a null asset, a set without mesh, a pose of another size, a joint
//          with a zero-length rotation, a zero scale or a value that is not finite (rotations not
//          of unit length are normalised), a max_depth negative or not finite;
//          kVersionMismatch for a set without joint parents.
#pragma once

#include <memory>
#include <optional>
#include <span>
#include <vector>

#include "skinspheres/runtime/api/character.h"
#include "skinspheres/runtime/fix/pose_solver.h"

namespace skinspheres::runtime {

struct PoseFixResult {
  bool holds = false;           // no part pair (not allowed) deeper than the limit after
  int steps = 0;                // least-squares steps taken
  float deepest_before = 0.0f;  // deepest penetration of a pair not allowed, model units
  float deepest_after = 0.0f;
};

class PoseFixer {
 public:
  static Result<PoseFixer> Create(std::shared_ptr<const CharacterAsset> asset);
  // settings.max_depth <= 0: the asset's touch tolerance.
  Result<PoseFixResult> Fix(std::span<skinning::Transform> locals, const PoseSolveSettings& settings);

 private:
  PoseFixer() = default;
  Result<PlayedPose> Play(std::span<const skinning::Transform> pose);
  float Deepest(const std::vector<std::pair<uint16_t, uint16_t>>& allow) const;

  std::shared_ptr<const CharacterAsset> asset_;
  std::optional<CharacterInstance> instance_;
  std::optional<PoseSolver> solver_;
  skinning::Skeleton skeleton_;
  std::vector<Mat4f> world_;
  std::vector<Eigen::Vector3f> correction_;
};

}  // namespace skinspheres::runtime
