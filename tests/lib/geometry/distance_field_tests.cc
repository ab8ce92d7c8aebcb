#include <gtest/gtest.h>

#include <random>

#include "lib/analytic_shapes.h"
#include "skinspheres/lib/character/builtin_character.h"
#include "skinspheres/lib/geometry/distance_field.h"
#include "skinspheres/lib/geometry/mesh_distance.h"

namespace skinspheres::lib {
namespace {

struct Errors {
  double mean = 0.0, max = 0.0, min = 0.0;  // of (estimate - exact)
};

// Estimates against the exact distance (MeshDistances, an AABB-tree branch and bound) at `queries`.
template <class F>
Errors Compare(const RawCharacter& ch, const std::vector<Eigen::Vector3f>& queries, F estimate) {
  std::vector<float> exact(queries.size());
  MeshDistances(ch.positions_rest, ch.triangles, queries, exact);
  Errors e{0.0, -1e30, 1e30};
  for (size_t i = 0; i < queries.size(); ++i) {
    const double d = double(estimate(queries[i])) - exact[i];
    e.mean += d / queries.size();
    e.max = std::max(e.max, d);
    e.min = std::min(e.min, d);
  }
  return e;
}

std::vector<Eigen::Vector3f> RandomPointsAround(const RawCharacter& ch, int n, float grow, unsigned seed) {
  Eigen::Vector3f lo = ch.positions_rest[0], hi = lo;
  for (const auto& p : ch.positions_rest) lo = lo.cwiseMin(p), hi = hi.cwiseMax(p);
  const Eigen::Vector3f ext = hi - lo;
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(-grow, 1.0f + grow);
  std::vector<Eigen::Vector3f> q(n);
  for (auto& p : q) p = lo + Eigen::Vector3f(u(rng), u(rng), u(rng)).cwiseProduct(ext);
  return q;
}

// Points a little off the surface: triangle centroids pushed along a random direction by up to
// one voxel (where the tightening pass samples sphere surfaces).
std::vector<Eigen::Vector3f> PointsNearSurface(const RawCharacter& ch, float reach, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  std::vector<Eigen::Vector3f> q;
  for (size_t t = 0; t < ch.triangles.size(); t += 7) {
    const auto& tri = ch.triangles[t];
    const Eigen::Vector3f c =
        (ch.positions_rest[tri[0]] + ch.positions_rest[tri[1]] + ch.positions_rest[tri[2]]) / 3.0f;
    q.push_back(c + reach * Eigen::Vector3f(u(rng), u(rng), u(rng)));
  }
  return q;
}

TEST(DistanceField, NeverUnderEstimatesAndStaysWithinAVoxelOnTheBuiltInCharacter) {
  const RawCharacter ch = MakeBuiltinCharacter();
  const DistanceField f = DistanceField::Build(ch.positions_rest, ch.triangles, 64);
  const float h = f.voxel_size();
  ASSERT_GT(h, 0.0f);
  const auto far = RandomPointsAround(ch, 4000, 0.1f, 1);
  const Errors fast = Compare(ch, far, [&](const Eigen::Vector3f& q) { return f.Distance(q); });
  EXPECT_GE(fast.min, -1e-5);  // a point of the mesh: never closer than the closest one
  EXPECT_LT(fast.mean, 0.25 * h);
  EXPECT_LT(fast.max, 2.0 * h);
  const Errors tri = Compare(ch, far, [&](const Eigen::Vector3f& q) { return f.TriangleDistance(q); });
  EXPECT_GE(tri.min, -1e-5);
  EXPECT_LE(tri.mean, fast.mean + 1e-7);

  // Near the surface the triangle distance is close to exact, the point lookup less so.
  const auto near = PointsNearSurface(ch, h, 2);
  const Errors near_fast = Compare(ch, near, [&](const Eigen::Vector3f& q) { return f.Distance(q); });
  const Errors near_tri = Compare(ch, near, [&](const Eigen::Vector3f& q) { return f.TriangleDistance(q); });
  EXPECT_GE(near_fast.min, -1e-5);
  EXPECT_GE(near_tri.min, -1e-5);
  EXPECT_LT(near_tri.mean, 0.15 * h) << "point lookup: " << near_fast.mean / h << " voxel";
  EXPECT_LT(near_tri.mean, 0.5 * near_fast.mean);
}

TEST(DistanceField, SphereMeshDistancesMatchTheAnalyticShape) {
  // Outside a finely tessellated sphere of radius 1 the distance is |q| - 1 (up to the chordal
  // sag of the tessellation, < 0.003 here).
  const RawCharacter ch = test::SphereMesh(1.0f, Eigen::Vector3f::Zero(), 48, 96);
  const DistanceField f = DistanceField::Build(ch.positions_rest, ch.triangles, 64, 0.5f);
  std::mt19937 rng(3);
  std::normal_distribution<float> n(0.0f, 1.0f);
  std::uniform_real_distribution<float> radius(1.05f, 1.7f);
  for (int i = 0; i < 500; ++i) {
    const Eigen::Vector3f q = Eigen::Vector3f(n(rng), n(rng), n(rng)).normalized() * radius(rng);
    const float analytic = q.norm() - 1.0f;
    EXPECT_NEAR(f.TriangleDistance(q), analytic, 0.01f + 0.5f * f.voxel_size()) << q.transpose();
    EXPECT_GE(f.Distance(q), analytic - 0.004f);
  }
}

TEST(DistanceField, EmptyMeshHasNoDistance) {
  const DistanceField f = DistanceField::Build({}, {}, 16);
  EXPECT_TRUE(f.empty());
  EXPECT_EQ(f.Distance(Eigen::Vector3f::Zero()), std::numeric_limits<float>::infinity());
  EXPECT_EQ(f.TriangleDistance(Eigen::Vector3f::Zero()), std::numeric_limits<float>::infinity());
}

TEST(DistanceField, ADegenerateTriangleIsStillASurface) {
  // A triangle collapsed to a segment from (0,0,0) to (1,0,0): the distance is to the segment.
  const std::vector<Eigen::Vector3f> pos = {{0, 0, 0}, {1, 0, 0}, {0.5f, 0, 0}};
  const std::vector<Eigen::Vector3i> tri = {{0, 1, 2}};
  const DistanceField f = DistanceField::Build(pos, tri, 32, 1.0f);
  EXPECT_NEAR(f.TriangleDistance(Eigen::Vector3f(0.5f, 0.3f, 0.0f)), 0.3f, 1e-5f);
  EXPECT_NEAR(f.TriangleDistance(Eigen::Vector3f(-0.4f, 0.0f, 0.3f)), 0.5f, 1e-5f);
  // A NaN query reads a real voxel (no out-of-bounds index) and answers NaN.
  EXPECT_TRUE(std::isnan(f.Distance(Eigen::Vector3f(std::nanf(""), 0.0f, 0.0f))));
  EXPECT_TRUE(std::isnan(f.TriangleDistance(Eigen::Vector3f(0.0f, std::nanf(""), 0.0f))));
}

TEST(DistanceField, AnyQueryIsClampedToTheGrid) {
  const std::vector<Eigen::Vector3f> pos = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
  const std::vector<Eigen::Vector3i> tri = {{0, 1, 2}};
  const DistanceField f = DistanceField::Build(pos, tri);
  for (float big : {1e30f, -1e30f, std::numeric_limits<float>::infinity(), -std::numeric_limits<float>::infinity()}) {
    for (int axis = 0; axis < 3; ++axis) {
      Eigen::Vector3f q(0.2f, 0.2f, 0.0f);
      q[axis] = big;
      EXPECT_GE(f.Distance(q), 1e29f);  // reads a real voxel: the distance is huge, not a crash
      EXPECT_GE(f.TriangleDistance(q), 1e29f);
    }
  }
}

TEST(DistanceField, AMeshCollapsedToOnePointIsStillAnswered) {
  const std::vector<Eigen::Vector3f> pos = {{1, 1, 1}, {1, 1, 1}, {1, 1, 1}};
  const std::vector<Eigen::Vector3i> tri = {{0, 1, 2}};
  const DistanceField f = DistanceField::Build(pos, tri);
  EXPECT_GT(f.voxel_size(), 0.0f);
  EXPECT_NEAR(f.Distance(Eigen::Vector3f(2, 1, 1)), 1.0f, 1e-5f);
  EXPECT_NEAR(f.TriangleDistance(Eigen::Vector3f(1, 3, 1)), 2.0f, 1e-5f);
}

TEST(DistanceField, AStrayTriangleFarAwayDoesNotCoarsenTheBody) {
  RawCharacter ch = MakeBuiltinCharacter();
  const float body_voxel = DistanceField::Build(ch.positions_rest, ch.triangles, 64).voxel_size();
  const int base = static_cast<int>(ch.positions_rest.size());
  for (const Eigen::Vector3f& p :
       {Eigen::Vector3f(200, 0, 0), Eigen::Vector3f(200.01f, 0, 0), Eigen::Vector3f(200, 0.01f, 0)}) {
    ch.positions_rest.push_back(p);
  }
  ch.triangles.emplace_back(base, base + 1, base + 2);
  const DistanceField f = DistanceField::Build(ch.positions_rest, ch.triangles, 64);
  EXPECT_LT(f.voxel_size(), 1.1f * body_voxel);
  // Still never below the exact distance, also near the stray triangle (outside the grid).
  const auto q = RandomPointsAround(ch, 500, 0.0f, 5);
  const Errors e = Compare(ch, q, [&](const Eigen::Vector3f& x) { return f.TriangleDistance(x); });
  EXPECT_GE(e.min, -1e-4);
  EXPECT_GE(f.Distance(Eigen::Vector3f(200.0f, 0.5f, 0.0f)), 0.49f);
}

}  // namespace
}  // namespace skinspheres::lib
