// SplitBodyParts: a skinned character -> body parts (torso, head, arms, legs, or chains).
//
// Decided from skeleton topology, skin weights and rest-pose geometry, never from names alone:
//  - A triangle's dominant joint is the joint with the largest summed weight over its 3 vertices
//    (bind entries map to joints through skin.binds[b].joint; ties -> smallest joint index).
//    A triangle whose vertices carry no weight at all takes its mesh's rigid_joint, else the
//    first root. Every triangle belongs to exactly one part: the part of its dominant joint.
//  - Only joints that carry weight (dominant joint of a vertex or a triangle) shape the body;
//    weightless helpers (Mixamo "HeadTop_End", finger ends, armature / Z-up nodes above the hips)
//    are skipped when looking for the structure and inherit their nearest ancestor's part
//    (-1 above the body).
//  - Humanoid: a pelvis P whose weighted children include two similar downward chains (legs) and
//    one upward chain (spine) that reaches a chest C whose weighted children include two lateral
//    chains (arms) and one upward chain (neck + head). "Up" comes from the legs towards the head;
//    "forward" from where the feet point (toes ahead of ankles); the character's left is
//    up x forward (glTF: +Y up, facing +Z -> left is +X). Names ("Left", "_L", ".L", ...) only
//    break ties where the feet give no direction; failing both, the glTF facing (+Z) is assumed.
//    Parts: torso = P .. C plus weighted joints above P; head = C's upward child subtree;
//    arm = clavicle/shoulder subtree; leg = thigh subtree. Weighted subtrees that hang
//    elsewhere (RobotExpressive's IK feet under the root, a prop bone) join the part whose bones
//    are nearest in the rest pose. Among several (P, C, head, arms, legs) choices the one with
//    the best mirror symmetry, limb similarity, spine-along-up and share of the weighted vertices
//    wins. The pelvis must be an ancestor of the spine (a rig rooted at the chest is not
//    recognised and falls back to chains).
//  - Not humanoid: one part per chain of the weighted tree, split at branch points (a branch
//    joint ends the chain that reaches it; each of its weighted children starts a new chain),
//    named chain_<k> in depth-first order.
//  - Overrides (joint name -> part name) are applied last: the joint moves to the named part,
//    and its triangles with it.
// Deterministic: the same input gives the same parts, independent of threads (there are none).
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <filesystem>
#include <map>
#include <string>
#include <vector>

#include "skinspheres/lib/character/raw_character.h"
#include "skinspheres/runtime/error.h"

namespace skinspheres::lib {

enum class PartKind { kTorso, kHead, kArmLeft, kArmRight, kLegLeft, kLegRight, kChain };

// "torso", "head", "arm_l", "arm_r", "leg_l", "leg_r"; kChain -> "chain".
const char* ToString(PartKind kind);

struct BodyPart {
  std::string name;  // "torso","head","arm_l","arm_r","leg_l","leg_r" or "chain_<k>"
  PartKind kind = PartKind::kChain;
  // Every joint of the part: the main chain first (root to tip), then the side branches
  // (fingers, weightless ends) in depth-first order.
  std::vector<int32_t> joints;
  // The main bone chain the disk follows, parent to child: torso = pelvis .. top of the spine
  // (neck base); head = neck .. head (end joint if present); limbs = clavicle/shoulder or thigh
  // .. wrist/ankle and on, at each fork, towards the joint farthest from the chain's start
  // (the middle finger on Mixamo hands, the toe end) where present. A detached
  // weighted chain that continues a limb's tip (an IK foot) is appended.
  std::vector<int32_t> chain;
  std::vector<uint32_t> triangles;  // ascending triangle indices
};

struct BodyParts {
  std::vector<BodyPart> parts;          // humanoid: torso, head, arm_l, arm_r, leg_l, leg_r
  std::vector<int32_t> joint_part;      // skeleton.size(): part index per joint, -1 if none
  std::vector<int32_t> triangle_part;   // triangle_count(): part index per triangle (never -1)
  std::vector<int32_t> triangle_joint;  // triangle_count(): dominant joint per triangle
  bool humanoid = false;
  // Humanoid only (zero / "" otherwise): unit axes in rest world space, up = legs -> head,
  // left = the character's left (up x forward), and what decided the facing: "feet", "names"
  // (the feet gave no direction) or "convention" (neither did the names: facing +Z assumed).
  Eigen::Vector3f up = Eigen::Vector3f::Zero();
  Eigen::Vector3f left = Eigen::Vector3f::Zero();
  std::string facing_from;

  // Index of the part with this name, or -1.
  int32_t Find(std::string_view name) const;
};

// Joint name -> part name, as read from a JSON object {"joint name": "part name", ...}.
struct PartOverrides {
  std::string source_file;  // for messages ("" when built in code)
  std::map<std::string, std::string> joint_to_part;
};

// Reads {"joint name": "part name", ...}. Part names must be torso, head, arm_l, arm_r, leg_l,
// leg_r or chain_<k>. With a skeleton, every joint name must exist in it.
// Errors name the file: kFileNotFound, kFileUnreadable (also a FIFO, device or directory: only a
// regular file is read), kFormatRejected (larger than kMaxPartsFileBytes, nested deeper than
// runtime::kMaxJsonDepth, malformed JSON, not an object, a value that is not a string),
// kNotFound (unknown joint), kInvalidArgument (unknown part name).
inline constexpr uint64_t kMaxPartsFileBytes = uint64_t{16} << 20;  // 16 MiB
Result<PartOverrides> LoadPartOverrides(const std::filesystem::path& file,
                                        const skinning::Skeleton* skeleton = nullptr);

// Errors: kInvalidData (RawCharacter::Validate refuses the character: skeleton arrays disagree,
// influences / binds / triangle indices out of range), kNotFound (an override names a joint the skeleton lacks),
// kInvalidArgument (an override names a part this character does not have, e.g. "arm_l" on a snake).
Result<BodyParts> SplitBodyParts(const RawCharacter& character, const PartOverrides* overrides = nullptr);

}  // namespace skinspheres::lib
