#include "skinspheres/skinning/skeleton.h"

#include <Eigen/SVD>

namespace skinspheres::skinning {

Mat4f Transform::ToMatrix() const {
  Mat4f m = Mat4f::Identity();
  m.topLeftCorner<3, 3>() = rotation.normalized().toRotationMatrix() * scale.asDiagonal();
  m.topRightCorner<3, 1>() = translation;
  return m;
}

Transform Transform::FromMatrix(const Mat4f& m) {
  Transform t;
  t.translation = m.topRightCorner<3, 1>();
  const Eigen::Matrix3f a = m.topLeftCorner<3, 3>();
  // Column norms are the scale of an R*S matrix; a negative determinant flips one axis.
  Eigen::Vector3f s(a.col(0).norm(), a.col(1).norm(), a.col(2).norm());
  if (a.determinant() < 0.0f) s.x() = -s.x();
  Eigen::Matrix3f r = a;
  for (int i = 0; i < 3; ++i) r.col(i) /= (s[i] != 0.0f ? s[i] : 1.0f);
  // Re-orthonormalise (polar decomposition through the SVD) so shear or noise cannot leak in.
  Eigen::JacobiSVD<Eigen::Matrix3f> svd(r, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3f q = svd.matrixU() * svd.matrixV().transpose();
  if (q.determinant() < 0.0f) {
    Eigen::Matrix3f u = svd.matrixU();
    u.col(2) = -u.col(2);
    q = u * svd.matrixV().transpose();
  }
  t.rotation = Quatf(q).normalized();
  t.scale = s;
  return t;
}

int32_t Skeleton::Find(std::string_view name) const {
  for (size_t i = 0; i < joint_names.size(); ++i) {
    if (joint_names[i] == name) return static_cast<int32_t>(i);
  }
  return -1;
}

bool Skeleton::Validate() const {
  if (parents.size() != joint_names.size() || rest_local.size() != joint_names.size()) return false;
  for (size_t i = 0; i < parents.size(); ++i) {
    if (parents[i] >= static_cast<int32_t>(i) || parents[i] < -1) return false;
  }
  return true;
}

void Skeleton::RestWorld(std::span<Mat4f> out) const {
  for (size_t i = 0; i < size(); ++i) {
    const Mat4f local = rest_local[i].ToMatrix();
    out[i] = parents[i] < 0 ? local : Mat4f(out[parents[i]] * local);
  }
}

}  // namespace skinspheres::skinning
