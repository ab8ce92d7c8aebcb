// RetargetClips: clips made for one rig, re-expressed on a character's skeleton so that the
// character moves the way the clip moves its own skeleton.
//
// Steps (lib/src/retarget/retarget_stages.h lists them with their files):
//  1. Correspondence: source node -> target joint, from the joint map (JointMap) first, then equal
//     names, then equal MatchKeys (namespaces, "mixamorig:", "Armature|", "Bip01 " and ASCII case
//     ignored) where one node and one joint share the key.
//  2. Core joints: when the target is a humanoid (names, else the body-part split), its hips,
//     spine, upper arms and thighs must all have a counterpart, or the error (kNotFound) lists the
//     ones that have none.
//  3. Same rig or not: the rigs are the same when every matched joint below the hips has the same
//     bone offset (its translation in its parent's frame) in both, up to one unit factor (1%). A
//     posed node tree keeps its offsets, so this holds for a file that stores a posed frame as
//     its node transforms.
//  4. Same rig (or RetargetMode::kCopy): the tracks are copied as local transforms, as they are
//     (bit for bit), with translation tracks scaled per joint when the units differ (the joint's
//     offset lengths differ by more than 0.1%).
//  5. Other rig (or kWorld): the rest-relative transfer in world space. With Q world rotations,
//       Q_target(t) = A · Q_source(t) · Q_source_rest⁻¹ · A⁻¹ · Q_target_rest
//     for every mapped joint, where A is the one rotation that aligns the source's rest pose with
//     the target's (least squares over the matched joints of the torso, head and legs, or without
//     a body-part split every joint outside the upper arms) and the rest poses are the reference
//     poses below. Unmapped joints keep their rest local transform;
//     bone lengths stay the target's; the hips' world position follows the source's hips,
//       p_target(t) = p_target_rest + k · A · (p_source(t) − p_source_rest),
//     k the ratio of the hip heights (target / source) above the lowest matched joint. The
//     result is baked as LINEAR keys at every key time of the source (STEP changes kept sharp by
//     a key kRetargetStepEpsilon_s before them, CUBICSPLINE intervals subdivided).
//     A bone whose rest direction differs between the rigs (an A-pose arm on a T-pose character, a
//     thumb) keeps that difference throughout. With match_rest_directions, Q_target_rest is first
//     turned by the smallest rotation S_j that lays the joint's bone (towards its mapped child
//     with the most mapped joints below it) along A times the source's rest bone, so bone
//     directions follow the source's: Q_target(t) = A · Q_source(t) · Q_source_rest⁻¹ · A⁻¹ · S_j ·
//     Q_target_rest (S_j is the identity where the rest directions agree).
//     Reference poses: the target's is its bind pose (BindPoseWorld). The source's comes from
//     SourceRest: a skinned character of the source's rig (the clip's file itself when it has a
//     skin, or a file of the rig), joints matched to the file's nodes by name; a time of the clip;
//     the file's node transforms; or identity rotations of the matched joints at the file's
//     offsets. Without one the error (kInvalidArgument) says that the rigs differ, that the file
//     has no rest pose, and names the options.
//  6. Report: what was mapped, what was not, the rest-pose difference per limb (the angle between
//     each matched bone's rest direction in the two rigs after A) and the largest one.
//
// World rotations compose local rotations (scales are taken as positive and uniform, as in rigs).
// Errors are one line naming the file: kNotFound (no animations; core joints without a
// counterpart; nothing matched), kInvalidArgument (no source rest pose for another rig; a map
// entry that names an unknown joint, a cycle, a joint twice or reverses the hierarchy).
#pragma once

#include <cstdint>
#include <filesystem>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "skinspheres/lib/body_parts/body_parts.h"
#include "skinspheres/lib/character/raw_character.h"
#include "skinspheres/runtime/error.h"
#include "skinspheres/skinning/animation_clip.h"
#include "skinspheres/skinning/skeleton.h"

