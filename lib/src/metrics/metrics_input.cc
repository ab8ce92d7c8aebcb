// Input checks and bounds shared by the fit metrics. See metrics_internal.h.
#include <limits>

#include "metrics_internal.h"

namespace skinspheres::lib::metrics_internal {

Error Invalid(std::string message) {
  return MakeError(ErrorCode::kInvalidArgument, "fit metrics: " + std::move(message));
}

std::optional<Error> ValidateMesh(std::span<const Eigen::Vector3f> positions,
                                  std::span<const Eigen::Vector3i> triangles) {
  if (positions.empty() || triangles.empty()) return Invalid("the mesh is empty (no vertices or no triangles)");
  for (size_t i = 0; i < positions.size(); ++i)
    if (!Finite(positions[i])) return Invalid("vertex " + std::to_string(i) + " is not finite");
  for (size_t t = 0; t < triangles.size(); ++t)
    for (int k = 0; k < 3; ++k)
      if (triangles[t][k] < 0 || size_t(triangles[t][k]) >= positions.size())
        return Invalid("triangle " + std::to_string(t) + " indexes vertex " + std::to_string(triangles[t][k]) + " of " +
                       std::to_string(positions.size()));
  return std::nullopt;
}

void Bounds(std::span<const Eigen::Vector3f> positions, Vec3d& lo, Vec3d& hi) {
  lo = Vec3d::Constant(std::numeric_limits<double>::max());
  hi = -lo;
  for (const auto& v : positions) {
    lo = lo.cwiseMin(v.cast<double>());
    hi = hi.cwiseMax(v.cast<double>());
  }
}

}  // namespace skinspheres::lib::metrics_internal
