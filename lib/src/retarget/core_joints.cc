// The core humanoid joints of a target (retarget_stages.h): by name, else from the body-part
// split; the refusal when one of them has no counterpart; the joint that carries root motion.
#include <algorithm>
#include <cmath>

#include "retarget_stages.h"

namespace skinspheres::lib::retarget {
namespace {

// MatchKey'd spellings per role, in order of preference (Mixamo, Unreal, Blender, 3ds Max biped).
// clang-format off
const std::vector<std::vector<std::string_view>> kNames = {
  {"hips", "pelvis", "hip"},
  {"spine", "spine_01", "spine01", "spine1", "abdomen"},
  {"leftarm", "leftupperarm", "upperarm_l", "l_upperarm", "upperarm.l", "upper_arm.l", "l upperarm", "upperarm_left"},
  {"rightarm", "rightupperarm", "upperarm_r", "r_upperarm", "upperarm.r", "upper_arm.r", "r upperarm", "upperarm_right"},
  {"leftupleg", "leftupperleg", "leftthigh", "thigh_l", "l_thigh", "thigh.l", "l thigh", "upperleg.l", "upperleg_l"},
  {"rightupleg", "rightupperleg", "rightthigh", "thigh_r", "r_thigh", "thigh.r", "r thigh", "upperleg.r", "upperleg_r"},
};
// clang-format on

int32_t FindByKeys(const skinning::Skeleton& s, const std::vector<std::string_view>& keys) {
  for (std::string_view key : keys) {
    for (size_t j = 0; j < s.size(); ++j) {
      if (MatchKey(s.joint_names[j]) == key) return static_cast<int32_t>(j);
    }
  }
  return -1;
}

// The upper arm on an arm chain: its first joint, or the second when the first bone is a short
// clavicle (under 0.6 of the next bone).
int32_t UpperArm(const std::vector<int32_t>& chain, const std::vector<Mat4f>& world) {
  if (chain.empty()) return -1;
  if (chain.size() < 3) return chain.front();
  auto at = [&](size_t k) { return Eigen::Vector3f(world[static_cast<size_t>(chain[k])].topRightCorner<3, 1>()); };
  const float first = (at(1) - at(0)).norm(), second = (at(2) - at(1)).norm();
  return first < 0.6f * second ? chain[1] : chain[0];
}

}  // namespace

const char* CoreJoints::Role(size_t k) {
  static const char* kRoles[kCount] = {"hips",       "spine",      "left upper arm", "right upper arm",
                                       "left thigh", "right thigh"};
  return k < kCount ? kRoles[k] : "?";
}

CoreJoints FindCoreJoints(const RawCharacter& target, const BodyParts* parts) {
  CoreJoints core;
  const skinning::Skeleton& s = target.skeleton;
  for (size_t k = 0; k < CoreJoints::kCount; ++k) core.joint[k] = FindByKeys(s, kNames[k]);
  if (parts == nullptr || !parts->humanoid) return core;
  std::vector<Mat4f> world(s.size());
  s.RestWorld(world);
  auto chain = [&](const char* name) -> const std::vector<int32_t>& {
    static const std::vector<int32_t> kNone;
    const int32_t p = parts->Find(name);
    return p >= 0 ? parts->parts[static_cast<size_t>(p)].chain : kNone;
  };
  const auto& torso = chain("torso");
  const int32_t by_structure[CoreJoints::kCount] = {torso.empty() ? -1 : torso[0],
                                                    torso.size() < 2 ? -1 : torso[1],
                                                    UpperArm(chain("arm_l"), world),
                                                    UpperArm(chain("arm_r"), world),
                                                    chain("leg_l").empty() ? -1 : chain("leg_l")[0],
                                                    chain("leg_r").empty() ? -1 : chain("leg_r")[0]};
  for (size_t k = 0; k < CoreJoints::kCount; ++k) {
    if (core.joint[k] < 0) core.joint[k] = by_structure[k];
  }
  return core;
}

std::optional<Error> CheckCoreJoints(const CoreJoints& core, const Correspondence& c, const SourceRig& source,
                                     const RawCharacter& target) {
  std::string missing;
  for (size_t k = 0; k < CoreJoints::kCount; ++k) {
    const int32_t j = core.joint[k];
    if (j < 0 || c.node_of[static_cast<size_t>(j)] >= 0) continue;
    missing += (missing.empty() ? "" : ", ") + std::string(CoreJoints::Role(k)) + " (" +
               target.skeleton.joint_names[static_cast<size_t>(j)] + ")";
  }
  const size_t matched =
      static_cast<size_t>(std::count_if(c.node_of.begin(), c.node_of.end(), [](int32_t n) { return n >= 0; }));
  if (missing.empty() && matched > 0) return std::nullopt;
  if (missing.empty()) missing = "every joint";
  return MakeError(ErrorCode::kNotFound,
                   source.source_file + ": cannot drive " + target.Name() + ": no joint of this file matches its " +
                       missing + " (" + std::to_string(matched) + " of its " + std::to_string(target.skeleton.size()) +
                       " joints matched by name; name the others in --joint-map)");
}

int32_t RootMotionJoint(const CoreJoints& core, const Correspondence& c, const skinning::Skeleton& target) {
  if (core.hips() >= 0 && c.node_of[static_cast<size_t>(core.hips())] >= 0) return core.hips();
  int32_t best = -1, best_depth = 0;
  for (size_t j = 0; j < target.size(); ++j) {
    if (c.node_of[j] < 0) continue;
    int32_t depth = 0;
    for (int32_t a = target.parents[j]; a >= 0; a = target.parents[static_cast<size_t>(a)]) ++depth;
    if (best < 0 || depth < best_depth) best = static_cast<int32_t>(j), best_depth = depth;
  }
  return best;
}

}  // namespace skinspheres::lib::retarget