namespace skinspheres::lib {

inline constexpr float kRetargetStepEpsilon_s = 1e-4f;  // a baked STEP change: a key this much before it
inline constexpr int kRetargetCubicSubdivisions = 4;    // baked CUBICSPLINE: samples per key interval
// A transferred clip holds at most this many keys (bake times x mapped joints, the readers' own
// limit on a file's keys): more is refused (kInvalidData) before anything is allocated.
inline constexpr uint64_t kMaxRetargetKeys = uint64_t{1} << 24;

// Clips as a file holds them: its node tree and animations.
struct SourceRig {
  std::string source_file;                     // path as given, for messages
  skinning::Skeleton nodes;                    // every node of the file, parents first
  std::vector<skinning::AnimationClip> clips;  // tracks index `nodes`
};

// The name as matched: the text after the last ':' or '|', then a leading "mixamorig" (with
// digits and '_' after it, Blender's spelling of "mixamorig:") or "bip01 " / "bip001 " removed,
// in ASCII lower case. "mixamorig:LeftHand", "Armature|mixamorig1:LeftHand",
// "mixamorig_LeftHand" -> "lefthand"; "Bip01 L Hand" -> "l hand".
std::string MatchKey(std::string_view name);

// --joint-map: a JSON object {"source node": "target joint", ...}; null as a value leaves the
// source node unmapped (it then matches nothing by name either). Names are matched exactly, else
// by a MatchKey only one node (joint) has.
struct JointMap {
  std::string source_file;                                   // for messages
  std::vector<std::pair<std::string, std::string>> entries;  // in file order; "" = null
  std::vector<bool> is_null;                                 // per entry
};
inline constexpr uint64_t kMaxJointMapBytes = uint64_t{16} << 20;  // 16 MiB
// Reads the map. Errors name the file: kFileNotFound, kFileUnreadable (not a regular file),
// kFormatRejected (too large, nested too deep, malformed JSON, not an object, a value that is not
// a string or null, a key given twice), kInvalidArgument (a target joint named twice; a cycle,
// "A" -> "B" -> ... -> "A": renaming in a circle does not mirror a motion).
Result<JointMap> LoadJointMap(const std::filesystem::path& file);

enum class RetargetMode {
  kAuto,   // copy when the rigs are the same, else transfer
  kCopy,   // copy the local tracks (today's behaviour; wrong across rigs)
  kWorld,  // transfer even when the rigs are the same
};
const char* ToString(RetargetMode mode);  // "auto", "copy", "world"

// Where the source's rest pose (the pose its clips are relative to) comes from.
struct SourceRest {
  enum class Kind {
    kNone,      // none known: fine for the same rig, an error otherwise
    kRig,       // rig's bind pose, joints matched to the file's nodes by name
    kTime,      // the clip itself at time_s
    kNodes,     // the file's node transforms
    kIdentity,  // identity rotations at the file's offsets (rigs such as Mixamo's Y Bot)
  };
  Kind kind = Kind::kNone;
  const RawCharacter* rig = nullptr;  // kRig: a skinned character of the source's rig
  float time_s = 0.0f;                // kTime
  std::string label;                  // how the report names it: "the file's skin", "frame 0", ...
  float fps = 0.0f;                   // kTime given as a frame: its rate (names the clip's last frame)
};

struct RetargetOptions {
  RetargetMode mode = RetargetMode::kAuto;
  const JointMap* joint_map = nullptr;      // optional
  SourceRest source_rest;                   // used when the rigs differ
  bool match_rest_directions = false;       // transfer: bones follow the source's rest directions
  const BodyParts* target_parts = nullptr;  // optional: humanoid roles by structure, limbs in the report
};

struct RestDifference {
  std::string limb;   // body part ("arm_l") or the joint's name when there are no parts
  std::string joint;  // the bone's joint (its start) with the largest difference
  float degrees = 0.0f;
};

struct RetargetReport {
  bool transferred = false;                         // false: tracks copied (same rig or kCopy)
  bool rest_directions_matched = false;             // transfer with match_rest_directions
  std::string rest_from;                            // the source rest pose used ("" when copied)
  std::vector<std::pair<int32_t, int32_t>> mapped;  // (target joint, source node), by target joint
  std::vector<std::string> unmapped_deforming;      // target joints that move vertices, without counterpart
  size_t unmapped_joints = 0;                       // every target joint without counterpart
  std::vector<std::string> dropped_nodes;           // source nodes with tracks and no target joint
  std::vector<std::string> rescaled_joints;         // copy: joints whose translation tracks were scaled
  std::string offsets_differ_at;                    // first joint whose bone offset differs ("" = same rig)
  float hip_scale = 1.0f;                           // transfer: k, the ratio of hip heights
  std::string root_joint;                           // transfer: the joint whose translation follows the source's
  float alignment_degrees = 0.0f;                   // transfer: the angle of A
  std::vector<RestDifference> rest_differences;     // transfer: per limb, largest first
  RestDifference largest_rest_difference;           // transfer: over every matched bone
};

// The file's clips on `target`'s skeleton (the contract above). Clip names and durations are kept.
Result<std::vector<skinning::AnimationClip>> RetargetClips(const SourceRig& source, const RawCharacter& target,
                                                           const RetargetOptions& options,
                                                           RetargetReport* report = nullptr);

// The bind pose of a character in world space, per joint: C · IBM⁻¹ of the joint's first bind
// entry, or (a joint without one) its parent's times its rest local transform. C takes the skin's
// bind space to the world: G_j(rest) · IBM_j where at least half the bound joints agree on it (a
// skin bound in a Z-up mesh space under a Y-up scene), else the identity (a character whose rest
// pose is not its bind pose).
std::vector<Mat4f> BindPoseWorld(const RawCharacter& character);

}  // namespace skinspheres::lib
