// Private to io/: what both Assimp readers, the character reader (importer_assimp.cc) and the
// animation-file reader (clip_import.cc), read the same way from an Assimp scene: the node tree,
// and each animation's clip header and keys. Not installed; included from lib/src/io/ and by its
// unit tests (tests/lib/io/assimp_clip_tests.cc).
#pragma once

#include <assimp/scene.h>

#include <cstdint>
#include <filesystem>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "skinspheres/runtime/error.h"
#include "skinspheres/skinning/animation_clip.h"
#include "skinspheres/skinning/math_types.h"
#include "skinspheres/skinning/skeleton.h"

namespace skinspheres::lib::detail {

// Assimp's row-major aiMatrix4x4 as a Mat4f (same element order, column vectors).
Mat4f ToMat4f(const aiMatrix4x4& m);

// Every node reachable from the scene's root once, in preorder (parents first, children in file
// order); a node reached a second time is skipped.
struct AssimpNodeTree {
  std::vector<const aiNode*> nodes;
  std::vector<int32_t> parent;                  // index into nodes; -1 for the root
  std::vector<skinning::Transform> local;       // each node's mTransformation
  std::map<std::string, int32_t> node_of_name;  // the first node of each name in preorder

  // The first node called `name` in preorder (what aiNode::FindNode from the root answers, from one
  // map: FindNode recurses, and per bone or channel it would make the work nodes x lookups); -1
  // when no node has that name.
  int32_t Find(const aiString& name) const;
};

// The tree of `scene` (its root must be non-null). Error kInvalidData "<file>: node '<name>' has a
// non-finite transform" for the first such node in preorder.
Result<AssimpNodeTree> ReadAssimpNodeTree(const aiScene& scene, const std::filesystem::path& file);

// An animation's clip before its tracks: the name (the animation's, or "animation_<index>" when it
// has none), the duration in seconds, and the ticks per second its keys are timed in (Assimp's
// default of 25 when the file gives 0, Assimp's "not given"). Error kInvalidData "<file>:
// animation "<name>" has a bad tick rate" for a rate that is negative or not finite, "... has a
// bad duration" for a duration that is negative or not finite. Callers skip animations with no
// node channel (morph or camera animation only): they move no joint, and Assimp leaves their
// duration at -1.
struct ClipHeader {
  skinning::AnimationClip clip;  // name and duration_s set, no tracks
  double ticks_per_second = 25.0;
};
Result<ClipHeader> ReadClipHeader(const aiAnimation& anim, unsigned index, const std::filesystem::path& file);

// Appends the translation, rotation (normalised, in double) and scale keys of `channel` to
// `track`, times in seconds. A key at the time of the previous one replaces it; an earlier one,
// or one at a non-finite time, is ignored (times strictly increasing, as Track requires). Error
// kInvalidData "<file>: animation "<clip>" has a key value that is NaN or infinite on node
// <node>" for the first key value that is not finite, "... has a rotation key of zero length on
// node <node>" for a rotation that is no rotation (`track` is then partly filled: drop it);
// nullopt otherwise (the optional<Error> of RawCharacter::Validate).
std::optional<Error> AppendChannelKeys(const aiNodeAnim& channel, const ClipHeader& header,
                                       const std::filesystem::path& file, skinning::JointTrack* track);

}  // namespace skinspheres::lib::detail
