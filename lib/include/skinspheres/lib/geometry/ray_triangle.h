// Ray-triangle intersection for the disk-of-rays fitter (paper §4.1 and §5, "Ray Triangle
// Intersection Test": every ray r_i of the disk * against the polygons Δ_j of one region).
//
// Contract
//   - Ray: origin + t·dir for t in [t_min, t_max]. `dir` need not be unit length; t is in units
//     of |dir| (for a unit dir, t is a distance). A zero or non-finite dir never hits.
//   - Two-sided: the fitter casts from inside the body, so it meets triangles from their back.
//     `front_face` says whether dir·n < 0 with n = (b - a) × (c - a).
//   - Degenerate triangles (zero area, a repeated vertex, collinear vertices, or any non-finite
//     coordinate; see IsDegenerateTriangle) never hit.
//   - A ray lying in the triangle's plane never hits (in a closed mesh it leaves through a
//     neighbouring, non-coplanar triangle).
//   - Deterministic: a pure function of its arguments.
//
// Choice of algorithm (why not a slower exactly-watertight test)
//   Möller-Trumbore ("Fast, minimum storage ray-triangle intersection", 1997), evaluated in DOUBLE
//   precision from the float inputs, with inclusive edges widened by kBarycentricTolerance
//   (1e-9, dimensionless): a hit is accepted when u >= -tol, v >= -tol and u + v <= 1 + tol.
//   A ray through an edge or a vertex shared by triangles of a closed mesh has barycentric
//   coordinates that are exactly 0 (or 1) in real arithmetic; in double they are off by ~1e-16
//   relative, far below the tolerance, so EVERY triangle around that edge/vertex reports a hit
//   and the ray cannot slip through the crack. The price is a possible double report of one crossing
//   (resolved by the BVH's "nearest t, then smallest triangle index" rule) and triangles that are
//   1e-9 of their size larger than exact, which is irrelevant for fitting spheres. The fully
//   watertight test of Woop, Benthin and Wald (JCGT 2013) would avoid the widening but needs a
//   per-ray shear set-up; the double-precision MT with a tolerance is watertight for every
//   non-grazing ray, which is what the fitter casts.
#pragma once

#include <Eigen/Core>
#include <limits>
#include <optional>

namespace skinspheres::lib {

// Barycentric slack that closes the cracks between triangles sharing an edge (see above).
inline constexpr double kBarycentricTolerance = 1e-9;

struct RayTriangleHit {
  float t = 0.0f;           // ray parameter of the hit: point = origin + t·dir
  float u = 0.0f;           // barycentric weight of vertex b
  float v = 0.0f;           // barycentric weight of vertex c; weight of a is 1 - u - v
  bool front_face = false;  // dir·((b-a)×(c-a)) < 0
};

// True when the triangle has (numerically) zero area: a non-finite coordinate, a zero-length edge,
// or |(b-a)×(c-a)| <= 1e-12·|b-a|·|c-a| (the angle at a below 1e-12 rad, i.e. collinear vertices).
bool IsDegenerateTriangle(const Eigen::Vector3f& a, const Eigen::Vector3f& b, const Eigen::Vector3f& c);

// The hit of the ray with triangle (a, b, c) for t in [t_min, t_max], or nullopt.
std::optional<RayTriangleHit> IntersectRayTriangle(const Eigen::Vector3f& origin, const Eigen::Vector3f& dir,
                                                   const Eigen::Vector3f& a, const Eigen::Vector3f& b,
                                                   const Eigen::Vector3f& c, float t_min = 0.0f,
                                                   float t_max = std::numeric_limits<float>::infinity());

}  // namespace skinspheres::lib
