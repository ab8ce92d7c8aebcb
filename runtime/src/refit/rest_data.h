// Private: the state of a RefitRestData (refit_job.h has the contract, refit_rest_data.cc builds
// it, docs/REFIT.md#refitrestdata-layout describes it), and the friend that reads it: the refit's
// job and kernels, tests and benchmarks.
#pragma once

#include <Eigen/Core>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "skinspheres/runtime/refit/refit_job.h"

namespace skinspheres::runtime {

struct RefitRestData::Data {
  size_t sphere_count = 0;
  size_t source_vertex_count = 0;
  std::vector<Eigen::Vector3f> center_in_joint;  // per influence entry: R_j^-1 · c_s
  std::vector<float> weights;                    // per influence entry: w_k renormalised to sum 1
  std::vector<float> reach;                      // per influence entry: W_k
  std::vector<float> radii_fast;                 // per sphere: radius_fast in the reference frame
  bool bind_reference = false;
  std::vector<uint32_t> group_offsets, group_reach_offsets;
  std::vector<float> group_radii, group_reach, group_blend, group_deviation, group_blend_sum;
  std::vector<Eigen::Matrix3f> rest_linear_inverse;  // per joint
  std::vector<float> rest_inverse_rows;              // 12 per joint
  std::vector<uint32_t> exact_point_offsets, exact_points;
  size_t point_count = 0;
};

namespace internal {

struct RestDataAccess {
  static RefitRestData::Data& Of(RefitRestData& r) { return *r.data_; }
  static const RefitRestData::Data& Of(const RefitRestData& r) { return *r.data_; }
};
inline const RefitRestData::Data& RestOf(const RefitRestData& r) { return RestDataAccess::Of(r); }

}  // namespace internal
}  // namespace skinspheres::runtime
