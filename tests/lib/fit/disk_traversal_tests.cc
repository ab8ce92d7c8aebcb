// Tests of disk_traversal.h against independent oracles: every contact TraverseDisk records is the
// first hit of its ray found by brute force over every triangle (BruteForceFirstHit), and every
// ray it leaves out misses; on closed cylinders and elliptic prisms the contacts lie on the
// analytic surface; the disk frame (γ0, γ1, γ) is orthonormal and carried by parallel transport;
// the disk is re-centred on the mean of its contacts only when at least half of its rays hit;
// BuildDiskPath merges, extends and falls back as its contract says; the result is deterministic.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <numbers>
#include <vector>

#include "lib/analytic_shapes.h"
#include "skinspheres/lib/fit/disk_traversal.h"

namespace skinspheres::lib {
namespace {

using V = Eigen::Vector3f;

// The direction of ray r_i of a level: α = 360°/Nr from γ0 towards γ1 (the header's contract).
V RayDirection(const DiskLevel& level, int i, int rays) {
  const float alpha = 2.0f * std::numbers::pi_v<float> / static_cast<float>(rays);
  return std::cos(i * alpha) * level.n0 + std::sin(i * alpha) * level.n1;
}

// Every ray of every level against the brute-force oracle: a listed contact is the oracle's first
// hit (same point, within rounding of the direction), a ray not listed has no hit within t_max.
void ExpectContactsAreFirstHits(const RawCharacter& ch, const std::vector<DiskLevel>& levels,
                                const DiskSettings& settings) {
  for (size_t h = 0; h < levels.size(); ++h) {
    const DiskLevel& level = levels[h];
    size_t next = 0;
    for (int i = 0; i < settings.rays; ++i) {
      const auto oracle = BruteForceFirstHit(ch.positions_rest, ch.triangles, {}, level.center,
                                             RayDirection(level, i, settings.rays), settings.ray_length);
      const bool listed = next < level.contacts.size() && level.contacts[next].ray == i;
      ASSERT_EQ(listed, oracle.has_value()) << "level " << h << " ray " << i;
      if (!listed) continue;
      EXPECT_LT((level.contacts[next].point - oracle->point).norm(), 1e-5f) << "level " << h << " ray " << i;
      ++next;
    }
    EXPECT_EQ(next, level.contacts.size()) << "level " << h << ": contacts out of ray order";
  }
}

DiskSettings Settings(int rays, float step) {
  DiskSettings s;
  s.rays = rays;
  s.step = step;
  s.ray_length = 10.0f;
  return s;
}

TEST(TraverseDisk, ContactsOnACylinderAreTheFirstHitsAndLieOnIt) {
  const float r = 0.2f;
  const RawCharacter ch = test::EllipticPrism(r, r, 0.0f, 1.0f);
  const std::vector<V> chain = {V(0, 0, 0), V(0, 1, 0)};
  const DiskPath path = BuildDiskPath(chain, ch.positions_rest);
  ASSERT_EQ(path.points.size(), 2u);  // the vertices do not reach beyond the chain's ends
  EXPECT_FLOAT_EQ(path.length(), 1.0f);
  auto bvh = TriangleBvh::Build(ch.positions_rest, ch.triangles);
  ASSERT_TRUE(bvh.ok());
  const DiskSettings settings = Settings(80, 0.05f);
  const std::vector<DiskLevel> levels = TraverseDisk(*bvh, path, settings);

  // Levels from s = 0 to s = length in equal steps of at most δ.
  ASSERT_EQ(levels.size(), static_cast<size_t>(std::ceil(path.length() / settings.step)) + 1);
  EXPECT_EQ(levels.front().s, 0.0f);
  EXPECT_EQ(levels.back().s, path.length());
  const float spacing = path.length() / static_cast<float>(levels.size() - 1);
  EXPECT_LE(spacing, settings.step * (1.0f + 1e-6f));
  for (size_t h = 1; h < levels.size(); ++h) EXPECT_NEAR(levels[h].s - levels[h - 1].s, spacing, 1e-5f);

  ExpectContactsAreFirstHits(ch, levels, settings);
  // Inside a closed tube every ray meets the wall, at the polygon's distance from the axis: between
  // r·cos(π/48) (mid-edge of the 48-gon) and r (a vertex).
  const float inner = r * std::cos(std::numbers::pi_v<float> / 48.0f);
  for (size_t h = 1; h + 1 < levels.size(); ++h) {
    ASSERT_EQ(levels[h].contacts.size(), 80u) << "level " << h;
    for (const DiskContact& c : levels[h].contacts) {
      const float radial = std::hypot(c.point.x(), c.point.z());
      EXPECT_GE(radial, inner * (1.0f - 1e-5f));
      EXPECT_LE(radial, r * (1.0f + 1e-5f));
      EXPECT_NEAR(c.point.y(), levels[h].s, 1e-5f);  // in the disk's plane
    }
  }
}

TEST(TraverseDisk, ContactsOnAnEllipticPrismLieOnTheEllipse) {
  const float a = 0.3f, b = 0.12f;
  const RawCharacter ch = test::EllipticPrism(a, b, 0.0f, 1.0f, 24, 96);
  const DiskPath path = BuildDiskPath(std::vector<V>{V(0, 0, 0), V(0, 1, 0)}, ch.positions_rest);
  auto bvh = TriangleBvh::Build(ch.positions_rest, ch.triangles);
  ASSERT_TRUE(bvh.ok());
  const DiskSettings settings = Settings(64, 0.1f);
  const std::vector<DiskLevel> levels = TraverseDisk(*bvh, path, settings);
  ExpectContactsAreFirstHits(ch, levels, settings);
  for (size_t h = 1; h + 1 < levels.size(); ++h) {
    ASSERT_EQ(levels[h].contacts.size(), 64u);
    for (const DiskContact& c : levels[h].contacts) {
      const float e = (c.point.x() / a) * (c.point.x() / a) + (c.point.z() / b) * (c.point.z() / b);
      EXPECT_GT(e, 0.99f);  // between the chords of the 96-gon and the ellipse itself
      EXPECT_LT(e, 1.0f + 1e-4f);
    }
  }
}

TEST(TraverseDisk, FrameIsOrthonormalAndCarriedByParallelTransport) {
  // A bent path (up, then up and back) with no triangles: the frame alone.
  DiskPath path =
      BuildDiskPath(std::vector<V>{V(0, 0, 0), V(0, 1, 0), V(0, 2, 1)}, std::vector<V>{V(0, 0, 0), V(0, 2, 1)});
  ASSERT_EQ(path.points.size(), 3u);
  const std::vector<DiskLevel> levels = TraverseDisk(TriangleBvh(), path, Settings(16, 0.1f));
  ASSERT_GT(levels.size(), 20u);
  for (size_t h = 0; h < levels.size(); ++h) {
    const DiskLevel& l = levels[h];
    EXPECT_NEAR(l.tangent.norm(), 1.0f, 1e-6f);
    EXPECT_NEAR(l.n0.norm(), 1.0f, 1e-6f);
    EXPECT_NEAR(l.n1.norm(), 1.0f, 1e-6f);
    EXPECT_NEAR(l.n0.dot(l.tangent), 0.0f, 1e-6f);
    EXPECT_NEAR(l.n1.dot(l.tangent), 0.0f, 1e-6f);
    EXPECT_NEAR(l.n0.dot(l.n1), 0.0f, 1e-6f);
    EXPECT_NEAR(l.n0.cross(l.n1).dot(l.tangent), 1.0f, 1e-6f);  // γ = γ0 × γ1
    EXPECT_TRUE(l.contacts.empty());
    if (h == 0) continue;
    // γ0 is the previous γ0 projected onto the new plane: never turned about the path.
    const V& prev = levels[h - 1].n0;
    const V transported = (prev - prev.dot(l.tangent) * l.tangent).normalized();
    EXPECT_LT((l.n0 - transported).norm(), 1e-6f) << "level " << h;
  }
  // The tangent turns at the joint, from +Y to (0, 1, 1)/√2.
  EXPECT_LT((levels.front().tangent - V(0, 1, 0)).norm(), 1e-6f);
  EXPECT_LT((levels.back().tangent - V(0, 1, 1).normalized()).norm(), 1e-6f);
}

TEST(TraverseDisk, RecentresOnTheContactsOnlyWhenHalfTheRaysHit) {
  // A closed tube with its path off the axis: every ray hits, so each next disk starts at the mean
  // of the previous contacts (moved along the path into the new plane).
  const RawCharacter tube = test::EllipticPrism(0.2f, 0.2f, 0.0f, 1.0f);
  const DiskPath path = BuildDiskPath(std::vector<V>{V(0.1f, 0, 0), V(0.1f, 1, 0)}, tube.positions_rest);
  auto bvh = TriangleBvh::Build(tube.positions_rest, tube.triangles);
  ASSERT_TRUE(bvh.ok());
  const DiskSettings settings = Settings(40, 0.1f);
  std::vector<DiskLevel> levels = TraverseDisk(*bvh, path, settings);
  ExpectContactsAreFirstHits(tube, levels, settings);
  for (size_t h = 1; h < levels.size(); ++h) {
    V point, tangent;
    path.Evaluate(levels[h].s, &point, &tangent);
    V expected = point;
    const DiskLevel& prev = levels[h - 1];
    if (2 * prev.contacts.size() >= static_cast<size_t>(settings.rays)) {
      V mean = V::Zero();
      for (const DiskContact& c : prev.contacts) mean += c.point;
      mean /= static_cast<float>(prev.contacts.size());
      V prev_point, prev_tangent;
      path.Evaluate(prev.s, &prev_point, &prev_tangent);
      const V offset = mean - prev_point;
      expected += offset - offset.dot(tangent) * tangent;
    }
    EXPECT_LT((levels[h].center - expected).norm(), 1e-5f) << "level " << h;
  }
  EXPECT_LT(std::abs(levels[3].center.x()), 0.09f);  // pulled towards the tube's axis

  // An open third of the tube's wall: fewer than half the rays hit, so the disk never leaves the
  // path, and the missing rays are simply not listed (r_i.Δ = -1).
  RawCharacter wall;
  wall.positions_rest = tube.positions_rest;
  for (const Eigen::Vector3i& t : tube.triangles) {
    const V c = (tube.positions_rest[t[0]] + tube.positions_rest[t[1]] + tube.positions_rest[t[2]]) / 3.0f;
    const float phi = std::atan2(c.z(), c.x());
    if (std::abs(c.y() - 0.5f) < 0.49f && phi > 0.0f && phi < 2.0f) wall.triangles.push_back(t);
  }
  auto wall_bvh = TriangleBvh::Build(wall.positions_rest, wall.triangles);
  ASSERT_TRUE(wall_bvh.ok());
  levels = TraverseDisk(*wall_bvh, path, settings);
  ExpectContactsAreFirstHits(wall, levels, settings);
  size_t hits = 0;
  for (const DiskLevel& l : levels) {
    V point, tangent;
    path.Evaluate(l.s, &point, &tangent);
    EXPECT_EQ(l.center, point);
    EXPECT_LT(2 * l.contacts.size(), static_cast<size_t>(settings.rays));
    hits += l.contacts.size();
  }
  EXPECT_GT(hits, 0u);
}

TEST(TraverseDisk, NothingToTraverse) {
  const RawCharacter tube = test::EllipticPrism(0.2f, 0.2f, 0.0f, 1.0f);
  auto bvh = TriangleBvh::Build(tube.positions_rest, tube.triangles);
  ASSERT_TRUE(bvh.ok());
  const DiskPath path = BuildDiskPath(std::vector<V>{V(0, 0, 0), V(0, 1, 0)}, tube.positions_rest);
  EXPECT_TRUE(TraverseDisk(*bvh, path, Settings(2, 0.1f)).empty());   // fewer than 3 rays
  EXPECT_TRUE(TraverseDisk(*bvh, path, Settings(16, 0.0f)).empty());  // no step
  EXPECT_TRUE(TraverseDisk(*bvh, DiskPath{}, Settings(16, 0.1f)).empty());
  // A step longer than the path: the two ends.
  const std::vector<DiskLevel> ends = TraverseDisk(*bvh, path, Settings(16, 5.0f));
  ASSERT_EQ(ends.size(), 2u);
  EXPECT_EQ(ends[0].s, 0.0f);
  EXPECT_EQ(ends[1].s, path.length());
}

TEST(TraverseDisk, Deterministic) {
  const RawCharacter ch = test::EllipticPrism(0.3f, 0.12f, 0.0f, 1.0f);
  const DiskPath path = BuildDiskPath(std::vector<V>{V(0.05f, 0, 0), V(0, 1, 0.02f)}, ch.positions_rest);
  auto bvh = TriangleBvh::Build(ch.positions_rest, ch.triangles);
  ASSERT_TRUE(bvh.ok());
  const auto a = TraverseDisk(*bvh, path, Settings(80, 0.02f));
  const auto b = TraverseDisk(*bvh, path, Settings(80, 0.02f));
  ASSERT_EQ(a.size(), b.size());
  for (size_t h = 0; h < a.size(); ++h) {
    EXPECT_EQ(a[h].center, b[h].center);
    EXPECT_EQ(a[h].n0, b[h].n0);
    ASSERT_EQ(a[h].contacts.size(), b[h].contacts.size());
    for (size_t k = 0; k < a[h].contacts.size(); ++k) {
      EXPECT_EQ(a[h].contacts[k].ray, b[h].contacts[k].ray);
      EXPECT_EQ(a[h].contacts[k].triangle, b[h].contacts[k].triangle);
      EXPECT_EQ(a[h].contacts[k].point, b[h].contacts[k].point);
    }
  }
}

TEST(BuildDiskPath, MergesCoincidentJointsAndExtendsToTheVertices) {
  // Vertices from y = 0 to 1 around a chain from 0.2 to 0.8 with a repeated joint.
  const RawCharacter tube = test::EllipticPrism(0.2f, 0.2f, 0.0f, 1.0f);
  const DiskPath path =
      BuildDiskPath(std::vector<V>{V(0, 0.2f, 0), V(0, 0.2f, 0), V(0, 0.5f, 0), V(0, 0.8f, 0)}, tube.positions_rest);
  ASSERT_EQ(path.points.size(), 5u);
  const float ys[5] = {0.0f, 0.2f, 0.5f, 0.8f, 1.0f};
  for (int k = 0; k < 5; ++k) {
    EXPECT_LT((path.points[k] - V(0, ys[k], 0)).norm(), 1e-6f) << k;
    EXPECT_NEAR(path.arc_length[k], ys[k], 1e-6f) << k;
  }
  V point, tangent;
  path.Evaluate(0.65f, &point, &tangent);
  EXPECT_LT((point - V(0, 0.65f, 0)).norm(), 1e-6f);
  EXPECT_LT((tangent - V(0, 1, 0)).norm(), 1e-6f);
  path.Evaluate(7.0f, &point, &tangent);  // clamped to the end
  EXPECT_LT((point - V(0, 1, 0)).norm(), 1e-6f);
}

TEST(BuildDiskPath, OneJointFallsBackToThePrincipalAxis) {
  // A box-like cloud elongated along X: the path runs along X through its centroid, over its extent.
  std::vector<V> verts;
  for (int i = 0; i <= 10; ++i) {
    for (float y : {-0.1f, 0.1f}) {
      for (float z : {-0.05f, 0.05f}) verts.emplace_back(-1.0f + 0.2f * i, 2.0f + y, z);
    }
  }
  const DiskPath path = BuildDiskPath(std::vector<V>{V(0, 2, 0)}, verts);
  ASSERT_GE(path.points.size(), 2u);
  const V d = (path.points.back() - path.points.front()).normalized();
  EXPECT_GT(std::abs(d.x()), 0.9999f);
  EXPECT_NEAR(path.length(), 2.0f, 1e-5f);
  for (const V& p : path.points) EXPECT_NEAR(p.y(), 2.0f, 1e-5f);
  EXPECT_TRUE(BuildDiskPath(std::vector<V>{V(0, 0, 0), V(0, 1, 0)}, {}).points.empty());
  EXPECT_EQ(DiskPath{}.length(), 0.0f);
}

}  // namespace
}  // namespace skinspheres::lib
