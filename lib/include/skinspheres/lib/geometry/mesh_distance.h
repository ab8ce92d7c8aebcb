// MeshDistances: the unsigned distance from many query points to a triangle mesh, exact per query
// (ClosestPointOnTriangle of closest_point.h) through an AABB tree of the triangles searched by
// branch and bound (nearest box first, boxes farther than the best distance so far skipped).
//
// Contract: `out.size()` must equal `queries.size()` and `triangles` must index `positions` and not
// be empty; otherwise nothing is written. Degenerate triangles count (their nearest edge point).
// Cost: O(triangles · log triangles) to build, about O(log triangles) per query on a body-like
// mesh; one thread; deterministic. Used by the fit metrics (the union boundary's distance to the
// body) and as the exact oracle of the distance field's tests.
#pragma once

#include <Eigen/Core>
#include <span>

namespace skinspheres::lib {

void MeshDistances(std::span<const Eigen::Vector3f> positions, std::span<const Eigen::Vector3i> triangles,
                   std::span<const Eigen::Vector3f> queries, std::span<float> out);

}  // namespace skinspheres::lib
