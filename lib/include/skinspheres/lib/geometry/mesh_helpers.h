// Small helpers over indexed triangle meshes, shared by the fitter's stages.
//
// * BodyHeight: the extent along +Y (glTF up) of a point set, the yardstick every relative figure
//   of the fit uses (growth, standoff targets).
// * UniqueVertices: the vertices of a list of triangles, each once, in first-seen order.
#pragma once

#include <Eigen/Core>
#include <algorithm>
#include <cstdint>
#include <span>
#include <vector>

namespace skinspheres::lib {

// max y - min y over `positions` (float arithmetic); 0 for an empty set. Positions must be finite.
float BodyHeight(std::span<const Eigen::Vector3f> positions);

// Lists the vertices of lists of triangles (indices into `triangles`), each vertex once, in
// first-seen order: triangle by triangle in list order, corners 0, 1, 2. A per-vertex stamp, sized
// once, makes each list cost O(its length) with nothing to clear in between. The triangles must
// index vertices in [0, vertex_count) and outlive the lister. Not thread-safe: one per thread.
class UniqueVertices {
 public:
  UniqueVertices(std::span<const Eigen::Vector3i> triangles, size_t vertex_count)
      : triangles_(triangles), stamp_(vertex_count, 0) {}

  // Calls visit(int32_t vertex) once for each vertex of the listed triangles.
  template <typename Visit>
  void ForEach(std::span<const uint32_t> list, Visit&& visit) {
    if (++now_ == 0) {  // the stamp wrapped: forget every mark
      std::fill(stamp_.begin(), stamp_.end(), 0u);
      now_ = 1;
    }
    for (uint32_t t : list) {
      for (int k = 0; k < 3; ++k) {
        const int32_t v = triangles_[t][k];
        if (stamp_[v] == now_) continue;
        stamp_[v] = now_;
        visit(v);
      }
    }
  }

  // The vertex indices, first-seen order.
  std::vector<uint32_t> Indices(std::span<const uint32_t> list);
  // positions[v] for those vertices, in the same order.
  std::vector<Eigen::Vector3f> Positions(std::span<const Eigen::Vector3f> positions, std::span<const uint32_t> list);

 private:
  std::span<const Eigen::Vector3i> triangles_;
  std::vector<uint32_t> stamp_;
  uint32_t now_ = 0;
};

}  // namespace skinspheres::lib
