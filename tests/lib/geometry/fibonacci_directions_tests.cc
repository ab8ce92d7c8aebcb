// Tests of fibonacci_directions.h: unit directions, the lattice's latitudes, an even spread (mean
// near zero, every cap of the sphere sampled in proportion to its area), none for n <= 0.
#include <gtest/gtest.h>

#include <cmath>

#include "skinspheres/lib/geometry/fibonacci_directions.h"

namespace skinspheres::lib {
namespace {

TEST(FibonacciDirections, UnitVectorsOnTheLatticeLatitudes) {
  for (int n : {1, 2, 7, 48, 256}) {
    const auto d = FibonacciDirections(n);
    ASSERT_EQ(d.size(), static_cast<size_t>(n));
    for (int k = 0; k < n; ++k) {
      EXPECT_NEAR(d[k].norm(), 1.0f, 1e-6f) << n << " " << k;
      EXPECT_NEAR(d[k].y(), 1.0 - (2.0 * k + 1.0) / n, 1e-6) << n << " " << k;
    }
  }
  EXPECT_TRUE(FibonacciDirections(0).empty());
  EXPECT_TRUE(FibonacciDirections(-3).empty());
}

TEST(FibonacciDirections, SpreadEvenly) {
  const int n = 1000;
  const auto d = FibonacciDirections(n);
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (const auto& u : d) mean += u.cast<double>();
  EXPECT_LT((mean / n).norm(), 0.01);
  // A cap around any axis holds about its share of the sphere's area, (1 - cos θ) / 2.
  for (const Eigen::Vector3f& axis : {Eigen::Vector3f(1, 0, 0), Eigen::Vector3f(0, 0, -1),
                                      Eigen::Vector3f(1, 1, 1).normalized(), Eigen::Vector3f(0, 1, 0)}) {
    int inside = 0;
    for (const auto& u : d) inside += u.dot(axis) > 0.8f;
    EXPECT_NEAR(inside / double(n), 0.1, 0.01) << axis.transpose();
  }
}

}  // namespace
}  // namespace skinspheres::lib
