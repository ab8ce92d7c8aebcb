// The inverse of an affine 4x4 transform in double, shared by the sphere-set checks and the fast
// refit's reference frames (refit_job.h). Internal to the runtime library.
#pragma once

#include <Eigen/Core>
#include <Eigen/LU>
#include <algorithm>
#include <array>
#include <cmath>
#include <optional>

#include "skinspheres/skinning/math_types.h"

namespace skinspheres::runtime::internal {

// DontAlign, as every Eigen type of 32 bytes or more in the runtime (skinning/math_types.h).
using Mat4d = Eigen::Matrix<double, 4, 4, Eigen::ColMajor | Eigen::DontAlign>;
using Vec4d = Eigen::Matrix<double, 4, 1, Eigen::ColMajor | Eigen::DontAlign>;

// The inverse of g with its last row taken as 0 0 0 1; nullopt when the linear part is singular
// (|det| at most 1e-12 of its largest entry cubed) or not finite.
inline std::optional<Mat4d> AffineInverse(const Mat4d& g) {
  const Eigen::Matrix3d linear = g.topLeftCorner<3, 3>();
  const double det = linear.determinant();
  const double scale = linear.cwiseAbs().maxCoeff();
  if (!(std::abs(det) > 1e-12 * scale * scale * scale) || !std::isfinite(det)) return std::nullopt;
  Mat4d inv = Mat4d::Identity();
  const Eigen::Matrix3d li = linear.inverse();
  inv.topLeftCorner<3, 3>() = li;
  inv.topRightCorner<3, 1>() = -li * g.topRightCorner<3, 1>();
  return inv;
}

// A 3x4 affine transform in double, row-major: row r is (m[r][0], m[r][1], m[r][2], m[r][3]).
using Affine34 = std::array<std::array<double, 4>, 3>;

inline Affine34 FromFloat(const Mat4f& g) {
  Affine34 m;
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 4; ++c) m[r][c] = static_cast<double>(g(r, c));
  }
  return m;
}

// The inverse of an affine transform by cofactors, each operation written out in a fixed order, so
// that every platform computes the same bits (what a stored radius is compared with must not
// depend on how a compiler vectorises Eigen); nullopt when singular, as internal::AffineInverse.
inline std::optional<Affine34> ScalarAffineInverse(const Affine34& m) {
  const double c00 = m[1][1] * m[2][2] - m[1][2] * m[2][1], c01 = m[1][2] * m[2][0] - m[1][0] * m[2][2],
               c02 = m[1][0] * m[2][1] - m[1][1] * m[2][0];
  const double det = (m[0][0] * c00 + m[0][1] * c01) + m[0][2] * c02;
  double scale = 0.0;
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) scale = std::max(scale, std::fabs(m[r][c]));
  }
  if (!(std::fabs(det) > 1e-12 * scale * scale * scale) || !std::isfinite(det)) return std::nullopt;
  const double inv_det = 1.0 / det;
  Affine34 out;
  out[0] = {c00 * inv_det, (m[0][2] * m[2][1] - m[0][1] * m[2][2]) * inv_det,
            (m[0][1] * m[1][2] - m[0][2] * m[1][1]) * inv_det, 0.0};
  out[1] = {c01 * inv_det, (m[0][0] * m[2][2] - m[0][2] * m[2][0]) * inv_det,
            (m[0][2] * m[1][0] - m[0][0] * m[1][2]) * inv_det, 0.0};
  out[2] = {c02 * inv_det, (m[0][1] * m[2][0] - m[0][0] * m[2][1]) * inv_det,
            (m[0][0] * m[1][1] - m[0][1] * m[1][0]) * inv_det, 0.0};
  for (int r = 0; r < 3; ++r) {
    out[r][3] = -((out[r][0] * m[0][3] + out[r][1] * m[1][3]) + out[r][2] * m[2][3]);
  }
  return out;
}

// a · b for affine a, b (the last rows 0 0 0 1), in a fixed order.
inline Affine34 Compose(const Affine34& a, const Affine34& b) {
  Affine34 out;
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 4; ++c) {
      out[r][c] = (a[r][0] * b[0][c] + a[r][1] * b[1][c]) + a[r][2] * b[2][c];
    }
    out[r][3] += a[r][3];
  }
  return out;
}

}  // namespace skinspheres::runtime::internal
