// The stages of RetargetClips (retarget/retarget.h), in the order it runs them. Internal to lib/.
//
//   MatchJoints            joint_correspondence.cc  the joint map, equal names, equal keys
//   FindCoreJoints         core_joints.cc           the target's hips, spine, upper arms, thighs
//   CheckCoreJoints        core_joints.cc           each of them has a counterpart
//   FirstOffsetDifference  same_rig.cc              the same rig or not (bone offsets)
//   CopyTracks             copy_tracks.cc           the same rig: the tracks as they are
//   TargetReference        reference_pose.cc        the target's bind pose
//   SourceReference        reference_pose.cc        the source's rest pose, from SourceRest
//   AlignRestPoses         rest_alignment.cc        A, the hip-height ratio, rest differences
//   TransferClip           rotation_transfer.cc     the world-space, rest-relative transfer, baked
#pragma once

#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "skinspheres/lib/retarget/retarget.h"

namespace skinspheres::lib::retarget {

// Source node <-> target joint, one to one.
struct Correspondence {
  std::vector<int32_t> joint_of;  // per source node: its target joint, or -1
  std::vector<int32_t> node_of;   // per target joint: its source node, or -1
};

// Map entries first (checked: every name known, no joint twice, the hierarchy kept: a joint
// above another in the target maps to a node that is not below the other's node in the
// source), then equal names, then equal MatchKeys shared by exactly one node and one joint.
// Source nodes the map sets to null match nothing. Errors name the map file (kInvalidArgument).
Result<Correspondence> MatchJoints(const SourceRig& source, const RawCharacter& target, const JointMap* map);

// The joints a humanoid clip must drive: by name ("hips", "spine", "leftarm", "leftupleg", and
// the other usual spellings, MatchKey'd), else from the body-part split (torso chain: pelvis,
// then spine; each arm chain's upper arm, after a short clavicle bone; each leg chain's thigh).
// -1 where neither finds one (a non-humanoid target has none).
struct CoreJoints {
  static constexpr size_t kCount = 6;
  std::array<int32_t, kCount> joint{-1, -1, -1, -1, -1, -1};  // hips, spine, arm_l, arm_r, thigh_l, thigh_r
  static const char* Role(size_t k);                          // "hips", "spine", "left upper arm", ...
  int32_t hips() const { return joint[0]; }
};
CoreJoints FindCoreJoints(const RawCharacter& target, const BodyParts* parts);

// nullopt when every core joint found has a counterpart; else kNotFound naming the file and the
// roles and joints without one.
std::optional<Error> CheckCoreJoints(const CoreJoints& core, const Correspondence& c, const SourceRig& source,
                                     const RawCharacter& target);

// The joint whose translation carries the motion: the hips when found and mapped, else the
// mapped joint nearest a root (-1 when nothing is mapped).
int32_t RootMotionJoint(const CoreJoints& core, const Correspondence& c, const skinning::Skeleton& target);

// The first matched joint below the root-motion joint whose bone offset differs between the
// rigs (beyond one unit factor and 1%), or -1 when none does (the same rig).
int32_t FirstOffsetDifference(const SourceRig& source, const skinning::Skeleton& target, const Correspondence& c,
                              int32_t root_joint);

// The same rig: every track of a matched node on its joint, as it is, translation tracks scaled
// per joint when the offsets' lengths differ by more than 0.1%. Fills rescaled_joints.
std::vector<skinning::AnimationClip> CopyTracks(const SourceRig& source, const skinning::Skeleton& target,
                                                const Correspondence& c, RetargetReport* report);

// A pose in world space: per joint, its rotation (local rotations composed) and position.
struct WorldPose {
  std::vector<Quatf> rotation;
  std::vector<Eigen::Vector3f> position;
};
// The pose of `locals` on `skeleton` (rotations composed as quaternions, positions by matrices).
void PoseOf(const skinning::Skeleton& skeleton, std::span<const skinning::Transform> locals, WorldPose* out,
            std::vector<Mat4f>* scratch);

// The target's bind pose (BindPoseWorld) as a WorldPose.
WorldPose TargetReference(const RawCharacter& target);

// The source's rest pose for clip `clip` (SourceRest::Kind), in the file's world. kRig: each
// matched node whose name (or unique MatchKey) a joint of the rig has takes the rotation of that
// joint's bind pose relative to its parent in the rig; kIdentity: each matched node takes the
// identity rotation; kTime: the clip sampled at time_s. Other nodes, translations and scales keep
// the file's node transforms (its units). Errors (naming the file): kInvalidArgument for kNone or
// a rig none of whose joints is named as a matched node, kInvalidData for a clip that cannot be
// sampled.
Result<WorldPose> SourceReference(const SourceRig& source, const SourceRest& rest, const Correspondence& c,
                                  size_t clip);

// The rotation A, the hip-height ratio k and the rest-pose differences (retarget.h, step 5-6).
// With match_directions, per target joint the swing S_j that lays its rest bone along the
// source's (retarget.h, step 5); else every S_j is the identity.
struct Alignment {
  Quatf rotation = Quatf::Identity();  // A: source world -> target world
  float hip_scale = 1.0f;              // k
  std::vector<Quatf> swing;            // S_j, per target joint
};
struct AlignmentSettings {
  const BodyParts* parts = nullptr;  // limbs in the report, the up direction (humanoids)
  std::vector<char> aligning;        // per target joint: its rest position takes part in finding A
  int32_t root_joint = -1;           // RootMotionJoint
  bool match_directions = false;
};
// The joints whose rest directions A-pose and T-pose rigs share, which A is fitted to: the torso,
// head and legs of a humanoid split, else every joint outside the core upper arms' subtrees.
std::vector<char> AligningJoints(const RawCharacter& target, const BodyParts* parts, const CoreJoints& core);
Alignment AlignRestPoses(const WorldPose& source_rest, const WorldPose& target_rest, const Correspondence& c,
                         const RawCharacter& target, const AlignmentSettings& settings, RetargetReport* report);

// One clip transferred: a rotation track per mapped joint and a translation track on
// `root_joint`, LINEAR keys at the bake times (retarget.h). Errors (kInvalidData) name the file.
Result<skinning::AnimationClip> TransferClip(const SourceRig& source, size_t clip, const RawCharacter& target,
                                             const Correspondence& c, const WorldPose& source_rest,
                                             const WorldPose& target_rest, const Alignment& alignment,
                                             int32_t root_joint);

// The key times a clip's transfer is baked at: every key, a key kRetargetStepEpsilon_s before
// each STEP change, kRetargetCubicSubdivisions samples per CUBICSPLINE interval, 0 and the
// duration; sorted, unique, inside [0, duration].
std::vector<float> BakeTimes(const skinning::AnimationClip& clip);

}  // namespace skinspheres::lib::retarget
