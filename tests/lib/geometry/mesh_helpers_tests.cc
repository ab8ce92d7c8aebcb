// Tests of mesh_helpers.h: BodyHeight by hand; UniqueVertices against a brute-force oracle (each
// vertex of the listed triangles exactly once, in first-seen order) over many lists with one
// lister, as the fitter and the tightening pass use it.
#include <gtest/gtest.h>

#include <algorithm>
#include <random>
#include <vector>

#include "shapes/uv_sphere.h"
#include "skinspheres/lib/geometry/mesh_helpers.h"

namespace skinspheres::lib {
namespace {

TEST(BodyHeight, ExtentAlongY) {
  const std::vector<Eigen::Vector3f> p = {{5, -0.25f, 1}, {-3, 1.5f, 0}, {0, 0.5f, -7}};
  EXPECT_EQ(BodyHeight(p), 1.75f);
  EXPECT_EQ(BodyHeight(std::vector<Eigen::Vector3f>{{1, 2, 3}}), 0.0f);
  EXPECT_EQ(BodyHeight({}), 0.0f);
}

// The oracle: walk the triangles' corners in order, keep a vertex the first time it appears.
std::vector<uint32_t> FirstSeen(const std::vector<Eigen::Vector3i>& triangles, const std::vector<uint32_t>& list) {
  std::vector<uint32_t> out;
  for (uint32_t t : list) {
    for (int k = 0; k < 3; ++k) {
      const uint32_t v = static_cast<uint32_t>(triangles[t][k]);
      if (std::find(out.begin(), out.end(), v) == out.end()) out.push_back(v);
    }
  }
  return out;
}

TEST(UniqueVertices, EachVertexOnceInFirstSeenOrderOverManyLists) {
  const test::TriangleMesh m = test::UvSphere(Eigen::Vector3f::Zero(), 1.0f, 12, 16);
  UniqueVertices unique(m.triangles, m.positions.size());
  std::mt19937 rng(5);
  std::uniform_int_distribution<uint32_t> pick(0, static_cast<uint32_t>(m.triangles.size()) - 1);
  for (int trial = 0; trial < 200; ++trial) {
    std::vector<uint32_t> list(trial % 37);  // empty lists too; repeats allowed
    for (auto& t : list) t = pick(rng);
    const std::vector<uint32_t> expected = FirstSeen(m.triangles, list);
    EXPECT_EQ(unique.Indices(list), expected) << trial;
    const std::vector<Eigen::Vector3f> positions = unique.Positions(m.positions, list);
    ASSERT_EQ(positions.size(), expected.size());
    for (size_t k = 0; k < expected.size(); ++k) EXPECT_EQ(positions[k], m.positions[expected[k]]);
  }
}

}  // namespace
}  // namespace skinspheres::lib
