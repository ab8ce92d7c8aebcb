// Triangle-triangle tests of the narrow phase (narrow_phase.h): do two triangles intersect, and
// if not, how close do they come.
//
// What the answers mean:
//  - A triangle is the closed set of its three vertices' convex hull: its edges and vertices belong
//    to it. Two triangles INTERSECT when they share at least one point, so touching counts (a
//    vertex on the other's face, edges that meet, coplanar triangles that overlap or share a piece
//    of boundary). Coplanar overlap, edge-edge and vertex-on-face cases are all covered.
//  - A DEGENERATE triangle (its three vertices exactly collinear, or two or three of them equal,
//    in the float coordinates given) has no area and never intersects anything, nor comes within
//    any distance of anything: TrianglesIntersect returns false and TriangleContactOf reports
//    nothing. In a closed mesh such a triangle's edges are shared with triangles that have area,
//    so what passes through it passes through them too. A sliver (thin but not exactly
//    degenerate) is a real triangle and is tested exactly like any other.
//  - Non-finite coordinates never intersect and never come close (no crash, no NaN out).
//
// Float rounding: the intersection test is EXACT for the float coordinates given. It only takes
// signs of 3x3 and 2x2 orientation determinants (Guigue & Devillers, "Fast and robust triangle-
// triangle overlap test using orientation predicates", 2003; the coplanar case by 2D orientation
// tests on the projection that drops the normal's largest axis), each evaluated in double with an
// error bound and, where the bound cannot decide, exactly (runtime/src/narrow_phase/exact_predicates.h). The
// answer therefore never depends on the order of the vertices or of the two triangles, nor on
// the compiler, and a pair that touches at a single point is found.
// Distances and points are computed in double from the float coordinates (relative error about
// 1e-15 of the coordinates' magnitude) and returned as float; a pair whose true distance lies
// within that rounding of the margin may fall on either side of it.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace skinspheres::runtime {

// True when the closed triangles (a0, a1, a2) and (b0, b1, b2) share at least one point (see above).
bool TrianglesIntersect(const Eigen::Vector3f& a0, const Eigen::Vector3f& a1, const Eigen::Vector3f& a2,
                        const Eigen::Vector3f& b0, const Eigen::Vector3f& b1, const Eigen::Vector3f& b2);

// True when the three points are exactly collinear (or two of them are equal) or one is not finite.
bool TriangleIsDegenerate(const Eigen::Vector3f& a0, const Eigen::Vector3f& a1, const Eigen::Vector3f& a2);

// Closest point of the closed triangle (a, b, c) to p, in double (Ericson, Real-Time Collision
// Detection §5.1.5: the Voronoi regions of the vertices, then of the edges, then the face). The
// triangle must have area: for a degenerate one the face step may divide by zero (callers that can
// meet one test first; lib's geometry/closest_point.h falls back to the nearest edge point).
// An internal helper of skinspheres shared by the narrow phase and the offline fitter, installed
// with this header; not part of the engine API.
Eigen::Vector3d ClosestPointOnTriangle(const Eigen::Vector3d& p, const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                                       const Eigen::Vector3d& c);

struct TriangleContactGeometry {
  bool intersecting = false;  // TrianglesIntersect
  float distance = 0.0f;      // 0 when intersecting; else the smallest distance between the triangles
  // Intersecting: the two ends of the intersection segment (for coplanar overlap, both are the centroid
  // of the overlap polygon's corners). Otherwise: the closest points, on a and on b.
  Eigen::Vector3f on_a = Eigen::Vector3f::Zero();
  Eigen::Vector3f on_b = Eigen::Vector3f::Zero();
};

// Classifies a pair: false when either triangle is degenerate or not finite, or when the triangles
// do not intersect and their distance is not < margin (margin <= 0: intersections only). True
// otherwise, with *out filled.
bool TriangleContactOf(const Eigen::Vector3f& a0, const Eigen::Vector3f& a1, const Eigen::Vector3f& a2,
                       const Eigen::Vector3f& b0, const Eigen::Vector3f& b1, const Eigen::Vector3f& b2, float margin,
                       TriangleContactGeometry* out);

// Smallest distance between two non-degenerate triangles and the points that realise it (the
// minimum over the 6 vertex-triangle and 9 edge-edge pairs, in double). Meaningful only when they
// do not intersect (for intersecting triangles it returns some distance >= 0, not 0). For tests and
// callers that want the distance whatever the margin.
float TriangleDistance(const Eigen::Vector3f& a0, const Eigen::Vector3f& a1, const Eigen::Vector3f& a2,
                       const Eigen::Vector3f& b0, const Eigen::Vector3f& b1, const Eigen::Vector3f& b2,
                       Eigen::Vector3f* on_a = nullptr, Eigen::Vector3f* on_b = nullptr);

}  // namespace skinspheres::runtime
