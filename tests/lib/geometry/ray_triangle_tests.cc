// Tests for ray_triangle.h against analytic hits: axis-aligned triangles, edges and vertices,
// parallel rays, back faces, degenerate triangles, and crack-freedom on shared edges.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <limits>
#include <random>
#include <vector>

#include "skinspheres/lib/geometry/ray_triangle.h"

namespace skinspheres::lib {
namespace {

using V = Eigen::Vector3f;

const V kA(0, 0, 0), kB(1, 0, 0), kC(0, 1, 0);  // in z = 0, normal +z

TEST(RayTriangle, AxisAlignedInteriorHitFromFront) {
  const auto h = IntersectRayTriangle(V(0.25f, 0.25f, 1), V(0, 0, -1), kA, kB, kC);
  ASSERT_TRUE(h);
  EXPECT_FLOAT_EQ(h->t, 1.0f);
  EXPECT_FLOAT_EQ(h->u, 0.25f);
  EXPECT_FLOAT_EQ(h->v, 0.25f);
  EXPECT_TRUE(h->front_face);
}

TEST(RayTriangle, BackFaceIsHitToo) {
  const auto h = IntersectRayTriangle(V(0.2f, 0.5f, -2), V(0, 0, 1), kA, kB, kC);
  ASSERT_TRUE(h);
  EXPECT_FLOAT_EQ(h->t, 2.0f);
  EXPECT_FLOAT_EQ(h->u, 0.2f);
  EXPECT_FLOAT_EQ(h->v, 0.5f);
  EXPECT_FALSE(h->front_face);
}

TEST(RayTriangle, TIsInUnitsOfDirLength) {
  const auto h = IntersectRayTriangle(V(0.25f, 0.25f, 1), V(0, 0, -4), kA, kB, kC);
  ASSERT_TRUE(h);
  EXPECT_FLOAT_EQ(h->t, 0.25f);
}

TEST(RayTriangle, ObliqueRayAnalytic) {
  // Triangle in the plane x = 3; ray from the origin towards (3, 1, 1).
  const V a(3, 0, 0), b(3, 4, 0), c(3, 0, 4);
  const auto h = IntersectRayTriangle(V(0, 0, 0), V(3, 1, 1).normalized(), a, b, c);
  ASSERT_TRUE(h);
  EXPECT_NEAR(h->t, std::sqrt(11.0f), 1e-6f);
  EXPECT_NEAR(h->u, 0.25f, 1e-6f);
  EXPECT_NEAR(h->v, 0.25f, 1e-6f);
}

TEST(RayTriangle, EdgesAndVerticesAreInclusive) {
  const std::vector<V> on_boundary = {V(0.5f, 0, 0), V(0, 0.5f, 0), V(0.5f, 0.5f, 0),  // edges
                                      V(0, 0, 0),    V(1, 0, 0),    V(0, 1, 0)};       // vertices
  for (const V& p : on_boundary) {
    for (float dz : {1.0f, -1.0f}) {
      const auto h = IntersectRayTriangle(p + V(0, 0, dz), V(0, 0, -dz), kA, kB, kC);
      ASSERT_TRUE(h) << p.transpose() << " dz " << dz;
      EXPECT_FLOAT_EQ(h->t, 1.0f);
      EXPECT_NEAR(h->u, p.x(), 1e-7f);
      EXPECT_NEAR(h->v, p.y(), 1e-7f);
    }
  }
}

TEST(RayTriangle, JustOutsideMisses) {
  const std::vector<V> outside = {V(0.5f, -1e-4f, 0),   V(-1e-4f, 0.5f, 0), V(0.5f + 1e-4f, 0.5f, 0),
                                  V(-1e-4f, -1e-4f, 0), V(1.0001f, 0, 0),   V(2, 2, 0)};
  for (const V& p : outside) {
    EXPECT_FALSE(IntersectRayTriangle(p + V(0, 0, 1), V(0, 0, -1), kA, kB, kC)) << p.transpose();
  }
}

TEST(RayTriangle, ParallelRaysMiss) {
  // In the plane, through the interior.
  EXPECT_FALSE(IntersectRayTriangle(V(-1, 0.25f, 0), V(1, 0, 0), kA, kB, kC));
  // Parallel above the plane.
  EXPECT_FALSE(IntersectRayTriangle(V(-1, 0.25f, 0.5f), V(1, 0, 0), kA, kB, kC));
}

TEST(RayTriangle, RangeOfT) {
  // Triangle behind the origin.
  EXPECT_FALSE(IntersectRayTriangle(V(0.25f, 0.25f, 1), V(0, 0, 1), kA, kB, kC));
  // t_max below the hit.
  EXPECT_FALSE(IntersectRayTriangle(V(0.25f, 0.25f, 1), V(0, 0, -1), kA, kB, kC, 0.0f, 0.5f));
  EXPECT_TRUE(IntersectRayTriangle(V(0.25f, 0.25f, 1), V(0, 0, -1), kA, kB, kC, 0.0f, 1.0f));
  // t_min above the hit.
  EXPECT_FALSE(IntersectRayTriangle(V(0.25f, 0.25f, 1), V(0, 0, -1), kA, kB, kC, 1.5f));
  // Origin on the triangle: t = 0 is a hit.
  const auto h = IntersectRayTriangle(V(0.25f, 0.25f, 0), V(0, 0, -1), kA, kB, kC);
  ASSERT_TRUE(h);
  EXPECT_EQ(h->t, 0.0f);
}

TEST(RayTriangle, DegenerateTrianglesNeverHit) {
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const float inf = std::numeric_limits<float>::infinity();
  struct Tri {
    V a, b, c;
  };
  const std::vector<Tri> degenerate = {
      {V(0, 0, 0), V(1, 0, 0), V(2, 0, 0)},        // collinear
      {V(0, 0, 0), V(1, 1, 0), V(0.5f, 0.5f, 0)},  // collinear, middle last
      {V(0, 0, 0), V(0, 0, 0), V(0, 1, 0)},        // repeated vertex
      {V(1, 1, 0), V(1, 1, 0), V(1, 1, 0)},        // a point
      {V(0, 0, 0), V(1, 0, 0), V(nan, 1, 0)},      // NaN
      {V(0, 0, 0), V(1, 0, 0), V(0, inf, 0)},      // infinity
  };
  for (const Tri& t : degenerate) {
    EXPECT_TRUE(IsDegenerateTriangle(t.a, t.b, t.c));
    // Aim at every vertex and the centroid, from both sides and obliquely.
    for (const V& target : {t.a, t.b, t.c, V((t.a + t.b + t.c) / 3.0f)}) {
      for (const V& d : {V(0, 0, -1), V(0, 0, 1), V(0.3f, -0.2f, -1)}) {
        EXPECT_FALSE(IntersectRayTriangle(target - d, d, t.a, t.b, t.c));
      }
    }
  }
  EXPECT_FALSE(IsDegenerateTriangle(kA, kB, kC));
  // A thin but real triangle is not degenerate.
  EXPECT_FALSE(IsDegenerateTriangle(V(0, 0, 0), V(1, 0, 0), V(0.5f, 1e-4f, 0)));
}

TEST(RayTriangle, ZeroOrNonFiniteDirectionMisses) {
  EXPECT_FALSE(IntersectRayTriangle(V(0.25f, 0.25f, 0), V(0, 0, 0), kA, kB, kC));
  EXPECT_FALSE(IntersectRayTriangle(V(0.25f, 0.25f, 1), V(0, 0, std::nanf("")), kA, kB, kC));
}

// An octahedron around the origin: rays from the centre aimed exactly at its 6 vertices and 12
// edge midpoints, and 20k random rays, must all leave through some triangle (no cracks).
TEST(RayTriangle, ClosedOctahedronHasNoCracks) {
  const std::vector<V> v = {V(1, 0, 0), V(-1, 0, 0), V(0, 1, 0), V(0, -1, 0), V(0, 0, 1), V(0, 0, -1)};
  const std::vector<Eigen::Vector3i> tris = {{0, 2, 4}, {2, 1, 4}, {1, 3, 4}, {3, 0, 4},
                                             {2, 0, 5}, {1, 2, 5}, {3, 1, 5}, {0, 3, 5}};
  auto hits_any = [&](const V& o, const V& d, float* t_out) {
    bool any = false;
    float best = std::numeric_limits<float>::infinity();
    for (const auto& t : tris) {
      if (const auto h = IntersectRayTriangle(o, d, v[t[0]], v[t[1]], v[t[2]])) {
        any = true;
        best = std::min(best, h->t);
      }
    }
    *t_out = best;
    return any;
  };
  float t;
  for (const V& p : v) {
    ASSERT_TRUE(hits_any(V::Zero(), p, &t)) << p.transpose();
    EXPECT_FLOAT_EQ(t, 1.0f);
  }
  for (const auto& tri : tris) {
    for (int k = 0; k < 3; ++k) {
      const V mid = 0.5f * (v[tri[k]] + v[tri[(k + 1) % 3]]);
      ASSERT_TRUE(hits_any(V::Zero(), mid, &t)) << mid.transpose();
      EXPECT_FLOAT_EQ(t, 1.0f);
    }
  }
  std::mt19937 rng(7);
  std::normal_distribution<float> g;
  std::uniform_real_distribution<float> u(-0.3f, 0.3f);
  for (int i = 0; i < 20000; ++i) {
    const V o(u(rng), u(rng), u(rng));
    const V d(g(rng), g(rng), g(rng));
    ASSERT_TRUE(hits_any(o, d, &t)) << "ray " << i;
  }
}

// Two triangles folded along a random shared edge; rays aimed at random points of that edge
// from the open side must hit at least one of them.
TEST(RayTriangle, SharedEdgeDoesNotLeak) {
  std::mt19937 rng(11);
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  int rays = 0;
  for (int trial = 0; trial < 200; ++trial) {
    const V p(u(rng), u(rng), u(rng)), q(u(rng), u(rng), u(rng));
    const V e = (q - p).normalized();
    V side = e.unitOrthogonal();
    const V up = e.cross(side);
    const V mid = 0.5f * (p + q);
    // Wings at +side and -side, lifted by a random fold.
    const float fold = 0.5f * u(rng);
    const V w0 = mid + side + fold * up, w1 = mid - side + fold * up;
    for (int i = 0; i < 50; ++i, ++rays) {
      const float s = 0.5f * (u(rng) + 1.0f);
      const V target = p + s * (q - p);
      // From below the fold, roughly along +up, with a random tilt.
      const V d = (up + 0.4f * V(u(rng), u(rng), u(rng))).normalized();
      const V o = target - 2.0f * d;
      const bool h0 = IntersectRayTriangle(o, d, p, q, w0).has_value();
      const bool h1 = IntersectRayTriangle(o, d, q, p, w1).has_value();
      ASSERT_TRUE(h0 || h1) << "trial " << trial << " ray " << i;
    }
  }
  EXPECT_EQ(rays, 10000);
}

TEST(RayTriangle, Deterministic) {
  const V o(0.1f, 0.2f, 3.0f), d(0.01f, -0.02f, -1.0f);
  const auto h1 = IntersectRayTriangle(o, d, kA, kB, kC);
  const auto h2 = IntersectRayTriangle(o, d, kA, kB, kC);
  ASSERT_TRUE(h1 && h2);
  EXPECT_EQ(h1->t, h2->t);
  EXPECT_EQ(h1->u, h2->u);
  EXPECT_EQ(h1->v, h2->v);
}

}  // namespace
}  // namespace skinspheres::lib
