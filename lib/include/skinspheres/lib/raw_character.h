// RawCharacter: an imported (or generated) skinned character, editable, before fitting.
//
// The mesh is one indexed triangle list in the rest pose, in the world space of the file's
// scene: each skinned vertex at Σ_k w_k · G_j(k) · IBM_k · p_bind (G from the node tree, no clip
// applied), each rigid mesh at its node's world transform. Vertices and triangles keep the
// file's order (mesh by mesh, primitive by primitive); nothing is reordered, welded or dropped,
// degenerate triangles included.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <string>
#include <vector>

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
  std::string source_file;                         // path as given, for messages
  skinning::Skeleton skeleton;                     // >= 1 joint (a static file gets one)
  std::vector<skinning::AnimationClip> clips;
  skinning::SkinnedMesh skin;                      // bind-space positions, bind entries, influences

  std::vector<Eigen::Vector3f> positions_rest;     // world space, rest pose (what is fitted)
  std::vector<Eigen::Vector3i> triangles;          // indices into positions_rest
  std::vector<MeshRange> meshes;

  size_t vertex_count() const { return positions_rest.size(); }
  size_t triangle_count() const { return triangles.size(); }
};

}  // namespace skinspheres::lib
