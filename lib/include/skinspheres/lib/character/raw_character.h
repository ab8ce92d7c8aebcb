// RawCharacter: an imported (or generated) skinned character, editable, before fitting.
//
// The mesh is one indexed triangle list in the rest pose, in the world space of the file's
// scene: each skinned vertex at Σ_k w_k · G_j(k) · IBM_k · p_bind (G from the node tree, no clip
// applied), each rigid mesh at its node's world transform. Vertices and triangles keep the
// file's order (mesh by mesh, primitive by primitive); nothing is reordered, welded or dropped,
// degenerate triangles included.
//
// Validate() holds the rules every stage relies on (the body-part split, the fitter, the GLB
// exporter call it first instead of checking them one by one).
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "skinspheres/runtime/error.h"
#include "skinspheres/skinning/animation_clip.h"
#include "skinspheres/skinning/skeleton.h"
#include "skinspheres/skinning/skinned_mesh.h"

namespace skinspheres::lib {

struct MeshRange {
  std::string name;
  uint32_t first_vertex = 0, vertex_count = 0;
  uint32_t first_triangle = 0, triangle_count = 0;
  bool skinned = false;  // false: rigid, follows `rigid_joint` (or the root) with weight 1
  int32_t rigid_joint = -1;
};

struct RawCharacter {
  std::string source_file;      // path as given, for messages
  skinning::Skeleton skeleton;  // >= 1 joint (a static file gets one)
  std::vector<skinning::AnimationClip> clips;
  skinning::SkinnedMesh skin;  // bind-space positions, bind entries, influences

  std::vector<Eigen::Vector3f> positions_rest;  // world space, rest pose (what is fitted)
  std::vector<Eigen::Vector3i> triangles;       // indices into positions_rest
  std::vector<MeshRange> meshes;

  size_t vertex_count() const { return positions_rest.size(); }
  size_t triangle_count() const { return triangles.size(); }

  // The character's name in messages: source_file, or "<character>" when it has none.
  std::string Name() const;

  // nullopt when the character is consistent; else Error kInvalidData "<Name()>: <problem>", one
  // line, for the first rule broken, in this order:
  //   - the skeleton has at least one joint, its arrays agree in size, parents come first;
  //   - every triangle index names a vertex of positions_rest;
  //   - when the skin has vertices (a character without a skin skips these): one per rest
  //     position; influence offsets start at 0, never decrease and end at the influence count,
  //     with one weight per influence; every bind entry names a joint; every influence names a
  //     bind entry and has a finite weight; every mesh's rigid_joint is below the joint count.
  // It checks structure, not geometry: finite and bounded positions, a non-degenerate rest pose
  // and per-stage limits stay with the stages that need them.
  std::optional<Error> Validate() const;
};

}  // namespace skinspheres::lib
