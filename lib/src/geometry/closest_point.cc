// Closest point on a triangle, in double (see closest_point.h; the float version is inline there):
// degenerate triangles here, the rest by the runtime's region tests (runtime/triangle_contact.h).
#include "skinspheres/lib/geometry/closest_point.h"

#include <Eigen/Geometry>
#include <algorithm>

#include "skinspheres/runtime/narrow_phase/triangle_contact.h"

namespace skinspheres::lib {

using Vec3d = Eigen::Vector3d;

Eigen::Vector3f ClosestPointOnTriangle(const Eigen::Vector3f& pf, const Eigen::Vector3f& af, const Eigen::Vector3f& bf,
                                       const Eigen::Vector3f& cf) {
  const Vec3d p = pf.cast<double>(), a = af.cast<double>(), b = bf.cast<double>(), c = cf.cast<double>();
  const Vec3d ab = b - a, ac = c - a;
  auto segment = [&](const Vec3d& s, const Vec3d& e) -> Vec3d {
    const Vec3d d = e - s;
    const double len2 = d.squaredNorm();
    const double tt = len2 > 0 ? std::clamp((p - s).dot(d) / len2, 0.0, 1.0) : 0.0;
    return s + tt * d;
  };
  const double n2 = ab.cross(ac).squaredNorm();
  if (!(n2 > 1e-24 * ab.squaredNorm() * ac.squaredNorm()) || n2 == 0) {
    Vec3d best = segment(a, b);
    for (const Vec3d& q : {segment(b, c), segment(c, a)})
      if ((q - p).squaredNorm() < (best - p).squaredNorm()) best = q;
    return best.cast<float>();
  }
  return runtime::ClosestPointOnTriangle(p, a, b, c).cast<float>();
}

}  // namespace skinspheres::lib
