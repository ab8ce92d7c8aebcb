// Triangle pieces (sphere_set.h, TrianglePiece; docs/REFIT.md#triangle-pieces): the grid tiles the
// triangle, Validate() refuses every broken ownership, and both refits hold every piece at random
// poses against skinning in double.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdio>
#include <functional>
#include <random>
#include <string>
#include <vector>

#include "format/grid_point.h"  // runtime/src: the inline grid points of the refit and narrow phase
#include "runtime/narrow_phase/same_contacts.h"
#include "runtime/refit/random_poses.h"
#include "runtime/sample_sphere_set.h"
#include "skinspheres/runtime/broad_phase/pair_filter.h"
#include "skinspheres/runtime/narrow_phase/narrow_phase.h"
#include "skinspheres/runtime/narrow_phase/triangle_contact.h"
#include "skinspheres/runtime/refit/refit_job.h"

namespace skinspheres::runtime {
namespace {

using test::PointInDouble;
using test::RandomWorld;
using test::SkinnedInDouble;

// Twice the signed area of the piece in grid coordinates (i, j).
int TwiceArea(const uint8_t c[3][2]) {
  return (c[1][0] - c[0][0]) * (c[2][1] - c[0][1]) - (c[2][0] - c[0][0]) * (c[1][1] - c[0][1]);
}

// Every level's L² pieces have the same orientation and area 1/L² of the triangle, their corners on
// the grid, and every point of the triangle (random barycentric points, and the grid's own nodes
// nudged inwards) lies in one of them: they tile it.
TEST(TrianglePieces, ThePiecesOfEachLevelTileTheTriangle) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  uint8_t c[3][2];
  for (uint16_t level = 2; level <= kMaxPieceLevel; ++level) {
    for (uint32_t index = 0; index < uint32_t{level} * level; ++index) {
      ASSERT_TRUE(PieceCorners(level, static_cast<uint16_t>(index), c)) << level << " " << index;
      EXPECT_EQ(TwiceArea(c), 1) << "level " << level << " piece " << index;  // the triangle's is L²
      for (const auto& corner : c) EXPECT_LE(corner[0] + corner[1], level);
    }
    EXPECT_FALSE(PieceCorners(level, static_cast<uint16_t>(level * level), c));
    for (int trial = 0; trial < 2000; ++trial) {
      double b1 = u(rng), b2 = u(rng);
      if (b1 + b2 > 1.0) b1 = 1.0 - b1, b2 = 1.0 - b2;
      const double x = b1 * level, y = b2 * level;
      int inside = 0;
      for (uint32_t index = 0; index < uint32_t{level} * level; ++index) {
        PieceCorners(level, static_cast<uint16_t>(index), c);
        bool in = true;
        for (int e = 0; e < 3; ++e) {
          const auto& a = c[e];
          const auto& b = c[(e + 1) % 3];
          in &= (b[0] - a[0]) * (y - a[1]) - (b[1] - a[1]) * (x - a[0]) >= -1e-12;
        }
        inside += in;
      }
      ASSERT_GE(inside, 1) << "level " << level << " point (" << x << ", " << y << ") is in no piece";
    }
  }
  EXPECT_FALSE(PieceCorners(1, 0, c));
  EXPECT_FALSE(PieceCorners(kMaxPieceLevel + 1, 0, c));
}

// The refit and the narrow phase compute grid points with GridPointInline (runtime/src), whose
// weights come from a table built at compile time: each entry must be the bits of the division at
// run time (volatile operands, so the compiler cannot fold it), and the points those of the
// formula written out here with run-time divisions, at every level and grid point.
TEST(TrianglePieces, GridPointWeightsAreTheRunTimeDivisions) {
  for (int level = 1; level <= kMaxPieceLevel; ++level) {
    for (int n = 0; n <= level; ++n) {
      volatile float num = static_cast<float>(n), den = static_cast<float>(level);
      const float quotient = num / den;
      ASSERT_EQ(std::bit_cast<uint32_t>(internal::kGridWeights.w[level][n]), std::bit_cast<uint32_t>(quotient))
          << n << " / " << level;
    }
  }
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> u(-10.0f, 10.0f);
  for (int trial = 0; trial < 50; ++trial) {
    Eigen::Vector3f p[3];
    for (auto& q : p) q = Eigen::Vector3f(u(rng), u(rng), u(rng));
    for (uint16_t level = 2; level <= kMaxPieceLevel; ++level) {
      volatile float den = static_cast<float>(level);
      for (uint8_t i = 0; i <= level; ++i) {
        for (uint8_t j = 0; i + j <= level; ++j) {
          const float w0 = static_cast<float>(level - i - j) / den, w1 = static_cast<float>(i) / den,
                      w2 = static_cast<float>(j) / den;
          const Eigen::Vector3f g = internal::GridPointInline(p[0], p[1], p[2], level, i, j);
          ASSERT_EQ(g, GridPoint(p[0], p[1], p[2], level, i, j));
          for (int a = 0; a < 3; ++a) {
            const float x = (w0 * p[0][a] + w1 * p[1][a]) + w2 * p[2][a];
            const float lo = std::min({p[0][a], p[1][a], p[2][a]}), hi = std::max({p[0][a], p[1][a], p[2][a]});
            ASSERT_EQ(std::bit_cast<uint32_t>(g[a]), std::bit_cast<uint32_t>(std::clamp(x, lo, hi)))
                << level << " " << int(i) << " " << int(j);
          }
        }
      }
    }
  }
}

// A grid point never leaves its triangle's box, even by an ulp: on an edge where the vertices share
// a coordinate it is that coordinate exactly (a piece's box lies in its triangle's), and a corner
// is its vertex exactly. Every level and grid point, on triangles with shared and random
// coordinates.
TEST(TrianglePieces, GridPointsStayInTheirTrianglesBox) {
  std::mt19937 rng(3);
  std::uniform_real_distribution<float> u(-10.0f, 10.0f);
  int checked = 0;
  for (int trial = 0; trial < 200; ++trial) {
    Eigen::Vector3f p[3];
    for (auto& q : p) q = Eigen::Vector3f(u(rng), u(rng), u(rng));
    if (trial % 2 == 0) p[1].x() = p[2].x() = p[0].x() = 0.9f;  // an axis-aligned face
    if (trial % 3 == 0) p[2].y() = p[1].y();                    // an axis-aligned edge
    for (uint16_t level = 2; level <= kMaxPieceLevel; ++level) {
      for (uint8_t i = 0; i <= level; ++i) {
        for (uint8_t j = 0; i + j <= level; ++j) {
          const Eigen::Vector3f g = GridPoint(p[0], p[1], p[2], level, i, j);
          for (int a = 0; a < 3; ++a) {
            ASSERT_GE(g[a], std::min({p[0][a], p[1][a], p[2][a]})) << level << " " << int(i) << " " << int(j);
            ASSERT_LE(g[a], std::max({p[0][a], p[1][a], p[2][a]})) << level << " " << int(i) << " " << int(j);
          }
          if (trial % 2 == 0) {
            ASSERT_EQ(g.x(), 0.9f);
          }
          ++checked;
        }
      }
      ASSERT_EQ(GridPoint(p[0], p[1], p[2], level, 0, 0), p[0]);
      ASSERT_EQ(GridPoint(p[0], p[1], p[2], level, uint8_t(level), 0), p[1]);
      ASSERT_EQ(GridPoint(p[0], p[1], p[2], level, 0, uint8_t(level)), p[2]);
    }
  }
  EXPECT_GT(checked, 100000);
}

TEST(TrianglePieces, ASetWithPiecesValidatesAndEachBrokenOwnershipIsRefused) {
  const SphereSet good = TwoJointsWithPieces();
  ASSERT_EQ(good.Validate(), std::nullopt) << good.Validate()->message;
  auto refused = [&](const char* what, auto edit, const char* words) {
    SphereSet set = good;
    edit(set);
    const auto err = set.Validate();
    ASSERT_NE(err, std::nullopt) << what;
    EXPECT_NE(err->message.find(words), std::string::npos) << what << ": " << err->message;
  };
  refused(
      "a piece missing", [](SphereSet& s) { s.pieces.pop_back(), s.piece_offsets[2] = 3; }, "grid's pieces once");
  refused(
      "a piece twice", [](SphereSet& s) { s.pieces[3].index = 0; }, "grid's pieces once");
  refused(
      "two levels", [](SphereSet& s) { s.pieces[3].level = 3; }, "grid's pieces once");
  refused(
      "owned whole and in pieces",
      [](SphereSet& s) {
        s.triangles = {0, 1}, s.triangle_offsets = {0, 2, 2};
      },
      "owned whole");
  refused(
      "a triangle owned by no one",
      [](SphereSet& s) {
        s.pieces.clear(), s.piece_offsets = {0, 0, 0};
      },
      "triangle entries");
  refused(
      "an index beyond L²", [](SphereSet& s) { s.pieces[0].index = 4; }, "out of range");
  refused(
      "a level beyond the largest", [](SphereSet& s) { s.pieces[0].level = kMaxPieceLevel + 1; }, "out of range");
  refused(
      "a corner listed as a grid point",
      [](SphereSet& s) {
        s.piece_points[0] = {1, 2, 2, 0};
      },
      "triangle corner");
  refused(
      "a grid point twice", [](SphereSet& s) { s.piece_points[1] = s.piece_points[0]; }, "listed twice");
  refused(
      "a corner not in the sphere's list", [](SphereSet& s) { s.vertices[7] = 1; }, "not its grid point");
  refused(
      "a point out of range", [](SphereSet& s) { s.vertices[8] = 7; }, "out of range");
  refused(
      "pieces in two parts",
      [](SphereSet& s) {
        s.parts.push_back({"arm_l", {1}});
        s.sphere_part[1] = 1;
      },
      "different parts");
  refused(
      "grid points without pieces",
      [](SphereSet& s) {
        s.pieces.clear();
        s.piece_offsets.clear();
      },
      "piece lists are malformed");
  refused(
      "pieces without offsets", [](SphereSet& s) { s.piece_offsets.clear(); }, "piece lists are malformed");
  refused(
      "pieces without a mesh",
      [](SphereSet& s) {
        s.triangle_vertices.clear();
        s.mesh = {};
      },
      "no mesh");
  refused(
      "a fast radius below a grid point's copies", [](SphereSet& s) { s.radii_fast[1] *= 0.9f; },
      "grid point (1, 0) of level 2 of triangle 1");
}

// The set's spheres refitted in exact mode from positions skinned at random poses, and in fast
// mode from the joints: every point of every sphere (a piece's corners; the piece is their hull)
// lies inside, the grid points taken in double from the same skinned vertices (exact) or skinned in
// double (fast). Sphere 1 holds only its corner piece of triangle 1: on rigid poses the radius
// around its centre that holds the whole triangle is larger.
// Point `point` of the set's lists from the skinned source vertices, in double: a vertex, or a
// grid point by its barycentric formula over its triangle's vertices.
Eigen::Vector3d PointFromSkinned(const SphereSet& set, const std::vector<Eigen::Vector3f>& skinned, uint32_t point) {
  if (point < set.source_vertex_count) return skinned[point].cast<double>();
  const PiecePoint& g = set.piece_points[point - set.source_vertex_count];
  const uint32_t* v = set.triangle_vertices.data() + 3 * size_t{g.triangle};
  return (double(g.level - g.i - g.j) * skinned[v[0]].cast<double>() + double(g.i) * skinned[v[1]].cast<double>() +
          double(g.j) * skinned[v[2]].cast<double>()) /
         double(g.level);
}

TEST(TrianglePieces, BothRefitsHoldEveryPieceAtRandomPoses) {
  const SphereSet set = TwoJointsWithPieces();
  auto rest = RefitRestData::Create(set);
  ASSERT_TRUE(rest.ok()) << rest.error().message;
  std::mt19937 rng(11);
  std::vector<skinspheres::Mat4f> world(set.joint_count());
  std::vector<Eigen::Vector3f> skinned(set.source_vertex_count);
  std::vector<Vec4f> exact(set.size()), fast(set.size());
  int smaller = 0;
  const int poses = 1000;
  for (int p = 0; p < poses; ++p) {
    RandomWorld(rng, p, &world);
    for (uint32_t v = 0; v < set.source_vertex_count; ++v) skinned[v] = SkinnedInDouble(set, world, v).cast<float>();
    ASSERT_TRUE((RefitJob{RefitMode::kExact, &set, &*rest, world, skinned, exact}.Run()));
    ASSERT_TRUE((RefitJob{RefitMode::kFast, &set, &*rest, world, {}, fast}.Run()));
    for (size_t s = 0; s < set.size(); ++s) {
      for (uint32_t k = set.vertex_offsets[s]; k < set.vertex_offsets[s + 1]; ++k) {
        const uint32_t point = set.vertices[k];
        const Eigen::Vector3d from_skinned = PointFromSkinned(set, skinned, point);
        ASSERT_LE((from_skinned - exact[s].head<3>().cast<double>()).norm(), exact[s].w())
            << "pose " << p << " sphere " << s << " point " << point << " (exact)";
        ASSERT_LE((PointInDouble(set, world, point) - fast[s].head<3>().cast<double>()).norm(), fast[s].w())
            << "pose " << p << " sphere " << s << " point " << point << " (fast)";
      }
    }
    double whole = 0.0;
    for (int c = 0; c < 3; ++c) {
      const uint32_t v = set.triangle_vertices[3 + c];
      whole = std::max(whole, (skinned[v].cast<double>() - exact[1].head<3>().cast<double>()).norm());
    }
    smaller += exact[1].w() < whole;
  }
  // On every pose that moves the joints together (rigidly), sphere 1 holds less than triangle 1. On
  // random poses the two joints pull the triangle apart, often leaving v3, which it holds, farthest
  // from its centre (informational).
  std::printf("sphere 1 smaller than triangle 1 needs on %d of %d random poses\n", smaller, poses);
  for (int p = 0; p < 100; ++p) {
    RandomWorld(rng, 2 * p, &world);
    world[1] = world[0];
    for (uint32_t v = 0; v < set.source_vertex_count; ++v) skinned[v] = SkinnedInDouble(set, world, v).cast<float>();
    ASSERT_TRUE((RefitJob{RefitMode::kExact, &set, &*rest, world, skinned, exact}.Run()));
    double whole = 0.0;
    for (int c = 0; c < 3; ++c) {
      whole = std::max(whole, (skinned[set.triangle_vertices[3 + c]] - exact[1].head<3>()).cast<double>().norm());
    }
    ASSERT_LT(exact[1].w(), 0.9 * whole) << "rigid pose " << p;
  }
}

// TwoJointsWithMesh with triangle 1 (v1 v3 v2) cut at `level`: sphere 1 owns the pieces of
// triangle 1 whose corners all lie in grid rows j <= rows (a trapezoid: v1, v3 and the grid points
// (level - rows, rows), (0, rows)), sphere 0 triangle 0 whole and the other pieces (the triangle
// above). Each sphere lists every corner of what it owns; box centre and holding radius at rest
// (rest = bind), radius_fast from the mesh. Most grid points lie inside those regions.
SphereSet TwoJointsCutAtLevel(uint16_t level, const std::function<int(const uint8_t (&)[3][2])>& sphere_of);
SphereSet TwoJointsCutAtLevel(uint16_t level, int rows) {
  return TwoJointsCutAtLevel(level, [rows](const uint8_t(&c)[3][2]) {
    return std::max({c[0][1], c[1][1], c[2][1]}) <= rows ? 1 : 0;
  });
}

// The same with sphere_of(corners) choosing the sphere (0 or 1) of each piece of triangle 1.
SphereSet TwoJointsCutAtLevel(uint16_t level, const std::function<int(const uint8_t (&)[3][2])>& sphere_of) {
  SphereSet set = TwoJointsWithMesh();
  const uint32_t svc = set.source_vertex_count;
  std::vector<std::pair<int, int>> grid;  // (i, j) of every grid point that is not a corner, key order
  for (int i = 0; i <= level; ++i) {
    for (int j = 0; i + j <= level; ++j) {
      if (GridCorner(level, uint8_t(i), uint8_t(j)) < 0) grid.push_back({i, j});
    }
  }
  set.piece_points.clear();
  for (const auto& [i, j] : grid) set.piece_points.push_back({1, level, uint8_t(i), uint8_t(j)});
  auto point = [&](uint8_t i, uint8_t j) {
    const int corner = GridCorner(level, i, j);
    if (corner >= 0) return set.triangle_vertices[3 + corner];
    const auto at = std::lower_bound(grid.begin(), grid.end(), std::pair<int, int>(i, j));
    return svc + uint32_t(at - grid.begin());
  };
  std::vector<TrianglePiece> mine[2];
  std::vector<uint32_t> points[2] = {{0, 1, 2}, {}};
  for (uint16_t index = 0; index < level * level; ++index) {
    uint8_t c[3][2];
    EXPECT_TRUE(PieceCorners(level, index, c));
    const int s = sphere_of(c);
    mine[s].push_back({1, level, index});
    for (const auto& ij : c) points[s].push_back(point(ij[0], ij[1]));
  }
  set.vertex_offsets = {0};
  set.vertices.clear();
  set.piece_offsets = {0};
  set.pieces.clear();
  for (int s = 0; s < 2; ++s) {
    std::sort(points[s].begin(), points[s].end());
    points[s].erase(std::unique(points[s].begin(), points[s].end()), points[s].end());
    set.vertices.insert(set.vertices.end(), points[s].begin(), points[s].end());
    set.vertex_offsets.push_back(uint32_t(set.vertices.size()));
    set.pieces.insert(set.pieces.end(), mine[s].begin(), mine[s].end());
    set.piece_offsets.push_back(uint32_t(set.pieces.size()));
  }
  set.triangle_offsets = {0, 1, 1};
  set.triangles = {0};
  FitSpheresToPointsAtBind(set);
  return set;
}

// At 300 random poses (seed `seed`), the exact refit with rest data holds every point each
// sphere lists, each computed in double from the skinned vertices (PointFromSkinned).
void ExactRefitHoldsEveryListedPoint(const SphereSet& set, const RefitRestData& rest, uint32_t seed,
                                     const std::string& what) {
  std::mt19937 rng(seed);
  std::vector<skinspheres::Mat4f> world(set.joint_count());
  std::vector<Eigen::Vector3f> skinned(set.source_vertex_count);
  std::vector<Vec4f> spheres(set.size());
  for (int p = 0; p < 300; ++p) {
    RandomWorld(rng, p, &world);
    for (uint32_t v = 0; v < set.source_vertex_count; ++v) skinned[v] = SkinnedInDouble(set, world, v).cast<float>();
    ASSERT_TRUE((RefitJob{RefitMode::kExact, &set, &rest, world, skinned, spheres}.Run()));
    for (size_t s = 0; s < set.size(); ++s) {
      for (uint32_t k = set.vertex_offsets[s]; k < set.vertex_offsets[s + 1]; ++k) {
        const Eigen::Vector3d q = PointFromSkinned(set, skinned, set.vertices[k]);
        ASSERT_LE((q - spheres[s].head<3>().cast<double>()).norm(), spheres[s].w())
            << what << " pose " << p << " sphere " << s << " point " << set.vertices[k];
      }
    }
  }
}

// Exact mode bounds only the corners of each sphere's hull on a cut triangle
// (RefitRestData::exact_points): the grid points inside are left out, yet at random poses the
// refitted sphere holds every point the set lists, each computed in double from the skinned
// vertices.
TEST(TrianglePieces, ExactRefitBoundsTheHullCornersAndHoldsEveryPoint) {
  for (const auto& [level, rows] : {std::pair<uint16_t, int>{8, 3}, {16, 5}, {5, 1}}) {
    const SphereSet set = TwoJointsCutAtLevel(level, rows);
    ASSERT_EQ(set.Validate(), std::nullopt) << set.Validate()->message;
    auto rest = RefitRestData::Create(set);
    ASSERT_TRUE(rest.ok()) << rest.error().message;
    ASSERT_EQ(rest->exact_point_offsets().size(), set.size() + 1);
    // Sphere 0 lists v0-v2 and, on triangle 1, v1, v2 and the grid points of its region: the hull
    // there is v1, (level - rows, rows), v2, so it keeps four points. Sphere 1 keeps its trapezoid's
    // four corners. Every other grid point is left out.
    ASSERT_EQ(rest->exact_point_offsets()[1], 4u) << "level " << level;
    ASSERT_EQ(rest->exact_points().size() - rest->exact_point_offsets()[1], 4u) << "level " << level;
    ExactRefitHoldsEveryListedPoint(set, *rest, 29, "level " + std::to_string(level));
    if (HasFatalFailure()) return;
  }
}

// A set may list a grid point of another level than its triangle's cut (Validate() accepts it):
// the hull is taken per level, so such a point is never compared in the wrong grid's coordinates,
// and every listed point stays inside the refitted sphere at random poses.
TEST(TrianglePieces, ExactRefitKeepsTheHullOfEachLevelApart) {
  // Sphere 1 owns one piece of the level-4 cut, corners (1, 1) (2, 1) (1, 2), and also lists the
  // level-2 grid point (1, 0), the midpoint of v1 v3, at level-4 coordinates (2, 0). Mixed with
  // level-4 coordinates it would read as (1, 0), and (1, 1) would seem to lie on the edge from it
  // to (1, 2); in truth (1, 1) is a corner of the four points' hull.
  SphereSet set = TwoJointsCutAtLevel(4, [](const uint8_t(&c)[3][2]) {
    return c[0][0] == 1 && c[0][1] == 1 && c[1][0] == 2 && c[1][1] == 1 && c[2][0] == 1 && c[2][1] == 2 ? 1 : 0;
  });
  const uint32_t stray = set.source_vertex_count + uint32_t(set.piece_points.size());
  set.piece_points.push_back({1, 2, 1, 0});
  set.vertices.push_back(stray);  // sphere 1 is the last
  ++set.vertex_offsets.back();
  FitSpheresToPointsAtBind(set);
  ASSERT_EQ(set.Validate(), std::nullopt) << set.Validate()->message;
  ASSERT_EQ(set.vertex_offsets[2] - set.vertex_offsets[1], 4u);
  auto rest = RefitRestData::Create(set);
  ASSERT_TRUE(rest.ok()) << rest.error().message;
  ExactRefitHoldsEveryListedPoint(set, *rest, 31, "mixed levels");
}

// Two triangles on two joints: A = (0,0,0) (1,0,0) (0,1,0) on joint a, cut at level 3, its pieces
// 0-4 owned by sphere 0 and 5-8 by sphere 1 (part "torso"); B, 0.4 above it, whole in sphere 2 on
// joint b (part "arm_l"). Rest = bind = identity. `excluded`: the sphere pairs the set excludes.
SphereSet CutTriangleAndAnother(std::vector<ExcludedPair> excluded) {
  SphereSet set;
  set.source_vertex_count = 6;
  set.source_triangle_count = 2;
  set.joint_names = {"a", "b"};
  set.joint_parents = {-1, 0};
  set.joint_rest_world = {skinspheres::Mat4f::Identity(), skinspheres::Mat4f::Identity()};
  set.parts = {{"torso", {0}}, {"arm_l", {1}}};
  set.triangle_vertices = {0, 1, 2, 3, 4, 5};
  set.mesh.positions_bind = {{0, 0, 0},          {1, 0, 0},          {0, 1, 0},
                             {0.2f, 0.2f, 0.4f}, {0.7f, 0.3f, 0.4f}, {0.3f, 0.6f, 0.4f}};
  set.mesh.binds = {skinning::BindEntry{0, skinspheres::Mat4f::Identity()},
                    skinning::BindEntry{1, skinspheres::Mat4f::Identity()}};
  set.mesh.influence_offsets = {0, 1, 2, 3, 4, 5, 6};
  set.mesh.influence_binds = {0, 0, 0, 1, 1, 1};
  set.mesh.influence_weights = {1, 1, 1, 1, 1, 1};
  const uint16_t level = 3;
  std::vector<std::vector<uint32_t>> points(3);
  set.piece_offsets = {0};
  for (uint32_t s = 0; s < 2; ++s) {
    for (uint16_t index = s == 0 ? 0 : 5; index < (s == 0 ? 5 : 9); ++index) {
      set.pieces.push_back({0, level, index});
      uint8_t c[3][2];
      PieceCorners(level, index, c);
      for (const auto& corner : c) {
        const uint8_t i = corner[0], j = corner[1];
        const int vertex = GridCorner(level, i, j);
        uint32_t point = vertex < 0 ? UINT32_MAX : uint32_t(vertex);  // triangle A is vertices 0 1 2
        if (point == UINT32_MAX) {
          const PiecePoint g{0, level, i, j};
          auto it = std::find(set.piece_points.begin(), set.piece_points.end(), g);
          if (it == set.piece_points.end()) it = set.piece_points.insert(it, g);
          point = set.source_vertex_count + static_cast<uint32_t>(it - set.piece_points.begin());
        }
        points[s].push_back(point);
      }
    }
    set.piece_offsets.push_back(static_cast<uint32_t>(set.pieces.size()));
  }
  set.piece_offsets.push_back(static_cast<uint32_t>(set.pieces.size()));
  points[2] = {3, 4, 5};
  set.vertex_offsets = {0};
  for (auto& list : points) {
    std::sort(list.begin(), list.end());
    list.erase(std::unique(list.begin(), list.end()), list.end());
    set.vertices.insert(set.vertices.end(), list.begin(), list.end());
    set.vertex_offsets.push_back(static_cast<uint32_t>(set.vertices.size()));
  }
  set.triangle_offsets = {0, 0, 0, 1};
  set.triangles = {1};
  set.influence_offsets = {0, 1, 2, 3};
  set.influence_joints = {0, 0, 1};
  set.influence_weights = {1, 1, 1};
  set.sphere_part = {0, 0, 1};
  set.sphere_joint = {0, 0, 1};
  set.sphere_level = {0, 1, 0};
  for (size_t s = 0; s < 3; ++s) {
    Eigen::Vector3f lo = Eigen::Vector3f::Constant(1e30f), hi = -lo;
    for (uint32_t k = set.vertex_offsets[s]; k < set.vertex_offsets[s + 1]; ++k) {
      const Eigen::Vector3f p = set.PointAt(set.vertices[k], set.mesh.positions_bind.data());
      lo = lo.cwiseMin(p), hi = hi.cwiseMax(p);
    }
    set.centers_rest.push_back(0.5f * (lo + hi));
    set.radii_rest.push_back(std::nextafter(0.5f * (hi - lo).norm(), 1e30f));
  }
  set.radii_fast = set.radii_rest;
  set.excluded_pairs = std::move(excluded);
  return set;
}

// The narrow phase on a cut triangle A against a whole triangle B that joint b carries through it
// at random poses (exact spheres, every pair the filter allows given, as a broad phase without
// culling would): equal to the brute-force oracle, bit for bit, and to an oracle that knows nothing
// of pieces or spheres. Rules on triangles with hops 0 (joints a and b apart enough): (A, B) is
// reported exactly when the whole triangles meet, once, under the part pair (torso, arm_l), whichever
// sphere owns the piece where they meet. With hops 1 (a is b's parent) rule 2 excludes them, and with
// it every sphere pair. A set with its rules on sphere pairs that excludes (0, 2) and (1, 2) reports
// nothing either.
TEST(TrianglePieces, TheNarrowPhaseTestsPiecesAndReportsEachTrianglePairOnce) {
  enum class Rules { kHopsZero, kHopsOne, kSpherePairs };
  for (const Rules rules : {Rules::kHopsZero, Rules::kHopsOne, Rules::kSpherePairs}) {
    SCOPED_TRACE(rules == Rules::kHopsZero ? "hops 0" : rules == Rules::kHopsOne ? "hops 1" : "sphere pairs");
    SphereSet set = CutTriangleAndAnother({});
    if (rules == Rules::kSpherePairs) {
      set.contact_rules = ContactRules::kSpherePairs;
      set.contact_hops = 0;
      set.excluded_pairs = {{0, 2, ExclusionReason::kBindOverlap}, {1, 2, ExclusionReason::kBindOverlap}};
    } else {
      ASSERT_EQ(WriteContactRules(&set, rules == Rules::kHopsZero ? 0 : 1, 0.0f), std::nullopt);
      // Rule 2 at hops 1 excludes every pair of spheres of joints a and b; at hops 0 only (0, 1).
      EXPECT_EQ(set.excluded_pairs.size(), rules == Rules::kHopsZero ? 1u : 3u);
    }
    ASSERT_EQ(set.Validate(), std::nullopt) << set.Validate()->message;
    auto filter = PairFilter::FromSphereSet(set);
    ASSERT_TRUE(filter.ok()) << filter.error().message;
    auto data = NarrowPhaseData::Create(set, *filter);
    ASSERT_TRUE(data.ok()) << data.error().message;
    auto rest = RefitRestData::Create(set);
    ASSERT_TRUE(rest.ok());
    std::vector<SpherePair> pairs;
    for (uint32_t i = 0; i < 3; ++i) {
      for (uint32_t j = i + 1; j < 3; ++j) {
        if (!filter->excluded(i, j)) pairs.push_back({i, j});
      }
    }
    NarrowPhaseContext ctx;
    ctx.Resize(*data, false);
    std::mt19937 rng(5);
    std::uniform_real_distribution<float> shift(-0.4f, 0.4f), drop(-0.55f, -0.25f), angle(-0.6f, 0.6f);
    std::vector<skinspheres::Mat4f> world(2, skinspheres::Mat4f::Identity());
    std::vector<Eigen::Vector3f> positions(6);
    std::vector<Vec4f> spheres(3);
    int reported = 0, by_sphere[3] = {0, 0, 0};
    for (int pose = 0; pose < 600; ++pose) {
      const Eigen::Affine3f b = Eigen::Translation3f(shift(rng), shift(rng), drop(rng)) *
                                Eigen::AngleAxisf(angle(rng), Eigen::Vector3f(shift(rng), shift(rng), 1).normalized());
      world[1] = b.matrix();
      for (uint32_t v = 0; v < 6; ++v) positions[v] = SkinnedInDouble(set, world, v).cast<float>();
      ASSERT_TRUE((RefitJob{RefitMode::kExact, &set, &*rest, world, positions, spheres}.Run()));
      FrameContacts out, oracle;
      ASSERT_TRUE((NarrowPhaseJob{&set, &*data, spheres, pairs, positions, world, &ctx, &out}.Run()));
      ASSERT_TRUE(FindContactsBruteForce(set, *data, *filter, positions, &oracle));
      EXPECT_SAME_CONTACTS(out, oracle, "pose " + std::to_string(pose));

      TriangleContactGeometry g;
      const bool whole = TriangleContactOf(positions[0], positions[1], positions[2], positions[3], positions[4],
                                           positions[5], 0.0f, &g);
      const bool expected = whole && rules == Rules::kHopsZero;
      ASSERT_EQ(out.triangle_pairs.size(), expected ? 1u : 0u) << "pose " << pose;
      if (!expected) continue;
      ++reported;
      EXPECT_EQ(out.triangle_pairs[0].triangle_a, 0u);
      EXPECT_EQ(out.triangle_pairs[0].triangle_b, 1u);
      ASSERT_EQ(out.parts.size(), 1u);
      EXPECT_EQ(out.parts[0].part_a, 0);
      EXPECT_EQ(out.parts[0].part_b, 1);
      EXPECT_EQ(out.parts[0].triangle_pair_count, 1u);
      // One sphere pair: the piece's owner where the segment's midpoint lies, and B's.
      ASSERT_EQ(out.parts[0].sphere_pair_count, 1u);
      const SpherePairId owners = out.sphere_pairs[out.parts[0].first_sphere_pair];
      EXPECT_EQ(owners.j, 2u);
      ++by_sphere[owners.i];
    }
    std::printf("%s: A and B reported on %d of 600 poses (the contact in sphere 0's pieces %d times, 1's %d)\n",
                rules == Rules::kHopsZero  ? "hops 0"
                : rules == Rules::kHopsOne ? "hops 1"
                                           : "sphere pairs",
                reported, by_sphere[0], by_sphere[1]);
    if (rules == Rules::kHopsZero) {
      EXPECT_GT(reported, 20);
      EXPECT_LT(reported, 580);
      EXPECT_GT(by_sphere[0], 0);
      EXPECT_GT(by_sphere[1], 0);
    }
  }
}

}  // namespace
}  // namespace skinspheres::runtime
