// Internal to lib/src/metrics/: input checks, bounds and the voxel grid shared by the fit metrics
// (fit_metrics.cc), the body volume (inside_volume.cc) and the naive baseline
// (naive_joint_spheres.cc).
#pragma once

#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "skinspheres/runtime/error.h"

namespace skinspheres::lib::metrics_internal {

using Vec3d = Eigen::Vector3d;

// kInvalidArgument, "fit metrics: <message>".
Error Invalid(std::string message);
inline bool Finite(const Eigen::Vector3f& v) { return v.allFinite(); }
// Non-empty, finite vertices, triangle indices in range.
std::optional<Error> ValidateMesh(std::span<const Eigen::Vector3f> positions,
                                  std::span<const Eigen::Vector3i> triangles);
// The bounding box of the positions, in double.
void Bounds(std::span<const Eigen::Vector3f> positions, Vec3d& lo, Vec3d& hi);

// Cubic voxels; voxel (i, j, k) has its centre at origin + (ijk + 0.5) · h.
struct Grid {
  Vec3d origin = Vec3d::Zero();
  double h = 1.0;
  std::array<int, 3> dims{1, 1, 1};
  size_t count() const { return size_t(dims[0]) * size_t(dims[1]) * size_t(dims[2]); }
  size_t stride(int axis) const { return axis == 0 ? 1 : axis == 1 ? size_t(dims[0]) : size_t(dims[0]) * dims[1]; }
};
// `resolution` voxels along the longest axis of [lo, hi], plus one voxel of padding on each side.
Grid MakeGrid(const Vec3d& lo, const Vec3d& hi, int resolution);

// 0..6 "inside" votes per voxel from the rays along ±X, ±Y, ±Z (fit_metrics.h explains the vote).
std::vector<uint8_t> InsideVotes(const Grid& g, std::span<const Eigen::Vector3f> positions,
                                 std::span<const Eigen::Vector3i> triangles);
inline constexpr uint8_t kInsideVotes = 4;  // of 6: the voxel is inside the body
inline constexpr uint8_t kUnionBit = 0x80;  // bit 7 of a voxel: inside a sphere of the union

}  // namespace skinspheres::lib::metrics_internal
