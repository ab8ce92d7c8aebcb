// Tests of mesh_distance.h: MeshDistances equals the brute-force minimum of ClosestPointOnTriangle
// over every triangle (a sphere and a box as two pieces), exactly.
#include <gtest/gtest.h>

#include <algorithm>
#include <limits>
#include <random>
#include <vector>

#include "shapes/box_mesh.h"
#include "shapes/uv_sphere.h"
#include "skinspheres/lib/geometry/closest_point.h"
#include "skinspheres/lib/geometry/mesh_distance.h"

namespace skinspheres::lib {
namespace {

TEST(MeshDistances, MatchBruteForce) {
  test::TriangleMesh m = test::UvSphere({0.1f, 0.2f, 0.3f}, 1.f, 16, 24);
  m.Append(test::BoxMesh({1, -1, -1}, {2, 0, 0.5f}));
  std::mt19937 rng(3);
  std::uniform_real_distribution<float> u(-3, 3);
  std::vector<Eigen::Vector3f> q(500);
  for (auto& p : q) p = Eigen::Vector3f(u(rng), u(rng), u(rng));
  q[0] = m.positions[5];  // on the surface
  std::vector<float> d(q.size());
  MeshDistances(m.positions, m.triangles, q, d);
  for (size_t i = 0; i < q.size(); ++i) {
    float best = std::numeric_limits<float>::max();
    for (const auto& t : m.triangles)
      best = std::min(
          best, (ClosestPointOnTriangle(q[i], m.positions[t[0]], m.positions[t[1]], m.positions[t[2]]) - q[i]).norm());
    EXPECT_EQ(d[i], best) << i;
  }
  EXPECT_NEAR(d[0], 0.f, 1e-6f);
}

TEST(MeshDistances, WrongSizesWriteNothing) {
  const test::TriangleMesh m = test::BoxMesh({0, 0, 0}, {1, 1, 1});
  const std::vector<Eigen::Vector3f> q = {{2, 0.5f, 0.5f}};
  std::vector<float> d(2, -1.0f);
  MeshDistances(m.positions, m.triangles, q, d);  // out.size() != queries.size()
  EXPECT_EQ(d, (std::vector<float>{-1.0f, -1.0f}));
  std::vector<float> one(1, -1.0f);
  MeshDistances(m.positions, {}, q, one);  // no triangles
  EXPECT_EQ(one[0], -1.0f);
  MeshDistances(m.positions, m.triangles, q, one);
  EXPECT_FLOAT_EQ(one[0], 1.0f);
}

}  // namespace
}  // namespace skinspheres::lib
