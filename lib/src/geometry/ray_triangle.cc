// Möller-Trumbore in double precision with widened inclusive edges (paper §5, "Ray Triangle
// Intersection Test"). See ray_triangle.h for why this is watertight for the fitter's rays.
#include "skinspheres/lib/geometry/ray_triangle.h"

#include <Eigen/Geometry>
#include <cmath>

namespace skinspheres::lib {
namespace {

// sin of the smallest accepted angle at vertex a; below it the triangle counts as zero-area.
constexpr double kDegenerateSin = 1e-12;
// |cos| of the angle between dir and the triangle's normal below which the ray counts as lying in
// the triangle's plane.
constexpr double kParallelCos = 1e-12;

bool Finite(const Eigen::Vector3f& p) { return std::isfinite(p.x()) && std::isfinite(p.y()) && std::isfinite(p.z()); }

}  // namespace

bool IsDegenerateTriangle(const Eigen::Vector3f& a, const Eigen::Vector3f& b, const Eigen::Vector3f& c) {
  if (!Finite(a) || !Finite(b) || !Finite(c)) return true;
  const Eigen::Vector3d e1 = (b.cast<double>() - a.cast<double>());
  const Eigen::Vector3d e2 = (c.cast<double>() - a.cast<double>());
  const double n2 = e1.cross(e2).squaredNorm();
  const double l2 = e1.squaredNorm() * e2.squaredNorm();
  // A zero-length edge gives l2 == 0 and n2 == 0: degenerate.
  return !(n2 > kDegenerateSin * kDegenerateSin * l2) || l2 == 0.0;
}

std::optional<RayTriangleHit> IntersectRayTriangle(const Eigen::Vector3f& origin, const Eigen::Vector3f& dir,
                                                   const Eigen::Vector3f& a, const Eigen::Vector3f& b,
                                                   const Eigen::Vector3f& c, float t_min, float t_max) {
  const Eigen::Vector3d o = origin.cast<double>();
  const Eigen::Vector3d d = dir.cast<double>();
  const Eigen::Vector3d va = a.cast<double>();
  const Eigen::Vector3d e1 = b.cast<double>() - va;
  const Eigen::Vector3d e2 = c.cast<double>() - va;

  // det = e1·(d × e2) = -d·n with n = e1 × e2.
  const Eigen::Vector3d p = d.cross(e2);
  const double det = e1.dot(p);
  const double d2 = d.squaredNorm();
  if (!(d2 > 0.0) || !std::isfinite(d2)) return std::nullopt;
  const double n2 = e1.cross(e2).squaredNorm();
  // Same rule as IsDegenerateTriangle (non-finite input makes n2 or l2 NaN/inf and fails too).
  const double l2 = e1.squaredNorm() * e2.squaredNorm();
  if (!(n2 > kDegenerateSin * kDegenerateSin * l2) || !(l2 > 0.0) || !std::isfinite(n2)) return std::nullopt;
  if (!(det * det > kParallelCos * kParallelCos * d2 * n2)) return std::nullopt;  // in-plane or NaN

  const double inv_det = 1.0 / det;
  const Eigen::Vector3d s = o - va;
  const double u = s.dot(p) * inv_det;
  if (u < -kBarycentricTolerance || !(u <= 1.0 + kBarycentricTolerance)) return std::nullopt;
  const Eigen::Vector3d q = s.cross(e1);
  const double v = d.dot(q) * inv_det;
  if (v < -kBarycentricTolerance || !(u + v <= 1.0 + kBarycentricTolerance)) return std::nullopt;
  const double t = e2.dot(q) * inv_det;
  const float tf = static_cast<float>(t);
  if (!(tf >= t_min && tf <= t_max)) return std::nullopt;

  RayTriangleHit hit;
  hit.t = tf;
  hit.u = static_cast<float>(u);
  hit.v = static_cast<float>(v);
  hit.front_face = det > 0.0;
  return hit;
}

}  // namespace skinspheres::lib
