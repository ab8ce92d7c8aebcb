// UV spheres and ellipsoids as indexed triangle meshes: the closed analytic shape of the tests and
// benchmarks (one generator for all of them; tests/lib/analytic_shapes.h wraps it as a character).
//
// UvEllipsoid(center, axes, rings, segments, pole_axis, poles): semi-axes `axes` (x, y, z) around
// `center`, poles on the `pole_axis` (0 X, 1 Y, 2 Z; the first vertex is the pole on its positive
// side), `rings` bands of latitude from pole to pole, `segments` meridians. Vertex (i, j) of
// latitude θ_i = π·i/rings and longitude φ_j = 2π·j/segments lies at
// axes ∘ (sinθ cosφ, sinθ sinφ, cosθ), the three components carried cyclically so that the last
// one is along pole_axis (a rotation: the winding stays outward). Computed in double, rounded to
// float once. Every triangle is wound outward (counter-clockwise seen from outside).
//   Poles::kShared: each pole is one vertex shared by its fan: 2 + segments·(rings - 1) vertices,
//     2·segments·(rings - 1) triangles, none degenerate; a closed 2-manifold.
//   Poles::kRingOfCopies: each pole is a ring of `segments` coincident vertices, so each polar band
//     has `segments` zero-area triangles beside its fan: segments·(rings + 1) vertices,
//     2·segments·rings triangles (for tests that must survive degenerate triangles).
#pragma once

#include <Eigen/Core>
#include <cmath>
#include <numbers>

#include "shapes/triangle_mesh.h"

namespace skinspheres::test {

enum class Poles { kShared, kRingOfCopies };

inline TriangleMesh UvEllipsoid(const Eigen::Vector3f& center, const Eigen::Vector3f& axes, int rings, int segments,
                                int pole_axis = 2, Poles poles = Poles::kShared) {
  TriangleMesh m;
  auto point = [&](int i, int j) {
    const double th = std::numbers::pi * i / rings, ph = 2.0 * std::numbers::pi * j / segments;
    // Exact poles: sin π is not 0 in double.
    const double sin_th = (i == 0 || i == rings) ? 0.0 : std::sin(th);
    const double cos_th = i == 0 ? 1.0 : i == rings ? -1.0 : std::cos(th);
    const double local[3] = {sin_th * std::cos(ph), sin_th * std::sin(ph), cos_th};
    Eigen::Vector3d p;
    for (int k = 0; k < 3; ++k) p[(pole_axis + 1 + k) % 3] = local[k];
    return Eigen::Vector3f((p.cwiseProduct(axes.cast<double>()) + center.cast<double>()).cast<float>());
  };
  if (poles == Poles::kShared) {
    m.positions.push_back(point(0, 0));
    for (int i = 1; i < rings; ++i) {
      for (int j = 0; j < segments; ++j) m.positions.push_back(point(i, j));
    }
    m.positions.push_back(point(rings, 0));
    const int south = static_cast<int>(m.positions.size()) - 1;
    auto ring = [&](int i, int j) { return 1 + (i - 1) * segments + (j % segments); };
    for (int j = 0; j < segments; ++j) m.triangles.emplace_back(0, ring(1, j), ring(1, j + 1));
    for (int i = 1; i < rings - 1; ++i) {
      for (int j = 0; j < segments; ++j) {
        m.triangles.emplace_back(ring(i, j), ring(i + 1, j), ring(i + 1, j + 1));
        m.triangles.emplace_back(ring(i, j), ring(i + 1, j + 1), ring(i, j + 1));
      }
    }
    for (int j = 0; j < segments; ++j) {
      m.triangles.emplace_back(south, ring(rings - 1, j + 1), ring(rings - 1, j));
    }
    return m;
  }
  for (int i = 0; i <= rings; ++i) {
    for (int j = 0; j < segments; ++j) m.positions.push_back(point(i, j));
  }
  auto vertex = [&](int i, int j) { return i * segments + (j % segments); };
  for (int i = 0; i < rings; ++i) {
    for (int j = 0; j < segments; ++j) {
      m.triangles.emplace_back(vertex(i, j), vertex(i + 1, j), vertex(i + 1, j + 1));
      m.triangles.emplace_back(vertex(i, j), vertex(i + 1, j + 1), vertex(i, j + 1));
    }
  }
  return m;
}

inline TriangleMesh UvSphere(const Eigen::Vector3f& center, float radius, int rings, int segments, int pole_axis = 2,
                             Poles poles = Poles::kShared) {
  return UvEllipsoid(center, Eigen::Vector3f::Constant(radius), rings, segments, pole_axis, poles);
}

}  // namespace skinspheres::test
