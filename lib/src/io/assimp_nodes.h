// Private to io/: an Assimp scene's node tree, read the one way both Assimp readers need it, the
// character reader (importer_assimp.cc) and the animation-file reader (clip_import.cc). Not
// installed; include only from lib/src/io/.
#pragma once

#include <assimp/scene.h>

#include <cstdint>
#include <filesystem>
#include <map>
#include <string>
#include <vector>

#include "skinspheres/runtime/error.h"
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

}  // namespace skinspheres::lib::detail
