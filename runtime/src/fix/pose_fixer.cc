// PoseFixer (fix/pose_fixer.h).
#include "skinspheres/runtime/fix/pose_fixer.h"

#include <algorithm>
#include <cmath>
#include <string>

#include "skinspheres/skinning/local_to_model_job.h"

namespace skinspheres::runtime {

Result<PoseFixer> PoseFixer::Create(std::shared_ptr<const CharacterAsset> asset) {
  if (!asset) return MakeError(ErrorCode::kInvalidArgument, "PoseFixer: no asset");
  const SphereSet& set = asset->sphere_set();
  if (!set.has_mesh() || !asset->narrow_phase()) {
    return MakeError(ErrorCode::kInvalidArgument, "PoseFixer: the set has no mesh (its triangles decide the contacts)");
  }
  if (set.joint_parents.size() != set.joint_count()) {
    return MakeError(ErrorCode::kVersionMismatch, "PoseFixer: the set has no joint parents");
  }
  auto instance = CharacterInstance::Create(asset);
  if (!instance.ok()) return instance.error();
  PoseFixer fixer;
  fixer.asset_ = std::move(asset);
  fixer.instance_.emplace(std::move(*instance));
  fixer.skeleton_.joint_names = set.joint_names;
  fixer.skeleton_.parents = set.joint_parents;
  fixer.skeleton_.rest_local.resize(set.joint_count());
  fixer.world_.resize(set.joint_count());
  fixer.solver_.emplace(set.joint_parents, TriangleJoints(set.mesh, set.triangle_vertices));
  return fixer;
}

Result<PlayedPose> PoseFixer::Play(std::span<const skinning::Transform> pose) {
  skinning::LocalToModelJob l2m;
  l2m.skeleton = &skeleton_;
  l2m.input = pose;
  l2m.output = world_;
  if (!l2m.Run()) return MakeError(ErrorCode::kInvalidArgument, "PoseFixer: the pose cannot be posed");
  FrameStatus status = instance_->UpdateFast(world_);
  if (status.code == ErrorCode::kOk) status = instance_->FindContacts();
  if (status.code != ErrorCode::kOk) return MakeError(status.code, std::string("PoseFixer: ") + status.message);
  return PlayedPose{&instance_->contacts(), world_};
}

float PoseFixer::Deepest(const std::vector<std::pair<uint16_t, uint16_t>>& allow) const {
  float deepest = 0.0f;
  for (const PoseViolation& v : solver_->Violations(instance_->contacts(), 0.0f, allow)) {
    deepest = std::max(deepest, v.depth);
  }
  return deepest;
}

Result<PoseFixResult> PoseFixer::Fix(std::span<skinning::Transform> locals, const PoseSolveSettings& settings) {
  if (locals.size() != skeleton_.size()) {
    return MakeError(ErrorCode::kInvalidArgument, "PoseFixer: a pose of " + std::to_string(locals.size()) +
                                                      " joints for a set of " + std::to_string(skeleton_.size()));
  }
  if (std::isnan(settings.max_depth) || settings.max_depth < 0.0f || std::isinf(settings.max_depth)) {
    return MakeError(ErrorCode::kInvalidArgument,
                     "PoseFixer: max_depth must be finite and >= 0 (0: the touch tolerance)");
  }
  for (size_t j = 0; j < locals.size(); ++j) {
    const skinning::Transform& t = locals[j];
    const float norm = t.rotation.norm();
    if (!t.translation.allFinite() || !t.scale.allFinite() || !t.rotation.coeffs().allFinite() || !(norm > 1e-6f) ||
        !(t.scale.cwiseAbs().minCoeff() > 0.0f)) {
      return MakeError(ErrorCode::kInvalidArgument,
                       "PoseFixer: joint " + std::to_string(j) + " (" + skeleton_.joint_names[j] +
                           "): a rotation of zero length, a zero scale or a value that is not finite");
    }
  }
  for (skinning::Transform& t : locals) {
    if (std::abs(t.rotation.norm() - 1.0f) > 1e-5f) t.rotation.normalize();  // unit ones stay bit for bit
  }
  PoseSolveSettings s = settings;
  if (!(s.max_depth > 0.0f)) s.max_depth = asset_->narrow_phase()->touch_tolerance();
  PoseFixResult result;
  auto before = Play(locals);
  if (!before.ok()) return before.error();
  result.deepest_before = Deepest(s.allow);
  correction_.assign(locals.size(), Eigen::Vector3f::Zero());
  auto steps = solver_->Solve(
      locals, s, [this](auto pose) { return Play(pose); }, &correction_);
  if (!steps.ok()) return steps.error();
  std::vector<skinning::Transform> fixed;
  ApplyCorrection(locals, correction_, &fixed);
  auto after = Play(fixed);
  if (!after.ok()) return after.error();
  result.deepest_after = Deepest(s.allow);
  result.holds = !(result.deepest_after > s.max_depth);
  result.steps = std::max(0, *steps);
  std::copy(fixed.begin(), fixed.end(), locals.begin());
  return result;
}

}  // namespace skinspheres::runtime
