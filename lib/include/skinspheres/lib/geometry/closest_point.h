// Closest point on a triangle to a point (Ericson, Real-Time Collision Detection §5.1.5: the
// Voronoi regions of the vertices, then of the edges, then the face).
//
// * ClosestPointOnTriangle: in double from the float inputs, rounded once: the runtime's
//   runtime::ClosestPointOnTriangle (runtime/triangle_contact.h), except that a degenerate triangle
//   (zero area, collinear or coincident vertices) gives the nearest point of its three edges.
// * ClosestPointOnTriangleFloat: the same region tests in float, for hot loops (the distance
//   field's seeding); a degenerate triangle resolves to a vertex or an edge point through the same
//   tests, and one that leaves no region (zero barycentric sum) falls back to the double version.
// Both always return a point of the triangle (up to rounding). Deterministic.
#pragma once

#include <Eigen/Core>

namespace skinspheres::lib {

Eigen::Vector3f ClosestPointOnTriangle(const Eigen::Vector3f& p, const Eigen::Vector3f& a, const Eigen::Vector3f& b,
                                       const Eigen::Vector3f& c);

inline Eigen::Vector3f ClosestPointOnTriangleFloat(const Eigen::Vector3f& p, const Eigen::Vector3f& a,
                                                   const Eigen::Vector3f& b, const Eigen::Vector3f& c) {
  const Eigen::Vector3f ab = b - a, ac = c - a, ap = p - a;
  const float d1 = ab.dot(ap), d2 = ac.dot(ap);
  if (d1 <= 0.0f && d2 <= 0.0f) return a;
  const Eigen::Vector3f bp = p - b;
  const float d3 = ab.dot(bp), d4 = ac.dot(bp);
  if (d3 >= 0.0f && d4 <= d3) return b;
  const float vc = d1 * d4 - d3 * d2;
  if (vc <= 0.0f && d1 >= 0.0f && d3 <= 0.0f && d1 - d3 > 0.0f) return a + (d1 / (d1 - d3)) * ab;
  const Eigen::Vector3f cp = p - c;
  const float d5 = ab.dot(cp), d6 = ac.dot(cp);
  if (d6 >= 0.0f && d5 <= d6) return c;
  const float vb = d5 * d2 - d1 * d6;
  if (vb <= 0.0f && d2 >= 0.0f && d6 <= 0.0f && d2 - d6 > 0.0f) return a + (d2 / (d2 - d6)) * ac;
  const float va = d3 * d6 - d5 * d4;
  if (va <= 0.0f && (d4 - d3) >= 0.0f && (d5 - d6) >= 0.0f && (d4 - d3) + (d5 - d6) > 0.0f) {
    return b + ((d4 - d3) / ((d4 - d3) + (d5 - d6))) * (c - b);
  }
  const float sum = va + vb + vc;
  if (!(sum > 0.0f)) return ClosestPointOnTriangle(p, a, b, c);  // degenerate: the careful version
  const float denom = 1.0f / sum;
  return a + ab * (vb * denom) + ac * (vc * denom);
}

}  // namespace skinspheres::lib
