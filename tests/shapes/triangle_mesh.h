// TriangleMesh: an indexed triangle mesh for the analytic shapes of tests and benchmarks
// (shapes/uv_sphere.h, shapes/box_mesh.h), with the divergence-theorem volume as an oracle.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <utility>
#include <vector>

namespace skinspheres::test {

struct TriangleMesh {
  std::vector<Eigen::Vector3f> positions;
  std::vector<Eigen::Vector3i> triangles;

  // Adds `other` as a separate piece (its indices shifted past ours).
  void Append(const TriangleMesh& other) {
    const int base = static_cast<int>(positions.size());
    positions.insert(positions.end(), other.positions.begin(), other.positions.end());
    for (const auto& t : other.triangles) triangles.push_back(t + Eigen::Vector3i::Constant(base));
  }
  // Turns every triangle inside out.
  void Flip() {
    for (auto& t : triangles) std::swap(t[1], t[2]);
  }
  // Signed volume by the divergence theorem: the exact volume of a closed, outward-wound mesh.
  double SignedVolume() const {
    double v = 0;
    for (const auto& t : triangles) {
      const Eigen::Vector3d a = positions[t[0]].cast<double>(), b = positions[t[1]].cast<double>(),
                            c = positions[t[2]].cast<double>();
      v += a.dot(b.cross(c)) / 6;
    }
    return v;
  }
};

}  // namespace skinspheres::test
