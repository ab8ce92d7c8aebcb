// Tests for enclosing_sphere.h: M1 by hand, M2 (Welzl) against the exhaustive oracle including
// collinear, coplanar, duplicate and cospherical sets, M1-A's guarantees, and F by hand.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <numbers>
#include <random>
#include <vector>

#include "skinspheres/lib/geometry/enclosing_sphere.h"
#include "skinspheres/skinning/math_types.h"

namespace skinspheres::lib {
namespace {

using V = Eigen::Vector3f;
using Points = std::vector<V>;

void ExpectContainsAll(const Ball& b, const Points& pts, const char* what) {
  for (size_t i = 0; i < pts.size(); ++i) {
    const double dd = (pts[i].cast<double>() - b.center.cast<double>()).norm();
    ASSERT_LE(dd, static_cast<double>(b.radius)) << what << ": point " << i << " outside (double)";
    ASSERT_LE((pts[i] - b.center).norm(), b.radius) << what << ": point " << i << " outside (float)";
  }
}

// ---- The holding radius ------------------------------------------------------------------------

TEST(HoldingRadius, HoldsEveryPointAndIsTheSmallestFloatThatDoes) {
  std::mt19937 rng(17);
  std::uniform_real_distribution<float> u(-3.0f, 3.0f);
  for (int trial = 0; trial < 200; ++trial) {
    Points pts(1 + trial % 9);
    for (V& p : pts) p = V(u(rng), u(rng), u(rng));
    const V c(u(rng), u(rng), u(rng));
    double max_sq = 0.0;
    for (const V& p : pts) max_sq = std::max(max_sq, (p.cast<double>() - c.cast<double>()).squaredNorm());
    const double exact = std::sqrt(max_sq);
    const float bare = HoldingRadius(pts, c, 0.0);
    // Unpadded: the smallest float at or above the exact (double) farthest distance.
    EXPECT_GE(static_cast<double>(bare), exact);
    EXPECT_LT(static_cast<double>(std::nextafter(bare, 0.0f)), exact);
    // Padded: at least kBallRadiusPad more, and no more than one float step beyond that.
    const float padded = HoldingRadius(pts, c);
    EXPECT_GE(static_cast<double>(padded), exact * (1.0 + kBallRadiusPad));
    EXPECT_LT(static_cast<double>(std::nextafter(padded, 0.0f)), exact * (1.0 + kBallRadiusPad));
    EXPECT_EQ(padded, HoldingRadius(max_sq));
    EXPECT_EQ(bare, HoldingRadius(max_sq, 0.0));
    // The unpadded radius holds every point in double only; the pad is what makes it hold in
    // float too (float's own rounding of the distance can exceed the exact one).
    for (const V& p : pts) EXPECT_LE((p.cast<double>() - c.cast<double>()).norm(), static_cast<double>(bare));
    ExpectContainsAll(Ball{c, padded}, pts, "padded");
  }
  EXPECT_EQ(HoldingRadius(Points{}, V(1, 2, 3)), 0.0f);
}

TEST(HoldingRadius, IsTheRadiusEveryBallCarries) {
  std::mt19937 rng(19);
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  Points pts(30);
  for (V& p : pts) p = V(u(rng), u(rng), 0.3f * u(rng));
  const Ball m1 = CentroidBall(pts);
  EXPECT_EQ(m1.radius, HoldingRadius(pts, m1.center));
  const Ball m2 = MinimumBall(pts);
  EXPECT_EQ(m2.radius, HoldingRadius(pts, m2.center));
  const Ball m1a = AdjustM1(m1, pts, V::Zero(), V::UnitX(), V::UnitY());
  EXPECT_EQ(m1a.radius, HoldingRadius(pts, m1a.center));
  const Points few(pts.begin(), pts.begin() + 8);
  const Ball exhaustive = ExhaustiveMinimumBall(few);
  EXPECT_EQ(exhaustive.radius, HoldingRadius(few, exhaustive.center));
}

// ---- F and M1 by hand --------------------------------------------------------------------------

TEST(FitError, ByHand) {
  const Ball b{V(0, 0, 0), 2.0f};
  const Points pts = {V(1, 0, 0), V(0, 2, 0), V(0, 0, 3)};  // F_i = 1, 0, 1
  const FitErrorStats e = FitError(b, pts);
  EXPECT_FLOAT_EQ(e.mean, 2.0f / 3.0f);
  EXPECT_FLOAT_EQ(e.max, 1.0f);
  EXPECT_EQ(FitError(b, Points{}).mean, 0.0f);
}

TEST(CentroidBall, ByHand) {
  const Points cross = {V(1, 0, 0), V(-1, 0, 0), V(0, 2, 0), V(0, -2, 0)};
  const Ball b = CentroidBall(cross);
  EXPECT_EQ(b.center, V(0, 0, 0));
  EXPECT_NEAR(b.radius, 2.0f, 2.0f * 2e-6f);
  EXPECT_GE(b.radius, 2.0f);
  // Mean (1.5, 0.75, 0); farthest is (0, 3, 0): sqrt(1.5² + 2.25²).
  const Points pts = {V(0, 0, 0), V(2, 0, 0), V(4, 0, 0), V(0, 3, 0)};
  const Ball c = CentroidBall(pts);
  EXPECT_FLOAT_EQ(c.center.x(), 1.5f);
  EXPECT_FLOAT_EQ(c.center.y(), 0.75f);
  EXPECT_FLOAT_EQ(c.center.z(), 0.0f);
  EXPECT_NEAR(c.radius, std::sqrt(1.5f * 1.5f + 2.25f * 2.25f), 1e-5f);
  ExpectContainsAll(c, pts, "M1");
  const Ball empty = CentroidBall(Points{});
  EXPECT_EQ(empty.radius, 0.0f);
  const Ball single = CentroidBall(Points{V(3, 4, 5)});
  EXPECT_EQ(single.center, V(3, 4, 5));
  EXPECT_EQ(single.radius, 0.0f);
}

// ---- M2 by hand --------------------------------------------------------------------------------

TEST(MinimumBall, AnalyticCases) {
  // Two points: the diametral ball.
  Ball b = MinimumBall(Points{V(-1, 2, 3), V(3, 2, 3)});
  EXPECT_NEAR((b.center - V(1, 2, 3)).norm(), 0.0f, 1e-6f);
  EXPECT_NEAR(b.radius, 2.0f, 1e-5f);
  // A cube's corners (plus interior points): the circumsphere, radius sqrt(3).
  Points cube;
  for (int i = 0; i < 8; ++i) cube.emplace_back(i & 1 ? 1 : -1, i & 2 ? 1 : -1, i & 4 ? 1 : -1);
  cube.emplace_back(0.5f, 0.1f, -0.3f);
  cube.emplace_back(0, 0, 0);
  b = MinimumBall(cube);
  EXPECT_NEAR(b.center.norm(), 0.0f, 1e-6f);
  EXPECT_NEAR(b.radius, std::sqrt(3.0f), 1e-5f);
  // An obtuse triangle: the diametral ball of its longest side, not the circumcircle.
  b = MinimumBall(Points{V(-2, 0, 0), V(2, 0, 0), V(0, 0.5f, 0)});
  EXPECT_NEAR((b.center - V(0, 0, 0)).norm(), 0.0f, 1e-6f);
  EXPECT_NEAR(b.radius, 2.0f, 1e-5f);
  // Equilateral triangle: the circumcircle.
  b = MinimumBall(Points{V(1, 0, 0), V(-0.5f, std::sqrt(3.0f) / 2, 0), V(-0.5f, -std::sqrt(3.0f) / 2, 0)});
  EXPECT_NEAR(b.center.norm(), 0.0f, 1e-6f);
  EXPECT_NEAR(b.radius, 1.0f, 1e-5f);
  // Many points on a sphere plus interior points: that sphere.
  std::mt19937 rng(3);
  std::normal_distribution<float> g;
  Points sphere;
  const V c(10, -5, 2);
  for (int i = 0; i < 2000; ++i) {
    const V d = V(g(rng), g(rng), g(rng)).normalized();
    sphere.push_back(c + (i % 2 ? 3.0f : 1.5f) * d);
  }
  b = MinimumBall(sphere);
  EXPECT_LT((b.center - c).norm(), 0.02f);
  EXPECT_LE(b.radius, 3.0f * (1.0f + 1e-5f));
  EXPECT_GT(b.radius, 2.95f);
  ExpectContainsAll(b, sphere, "sphere");
  EXPECT_EQ(MinimumBall(Points{}).radius, 0.0f);
  const Ball one = MinimumBall(Points{V(1, 2, 3)});
  EXPECT_EQ(one.center, V(1, 2, 3));
  EXPECT_EQ(one.radius, 0.0f);
}

// ---- M2 against the oracle ---------------------------------------------------------------------

enum class SetKind { kGeneral, kCollinear, kCoplanar, kDuplicates, kCospherical, kClustered, kMixed };

Points MakeSet(SetKind kind, int n, std::mt19937& rng) {
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  std::normal_distribution<float> g;
  const V offset(u(rng) * 50, u(rng) * 50, u(rng) * 50);
  const float scale = std::pow(10.0f, u(rng) * 2);  // 0.01 .. 100
  Points pts;
  const V dir = V(g(rng), g(rng), g(rng)).normalized();
  const V e0 = dir.unitOrthogonal(), e1 = dir.cross(e0);
  for (int i = 0; i < n; ++i) {
    V p;
    switch (kind) {
      case SetKind::kGeneral: p = V(u(rng), u(rng), u(rng)); break;
      case SetKind::kCollinear: p = u(rng) * dir; break;
      case SetKind::kCoplanar: p = u(rng) * e0 + u(rng) * e1; break;
      case SetKind::kDuplicates: p = (i > 0 && rng() % 2) ? pts[rng() % pts.size()] : V(u(rng), u(rng), u(rng)); break;
      case SetKind::kCospherical: p = V(g(rng), g(rng), g(rng)).normalized(); break;
      case SetKind::kClustered: p = (i % 2 ? 1e-4f : 1.0f) * V(u(rng), u(rng), u(rng)); break;
      case SetKind::kMixed: {
        const int m = static_cast<int>(rng() % 4);
        p = m == 0 ? V(u(rng) * dir) : m == 1 ? V(u(rng) * e0) : m == 2 ? V(u(rng), u(rng), u(rng)) : V::Zero();
        break;
      }
    }
    pts.push_back(kind == SetKind::kDuplicates ? p : V(offset + scale * p));
  }
  if (kind == SetKind::kDuplicates) {
    for (V& p : pts) p = offset + scale * p;  // duplicates stay exact duplicates
  }
  return pts;
}

class WelzlVsOracle : public ::testing::TestWithParam<SetKind> {};

TEST_P(WelzlVsOracle, SameBallAndContainsAll) {
  std::mt19937 rng(100 + static_cast<int>(GetParam()));
  for (int trial = 0; trial < 300; ++trial) {
    const int n = 1 + trial % 12;
    const Points pts = MakeSet(GetParam(), n, rng);
    const Ball fast = MinimumBall(pts);
    const Ball oracle = ExhaustiveMinimumBall(pts);
    ExpectContainsAll(fast, pts, "MinimumBall");
    ExpectContainsAll(oracle, pts, "ExhaustiveMinimumBall");
    // Extent of the set for absolute tolerances.
    float extent = 0.0f;
    for (const V& p : pts) extent = std::max(extent, (p - pts[0]).norm());
    const float tol = 1e-5f * extent + 1e-6f * pts[0].norm();
    EXPECT_NEAR(fast.radius, oracle.radius, tol) << "trial " << trial << " n " << n;
    EXPECT_LE((fast.center - oracle.center).norm(), 10 * tol + 1e-3f * extent) << "trial " << trial;
    // Deterministic, bit for bit.
    const Ball again = MinimumBall(pts);
    EXPECT_EQ(again.center, fast.center);
    EXPECT_EQ(again.radius, fast.radius);
  }
}

INSTANTIATE_TEST_SUITE_P(Sets, WelzlVsOracle,
                         ::testing::Values(SetKind::kGeneral, SetKind::kCollinear, SetKind::kCoplanar,
                                           SetKind::kDuplicates, SetKind::kCospherical, SetKind::kClustered,
                                           SetKind::kMixed));

TEST(MinimumBall, NeverLargerThanM1AndOrderIndependent) {
  std::mt19937 rng(77);
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  for (int trial = 0; trial < 50; ++trial) {
    Points pts;
    for (int i = 0; i < 80; ++i) pts.emplace_back(3 * u(rng), u(rng), 0.2f * u(rng));
    const Ball m2 = MinimumBall(pts);
    ExpectContainsAll(m2, pts, "M2");
    EXPECT_LE(m2.radius, CentroidBall(pts).radius * (1 + 1e-6f));
    Points reversed(pts.rbegin(), pts.rend());
    EXPECT_NEAR(MinimumBall(reversed).radius, m2.radius, 1e-5f * m2.radius);
  }
}

// ---- M1-A --------------------------------------------------------------------------------------

struct Frame {
  V origin, n0, n1;
};

Frame RandomFrame(std::mt19937& rng) {
  std::normal_distribution<float> g;
  const skinspheres::Quatf q = skinspheres::Quatf(g(rng), g(rng), g(rng), g(rng)).normalized();
  return Frame{V(g(rng), g(rng), g(rng)) * 3.0f, q * V(1, 0, 0), q * V(0, 1, 0)};
}

// Points on an ellipse (semi-axes a along n0, b along n1) between angles th0 and th1.
Points EllipseArc(const Frame& f, float a, float b, float th0, float th1, int n) {
  Points pts;
  for (int i = 0; i < n; ++i) {
    const float th = th0 + (th1 - th0) * static_cast<float>(i) / static_cast<float>(n - 1);
    pts.push_back(f.origin + a * std::cos(th) * f.n0 + b * std::sin(th) * f.n1);
  }
  return pts;
}

void ExpectAdjustGuarantees(const Points& pts, const Frame& f, const char* what, Ball* out = nullptr) {
  const Ball m1 = CentroidBall(pts);
  const Ball m1a = AdjustM1(m1, pts, f.origin, f.n0, f.n1);
  ExpectContainsAll(m1a, pts, what);
  const FitErrorStats e0 = FitError(m1, pts), e1 = FitError(m1a, pts);
  EXPECT_LE(e1.max, e0.max) << what;
  EXPECT_LE(e1.mean, e0.mean) << what;
  EXPECT_LE(m1a.radius, m1.radius) << what;  // moves never grow the sphere
  // Moves stay in the disk plane: the offset from M1's centre has no normal component.
  const V normal = f.n0.cross(f.n1);
  EXPECT_NEAR((m1a.center - m1.center).dot(normal), 0.0f, 1e-4f * (1.0f + m1.radius)) << what;
  // Deterministic.
  const Ball again = AdjustM1(m1, pts, f.origin, f.n0, f.n1);
  EXPECT_EQ(again.center, m1a.center);
  EXPECT_EQ(again.radius, m1a.radius);
  if (out) *out = m1a;
}

TEST(AdjustM1, LowersMeanFOnEllipseArcSectors) {
  std::mt19937 rng(21);
  const float pi = static_cast<float>(std::numbers::pi);
  struct Sector {
    float th0, th1;
  };
  // Halves and quarters of a torso-like ellipse (2 and 4 partitions per level, paper §4.4).
  for (const Sector s : {Sector{-pi / 2, pi / 2}, Sector{0, pi}, Sector{-pi / 4, pi / 4}, Sector{0, pi / 2},
                         Sector{pi / 4, 3 * pi / 4}}) {
    const Frame f = RandomFrame(rng);
    const Points pts = EllipseArc(f, 2.0f, 1.0f, s.th0, s.th1, 40);
    Ball m1a;
    ExpectAdjustGuarantees(pts, f, "ellipse arc", &m1a);
    const FitErrorStats e0 = FitError(CentroidBall(pts), pts), e1 = FitError(m1a, pts);
    EXPECT_LT(e1.mean, 0.9f * e0.mean) << "sector " << s.th0 << ".." << s.th1;
  }
}

TEST(AdjustM1, GuaranteesOnRandomAndEllipseSets) {
  std::mt19937 rng(22);
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  for (int trial = 0; trial < 200; ++trial) {
    const Frame f = RandomFrame(rng);
    Points pts;
    const int n = 1 + static_cast<int>(rng() % 60);
    if (trial % 2 == 0) {
      for (int i = 0; i < n; ++i) pts.push_back(f.origin + V(u(rng), u(rng), u(rng)) * 2.0f);
    } else {
      // Noisy ellipse points off the disk plane (adjacent levels), arbitrary sector.
      const float th0 = 3.14f * u(rng), th1 = th0 + 3.14f * (0.1f + std::fabs(u(rng)));
      pts = EllipseArc(f, 1.0f + std::fabs(u(rng)) * 2, 1.0f, th0, th1, std::max(n, 2));
      for (V& p : pts) p += 0.05f * V(u(rng), u(rng), u(rng));
    }
    ExpectAdjustGuarantees(pts, f, trial % 2 ? "noisy ellipse" : "random");
  }
}

TEST(AdjustM1, DegenerateInputs) {
  const Frame f{V(0, 0, 0), V(1, 0, 0), V(0, 1, 0)};
  EXPECT_EQ(AdjustM1(Ball{}, Points{}, f.origin, f.n0, f.n1).radius, 0.0f);
  ExpectAdjustGuarantees(Points{V(1, 2, 3)}, f, "one point");
  ExpectAdjustGuarantees(Points{V(1, 2, 3), V(1, 2, 3), V(1, 2, 3)}, f, "duplicates");
  // Disk centre at M1's centre: nothing to move towards.
  const Points pts = {V(1, 0, 0), V(-1, 0, 0), V(0, 1, 0)};
  const Ball m1 = CentroidBall(pts);
  const Ball same = AdjustM1(m1, pts, m1.center, f.n0, f.n1);
  EXPECT_EQ(same.center, m1.center);
  EXPECT_LE(same.radius, m1.radius);
}

}  // namespace
}  // namespace skinspheres::lib
