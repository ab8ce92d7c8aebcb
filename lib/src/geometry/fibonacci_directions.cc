// The Fibonacci lattice on the unit sphere. See fibonacci_directions.h.
#include "skinspheres/lib/geometry/fibonacci_directions.h"

#include <algorithm>
#include <cmath>
#include <numbers>

namespace skinspheres::lib {

std::vector<Eigen::Vector3f> FibonacciDirections(int n) {
  std::vector<Eigen::Vector3f> out;
  if (n <= 0) return out;
  out.reserve(static_cast<size_t>(n));
  const double golden = std::numbers::pi * (3.0 - std::sqrt(5.0));
  for (int k = 0; k < n; ++k) {
    const double y = 1.0 - (2.0 * k + 1.0) / n, rr = std::sqrt(std::max(0.0, 1.0 - y * y)), phi = golden * k;
    out.emplace_back(float(rr * std::cos(phi)), float(y), float(rr * std::sin(phi)));
  }
  return out;
}

}  // namespace skinspheres::lib
