// Triangle-triangle tests (triangle_contact.h) against independent oracles:
//  - exact integer arithmetic (__int128) on integer coordinates: "two closed triangles meet iff an
//    edge of one meets the other", with every touching and coplanar coincidence a small grid gives,
//    and near-coplanar configurations with full 24-bit mantissas (where double rounding matters);
//  - analytic configurations with known answers (crossing, touching at a vertex / an edge, coplanar
//    overlap / containment / shared edge, one float step apart, degenerate and sliver triangles);
//  - distances: parallel faces, vertex-face, skew edges with known distance, and dense sampling.
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <random>

#include "narrow_phase/exact_predicates.h"
#include "skinspheres/runtime/narrow_phase/triangle_contact.h"

namespace skinspheres::runtime {
namespace {

using Eigen::Vector3f;
__extension__ using i128 = __int128;  // GCC and clang have it; -Wpedantic needs the marker

// ------------------------------------------------------------------ the integer oracle

struct I3 {
  int64_t x, y, z;
};
using ITri = std::array<I3, 3>;

i128 Orient(const I3& a, const I3& b, const I3& c, const I3& d) {
  const i128 ux = b.x - a.x, uy = b.y - a.y, uz = b.z - a.z;
  const i128 vx = c.x - a.x, vy = c.y - a.y, vz = c.z - a.z;
  const i128 wx = d.x - a.x, wy = d.y - a.y, wz = d.z - a.z;
  return wx * (uy * vz - uz * vy) + wy * (uz * vx - ux * vz) + wz * (ux * vy - uy * vx);
}
int Sgn(i128 v) { return (v > 0) - (v < 0); }

struct I2 {
  i128 x, y;
};
i128 Orient2(const I2& a, const I2& b, const I2& c) { return (b.x - a.x) * (c.y - a.y) - (b.y - a.y) * (c.x - a.x); }

struct Normal {
  i128 x, y, z;
};
Normal NormalOf(const ITri& t) {
  const i128 ux = t[1].x - t[0].x, uy = t[1].y - t[0].y, uz = t[1].z - t[0].z;
  const i128 vx = t[2].x - t[0].x, vy = t[2].y - t[0].y, vz = t[2].z - t[0].z;
  return {uy * vz - uz * vy, uz * vx - ux * vz, ux * vy - uy * vx};
}
bool IsDegenerate(const ITri& t) {
  const Normal n = NormalOf(t);
  return n.x == 0 && n.y == 0 && n.z == 0;
}
I2 Drop(const I3& p, int axis) {
  if (axis == 0) return {p.y, p.z};
  if (axis == 1) return {p.x, p.z};
  return {p.x, p.y};
}
bool OnSeg(const I2& p, const I2& q, const I2& r) {
  return std::min(p.x, q.x) <= r.x && r.x <= std::max(p.x, q.x) && std::min(p.y, q.y) <= r.y &&
         r.y <= std::max(p.y, q.y);
}
bool Seg2(const I2& p1, const I2& q1, const I2& p2, const I2& q2) {
  const int o1 = Sgn(Orient2(p1, q1, p2)), o2 = Sgn(Orient2(p1, q1, q2)), o3 = Sgn(Orient2(p2, q2, p1)),
            o4 = Sgn(Orient2(p2, q2, q1));
  if (o1 * o2 < 0 && o3 * o4 < 0) return true;
  return (o1 == 0 && OnSeg(p1, q1, p2)) || (o2 == 0 && OnSeg(p1, q1, q2)) || (o3 == 0 && OnSeg(p2, q2, p1)) ||
         (o4 == 0 && OnSeg(p2, q2, q1));
}
bool In2(const I2& p, const I2 t[3]) {
  const int s0 = Sgn(Orient2(t[0], t[1], p)), s1 = Sgn(Orient2(t[1], t[2], p)), s2 = Sgn(Orient2(t[2], t[0], p));
  return (s0 >= 0 && s1 >= 0 && s2 >= 0) || (s0 <= 0 && s1 <= 0 && s2 <= 0);
}

// Closed segment [p, q] against the closed, non-degenerate triangle t.
bool SegmentMeetsTriangle(const I3& p, const I3& q, const ITri& t) {
  const int sp = Sgn(Orient(t[0], t[1], t[2], p)), sq = Sgn(Orient(t[0], t[1], t[2], q));
  if (sp * sq > 0) return false;
  if (sp == 0 && sq == 0) {  // in the plane: 2D, dropping an axis the normal has
    const Normal n = NormalOf(t);
    const int axis = n.x != 0 ? 0 : (n.y != 0 ? 1 : 2);
    const I2 tp[3] = {Drop(t[0], axis), Drop(t[1], axis), Drop(t[2], axis)};
    const I2 a = Drop(p, axis), b = Drop(q, axis);
    if (In2(a, tp) || In2(b, tp)) return true;
    for (int e = 0; e < 3; ++e) {
      if (Seg2(a, b, tp[e], tp[(e + 1) % 3])) return true;
    }
    return false;
  }
  // The line pq crosses the plane once, on the segment: inside iff it passes every edge on the
  // same side.
  const int s0 = Sgn(Orient(p, q, t[0], t[1])), s1 = Sgn(Orient(p, q, t[1], t[2])), s2 = Sgn(Orient(p, q, t[2], t[0]));
  return (s0 >= 0 && s1 >= 0 && s2 >= 0) || (s0 <= 0 && s1 <= 0 && s2 <= 0);
}

bool OracleIntersect(const ITri& a, const ITri& b) {
  if (IsDegenerate(a) || IsDegenerate(b)) return false;
  for (int e = 0; e < 3; ++e) {
    if (SegmentMeetsTriangle(a[e], a[(e + 1) % 3], b) || SegmentMeetsTriangle(b[e], b[(e + 1) % 3], a)) return true;
  }
  return false;
}

Vector3f ToF(const I3& p, float scale) { return Vector3f(float(p.x) * scale, float(p.y) * scale, float(p.z) * scale); }

bool Intersect(const ITri& a, const ITri& b, float scale) {
  return TrianglesIntersect(ToF(a[0], scale), ToF(a[1], scale), ToF(a[2], scale), ToF(b[0], scale), ToF(b[1], scale),
                            ToF(b[2], scale));
}

// Every vertex order and both triangle orders must give the same answer.
void ExpectSymmetric(const ITri& a, const ITri& b, float scale, bool expected) {
  static const int kPerm[6][3] = {{0, 1, 2}, {1, 2, 0}, {2, 0, 1}, {0, 2, 1}, {2, 1, 0}, {1, 0, 2}};
  for (const auto& pa : kPerm) {
    const ITri a2 = {a[pa[0]], a[pa[1]], a[pa[2]]};
    for (const auto& pb : {kPerm[0], kPerm[3], kPerm[4]}) {
      const ITri b2 = {b[pb[0]], b[pb[1]], b[pb[2]]};
      ASSERT_EQ(Intersect(a2, b2, scale), expected);
      ASSERT_EQ(Intersect(b2, a2, scale), expected);
    }
  }
}

TEST(TriangleIntersect, MatchesExactIntegerOracleOnASmallGrid) {
  // Coordinates in [-2, 2]: shared vertices, touching edges, coplanar pieces and degenerate
  // triangles are everywhere.
  std::mt19937 rng(7);
  std::uniform_int_distribution<int> c(-2, 2);
  size_t hits = 0, coplanar = 0, degenerate = 0;
  constexpr int kPairs = 400000;
  for (int n = 0; n < kPairs; ++n) {
    ITri a, b;
    for (auto& p : a) p = {c(rng), c(rng), c(rng)};
    for (auto& p : b) p = {c(rng), c(rng), c(rng)};
    if (n % 3 == 0) {  // force coplanar pairs: put b in a's plane z = 0
      for (auto& p : a) p.z = 0;
      for (auto& p : b) p.z = 0;
    }
    const bool expected = OracleIntersect(a, b);
    degenerate += IsDegenerate(a) || IsDegenerate(b);
    coplanar += !IsDegenerate(a) && Sgn(Orient(a[0], a[1], a[2], b[0])) == 0 &&
                Sgn(Orient(a[0], a[1], a[2], b[1])) == 0 && Sgn(Orient(a[0], a[1], a[2], b[2])) == 0;
    hits += expected;
    // Scales that are powers of two keep the coordinates exact in float.
    const float scale = (n % 2) ? 1.0f : 0.125f;
    ASSERT_EQ(Intersect(a, b, scale), expected) << "pair " << n;
    if (n % 50 == 0) ExpectSymmetric(a, b, scale, expected);
  }
  std::printf("[grid] %d pairs: %zu intersect, %zu coplanar, %zu with a degenerate triangle\n", kPairs, hits, coplanar,
              degenerate);
  EXPECT_GT(hits, size_t(kPairs / 10));
  EXPECT_GT(coplanar, size_t(kPairs / 10));
  EXPECT_GT(degenerate, size_t(kPairs / 100));
}

TEST(TriangleIntersect, MatchesExactOracleNearCoplanarWithFullMantissas) {
  // Integers up to 2^22 (exact in float) scaled by 2^-20: double products of three differences
  // round, so the filter cannot decide near-coplanar pairs and the exact path must.
  std::mt19937 rng(11);
  std::uniform_int_distribution<int64_t> c(-(1 << 22), 1 << 22);
  std::uniform_int_distribution<int> small(-1, 1);
  const float scale = std::ldexp(1.0f, -20);
  size_t hits = 0, near_coplanar = 0;
  for (int n = 0; n < 100000; ++n) {
    ITri a, b;
    for (auto& p : a) p = {c(rng), c(rng), c(rng)};
    // b's vertices: affine combinations of a's rounded to the grid, nudged by -1..1: within a few
    // units of a's plane, often exactly on it.
    for (auto& p : b) {
      const double s = std::uniform_real_distribution<double>(-0.5, 1.5)(rng);
      const double t = std::uniform_real_distribution<double>(-0.5, 1.5)(rng);
      p.x = int64_t(std::llround(a[0].x + s * (a[1].x - a[0].x) + t * (a[2].x - a[0].x))) + small(rng);
      p.y = int64_t(std::llround(a[0].y + s * (a[1].y - a[0].y) + t * (a[2].y - a[0].y))) + small(rng);
      p.z = int64_t(std::llround(a[0].z + s * (a[1].z - a[0].z) + t * (a[2].z - a[0].z))) + small(rng);
      if (std::abs(p.x) > (1 << 23) || std::abs(p.y) > (1 << 23) || std::abs(p.z) > (1 << 23)) p = a[0];
    }
    const bool expected = OracleIntersect(a, b);
    hits += expected;
    near_coplanar += Sgn(Orient(a[0], a[1], a[2], b[0])) == 0;
    ASSERT_EQ(Intersect(a, b, scale), expected) << "pair " << n;
  }
  std::printf("[near-coplanar] %zu of 100000 intersect, %zu with a vertex exactly on the plane\n", hits, near_coplanar);
  EXPECT_GT(hits, 1000u);
  EXPECT_GT(near_coplanar, 1000u);
}

TEST(ExactPredicates, Orient3dSignIsExact) {
  std::mt19937 rng(3);
  std::uniform_int_distribution<int64_t> c(-(1 << 23), 1 << 23);
  const double scale = std::ldexp(1.0, -20);
  int exact_zero = 0;
  for (int n = 0; n < 200000; ++n) {
    I3 p[4];
    for (int k = 0; k < 3; ++k) p[k] = {c(rng), c(rng), c(rng)};
    // d near the plane of a, b, c: a + (b - a) + (c - a) / 2^k rounded, with +-1 nudges.
    const int shift = n % 8;
    p[3] = {p[0].x + (p[1].x - p[0].x) / 2 + ((p[2].x - p[0].x) >> shift) + (n % 3 - 1),
            p[0].y + (p[1].y - p[0].y) / 2 + ((p[2].y - p[0].y) >> shift),
            p[0].z + (p[1].z - p[0].z) / 2 + ((p[2].z - p[0].z) >> shift)};
    if (std::abs(p[3].x) > (1 << 24) || std::abs(p[3].y) > (1 << 24) || std::abs(p[3].z) > (1 << 24)) continue;
    exact::P3 q[4];
    for (int k = 0; k < 4; ++k) q[k] = {double(p[k].x) * scale, double(p[k].y) * scale, double(p[k].z) * scale};
    const int expected = Sgn(Orient(p[0], p[1], p[2], p[3]));
    exact_zero += expected == 0;
    ASSERT_EQ(exact::Orient3d(q[0], q[1], q[2], q[3]), expected) << n;
    ASSERT_EQ(exact::Orient3dExact(q[0], q[1], q[2], q[3]), expected) << n;
    ASSERT_EQ(exact::Orient3d(q[1], q[2], q[0], q[3]), expected) << n;
    ASSERT_EQ(exact::Orient3d(q[1], q[0], q[2], q[3]), -expected) << n;
    // 2D: the xy projections.
    const int e2 = Sgn(Orient2({p[0].x, p[0].y}, {p[1].x, p[1].y}, {p[3].x, p[3].y}));
    ASSERT_EQ(exact::Orient2d(q[0].x, q[0].y, q[1].x, q[1].y, q[3].x, q[3].y), e2) << n;
    ASSERT_EQ(exact::Orient2dExact(q[0].x, q[0].y, q[1].x, q[1].y, q[3].x, q[3].y), e2) << n;
  }
  EXPECT_GT(exact_zero, 100);
}

TEST(ExactPredicates, CoordinatesOfVeryDifferentMagnitude) {
  // The plane through (2^60, 0, 0), (0, 2^-60, 0), (0, 0, 1): x / 2^60 + y * 2^60 + z = 1. Its
  // normal is (2^-60, 2^60, 1), so a point's side is decided by terms 2^120 apart: the double
  // filter cannot, the exact path must. Every coordinate is a float.
  const double big = std::ldexp(1.0, 60), small = std::ldexp(1.0, -60);
  const double tiny = double(std::numeric_limits<float>::denorm_min());
  const exact::P3 a{big, 0, 0}, b{0, small, 0}, c{0, 0, 1};
  EXPECT_EQ(exact::Orient3d(a, b, c, {big / 2, small / 2, 0}), 0);
  EXPECT_EQ(exact::Orient3d(a, b, c, {big / 2, small / 2, tiny}), 1);
  EXPECT_EQ(exact::Orient3d(a, b, c, {big / 2, small / 2, -tiny}), -1);
  EXPECT_EQ(exact::Orient3d(b, a, c, {big / 2, small / 2, tiny}), -1);
  EXPECT_EQ(exact::Orient2d(big, 0, 0, small, big / 2, small / 2), 0);
  // Beyond the line x / 2^60 + y * 2^60 = 1 by one float step of y: (b - a) x (c - a) < 0.
  EXPECT_EQ(exact::Orient2d(big, 0, 0, small, big / 2, double(std::nextafter(float(small / 2), 1.0f))), -1);
  EXPECT_EQ(exact::Orient2d(big, 0, 0, small, big / 2, double(std::nextafter(float(small / 2), 0.0f))), 1);
}

// ------------------------------------------------------------------ analytic configurations

struct Tri {
  Vector3f a, b, c;
};

bool Hit(const Tri& s, const Tri& t) { return TrianglesIntersect(s.a, s.b, s.c, t.a, t.b, t.c); }

float Up(float v) { return std::nextafter(v, INFINITY); }
float Down(float v) { return std::nextafter(v, -INFINITY); }

const Tri kFloor = {{0, 0, 0}, {2, 0, 0}, {0, 2, 0}};  // in z = 0

TEST(TriangleIntersect, CrossingAndSeparated) {
  const Tri through = {{0.5f, 0.5f, -1}, {0.5f, 0.5f, 1}, {1.5f, -1, 0.3f}};
  EXPECT_TRUE(Hit(kFloor, through));
  EXPECT_TRUE(Hit(through, kFloor));
  const Tri above = {{0.5f, 0.5f, 0.25f}, {0.5f, 0.5f, 1}, {1.5f, -1, 0.3f}};
  EXPECT_FALSE(Hit(kFloor, above));
  // Planes cross but the triangles miss each other (the other triangle's piece of the line lies
  // beyond the floor's hypotenuse).
  const Tri beside = {{1.6f, 1.6f, -1}, {1.6f, 1.6f, 1}, {3, 3, 0}};
  EXPECT_FALSE(Hit(kFloor, beside));
}

TEST(TriangleIntersect, VertexOnFaceTouchesAndOneFloatStepAboveDoesNot) {
  const Tri on = {{0.5f, 0.5f, 0}, {0.5f, 0.5f, 1}, {1, 0.75f, 1}};
  EXPECT_TRUE(Hit(kFloor, on));
  const Tri above = {{0.5f, 0.5f, Up(0.0f)}, {0.5f, 0.5f, 1}, {1, 0.75f, 1}};
  EXPECT_FALSE(Hit(kFloor, above));
  // A vertex exactly on the hypotenuse edge x + y = 2 (touching), and one float step outside it.
  const Tri on_edge = {{1, 1, 0}, {1, 1, 1}, {2, 2, 1}};
  EXPECT_TRUE(Hit(kFloor, on_edge));
  const Tri off_edge = {{1, Up(1.0f), 0}, {1, Up(1.0f), 1}, {2, 2, 1}};
  EXPECT_FALSE(Hit(kFloor, off_edge));
}

TEST(TriangleIntersect, EdgeAgainstEdge) {
  // The floor's edge along x (y = 0, z = 0) crossed by an edge of a vertical triangle in x = 1.
  const Tri crossing = {{1, -1, 0}, {1, 1, 0}, {1, 0, 1}};  // edge (1,-1,0)-(1,1,0) crosses (1,0,0)
  EXPECT_TRUE(Hit(kFloor, crossing));
  const Tri edge_touch = {{1, 0, 0}, {1, -1, 1}, {1, -1, -1}};  // only the point (1,0,0) is shared
  EXPECT_TRUE(Hit(kFloor, edge_touch));
  const Tri edge_apart = {{1, Down(0.0f), 0}, {1, -1, 1}, {1, -1, -1}};
  EXPECT_FALSE(Hit(kFloor, edge_apart));
  // Skew edges: the floor's edge x = 0 (along y) and an edge along x at z = 0, y = 1 crossing it
  // exactly, with the rest of the triangle below the floor plane.
  const Tri skew = {{-1, 1, 0}, {1, 1, 0}, {0, 1, -1}};
  EXPECT_TRUE(Hit(kFloor, skew));
}

TEST(TriangleIntersect, CoplanarCases) {
  EXPECT_TRUE(Hit(kFloor, {{0.5f, 0.5f, 0}, {3, 0.5f, 0}, {0.5f, 3, 0}}));        // overlapping
  EXPECT_TRUE(Hit(kFloor, {{0.1f, 0.1f, 0}, {0.5f, 0.1f, 0}, {0.1f, 0.5f, 0}}));  // contained
  EXPECT_TRUE(Hit({{0.1f, 0.1f, 0}, {0.5f, 0.1f, 0}, {0.1f, 0.5f, 0}}, kFloor));  // container second
  EXPECT_TRUE(Hit(kFloor, {{2, 0, 0}, {0, 2, 0}, {2, 2, 0}}));                    // shared edge
  EXPECT_TRUE(Hit(kFloor, {{2, 0, 0}, {3, 0, 0}, {3, 1, 0}}));                    // shared vertex
  EXPECT_TRUE(Hit(kFloor, {{1, 1, 0}, {3, 1, 0}, {1, 3, 0}}));                    // vertex on edge
  EXPECT_FALSE(Hit(kFloor, {{Up(1.0f), Up(1.0f), 0}, {3, 1, 0}, {1, 3, 0}}));     // a float step off
  EXPECT_FALSE(Hit(kFloor, {{3, 0, 0}, {4, 0, 0}, {3, 1, 0}}));                   // apart
  EXPECT_TRUE(Hit(kFloor, {{-1, 1, 0}, {3, 1, 0}, {1, 1.5f, 0}}));                // edges cross, no vertex inside
}

TEST(TriangleIntersect, DegenerateTrianglesNeverIntersect) {
  // A segment-shaped triangle straight through the floor, a point on it, a segment lying in it.
  const Tri segment = {{0.5f, 0.5f, -1}, {0.5f, 0.5f, 1}, {0.5f, 0.5f, 0}};
  const Tri point = {{0.5f, 0.5f, 0}, {0.5f, 0.5f, 0}, {0.5f, 0.5f, 0}};
  const Tri in_plane = {{0.1f, 0.1f, 0}, {0.9f, 0.9f, 0}, {0.5f, 0.5f, 0}};
  for (const Tri& d : {segment, point, in_plane}) {
    EXPECT_TRUE(TriangleIsDegenerate(d.a, d.b, d.c));
    EXPECT_FALSE(Hit(kFloor, d));
    EXPECT_FALSE(Hit(d, kFloor));
    EXPECT_FALSE(Hit(d, d));
    TriangleContactGeometry g;
    EXPECT_FALSE(TriangleContactOf(kFloor.a, kFloor.b, kFloor.c, d.a, d.b, d.c, 10.0f, &g));
  }
  EXPECT_FALSE(TriangleIsDegenerate(kFloor.a, kFloor.b, kFloor.c));
}

TEST(TriangleIntersect, SliversAreRealTriangles) {
  // Width one float step at 1.0: not degenerate, and it crosses the floor.
  const Tri sliver = {{0.5f, 0.5f, -1}, {0.5f, 0.5f, 1}, {0.5f, Up(0.5f), 1}};
  EXPECT_FALSE(TriangleIsDegenerate(sliver.a, sliver.b, sliver.c));
  EXPECT_TRUE(Hit(kFloor, sliver));
  const Tri sliver_above = {{0.5f, 0.5f, 0.001f}, {0.5f, 0.5f, 1}, {0.5f, Up(0.5f), 1}};
  EXPECT_FALSE(Hit(kFloor, sliver_above));
  // A sliver lying in the floor plane across its hypotenuse.
  const Tri flat = {{1, 0.5f, 0}, {3, 0.5f, 0}, {3, Up(0.5f), 0}};
  EXPECT_TRUE(Hit(kFloor, flat));
}

TEST(TriangleIntersect, NonFiniteIsNeverAContact) {
  const float nan = std::numeric_limits<float>::quiet_NaN(), inf = std::numeric_limits<float>::infinity();
  for (float bad : {nan, inf, -inf}) {
    const Tri t = {{0.5f, 0.5f, -1}, {0.5f, 0.5f, bad}, {1.5f, -1, 0.3f}};
    EXPECT_FALSE(Hit(kFloor, t));
    EXPECT_TRUE(TriangleIsDegenerate(t.a, t.b, t.c));
    TriangleContactGeometry g;
    EXPECT_FALSE(TriangleContactOf(kFloor.a, kFloor.b, kFloor.c, t.a, t.b, t.c, 100.0f, &g));
  }
}

TEST(TriangleIntersect, FarFromTheOrigin) {
  // The same crossing 4096 units away (float spacing 1/2048 there): still exact.
  const Vector3f o(4096, -4096, 4096);
  const Tri floor = {kFloor.a + o, kFloor.b + o, kFloor.c + o};
  EXPECT_TRUE(Hit(floor, {Vector3f(0.5f, 0.5f, -1) + o, Vector3f(0.5f, 0.5f, 1) + o, Vector3f(1.5f, -1, 0.3f) + o}));
  EXPECT_TRUE(Hit(floor, {Vector3f(0.5f, 0.5f, 0) + o, Vector3f(0.5f, 0.5f, 1) + o, Vector3f(1, 0.75f, 1) + o}));
  const Vector3f lifted(0.5f + o.x(), 0.5f + o.y(), Up(o.z()));
  EXPECT_FALSE(Hit(floor, {lifted, Vector3f(0.5f, 0.5f, 1) + o, Vector3f(1, 0.75f, 1) + o}));
}

// ------------------------------------------------------------------ segments and distances

TEST(TriangleContact, IntersectionSegmentOfACrossing) {
  // A vertical triangle in the plane x = 0.5 crossing the floor: the floor's piece of the line
  // x = 0.5, z = 0 is y in [0, 1.5]; the other triangle's is y in [-0.5, 1] -> segment y in [0, 1].
  const Tri wall = {{0.5f, -0.5f, -1}, {0.5f, -0.5f, 1}, {0.5f, 2.5f, -1}};
  TriangleContactGeometry g;
  ASSERT_TRUE(TriangleContactOf(kFloor.a, kFloor.b, kFloor.c, wall.a, wall.b, wall.c, 0.0f, &g));
  EXPECT_TRUE(g.intersecting);
  EXPECT_EQ(g.distance, 0.0f);
  const float lo = std::min(g.on_a.y(), g.on_b.y()), hi = std::max(g.on_a.y(), g.on_b.y());
  EXPECT_NEAR(lo, 0.0f, 1e-6f);
  EXPECT_NEAR(hi, 1.0f, 1e-6f);
  for (const Vector3f& p : {g.on_a, g.on_b}) {
    EXPECT_NEAR(p.x(), 0.5f, 1e-6f);
    EXPECT_NEAR(p.z(), 0.0f, 1e-6f);
  }
}

TEST(TriangleContact, CoplanarOverlapPointLiesInBoth) {
  const Tri other = {{0.5f, 0.5f, 0}, {3, 0.5f, 0}, {0.5f, 3, 0}};
  TriangleContactGeometry g;
  ASSERT_TRUE(TriangleContactOf(kFloor.a, kFloor.b, kFloor.c, other.a, other.b, other.c, 0.0f, &g));
  EXPECT_TRUE(g.intersecting);
  // Overlap: the triangle (0.5,0.5), (1.5,0.5), (0.5,1.5); its corners' centroid (5/6, 5/6).
  EXPECT_NEAR(g.on_a.x(), 5.0f / 6.0f, 1e-5f);
  EXPECT_NEAR(g.on_a.y(), 5.0f / 6.0f, 1e-5f);
  EXPECT_EQ(g.on_a, g.on_b);
}

TEST(TriangleDistance, AnalyticConfigurations) {
  Vector3f pa, pb;
  // Parallel faces 0.25 apart, overlapping in projection.
  EXPECT_NEAR(TriangleDistance(kFloor.a, kFloor.b, kFloor.c, {0.1f, 0.1f, 0.25f}, {1, 0.1f, 0.25f}, {0.1f, 1, 0.25f}),
              0.25f, 1e-6f);
  // Vertex above the face: (0.5, 0.5, 0.3) -> 0.3, closest point (0.5, 0.5, 0).
  float d = TriangleDistance(kFloor.a, kFloor.b, kFloor.c, {0.5f, 0.5f, 0.3f}, {0.5f, 0.5f, 2}, {1, 1, 2}, &pa, &pb);
  EXPECT_NEAR(d, 0.3f, 1e-6f);
  EXPECT_NEAR((pa - Vector3f(0.5f, 0.5f, 0)).norm(), 0.0f, 1e-6f);
  EXPECT_NEAR((pb - Vector3f(0.5f, 0.5f, 0.3f)).norm(), 0.0f, 1e-6f);
  // Skew edges: the floor's edge from (0,0,0) to (2,0,0), and an edge along y at x = 1, z = 0.4
  // from (1,-1,0.4) to (1,-0.2,0.4) whose triangle rises away: distance sqrt(0.2^2 + 0.4^2).
  d = TriangleDistance(kFloor.a, kFloor.b, kFloor.c, {1, -1, 0.4f}, {1, -0.2f, 0.4f}, {1, -1, 3}, &pa, &pb);
  EXPECT_NEAR(d, std::sqrt(0.2f * 0.2f + 0.4f * 0.4f), 1e-6f);
  EXPECT_NEAR((pa - Vector3f(1, 0, 0)).norm(), 0.0f, 1e-6f);
  // Two edges crossing at right angles 0.5 apart: edges (0,0,0)-(2,0,0) of the floor and
  // (1,-1,-0.5)-(1,1,-0.5), whose triangle goes further down.
  // (Part of that edge runs under the floor's face, so the closest pair is not unique: check the
  // distance and that the points are 0.5 apart straight down.)
  d = TriangleDistance(kFloor.a, kFloor.b, kFloor.c, {1, -1, -0.5f}, {1, 1, -0.5f}, {1, 0, -3}, &pa, &pb);
  EXPECT_NEAR(d, 0.5f, 1e-6f);
  EXPECT_NEAR(pa.z(), 0.0f, 1e-6f);
  EXPECT_NEAR(pb.z(), -0.5f, 1e-6f);
  EXPECT_NEAR((pa - pb).head<2>().norm(), 0.0f, 1e-6f);
}

TEST(TriangleDistance, NeverAboveDenseSamplingAndClose) {
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> u(-1, 1);
  for (int n = 0; n < 300; ++n) {
    Tri a = {{u(rng), u(rng), u(rng)}, {u(rng), u(rng), u(rng)}, {u(rng), u(rng), u(rng)}};
    Tri b = {{u(rng), u(rng), u(rng) + 2}, {u(rng), u(rng), u(rng) + 2}, {u(rng), u(rng), u(rng) + 2}};
    if (Hit(a, b)) continue;
    Vector3f pa, pb;
    const float d = TriangleDistance(a.a, a.b, a.c, b.a, b.b, b.c, &pa, &pb);
    EXPECT_NEAR((pa - pb).norm(), d, 1e-5f);
    // Sample both triangles on a 40x40 barycentric grid: no sample pair is closer than d, and the
    // closest sample pair is within the grid spacing of d.
    constexpr int kN = 40;
    float best = INFINITY;
    std::vector<Vector3f> sa, sb;
    for (int i = 0; i <= kN; ++i) {
      for (int j = 0; i + j <= kN; ++j) {
        const float s = float(i) / kN, t = float(j) / kN;
        sa.push_back(a.a + s * (a.b - a.a) + t * (a.c - a.a));
        sb.push_back(b.a + s * (b.b - b.a) + t * (b.c - b.a));
      }
    }
    for (const auto& p : sa) {
      for (const auto& q : sb) best = std::min(best, (p - q).norm());
    }
    const float spacing =
        std::max({(a.b - a.a).norm(), (a.c - a.a).norm(), (b.b - b.a).norm(), (b.c - b.a).norm()}) / kN;
    EXPECT_LE(d, best + 1e-5f);
    EXPECT_GE(d, best - 2 * spacing);
  }
}

TEST(TriangleContact, MarginBoundary) {
  const Tri above = {{0.5f, 0.5f, 0.25f}, {0.5f, 0.5f, 1}, {1, 0.75f, 1}};
  TriangleContactGeometry g;
  EXPECT_FALSE(TriangleContactOf(kFloor.a, kFloor.b, kFloor.c, above.a, above.b, above.c, 0.0f, &g));
  EXPECT_FALSE(TriangleContactOf(kFloor.a, kFloor.b, kFloor.c, above.a, above.b, above.c, 0.25f, &g))
      << "distance 0.25 is not < margin 0.25";
  ASSERT_TRUE(TriangleContactOf(kFloor.a, kFloor.b, kFloor.c, above.a, above.b, above.c, Up(0.25f), &g));
  EXPECT_FALSE(g.intersecting);
  EXPECT_FLOAT_EQ(g.distance, 0.25f);
  EXPECT_NEAR((g.on_a - Vector3f(0.5f, 0.5f, 0)).norm(), 0.0f, 1e-6f);
  EXPECT_NEAR((g.on_b - above.a).norm(), 0.0f, 1e-6f);
  // Intersecting pairs are reported whatever the margin, with distance 0.
  const Tri through = {{0.5f, 0.5f, -1}, {0.5f, 0.5f, 1}, {1.5f, -1, 0.3f}};
  ASSERT_TRUE(TriangleContactOf(kFloor.a, kFloor.b, kFloor.c, through.a, through.b, through.c, 0.1f, &g));
  EXPECT_TRUE(g.intersecting);
  EXPECT_EQ(g.distance, 0.0f);
}

}  // namespace
}  // namespace skinspheres::runtime
