// Arithmetic shared by the sort-and-sweep path and the all-pairs oracle (broad_phase.h): both must
// evaluate the overlap test and the depth with the same float operations in the same order.
#pragma once

#include <Eigen/Core>
#include <cmath>

#include "skinspheres/skinning/math_types.h"

namespace skinspheres::runtime::internal {

// Largest |coordinate| and radius accepted: squares and sums of the overlap test stay finite
// (3 * (2e18)^2 << FLT_MAX), so interval ends never overflow to infinity.
inline constexpr float kMaxMagnitude = 1e18f;

// True when the centre and radius are finite, within ±kMaxMagnitude, and the radius >= 0
// (x - x == 0 fails for inf and NaN).
inline bool SphereValuesOk(const Vec4f& s) {
  return (s.x() - s.x() == 0.0f) & (s.y() - s.y() == 0.0f) & (s.z() - s.z() == 0.0f) & (s.w() - s.w() == 0.0f) &
         (s.w() >= 0.0f) & (s.cwiseAbs().maxCoeff() <= kMaxMagnitude);
}

// |c_i - c_j|^2 as ((dx*dx + dy*dy) + dz*dz). The sign of d does not matter (negation is exact).
inline float CenterDistanceSquared(const Vec4f& a, const Vec4f& b) {
  const float dx = b.x() - a.x();
  const float dy = b.y() - a.y();
  const float dz = b.z() - a.z();
  return (dx * dx + dy * dy) + dz * dz;
}

// Overlap or touch: d^2 <= (r_i + r_j)^2.
inline bool SpheresTouch(float distance_squared, float radius_sum) {
  return distance_squared <= radius_sum * radius_sum;
}

// Penetration depth r_i + r_j - |c_i - c_j|.
inline float PenetrationDepth(const Vec4f& a, const Vec4f& b) {
  return (a.w() + b.w()) - std::sqrt(CenterDistanceSquared(a, b));
}

}  // namespace skinspheres::runtime::internal
