// Which joints a sphere set lists, which of them the runtime reads, and the mapping from an
// engine's own joint list to them.
//
// What a set lists (SphereSet::joint_names, joint_parents, joint_rest_world): the character's
// skeleton as the fitter read it, i.e. every node of the file's scene on a path from the scene root
// to a skin joint, parents first. That is the skin's joints plus their non-joint ancestors, which
// carry the file's own placement (an axis change, a unit scale) so that the rest transforms are in
// the file's world space. Xbot: 66 joints, `Armature` (a node that is not a skin joint) followed by
// the glTF skin's 65 `mixamorig:` joints; an engine that imports Xbot has those 65.
//
// What the runtime reads every frame: G_j(t) of the joints that influence a sphere
// (SphereSet::influence_joints: fast refit, and the centres in exact refit) and, when the set has
// a mesh, of the joints of its bind entries (per-vertex skinning for triangle tests). Those are skin
// joints; an ancestor such as `Armature` is never read. JointsReadPerFrame lists them.
//
// The engine passes joint world matrices in its own order: JointMapping maps each set joint to the
// engine joint of the same name (exact match), and CharacterInstance::Create(asset, mapping) makes
// the instance read matrices in the engine's order (a gather of the read joints per update, into a
// buffer sized at set-up: no allocation). The matrices must all be in one frame (model or world
// space, including or not the ancestors' transform): the spheres come out in that frame.
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "skinspheres/runtime/error.h"
#include "skinspheres/runtime/format/sphere_set.h"

namespace skinspheres::runtime {

struct JointMapping {
  static constexpr int32_t kUnmapped = -1;

  // Per set joint: the engine joint of the same name, or kUnmapped (only for joints never read).
  std::vector<int32_t> engine_index;
  // How many joints the engine's list has: the matrices an update then takes.
  size_t engine_joint_count = 0;
  // Set joints the engine's list lacks, none of them read per frame (e.g. `Armature`).
  std::vector<std::string> unmapped_set_joints;
  // Engine joints the set does not list (ignored: helper bones, IK targets, props).
  std::vector<std::string> extra_engine_joints;

  // True when the engine's list is the set's list in the same order (no gather needed).
  bool identity() const;
};

// Per set joint: whether the runtime reads its matrix every frame (see the header comment).
std::vector<bool> JointsReadPerFrame(const SphereSet& set);

// Maps the engine's joint names onto the set's joints by exact name. The set's own list, in its
// order, is the identity (even where names repeat). Refused (kMismatchedAsset, the message naming
// the set's file, see DescribeSphereSet, and up to 8 joints by name) when a joint read per frame is
// not in the engine's list, or its name appears twice in either list (ambiguous). Joints the set
// lists but never reads may be missing; extra engine joints are allowed; both are reported by name
// in the result.
Result<JointMapping> MapJoints(const SphereSet& set, std::span<const std::string> engine_joint_names);

// "sphere set 'xbot.ssb' (fitted on Xbot.glb)": the file the set was loaded from (loaded_from)
// and the character it was fitted on, for messages.
std::string DescribeSphereSet(const SphereSet& set);

}  // namespace skinspheres::runtime
