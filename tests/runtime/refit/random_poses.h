// Random joint transforms and skinning in double: the oracles of "every vertex inside" for the
// refit tests.
#pragma once

#include <Eigen/Geometry>
#include <random>
#include <span>
#include <vector>

#include "skinspheres/runtime/format/sphere_set.h"

namespace skinspheres::test {

using runtime::PiecePoint;
using runtime::SphereSet;

// Random joint transforms: a rigid motion each, times a non-uniform scale on odd poses p.
inline void RandomWorld(std::mt19937& rng, int p, std::vector<skinspheres::Mat4f>* world) {
  std::uniform_real_distribution<float> angle(-3.1f, 3.1f), move(-3.0f, 3.0f), scale(0.3f, 3.0f);
  for (auto& g : *world) {
    const Eigen::Vector3f axis = Eigen::Vector3f(move(rng), move(rng), move(rng)).normalized();
    Eigen::Affine3f t = Eigen::Translation3f(move(rng), move(rng), move(rng)) * Eigen::AngleAxisf(angle(rng), axis);
    if (p % 2) t = t * Eigen::Scaling(Eigen::Vector3f(scale(rng), scale(rng), scale(rng)));
    g = t.matrix();
  }
}

// Source vertex v of the set's mesh skinned in double.
inline Eigen::Vector3d SkinnedInDouble(const SphereSet& set, std::span<const skinspheres::Mat4f> world, uint32_t v) {
  Eigen::Vector3d skinned = Eigen::Vector3d::Zero();
  for (uint32_t q = set.mesh.influence_offsets[v]; q < set.mesh.influence_offsets[v + 1]; ++q) {
    const skinning::BindEntry& b = set.mesh.binds[set.mesh.influence_binds[q]];
    const Eigen::Matrix4d m = world[static_cast<size_t>(b.joint)].cast<double>() * b.inverse_bind.cast<double>();
    skinned +=
        double{set.mesh.influence_weights[q]} * (m * set.mesh.positions_bind[v].cast<double>().homogeneous()).head<3>();
  }
  return skinned;
}

// Point k of the set's point lists (a source vertex or a grid point, sphere_set.h) skinned in
// double: a grid point as its barycentric combination of the triangle's vertices skinned in double.
inline Eigen::Vector3d PointInDouble(const SphereSet& set, std::span<const skinspheres::Mat4f> world, uint32_t k) {
  if (k < set.source_vertex_count) return SkinnedInDouble(set, world, k);
  const PiecePoint& g = set.piece_points[k - set.source_vertex_count];
  const uint32_t* v = set.triangle_vertices.data() + 3 * size_t{g.triangle};
  const double l = g.level;
  return (double(g.level - g.i - g.j) / l) * SkinnedInDouble(set, world, v[0]) +
         (double(g.i) / l) * SkinnedInDouble(set, world, v[1]) + (double(g.j) / l) * SkinnedInDouble(set, world, v[2]);
}

}  // namespace skinspheres::test
