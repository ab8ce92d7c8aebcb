// Closest point on a triangle, in double (see closest_point.h; the float version is inline there).
#include "skinspheres/lib/geometry/closest_point.h"

#include <Eigen/Geometry>
#include <algorithm>

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
  const Vec3d ap = p - a;
  const double d1 = ab.dot(ap), d2 = ac.dot(ap);
  if (d1 <= 0 && d2 <= 0) return af;
  const Vec3d bp = p - b;
  const double d3 = ab.dot(bp), d4 = ac.dot(bp);
  if (d3 >= 0 && d4 <= d3) return bf;
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0 && d1 >= 0 && d3 <= 0) return (a + (d1 / (d1 - d3)) * ab).cast<float>();
  const Vec3d cp = p - c;
  const double d5 = ab.dot(cp), d6 = ac.dot(cp);
  if (d6 >= 0 && d5 <= d6) return cf;
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0 && d2 >= 0 && d6 <= 0) return (a + (d2 / (d2 - d6)) * ac).cast<float>();
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0 && (d4 - d3) >= 0 && (d5 - d6) >= 0)
    return (b + ((d4 - d3) / ((d4 - d3) + (d5 - d6))) * (c - b)).cast<float>();
  const double denom = 1.0 / (va + vb + vc);
  return (a + ab * (vb * denom) + ac * (vc * denom)).cast<float>();
}

}  // namespace skinspheres::lib
