// A small, valid SphereSet for runtime tests.
#pragma once

#include "skinspheres/runtime/format/sphere_set.h"

namespace skinspheres::runtime {

inline SphereSet TwoSpheres() {
  SphereSet set;
  set.source_vertex_count = 4;
  set.source_triangle_count = 2;
  set.joint_names = {"root"};
  set.joint_parents = {-1};
  set.joint_rest_world = {skinspheres::Mat4f::Identity()};
  set.parts = {{"torso", {0}}};
  set.centers_rest = {Eigen::Vector3f(0, 0, 0), Eigen::Vector3f(1, 0, 0)};
  set.radii_rest = {1.0f, 1.0f};
  set.radii_fast = {1.0f, 1.0f};
  set.sphere_part = {0, 0};
  set.sphere_joint = {0, 0};
  set.sphere_level = {0, 1};
  set.vertex_offsets = {0, 3, 6};
  set.vertices = {0, 1, 2, 1, 2, 3};
  set.triangle_offsets = {0, 1, 2};
  set.triangles = {0, 1};
  set.influence_offsets = {0, 1, 2};
  set.influence_joints = {0, 0};
  set.influence_weights = {1.0f, 1.0f};
  set.excluded_pairs = {{0, 1, ExclusionReason::kSameJoint}};
  return set;
}

// TwoSpheres with its mesh (version 2): two triangles (0 1 2) and (1 2 3) on a quad, one bind
// entry on the root joint with a non-trivial inverse bind matrix, vertex 3 blended with weight 1.
inline SphereSet TwoSpheresWithMesh() {
  SphereSet set = TwoSpheres();
  set.triangle_vertices = {0, 1, 2, 1, 2, 3};
  set.mesh.positions_bind = {Eigen::Vector3f(0, 0, 0), Eigen::Vector3f(0.5f, 0, 0), Eigen::Vector3f(0, 0.5f, 0),
                             Eigen::Vector3f(1.0f / 3.0f, 0.7f, -0.1f)};
  skinning::BindEntry entry;
  entry.joint = 0;
  entry.inverse_bind(1, 3) = -0.25f;
  set.mesh.binds = {entry};
  set.mesh.influence_offsets = {0, 1, 2, 3, 4};
  set.mesh.influence_binds = {0, 0, 0, 0};
  set.mesh.influence_weights = {1.0f, 1.0f, 1.0f, 1.0f};
  return set;
}

// Two joints "a" (root) and "b", rest = bind = identity, and a mesh of four vertices in the z = 0
// plane, v0 (0, 0), v1 (0.5, 0), v2 (0.5, 0.5), v3 (1, 0.5), two triangles (0 1 2) and (1 3 2).
// Skin weights: v0 a 1; v1 a 0.75, b 0.25; v2 a 0.5, b 0.25 + 0.25 (two bind entries on b, the same
// inverse bind matrix); v3 b 1. Sphere 0 holds v0 v1 v2 (centre (0.25, 0.25, 0)), sphere 1 holds
// v1 v2 v3 (centre (0.75, 0.25, 0)), both radius 0.5, both influenced by a and b with their mean
// weights. No influence reach stored: by hand, the mesh gives sphere 0 reach a 1, b 0.5 and sphere 1
// reach a 0.75, b 1.
inline SphereSet TwoJointsWithMesh() {
  SphereSet set = TwoSpheres();
  set.joint_names = {"a", "b"};
  set.joint_parents = {-1, 0};
  set.joint_rest_world = {skinspheres::Mat4f::Identity(), skinspheres::Mat4f::Identity()};
  set.parts = {{"torso", {0, 1}}};
  set.centers_rest = {Eigen::Vector3f(0.25f, 0.25f, 0), Eigen::Vector3f(0.75f, 0.25f, 0)};
  set.radii_rest = {0.5f, 0.5f};
  set.radii_fast = {0.5f, 0.5f};
  set.sphere_joint = {0, 1};
  set.vertices = {0, 1, 2, 1, 2, 3};
  set.influence_offsets = {0, 2, 4};
  set.influence_joints = {0, 1, 0, 1};
  set.influence_weights = {0.75f, 0.25f, 5.0f / 12.0f, 7.0f / 12.0f};
  set.excluded_pairs.clear();
  set.triangle_vertices = {0, 1, 2, 1, 3, 2};
  set.mesh.positions_bind = {Eigen::Vector3f(0, 0, 0), Eigen::Vector3f(0.5f, 0, 0), Eigen::Vector3f(0.5f, 0.5f, 0),
                             Eigen::Vector3f(1, 0.5f, 0)};
  set.mesh.binds = {skinning::BindEntry{0, skinspheres::Mat4f::Identity()},
                    skinning::BindEntry{1, skinspheres::Mat4f::Identity()},
                    skinning::BindEntry{1, skinspheres::Mat4f::Identity()}};
  set.mesh.influence_offsets = {0, 1, 3, 6, 7};
  set.mesh.influence_binds = {0, 0, 1, 0, 1, 2, 1};
  set.mesh.influence_weights = {1.0f, 0.75f, 0.25f, 0.5f, 0.25f, 0.25f, 1.0f};
  return set;
}

}  // namespace skinspheres::runtime
