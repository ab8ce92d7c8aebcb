// Fitting one collider to a cloud of points (internal to lib/colliders).
#pragma once

#include <Eigen/Core>
#include <span>
#include <vector>

namespace skinspheres::lib::colliders {

// The convex hull of two spheres (a sphere when a == b): the shape every collider is.
struct RoundCone {
  Eigen::Vector3f a = Eigen::Vector3f::Zero(), b = Eigen::Vector3f::Zero();
  float ra = 0.0f, rb = 0.0f;
};
// Exact signed distance (negative inside), in double internally.
float SignedDistance(const RoundCone& s, const Eigen::Vector3f& p);
// A cost that grows with the shape's size: its volume (frustum between the centres plus two half
// balls, an upper bound that is exact for a sphere and a straight capsule).
double Volume(const RoundCone& s);

enum class ShapeKind { kSphere, kCapsule, kTaperedCapsule };
struct ShapeFitSettings {
  float slack = 0.0f;      // points may lie this far outside
  float quantile = 0.99f;  // share of the points that must be within slack
  bool allow_sphere = true;
  bool allow_capsule = true;
  bool tapered = true;
};
struct ShapeFitResult {
  RoundCone shape;
  double cost = 0.0;  // summed depth of the points under the surface (model units): what the budget spends
  bool ok = false;
};
// points: the cloud, in the frame the shape is fitted in; hint: a preferred axis (the bone's
// direction; zero for none), tried beside the cloud's principal axis.
ShapeFitResult FitShape(std::span<const Eigen::Vector3f> points, const Eigen::Vector3f& hint,
                        const ShapeFitSettings& settings);

// Points spread evenly by area over the shape's surface, with the area each stands for.
void SurfaceSamples(const RoundCone& s, int per_sphere, std::vector<Eigen::Vector3f>* points,
                    std::vector<float>* areas);

}  // namespace skinspheres::lib::colliders
