// Tests of closest_point.h: the double version against a dense barycentric lattice (degenerate
// triangles included), the float version against the double one.
#include <gtest/gtest.h>

#include <algorithm>
#include <limits>
#include <random>

#include "skinspheres/lib/geometry/closest_point.h"

namespace skinspheres::lib {
namespace {

TEST(ClosestPoint, MatchesDenseSampling) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> u(-1, 1);
  for (int trial = 0; trial < 300; ++trial) {
    Eigen::Vector3f a(u(rng), u(rng), u(rng)), b(u(rng), u(rng), u(rng)), c(u(rng), u(rng), u(rng));
    if (trial % 10 == 0) c = a + 0.5f * (b - a);  // degenerate: collinear
    if (trial % 10 == 1) b = a;                   // degenerate: repeated vertex
    const Eigen::Vector3f p = 2.f * Eigen::Vector3f(u(rng), u(rng), u(rng));
    const float d = (ClosestPointOnTriangle(p, a, b, c) - p).norm();
    // Oracle: minimum over a dense barycentric lattice (an upper bound, within one lattice step).
    const int n = 200;
    float best = std::numeric_limits<float>::max();
    for (int i = 0; i <= n; ++i)
      for (int j = 0; i + j <= n; ++j) {
        const Eigen::Vector3f q = a + (b - a) * (float(i) / n) + (c - a) * (float(j) / n);
        best = std::min(best, (q - p).norm());
      }
    const float step = std::max({(b - a).norm(), (c - a).norm(), (c - b).norm()}) / n;
    EXPECT_LE(d, best + 1e-5f) << trial;
    EXPECT_GE(d, best - step - 1e-5f) << trial;
  }
}

TEST(ClosestPoint, FloatVersionAgreesWithTheDoubleOne) {
  std::mt19937 rng(11);
  std::uniform_real_distribution<float> u(-1, 1);
  for (int trial = 0; trial < 2000; ++trial) {
    Eigen::Vector3f a(u(rng), u(rng), u(rng)), b(u(rng), u(rng), u(rng)), c(u(rng), u(rng), u(rng));
    if (trial % 10 == 0) c = a + 0.5f * (b - a);  // degenerate: collinear
    if (trial % 10 == 1) b = a;                   // degenerate: repeated vertex
    if (trial % 10 == 2) b = c = a;               // degenerate: a point
    const Eigen::Vector3f p = 2.f * Eigen::Vector3f(u(rng), u(rng), u(rng));
    const float exact = (ClosestPointOnTriangle(p, a, b, c) - p).norm();
    const float fast = (ClosestPointOnTriangleFloat(p, a, b, c) - p).norm();
    // Both are points of the triangle: the float one is never closer than the exact one by more
    // than rounding, nor farther by more than float's error on unit-sized input.
    EXPECT_NEAR(fast, exact, 1e-5f) << trial;
  }
}

}  // namespace
}  // namespace skinspheres::lib
