// MeshInsideVolume: the volume inside a triangle mesh that need not be watertight, by the fit
// metrics' six-ray voxel vote (fit_metrics.h describes it: parity and winding number per ray,
// closed inside-out pieces turned around, a voxel inside when 4 of its 6 rays say so).
#pragma once

#include <Eigen/Core>
#include <span>

#include "skinspheres/runtime/error.h"

namespace skinspheres::lib {

// The estimate on a grid with `grid_resolution` voxels along the longest axis of the mesh's bounding
// box (padded by one voxel). Errors (kInvalidArgument): empty mesh, non-finite vertices, indices out
// of range, grid_resolution outside [8, 1024].
Result<double> MeshInsideVolume(std::span<const Eigen::Vector3f> positions, std::span<const Eigen::Vector3i> triangles,
                                int grid_resolution = 160);

}  // namespace skinspheres::lib
