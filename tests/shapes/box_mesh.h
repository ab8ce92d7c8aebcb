// BoxMesh: an axis-aligned box as a closed, outward-wound triangle mesh (two triangles per face), or
// an open one with a face left out.
#pragma once

#include <Eigen/Core>

#include "shapes/triangle_mesh.h"

namespace skinspheres::test {

// Axis-aligned box [lo, hi], outward-facing; `skip_face` (0..5: -X,+X,-Y,+Y,-Z,+Z) leaves one face out.
inline TriangleMesh BoxMesh(const Eigen::Vector3f& lo, const Eigen::Vector3f& hi, int skip_face = -1) {
  TriangleMesh m;
  for (int i = 0; i < 8; ++i)
    m.positions.emplace_back(i & 1 ? hi.x() : lo.x(), i & 2 ? hi.y() : lo.y(), i & 4 ? hi.z() : lo.z());
  const int quads[6][4] = {{0, 4, 6, 2}, {1, 3, 7, 5}, {0, 1, 5, 4}, {2, 6, 7, 3}, {0, 2, 3, 1}, {4, 5, 7, 6}};
  for (int f = 0; f < 6; ++f) {
    if (f == skip_face) continue;
    const int* q = quads[f];
    m.triangles.emplace_back(q[0], q[1], q[2]);
    m.triangles.emplace_back(q[0], q[2], q[3]);
  }
  return m;
}

}  // namespace skinspheres::test
