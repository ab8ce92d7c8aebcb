// Mesh helpers: body height and the unique vertices of triangle lists. See mesh_helpers.h.
#include "skinspheres/lib/geometry/mesh_helpers.h"

#include <limits>

namespace skinspheres::lib {

float BodyHeight(std::span<const Eigen::Vector3f> positions) {
  float lo = std::numeric_limits<float>::infinity(), hi = -lo;
  for (const Eigen::Vector3f& p : positions) {
    lo = std::min(lo, p.y());
    hi = std::max(hi, p.y());
  }
  return positions.empty() ? 0.0f : hi - lo;
}

std::vector<uint32_t> UniqueVertices::Indices(std::span<const uint32_t> list) {
  std::vector<uint32_t> out;
  ForEach(list, [&](int32_t v) { out.push_back(static_cast<uint32_t>(v)); });
  return out;
}

std::vector<Eigen::Vector3f> UniqueVertices::Positions(std::span<const Eigen::Vector3f> positions,
                                                       std::span<const uint32_t> list) {
  std::vector<Eigen::Vector3f> out;
  out.reserve(list.size());
  ForEach(list, [&](int32_t v) { out.push_back(positions[v]); });
  return out;
}

}  // namespace skinspheres::lib
