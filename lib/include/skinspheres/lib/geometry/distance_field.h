// DistanceField: unsigned distance from any point to a triangle mesh, answered in O(1) by a voxel
// grid of closest surface points (a vector distance transform). Used by the fitter's tightening
// pass (tighten/sphere_tightener.h) to score where a sphere's surface stands off the body.
//
// Contract:
// * Build(positions, triangles, resolution, padding): cubic voxels over the body's box grown by
//   `padding` (relative to its largest extent) on every side, `resolution` voxels along the
//   largest extent of that box. The body's box spans the 0.5% to 99.5% quantiles of the triangle
//   centroids on each axis, so a few stray triangles far away do not make the voxels coarse
//   (triangles outside the grid seed its boundary voxels, and queries beyond the grid also measure
//   them directly). Each voxel stores a point ON the mesh:
//     1. seeding: every voxel centre within one voxel of a triangle's bounding box gets the exact
//        closest point of that triangle (Ericson §5.1.5, in float), the nearest kept;
//     2. propagation: two raster sweeps (forward, then backward) pass closest points on to the 26
//        neighbours (Danielsson-style vector propagation), each voxel keeping the one nearest its
//        centre.
// * Distance(q) = |q - cp(v)| with v the voxel nearest q (clamped to the grid). Since cp(v) lies on
//   the mesh, Distance(q) >= the exact distance d(q) (never an under-estimate, up to float
//   rounding), and for q inside the grid it is at most d(q) + sqrt(3)·voxel + the propagation's
//   error (zero near the surface, where seeding is exact; measured against the exact distance in
//   tests/lib/geometry/distance_field_tests.cc). Any query is safe: huge, infinite or NaN coordinates are
//   clamped to the grid in float (a NaN query answers NaN).
// * Degenerate triangles are seeded like any other (their closest point is on an edge). An empty
//   mesh gives an empty field whose Distance() is +inf.
// Cost: O(triangles · voxels per triangle + voxels · 26); one thread; deterministic.
// Memory: 20 bytes per voxel (a 64-voxel grid over a humanoid is ~100k voxels, 2 MB).
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <span>
#include <vector>

namespace skinspheres::lib {

class DistanceField {
 public:
  DistanceField() = default;
  DistanceField(const DistanceField&) = delete;
  DistanceField& operator=(const DistanceField&) = delete;
  DistanceField(DistanceField&&) = default;
  DistanceField& operator=(DistanceField&&) = default;

  // resolution in [2, 256] (clamped); padding >= 0 (0.15 leaves room for spheres that stand off
  // the body). The field keeps views of positions and triangles (TriangleDistance reads them):
  // they must outlive it, hence no copies.
  static DistanceField Build(std::span<const Eigen::Vector3f> positions, std::span<const Eigen::Vector3i> triangles,
                             int resolution = 64, float padding = 0.15f);

  float Distance(const Eigen::Vector3f& q) const;
  // |q - closest point of T(v)|, T(v) the triangle cp(v) lies on: also an upper bound of d(q), and
  // far closer to it than Distance() within a voxel or two of the surface (where q's nearest
  // triangle is the voxel's); ~5x the cost. Reads the mesh given to Build, which must outlive
  // the field.
  float TriangleDistance(const Eigen::Vector3f& q) const;

  float voxel_size() const { return voxel_; }
  Eigen::Vector3i dims() const { return dims_; }
  bool empty() const { return closest_.empty(); }

 private:
  size_t Nearest(const Eigen::Vector3f& q) const;                  // index of the voxel nearest q (clamped)
  float OutsideDistance(const Eigen::Vector3f& q, float d) const;  // min(d, outside triangles) beyond the grid
  size_t Index(int x, int y, int z) const {
    return (static_cast<size_t>(z) * dims_.y() + static_cast<size_t>(y)) * dims_.x() + static_cast<size_t>(x);
  }
  Eigen::Vector3f origin_ = Eigen::Vector3f::Zero();  // centre of voxel (0,0,0)
  float voxel_ = 0.0f;
  float inv_voxel_ = 0.0f;
  Eigen::Vector3i dims_ = Eigen::Vector3i::Zero();
  std::vector<Eigen::Vector3f> closest_;               // per voxel: a point on the mesh (nearest found)
  std::vector<int32_t> closest_triangle_;              // per voxel: the triangle that point lies on
  std::vector<int32_t> outside_;                       // triangles not wholly inside the grid
  Eigen::Vector3f grid_hi_ = Eigen::Vector3f::Zero();  // centre of the last voxel
  std::span<const Eigen::Vector3f> positions_;
  std::span<const Eigen::Vector3i> triangles_;
};

}  // namespace skinspheres::lib
