// A small, valid SphereSet for runtime tests.
#pragma once

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <functional>
#include <vector>

#include "skinspheres/runtime/format/sphere_set.h"
#include "skinspheres/runtime/refit/mesh_bounds.h"

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
  // The fast radius holds every vertex's rest copies (one each here; SphereSet::Validate checks it
  // against the mesh): vertex 2's copy (0, 0.25, 0) lies 1.031 from sphere 1's centre.
  set.radii_fast = {1.1f, 1.1f};
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

// Each sphere of a set whose rest pose is its bind pose: the box centre of its points (SphereSet::
// vertices, grid points included) at rest, the radius holding them rounded up, radius_fast from the
// mesh (FastReferenceRadiiFromMesh: a grid point's copies spread where its triangle's vertices weigh
// the joints differently).
inline void FitSpheresToPointsAtBind(SphereSet& set) {
  const Eigen::Vector3f* bind = set.mesh.positions_bind.data();
  for (size_t s = 0; s < set.size(); ++s) {
    Eigen::Vector3f lo = Eigen::Vector3f::Constant(1e30f), hi = -lo;
    for (uint32_t k = set.vertex_offsets[s]; k < set.vertex_offsets[s + 1]; ++k) {
      lo = lo.cwiseMin(set.PointAt(set.vertices[k], bind)), hi = hi.cwiseMax(set.PointAt(set.vertices[k], bind));
    }
    set.centers_rest[s] = 0.5f * (lo + hi);
    double r = 0.0;
    for (uint32_t k = set.vertex_offsets[s]; k < set.vertex_offsets[s + 1]; ++k) {
      r = std::max(r, (set.PointAt(set.vertices[k], bind) - set.centers_rest[s]).cast<double>().norm());
    }
    set.radii_rest[s] = set.radii_fast[s] = std::nextafter(static_cast<float>(r), 1e30f);
  }
  const auto fast = FastReferenceRadiiFromMesh(set);
  for (size_t s = 0; s < set.size() && fast.ok(); ++s) set.radii_fast[s] = std::max(set.radii_rest[s], (*fast)[s]);
}

// TwoJointsWithMesh with triangle 1 (v1 v3 v2) cut at level 2 (sphere_set.h, TrianglePiece): its
// grid points (1, 0) (mid v1-v3), (0, 1) (mid v1-v2) and (1, 1) (mid v3-v2) are points 4, 5, 6.
// Sphere 0 owns triangle 0 whole and pieces 0, 2, 3 of triangle 1; sphere 1 owns piece 1, the
// corner at v3: points 4, 3, 6. Each sphere is the box centre of its points at rest with the
// radius holding them rounded up, radius_fast from the mesh (FastReferenceRadiiFromMesh: a grid
// point's copies spread where its triangle's vertices weigh the joints differently).
inline SphereSet TwoJointsWithPieces() {
  SphereSet set = TwoJointsWithMesh();
  set.piece_points = {{1, 2, 1, 0}, {1, 2, 0, 1}, {1, 2, 1, 1}};
  set.vertex_offsets = {0, 6, 9};
  set.vertices = {0, 1, 2, 4, 5, 6, 4, 3, 6};
  set.triangle_offsets = {0, 1, 1};
  set.triangles = {0};
  set.piece_offsets = {0, 3, 4};
  set.pieces = {{1, 2, 0}, {1, 2, 2}, {1, 2, 3}, {1, 2, 1}};
  FitSpheresToPointsAtBind(set);
  return set;
}

// TwoJointsWithMesh with joint b's rest transform moved by (0.3, 0.1, 0) from its bind pose (a bone
// length that differs; the bind pose is identity for both joints), and the rest-pose data as the
// fitter writes it: rest positions by skinning at rest, each sphere the box centre of its vertices,
// radius_fast holding every rest copy (as files written before 2026-12-06 store it; the mean copy
// distance the fitter now stores is smaller, and TheFastRadiusIsTheLargestMeanCopyDistance sets
// it). Each vertex's rest copies through its two joints lie apart:
// the case the fast refit's bind-pose reference is for (docs/REFIT.md#reference-frame).
// edit_mesh, when given, changes the mesh first (the rest data then follows from it).
inline SphereSet TwoJointsRestAwayFromBind(const std::function<void(SphereSet&)>& edit_mesh = {}) {
  SphereSet set = TwoJointsWithMesh();
  if (edit_mesh) edit_mesh(set);
  const Eigen::Affine3f turn(Eigen::Translation3f(0.3f, 0.1f, 0.0f));
  set.joint_rest_world[1] = turn.matrix();
  std::vector<Eigen::Vector3d> rest_positions(4, Eigen::Vector3d::Zero());
  std::vector<std::vector<Eigen::Vector3d>> copies(4);
  for (uint32_t v = 0; v < 4; ++v) {
    for (uint32_t q = set.mesh.influence_offsets[v]; q < set.mesh.influence_offsets[v + 1]; ++q) {
      const skinning::BindEntry& b = set.mesh.binds[set.mesh.influence_binds[q]];
      const Eigen::Vector3d copy =
          (set.joint_rest_world[static_cast<size_t>(b.joint)].cast<double>() * b.inverse_bind.cast<double>() *
           set.mesh.positions_bind[v].cast<double>().homogeneous())
              .head<3>();
      rest_positions[v] += double{set.mesh.influence_weights[q]} * copy;
      copies[v].push_back(copy);
    }
  }
  for (size_t s = 0; s < 2; ++s) {
    Eigen::Vector3d lo = Eigen::Vector3d::Constant(1e30), hi = -lo;
    for (uint32_t k = set.vertex_offsets[s]; k < set.vertex_offsets[s + 1]; ++k) {
      lo = lo.cwiseMin(rest_positions[set.vertices[k]]), hi = hi.cwiseMax(rest_positions[set.vertices[k]]);
    }
    const Eigen::Vector3d c = 0.5 * (lo + hi);
    double r = 0.0, r_fast = 0.0;
    for (uint32_t k = set.vertex_offsets[s]; k < set.vertex_offsets[s + 1]; ++k) {
      r = std::max(r, (rest_positions[set.vertices[k]] - c).norm());
      for (const auto& copy : copies[set.vertices[k]]) r_fast = std::max(r_fast, (copy - c).norm());
    }
    set.centers_rest[s] = c.cast<float>();
    set.radii_rest[s] = std::nextafter(static_cast<float>(r), 1e30f);
    set.radii_fast[s] = std::max(set.radii_rest[s], std::nextafter(static_cast<float>(r_fast), 1e30f));
  }
  return set;
}

}  // namespace skinspheres::runtime
