// The naive baseline of the fit metrics: one sphere per joint around the vertices it dominates.
// See naive_joint_spheres.h.
#include "skinspheres/lib/metrics/naive_joint_spheres.h"

#include <algorithm>
#include <limits>

#include "metrics_internal.h"

namespace skinspheres::lib {

using metrics_internal::Finite;
using metrics_internal::Invalid;

Result<JointSpheres> NaiveJointSpheres(std::span<const Eigen::Vector3f> positions,
                                       std::span<const uint32_t> dominant_joint) {
  if (positions.size() != dominant_joint.size())
    return Invalid(std::to_string(dominant_joint.size()) + " dominant joints for " + std::to_string(positions.size()) +
                   " vertices");
  if (positions.empty()) return Invalid("no vertices");
  uint32_t joints = 0;
  for (size_t i = 0; i < positions.size(); ++i) {
    if (!Finite(positions[i])) return Invalid("vertex " + std::to_string(i) + " is not finite");
    joints = std::max(joints, dominant_joint[i] + 1);
  }
  if (joints > (1u << 24)) return Invalid("dominant joint index too large");
  std::vector<Eigen::Vector3f> lo(joints, Eigen::Vector3f::Constant(std::numeric_limits<float>::max())),
      hi(joints, -lo[0]);
  std::vector<uint8_t> used(joints, 0);
  for (size_t i = 0; i < positions.size(); ++i) {
    const uint32_t j = dominant_joint[i];
    lo[j] = lo[j].cwiseMin(positions[i]);
    hi[j] = hi[j].cwiseMax(positions[i]);
    used[j] = 1;
  }
  JointSpheres out;
  std::vector<int32_t> slot(joints, -1);
  for (uint32_t j = 0; j < joints; ++j) {
    if (!used[j]) continue;
    slot[j] = int32_t(out.centers.size());
    out.centers.push_back(0.5f * (lo[j] + hi[j]));
    out.radii.push_back(0.f);
    out.joints.push_back(j);
  }
  for (size_t i = 0; i < positions.size(); ++i) {
    const int32_t s = slot[dominant_joint[i]];
    out.radii[size_t(s)] = std::max(out.radii[size_t(s)], (positions[i] - out.centers[size_t(s)]).norm());
  }
  return out;
}

Result<JointSpheres> NaiveJointSpheres(const RawCharacter& character) {
  const skinning::SkinnedMesh& skin = character.skin;
  std::vector<uint32_t> dominant(character.vertex_count(), 0);
  if (skin.influence_offsets.size() == character.vertex_count() + 1) {
    for (size_t v = 0; v < character.vertex_count(); ++v) {
      float best = -1.f;
      for (uint32_t k = skin.influence_offsets[v]; k < skin.influence_offsets[v + 1]; ++k) {
        if (k >= skin.influence_weights.size() || k >= skin.influence_binds.size() ||
            skin.influence_binds[k] >= skin.binds.size())
          return Invalid(character.source_file + ": skin influence " + std::to_string(k) + " is out of range");
        if (skin.influence_weights[k] > best) {
          best = skin.influence_weights[k];
          dominant[v] = uint32_t(std::max(0, skin.binds[skin.influence_binds[k]].joint));
        }
      }
    }
  } else if (!skin.influence_offsets.empty()) {
    return Invalid(character.source_file + ": influence_offsets has " + std::to_string(skin.influence_offsets.size()) +
                   " entries for " + std::to_string(character.vertex_count()) + " vertices");
  }
  return NaiveJointSpheres(character.positions_rest, dominant);
}

}  // namespace skinspheres::lib
