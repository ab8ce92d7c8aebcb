// Disk traversal (paper §4.1 "Disk Translation" and §5 "Disk Construction", "Ray Triangle
// Intersection Test", "Disk Centered"): a disk * of Nr rays moves along a path through one body
// part and records, at every step h, where its rays first meet the part's own triangles: the
// surrounding region ⊗_h.
//
// The path is a polyline: for a limb the bone chain (the disk stays perpendicular to the current
// bone and turns at joints), for the torso the spine, for the head neck -> head; it is extended
// at both ends to the extent of the part's vertices so the ends of the part are swept too.
// The disk plane γ0γ1 is kept perpendicular to the path tangent γ = γ0 × γ1; γ0 is carried from
// step to step by parallel transport so ray r_i keeps its meaning along the path.
// After each step the disk is re-centred on the mean of its contact points (in its plane), which
// the next step inherits (§4.1: "After the disk is translated, its center is re-computed"),
// when at least half of its rays hit; otherwise the next disk starts back on the path.
// Rays that meet nothing are kept as misses (r_i.Δ = -1; open meshes and holes, Figure 5).
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <span>
#include <vector>

#include "skinspheres/lib/geometry/triangle_bvh.h"

namespace skinspheres::lib {

// A polyline with arc-length parametrisation. points.size() >= 2, consecutive points distinct.
struct DiskPath {
  std::vector<Eigen::Vector3f> points;
  std::vector<float> arc_length;  // cumulative, arc_length[0] = 0

  float length() const { return arc_length.empty() ? 0.0f : arc_length.back(); }
  // Point and unit tangent (the direction of the segment holding s) at arc length s in [0, length].
  void Evaluate(float s, Eigen::Vector3f* point, Eigen::Vector3f* tangent) const;
};

// The path through a part: the chain's joint positions (rest pose, world), with consecutive
// coincident joints merged, extended backwards from the first and forwards from the last joint
// along the end segments to cover the extreme projections of `part_vertices`. A chain of fewer
// than two distinct joints gives the principal axis of the vertices through their centroid.
// Returns an empty path when part_vertices is empty.
DiskPath BuildDiskPath(std::span<const Eigen::Vector3f> chain_joint_positions,
                       std::span<const Eigen::Vector3f> part_vertices);

struct DiskContact {
  uint16_t ray = 0;       // r_i, i in [0, Nr)
  int32_t triangle = -1;  // r_i.Δ
  Eigen::Vector3f point = Eigen::Vector3f::Zero();
};

// One disk position *_h and its surrounding region ⊗_h.
struct DiskLevel {
  float s = 0.0f;                                      // arc length along the path
  Eigen::Vector3f center = Eigen::Vector3f::Zero();    // *.c, where the rays started
  Eigen::Vector3f tangent = Eigen::Vector3f::UnitY();  // γ
  Eigen::Vector3f n0 = Eigen::Vector3f::UnitX();       // γ0 (ray r_0 points along it)
  Eigen::Vector3f n1 = Eigen::Vector3f::UnitZ();       // γ1 = γ × γ0
  std::vector<DiskContact> contacts;                   // hits only, in ray order; misses are the rays not listed
};

struct DiskSettings {
  int rays = 80;            // Nr, α = 360° / Nr
  float step = 0.0f;        // δ, absolute (the fitter derives it from the part's size)
  float ray_length = 0.0f;  // t_max of every ray
};

// Moves the disk from s = 0 to s = length in steps of δ (the last step lands on the end) and
// casts Nr rays at each step against `bvh` (first hit). Deterministic.
std::vector<DiskLevel> TraverseDisk(const TriangleBvh& bvh, const DiskPath& path, const DiskSettings& settings);

}  // namespace skinspheres::lib
