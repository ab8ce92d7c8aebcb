// TriangleBvh: nearest-hit ray casting against a SUBSET of an indexed triangle mesh (paper §4.1,
// §5: the disk's rays r_i are tested against the polygons Δ_j of one region R only).
//
// Contract
//   - Build copies the vertices of the selected triangles, so `positions` and `triangles` may die
//     after Build. `subset` lists triangle indices into `triangles` (empty = all triangles);
//     duplicates in `subset` are allowed and ignored. An index out of range (a triangle index, or a
//     vertex index of a selected triangle) is an error (kInvalidArgument) naming the culprit.
//   - Degenerate triangles (IsDegenerateTriangle) are dropped at build time and never hit.
//   - FirstHit(origin, dir, t_max) returns the hit with the smallest t in [0, t_max] over the
//     subset, with the exact per-triangle test of ray_triangle.h; ties in t are broken by the
//     smallest triangle index. The result is therefore identical to BruteForceFirstHit (the oracle)
//     and independent of the tree's shape. t is in units of |dir|.
//   - Binned SAH build (16 bins along the largest centroid extent, leaves of <= 4 triangles unless
//     centroids coincide), deterministic.
//     FirstHit is const and allocation-free, so one TriangleBvh may be shared by many threads.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <limits>
#include <optional>
#include <span>
#include <vector>

#include "skinspheres/runtime/error.h"

namespace skinspheres::lib {

struct TriangleHit {
  float t = 0.0f;                                   // ray parameter: point = origin + t·dir
  int32_t triangle = -1;                            // index into the `triangles` span given to Build
  Eigen::Vector3f point = Eigen::Vector3f::Zero();  // the contact point, from the barycentrics
  float u = 0.0f, v = 0.0f;                         // barycentrics of vertices 1 and 2 (vertex 0: 1 - u - v)
  bool front_face = false;                          // see RayTriangleHit
};

class TriangleBvh {
 public:
  TriangleBvh() = default;  // empty: FirstHit always misses

  static Result<TriangleBvh> Build(std::span<const Eigen::Vector3f> positions,
                                   std::span<const Eigen::Vector3i> triangles, std::span<const int32_t> subset = {});

  std::optional<TriangleHit> FirstHit(const Eigen::Vector3f& origin, const Eigen::Vector3f& dir,
                                      float t_max = std::numeric_limits<float>::infinity()) const;

  size_t triangle_count() const { return prims_.size(); }  // non-degenerate triangles kept
  size_t node_count() const { return nodes_.size(); }
  int depth() const { return depth_; }

 private:
  struct Node {
    Eigen::Vector3f lo, hi;  // bounds, padded outward (see Build)
    uint32_t first = 0;      // leaf: first primitive; inner: index of the right child (left = this + 1)
    uint32_t count = 0;      // leaf: primitive count (> 0); inner: 0
  };
  struct Prim {
    Eigen::Vector3f a, b, c;
    int32_t triangle = -1;
  };
  std::vector<Node> nodes_;
  std::vector<Prim> prims_;
  int depth_ = 0;
};

// The oracle: every triangle of `subset` (empty = all) tested in index order, same rules as
// TriangleBvh::FirstHit. Out-of-range indices are skipped (the BVH refuses them at build).
std::optional<TriangleHit> BruteForceFirstHit(std::span<const Eigen::Vector3f> positions,
                                              std::span<const Eigen::Vector3i> triangles,
                                              std::span<const int32_t> subset, const Eigen::Vector3f& origin,
                                              const Eigen::Vector3f& dir,
                                              float t_max = std::numeric_limits<float>::infinity());

}  // namespace skinspheres::lib
