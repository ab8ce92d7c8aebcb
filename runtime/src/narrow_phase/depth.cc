// The contact normal's helper of the depth estimate (depth.h).
#include <algorithm>
#include <cmath>
#include <cstring>
#include <vector>

#include "narrow_phase/internal.h"

namespace skinspheres::runtime::narrow_phase {

Eigen::Vector3d Normal(const Frame& f, uint32_t t) {
  const Eigen::Vector3d a = Vertex(f, t, 0).cast<double>();
  return (Vertex(f, t, 1).cast<double>() - a).cross(Vertex(f, t, 2).cast<double>() - a);
}

}  // namespace skinspheres::runtime::narrow_phase
