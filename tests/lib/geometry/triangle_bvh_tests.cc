// Tests for triangle_bvh.h: the BVH must return exactly what the brute-force oracle returns
// (same triangle, same t, same point) on random soups, subsets and a closed sphere mesh.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <random>
#include <vector>

#include "shapes/uv_sphere.h"
#include "skinspheres/lib/geometry/triangle_bvh.h"

namespace skinspheres::lib {
namespace {

using V = Eigen::Vector3f;

using Mesh = test::TriangleMesh;

// Random triangles of varied size in [-1, 1]^3, with some degenerate ones and exact duplicates.
Mesh RandomSoup(int count, uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  std::uniform_real_distribution<float> size(0.005f, 0.3f);
  Mesh m;
  for (int i = 0; i < count; ++i) {
    const V c(u(rng), u(rng), u(rng));
    const float s = size(rng);
    const int base = static_cast<int>(m.positions.size());
    V a = c + s * V(u(rng), u(rng), u(rng)), b = c + s * V(u(rng), u(rng), u(rng)),
      d = c + s * V(u(rng), u(rng), u(rng));
    if (i % 37 == 0) d = a + 0.5f * (b - a);  // collinear: degenerate
    if (i % 41 == 0) b = a;                   // repeated vertex: degenerate
    m.positions.insert(m.positions.end(), {a, b, d});
    m.triangles.emplace_back(base, base + 1, base + 2);
    if (i % 53 == 0) m.triangles.emplace_back(base, base + 1, base + 2);  // exact duplicate
  }
  return m;
}

V RandomDirection(std::mt19937& rng) {
  std::normal_distribution<float> g;
  std::uniform_int_distribution<int> kind(0, 9);
  const int k = kind(rng);
  if (k == 0) {  // axis-aligned: two zero components
    V d = V::Zero();
    d[std::uniform_int_distribution<int>(0, 2)(rng)] = (g(rng) < 0 ? -1.0f : 1.0f);
    return d;
  }
  if (k == 1) {  // one zero component
    V d(g(rng), g(rng), g(rng));
    d[std::uniform_int_distribution<int>(0, 2)(rng)] = 0.0f;
    return d;
  }
  return V(g(rng), g(rng), g(rng));
}

void ExpectSame(const std::optional<TriangleHit>& fast, const std::optional<TriangleHit>& slow, int ray) {
  ASSERT_EQ(fast.has_value(), slow.has_value()) << "ray " << ray;
  if (!fast) return;
  EXPECT_EQ(fast->triangle, slow->triangle) << "ray " << ray;
  EXPECT_EQ(fast->t, slow->t) << "ray " << ray;
  EXPECT_EQ(fast->point, slow->point) << "ray " << ray;
  EXPECT_EQ(fast->front_face, slow->front_face) << "ray " << ray;
}

TEST(TriangleBvh, MatchesBruteForceOnRandomSoup) {
  const Mesh m = RandomSoup(3000, 1);
  const auto bvh = TriangleBvh::Build(m.positions, m.triangles);
  ASSERT_TRUE(bvh.ok()) << bvh.error().message;
  EXPECT_LT(bvh->triangle_count(), m.triangles.size());  // degenerate ones dropped
  EXPECT_GT(bvh->node_count(), 1u);
  std::mt19937 rng(2);
  std::uniform_real_distribution<float> u(-1.5f, 1.5f);
  int hits = 0;
  for (int i = 0; i < 4000; ++i) {
    const V o(u(rng), u(rng), u(rng));
    const V d = RandomDirection(rng);
    const auto fast = bvh->FirstHit(o, d);
    const auto slow = BruteForceFirstHit(m.positions, m.triangles, {}, o, d);
    ExpectSame(fast, slow, i);
    hits += fast.has_value();
  }
  EXPECT_GT(hits, 1000);  // the test exercises hits, not only misses
}

TEST(TriangleBvh, MatchesBruteForceWithTMax) {
  const Mesh m = RandomSoup(1000, 3);
  const auto bvh = TriangleBvh::Build(m.positions, m.triangles);
  ASSERT_TRUE(bvh.ok());
  std::mt19937 rng(4);
  std::uniform_real_distribution<float> u(-1.5f, 1.5f), tm(0.0f, 2.0f);
  for (int i = 0; i < 2000; ++i) {
    const V o(u(rng), u(rng), u(rng));
    const V d = RandomDirection(rng);
    const float t_max = tm(rng);
    const auto fast = bvh->FirstHit(o, d, t_max);
    ExpectSame(fast, BruteForceFirstHit(m.positions, m.triangles, {}, o, d, t_max), i);
    if (fast) {
      EXPECT_LE(fast->t, t_max);
    }
  }
}

TEST(TriangleBvh, SubsetOnlyHitsItsTriangles) {
  const Mesh m = RandomSoup(2000, 5);
  std::vector<int32_t> subset;
  std::mt19937 rng(6);
  for (int32_t t = 0; t < static_cast<int32_t>(m.triangles.size()); ++t) {
    if (rng() % 3 == 0) subset.push_back(t);
  }
  std::vector<bool> in_subset(m.triangles.size(), false);
  for (int32_t t : subset) in_subset[t] = true;
  // Unsorted with duplicates: same set.
  std::vector<int32_t> shuffled = subset;
  std::shuffle(shuffled.begin(), shuffled.end(), rng);
  shuffled.push_back(subset[0]);
  const auto bvh = TriangleBvh::Build(m.positions, m.triangles, shuffled);
  ASSERT_TRUE(bvh.ok());
  std::uniform_real_distribution<float> u(-1.5f, 1.5f);
  int hits = 0;
  for (int i = 0; i < 3000; ++i) {
    const V o(u(rng), u(rng), u(rng));
    const V d = RandomDirection(rng);
    const auto fast = bvh->FirstHit(o, d);
    ExpectSame(fast, BruteForceFirstHit(m.positions, m.triangles, subset, o, d), i);
    if (fast) {
      ++hits;
      EXPECT_TRUE(in_subset[fast->triangle]);
    }
  }
  EXPECT_GT(hits, 300);
}

TEST(TriangleBvh, SphereMeshAlwaysHitFromInside) {
  const V center(0.3f, -0.2f, 1.1f);
  const float r = 0.8f;
  const Mesh m = test::UvSphere(center, r, 40, 64);  // poles single vertices, wound outward
  const auto bvh = TriangleBvh::Build(m.positions, m.triangles);
  ASSERT_TRUE(bvh.ok());
  EXPECT_EQ(bvh->triangle_count(), m.triangles.size());
  std::mt19937 rng(8);
  std::uniform_real_distribution<float> u(-0.45f, 0.45f);
  // Chord sagitta: the mesh lies between r·cos(max half-angle) and r.
  const float inner = r * std::cos(static_cast<float>(std::numbers::pi) / 40.0f);
  for (int i = 0; i < 3000; ++i) {
    const V o = center + V(u(rng), u(rng), u(rng));
    const V d = RandomDirection(rng);
    const auto fast = bvh->FirstHit(o, d);
    ASSERT_TRUE(fast) << "ray " << i << " leaked out of a closed sphere";
    const float dist = (fast->point - center).norm();
    EXPECT_LE(dist, r * (1.0f + 1e-5f));
    EXPECT_GE(dist, inner * (1.0f - 1e-5f));
    EXPECT_LT((o + fast->t * d - fast->point).norm(), 1e-5f);
    EXPECT_FALSE(fast->front_face);  // outward-wound sphere, seen from inside
    ExpectSame(fast, BruteForceFirstHit(m.positions, m.triangles, {}, o, d), i);
  }
  // Rays from the centre exactly through every vertex (shared by 4-6 triangles).
  for (size_t k = 0; k < m.positions.size(); ++k) {
    const V d = m.positions[k] - center;
    const auto fast = bvh->FirstHit(center, d);
    ASSERT_TRUE(fast) << "vertex " << k;
    EXPECT_NEAR(fast->t, 1.0f, 1e-5f);
    ExpectSame(fast, BruteForceFirstHit(m.positions, m.triangles, {}, center, d), static_cast<int>(k));
  }
}

TEST(TriangleBvh, TiesGoToTheSmallestTriangleIndex) {
  // The same square four times (two copies each of two triangles) under different indices.
  const std::vector<V> p = {V(0, 0, 0), V(1, 0, 0), V(1, 1, 0), V(0, 1, 0)};
  const std::vector<Eigen::Vector3i> t = {{0, 1, 2}, {0, 2, 3}, {0, 2, 3}, {0, 1, 2}, {2, 1, 0}};
  const auto bvh = TriangleBvh::Build(p, t);
  ASSERT_TRUE(bvh.ok());
  const auto h_lower = bvh->FirstHit(V(0.7f, 0.2f, 1), V(0, 0, -1));
  ASSERT_TRUE(h_lower);
  EXPECT_EQ(h_lower->triangle, 0);
  const auto h_upper = bvh->FirstHit(V(0.2f, 0.7f, 1), V(0, 0, -1));
  ASSERT_TRUE(h_upper);
  EXPECT_EQ(h_upper->triangle, 1);
  // The shared diagonal: both triangles hit at the same t, the smaller index wins.
  const auto h_diag = bvh->FirstHit(V(0.5f, 0.5f, 1), V(0, 0, -1));
  ASSERT_TRUE(h_diag);
  EXPECT_EQ(h_diag->triangle, 0);
  // Subset without 0 and 1: the next copies.
  const std::vector<int32_t> sub = {4, 3, 2};
  const auto bvh2 = TriangleBvh::Build(p, t, sub);
  ASSERT_TRUE(bvh2.ok());
  EXPECT_EQ(bvh2->FirstHit(V(0.7f, 0.2f, 1), V(0, 0, -1))->triangle, 3);
  EXPECT_EQ(bvh2->FirstHit(V(0.5f, 0.5f, 1), V(0, 0, -1))->triangle, 2);
}

TEST(TriangleBvh, RejectsOutOfRangeIndices) {
  const std::vector<V> p = {V(0, 0, 0), V(1, 0, 0), V(0, 1, 0)};
  const std::vector<Eigen::Vector3i> good = {{0, 1, 2}};
  const std::vector<int32_t> bad_subset = {0, 1};
  const auto r1 = TriangleBvh::Build(p, good, bad_subset);
  ASSERT_FALSE(r1.ok());
  EXPECT_EQ(r1.error().code, ErrorCode::kInvalidArgument);
  EXPECT_NE(r1.error().message.find("triangle 1"), std::string::npos) << r1.error().message;
  const std::vector<int32_t> negative = {-1};
  EXPECT_FALSE(TriangleBvh::Build(p, good, negative).ok());
  const std::vector<Eigen::Vector3i> bad_vertex = {{0, 1, 2}, {0, 1, 3}};
  const auto r2 = TriangleBvh::Build(p, bad_vertex);
  ASSERT_FALSE(r2.ok());
  EXPECT_NE(r2.error().message.find("vertex 3"), std::string::npos) << r2.error().message;
  // A subset that avoids the bad triangle is fine.
  const std::vector<int32_t> only_good = {0};
  EXPECT_TRUE(TriangleBvh::Build(p, bad_vertex, only_good).ok());
}

TEST(TriangleBvh, EmptyAndAllDegenerateMeshesMiss) {
  const TriangleBvh empty;
  EXPECT_FALSE(empty.FirstHit(V::Zero(), V(1, 0, 0)));
  const auto built_empty = TriangleBvh::Build({}, {});
  ASSERT_TRUE(built_empty.ok());
  EXPECT_FALSE(built_empty->FirstHit(V::Zero(), V(1, 0, 0)));
  const std::vector<V> p = {V(0, 0, 0), V(1, 0, 0), V(2, 0, 0)};
  const std::vector<Eigen::Vector3i> t = {{0, 1, 2}, {0, 0, 1}};
  const auto bvh = TriangleBvh::Build(p, t);
  ASSERT_TRUE(bvh.ok());
  EXPECT_EQ(bvh->triangle_count(), 0u);
  EXPECT_FALSE(bvh->FirstHit(V(1, 0, 1), V(0, 0, -1)));
}

TEST(TriangleBvh, ManyCoincidentCentroidsStillBuildAndMatch) {
  // 200 triangles sharing one centroid (a fan of rotated copies): SAH cannot split by centroid.
  std::vector<V> p;
  std::vector<Eigen::Vector3i> t;
  for (int i = 0; i < 200; ++i) {
    const float a = 2.0f * static_cast<float>(std::numbers::pi) * i / 200.0f;
    const V e0(std::cos(a), std::sin(a), 0.01f * i), e1(-std::sin(a), std::cos(a), -0.01f * i);
    const int b = static_cast<int>(p.size());
    p.insert(p.end(), {e0, e1, -e0 - e1});
    t.emplace_back(b, b + 1, b + 2);
  }
  const auto bvh = TriangleBvh::Build(p, t);
  ASSERT_TRUE(bvh.ok());
  std::mt19937 rng(9);
  std::uniform_real_distribution<float> u(-1.5f, 1.5f);
  for (int i = 0; i < 500; ++i) {
    const V o(u(rng), u(rng), u(rng));
    const V d = RandomDirection(rng);
    ExpectSame(bvh->FirstHit(o, d), BruteForceFirstHit(p, t, {}, o, d), i);
  }
}

}  // namespace
}  // namespace skinspheres::lib
