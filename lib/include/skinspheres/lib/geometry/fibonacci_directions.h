// FibonacciDirections: n unit directions spread evenly over the sphere (the Fibonacci lattice), to
// sample sphere surfaces: the tightening pass's exposure (tighten/sphere_tightener.h) and the fit
// metrics' union boundary (metrics/fit_metrics.h).
//
// Direction k in [0, n): y = 1 - (2k + 1)/n, longitude φ = k·π(3 - √5) (the golden angle),
// (sqrt(1 - y²)·cos φ, y, sqrt(1 - y²)·sin φ), computed in double and rounded to float once.
// Deterministic; n <= 0 gives no direction.
#pragma once

#include <Eigen/Core>
#include <vector>

namespace skinspheres::lib {

std::vector<Eigen::Vector3f> FibonacciDirections(int n);

}  // namespace skinspheres::lib
