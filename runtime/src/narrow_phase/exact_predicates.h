// Exact orientation predicates for float input (internal to the runtime).
//
//   Orient3d(a, b, c, d) = sign of ((b - a) x (c - a)) . (d - a)      (+1: d on the side the normal
//                                                                     of the ccw triangle abc points to)
//   Orient2d(a, b, c)    = sign of (b - a) x (c - a)                 (+1: abc counter-clockwise)
//
// The inputs are doubles that hold float values exactly (every float converts exactly). The sign
// is exact: a floating-point evaluation in double answers when its error bound (Shewchuk,
// "Adaptive precision floating-point arithmetic and fast robust geometric predicates", 1997,
// bound A of orient2d / orient3d, taken 2-3x wider) proves the sign; otherwise the determinant
// is evaluated exactly as a floating-point expansion (sums and products without rounding). Float
// inputs keep every intermediate far from double overflow and underflow (products of three
// differences of floats stay within 1e-140 .. 1e117), so no case is left to chance. The exact path
// runs only for (nearly) degenerate configurations: coplanar, collinear, touching.
#pragma once

#include <cmath>

namespace skinspheres::runtime::exact {

struct P3 {
  double x, y, z;
};

// The exact evaluations (exact_predicates.cc), used when the filters below cannot decide.
int Orient3dExact(const P3& a, const P3& b, const P3& c, const P3& d);
int Orient2dExact(double ax, double ay, double bx, double by, double cx, double cy);

inline int Sign(double v) { return (v > 0.0) - (v < 0.0); }

inline int Orient3d(const P3& a, const P3& b, const P3& c, const P3& d) {
  const double ux = b.x - a.x, uy = b.y - a.y, uz = b.z - a.z;
  const double vx = c.x - a.x, vy = c.y - a.y, vz = c.z - a.z;
  const double wx = d.x - a.x, wy = d.y - a.y, wz = d.z - a.z;
  const double uyvz = uy * vz, uzvy = uz * vy;
  const double uzvx = uz * vx, uxvz = ux * vz;
  const double uxvy = ux * vy, uyvx = uy * vx;
  const double det = wx * (uyvz - uzvy) + wy * (uzvx - uxvz) + wz * (uxvy - uyvx);
  const double permanent = std::abs(wx) * (std::abs(uyvz) + std::abs(uzvy)) +
                           std::abs(wy) * (std::abs(uzvx) + std::abs(uxvz)) +
                           std::abs(wz) * (std::abs(uxvy) + std::abs(uyvx));
  // Shewchuk's bound A is (7 + 56 eps) eps ~ 7.8e-16 of the permanent; 2e-15 leaves room.
  const double bound = 2e-15 * permanent;
  if (det > bound) return 1;
  if (-det > bound) return -1;
  if (permanent == 0.0) return 0;  // every product is zero: det is exactly 0
  return Orient3dExact(a, b, c, d);
}

inline int Orient2d(double ax, double ay, double bx, double by, double cx, double cy) {
  const double left = (bx - ax) * (cy - ay), right = (by - ay) * (cx - ax);
  const double det = left - right;
  // Shewchuk's bound A is (3 + 16 eps) eps ~ 3.3e-16 of |left| + |right|; 1e-15 leaves room.
  const double bound = 1e-15 * (std::abs(left) + std::abs(right));
  if (det > bound) return 1;
  if (-det > bound) return -1;
  if (left == 0.0 && right == 0.0) return 0;
  return Orient2dExact(ax, ay, bx, by, cx, cy);
}

}  // namespace skinspheres::runtime::exact
