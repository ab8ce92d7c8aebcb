// The fast refit's frame of reference (docs/REFIT.md#reference-frame): the rest pose, or the bind
// pose where it bounds tighter (ChooseFastReference).
#include "refit/fast_reference.h"

#include <Eigen/LU>
#include <algorithm>
#include <array>
#include <atomic>
#include <cfloat>
#include <cmath>
#include <cstdint>
#include <limits>
#include <optional>
#include <string>
#include <tuple>
#include <type_traits>
#include <utility>
#include <vector>

#include "format/affine_inverse.h"
#include "format/grid_point.h"
#include "refit/fast_reference.h"
#include "refit/refit_internal.h"
#include "skinspheres/runtime/refit/mesh_bounds.h"
#include "skinspheres/runtime/refit/refit_job.h"
#include "skinspheres/skinning/platform.h"

namespace skinspheres::runtime {

using internal::AffineInverse;
using internal::Mat4d;
using internal::Reference;
using internal::StoredReference;
using internal::Vec4d;

// The reference the set stores (sphere_set.h), else its rest pose. An error names a joint whose
// rest transform cannot be inverted.
Result<Reference> internal::StoredReference(const SphereSet& set) {
  Reference ref;
  const size_t joints = set.joint_count();
  ref.inverse.resize(joints);
  const bool stored = !set.fast_reference_inverse.empty();
  for (size_t j = 0; j < joints; ++j) {
    if (stored) {
      ref.inverse[j] = set.fast_reference_inverse[j].cast<double>();
      continue;
    }
    const auto inv = AffineInverse(set.joint_rest_world[j].cast<double>());
    if (!inv) {
      return MakeError(ErrorCode::kInvalidData, "RefitRestData: sphere set '" + set.source_file +
                                                    "': rest transform of joint " + std::to_string(j) + " '" +
                                                    set.joint_names[j] + "' is not invertible");
    }
    ref.inverse[j] = *inv;
  }
  for (size_t s = 0; s < set.size(); ++s) {
    if (stored) {
      ref.center.push_back(set.fast_reference_spheres[s].head<3>().cast<double>().homogeneous());
      ref.radius.push_back(set.fast_reference_spheres[s].w());
    } else {
      ref.center.push_back(set.centers_rest[s].cast<double>().homogeneous());
      ref.radius.push_back(set.radii_fast[s]);
    }
  }
  return ref;
}

namespace {

// Every bind entry carries its vertices to the same place at rest, G_j(rest) · IBM_b = I (to 1e-6 of
// the larger of 1 and the matrix's largest entry): the rest copies coincide and the rest reference
// is already the tight one. Also true without a mesh.
bool RestIsBind(const SphereSet& set) {
  for (const skinning::BindEntry& b : set.mesh.binds) {
    const Mat4d m = set.joint_rest_world[b.joint].cast<double>() * b.inverse_bind.cast<double>();
    const double tolerance = 1e-6 * std::max(1.0, m.topRightCorner<3, 1>().cwiseAbs().maxCoeff());
    if ((m.topLeftCorner<3, 4>() - Mat4d::Identity().topLeftCorner<3, 4>()).cwiseAbs().maxCoeff() > tolerance) {
      return false;
    }
  }
  return true;
}

// The bind pose as the reference, stored into set's fast_reference arrays: R_j^-1 the inverse bind
// matrix of j's first bind entry (the rest inverse for a joint with none), each centre the rest
// centre carried back by the sphere's blended rest-from-bind transform, each radius
// FastReferenceRadiiFromMesh's. false (arrays cleared) where a transform cannot be inverted or a
// source vertex has no weight.
bool StoreBindReference(SphereSet* set, std::span<const Mat4d> rest_inverse, std::span<const float> weights) {
  const skinning::SkinnedMesh& mesh = set->mesh;
  const size_t joints = set->joint_count();
  std::vector<int> first_bind(joints, -1);
  for (size_t b = 0; b < mesh.binds.size(); ++b) {  // the first invertible entry (exporters write zeros)
    if (first_bind[mesh.binds[b].joint] < 0 && AffineInverse(mesh.binds[b].inverse_bind.cast<double>())) {
      first_bind[mesh.binds[b].joint] = static_cast<int>(b);
    }
  }
  std::vector<Mat4d> inverse(rest_inverse.begin(), rest_inverse.end());
  set->fast_reference_inverse.resize(joints);
  for (size_t j = 0; j < joints; ++j) {
    if (first_bind[j] >= 0) inverse[j] = mesh.binds[first_bind[j]].inverse_bind.cast<double>();
    set->fast_reference_inverse[j] = inverse[j].cast<float>();
  }
  set->fast_reference_spheres.clear();
  for (size_t s = 0; s < set->size(); ++s) {
    Mat4d blend = Mat4d::Zero();
    for (uint32_t k = set->influence_offsets[s]; k < set->influence_offsets[s + 1]; ++k) {
      const uint16_t j = set->influence_joints[k];
      blend += double(weights[k]) * (set->joint_rest_world[j].cast<double>() * inverse[j]);
    }
    blend.row(3) = Eigen::RowVector4d(0.0, 0.0, 0.0, 1.0);
    const auto unblend = AffineInverse(blend);
    const Vec4d c = unblend ? Vec4d(*unblend * set->centers_rest[s].cast<double>().homogeneous()) : Vec4d::Zero();
    if (!unblend || !c.allFinite()) break;
    set->fast_reference_spheres.push_back(Vec4f(float(c.x()), float(c.y()), float(c.z()), 1.0f));
  }
  auto radii = set->fast_reference_spheres.size() == set->size()
                   ? FastReferenceRadiiFromMesh(*set)
                   : Result<std::vector<float>>(MakeError(ErrorCode::kInvalidData, "not invertible"));
  if (!radii.ok()) {
    set->fast_reference_inverse.clear();
    set->fast_reference_spheres.clear();
    return false;
  }
  for (size_t s = 0; s < set->size(); ++s) set->fast_reference_spheres[s].w() = (*radii)[s];
  return true;
}

// Σ over spheres of the fast bound (without its rounding margin), in double, with the joints at
// `world`: how loose a reference is at one pose.
double BoundSum(const SphereSet& set, const Reference& ref, std::span<const Mat4d> world,
                std::span<const float> weights, std::span<const float> reach) {
  double sum = 0.0;
  std::vector<Eigen::Vector3d> moved;
  for (size_t s = 0; s < set.size(); ++s) {
    const uint32_t k0 = set.influence_offsets[s], k1 = set.influence_offsets[s + 1];
    moved.clear();
    Eigen::Vector3d c = Eigen::Vector3d::Zero();
    double s2 = 0.0;
    for (uint32_t k = k0; k < k1; ++k) {
      const uint16_t j = set.influence_joints[k];
      const Mat4d t = world[j] * ref.inverse[j];
      moved.push_back((t * ref.center[s]).head<3>());
      c += double(weights[k]) * moved.back();
      const Eigen::Matrix3d ata = t.topLeftCorner<3, 3>().transpose() * t.topLeftCorner<3, 3>();
      s2 = std::max(s2, ata.cwiseAbs().rowwise().sum().maxCoeff());
    }
    double spread = 0.0, reached = 0.0;
    for (uint32_t k = k0; k < k1; ++k) {
      const double d = (moved[k - k0] - c).norm();
      spread = std::max(spread, d);
      reached += double(reach[k]) * d;
    }
    sum += std::sqrt(s2) * double(ref.radius[s]) + std::min(spread, reached);
  }
  return sum;
}

// The bind pose is taken when it lowers the summed bound by more than this share: where the two
// poses differ only by float rounding, or on bind entries no vertex weighs (Xbot, CesiumMan: 1e-6 of
// the sum), the set keeps the rest pose and its files stay as they were.
constexpr double kBindReferenceGain = 1e-3;

}  // namespace

Result<bool> internal::StoreBindFastReference(SphereSet* set) {
  set->fast_reference_inverse.clear();
  set->fast_reference_spheres.clear();
  set->ClearReachGroups();
  if (!set->has_mesh() || set->fast_only) return false;
  auto data = RefitRestData::Create(*set);
  if (!data.ok()) return data.error();
  auto rest = StoredReference(*set);
  if (!rest.ok()) return rest.error();
  return StoreBindReference(set, rest->inverse, data->weights());
}

Result<bool> ChooseFastReference(SphereSet* set) {
  set->fast_reference_inverse.clear();
  set->fast_reference_spheres.clear();
  // Reach groups are measured in the reference frame: they go with it (the fitter writes them after).
  set->ClearReachGroups();
  if (!set->has_mesh() || set->fast_only || RestIsBind(*set)) return false;
  auto data = RefitRestData::Create(*set);  // the rest reference, its weights and reach
  if (!data.ok()) return data.error();
  auto rest = StoredReference(*set);
  if (!rest.ok()) return rest.error();
  if (!StoreBindReference(set, rest->inverse, data->weights())) return false;
  auto bind = StoredReference(*set);
  if (!bind.ok()) return bind.error();
  // The bound summed over the spheres at the rest pose and at the bind pose.
  const size_t joints = set->joint_count();
  std::vector<Mat4d> rest_world(joints), bind_world(joints);
  for (size_t j = 0; j < joints; ++j) {
    rest_world[j] = set->joint_rest_world[j].cast<double>();
    bind_world[j] = AffineInverse(bind->inverse[j]).value_or(rest_world[j]);
  }
  const double with_rest = BoundSum(*set, *rest, rest_world, data->weights(), data->reach()) +
                           BoundSum(*set, *rest, bind_world, data->weights(), data->reach());
  const double with_bind = BoundSum(*set, *bind, rest_world, data->weights(), data->reach()) +
                           BoundSum(*set, *bind, bind_world, data->weights(), data->reach());
  if (with_bind < (1.0 - kBindReferenceGain) * with_rest) return true;
  set->fast_reference_inverse.clear();
  set->fast_reference_spheres.clear();
  return false;
}

}  // namespace skinspheres::runtime
