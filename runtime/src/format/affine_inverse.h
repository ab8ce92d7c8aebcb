// The inverse of an affine 4x4 transform in double, shared by the sphere-set checks and the fast
// refit's reference frames (refit_job.h). Internal to the runtime library.
#pragma once

#include <Eigen/Core>
#include <Eigen/LU>
#include <cmath>
#include <optional>

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

}  // namespace skinspheres::runtime::internal
