// The refit's rest data (refit_job.h, RefitRestData): per sphere its weights, reach groups, centre in
// each joint's reference frame and the exact points, computed once per set.
#include <Eigen/LU>
#include <algorithm>
#include <array>
#include <cfloat>
#include <cmath>
#include <cstdint>
#include <limits>
#include <memory>
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
#include "refit/rest_data.h"
#include "skinspheres/runtime/refit/mesh_bounds.h"
#include "skinspheres/runtime/refit/refit_job.h"
#include "skinspheres/skinning/platform.h"

namespace skinspheres::runtime {

using internal::Mat4d;
using internal::StoredReference;
using internal::Vec4d;

namespace {

// 2D cross product of (b - a) and (c - a) in grid coordinates.
int64_t Cross(const std::array<int, 2>& a, const std::array<int, 2>& b, const std::array<int, 2>& c) {
  return int64_t{b[0] - a[0]} * (c[1] - a[1]) - int64_t{b[1] - a[1]} * (c[0] - a[0]);
}

// RefitRestData::exact_points(): per sphere, its source vertices and, per cut triangle, the grid
// points at the corners of the convex hull of what it lists on that triangle (Andrew's monotone
// chain on integer grid coordinates; points on a hull edge are not corners). The hull is taken per
// (triangle, level): grid coordinates of two levels are not comparable, and Validate() does not
// require a listed grid point to be at its triangle's cut level.
void ExactPoints(const SphereSet& set, std::vector<uint32_t>* offsets, std::vector<uint32_t>* points) {
  const uint32_t svc = set.source_vertex_count;
  offsets->assign(1, 0);
  struct Listed {
    uint32_t triangle;
    int level;
    std::array<int, 2> ij;
    uint32_t point;  // the set's numbering; a triangle's vertex when < svc
  };
  std::vector<Listed> listed;
  std::vector<uint32_t> sources;
  std::vector<std::pair<uint32_t, int>> cut;  // (triangle, level)
  std::vector<size_t> order, chain;
  std::vector<uint8_t> keep;
  const auto by_key = [](const Listed& a, const Listed& b) {
    return std::tie(a.triangle, a.level, a.ij, a.point) < std::tie(b.triangle, b.level, b.ij, b.point);
  };
  for (size_t s = 0; s < set.size(); ++s) {
    const uint32_t v0 = set.vertex_offsets[s], v1 = set.vertex_offsets[s + 1];
    sources.clear();
    listed.clear();
    for (uint32_t k = v0; k < v1; ++k) {
      const uint32_t p = set.vertices[k];
      if (p < svc) {
        sources.push_back(p);
        continue;
      }
      const PiecePoint& g = set.piece_points[p - svc];
      listed.push_back({g.triangle, g.level, {g.i, g.j}, p});
    }
    std::sort(sources.begin(), sources.end());
    // Each cut triangle's listed vertices join its grid points of each level as hull candidates.
    cut.clear();
    for (const Listed& l : listed) cut.push_back({l.triangle, l.level});
    std::sort(cut.begin(), cut.end());
    cut.erase(std::unique(cut.begin(), cut.end()), cut.end());
    for (const auto& [t, level] : cut) {
      const uint32_t* v = set.triangle_vertices.data() + 3 * size_t{t};
      const std::array<int, 2> corner_ij[3] = {{0, 0}, {level, 0}, {0, level}};
      for (int c = 0; c < 3; ++c) {
        if (std::binary_search(sources.begin(), sources.end(), v[c])) listed.push_back({t, level, corner_ij[c], v[c]});
      }
    }
    std::sort(listed.begin(), listed.end(), by_key);
    keep.assign(listed.size(), 0);
    for (size_t b = 0; b < listed.size();) {
      size_t e = b;
      while (e < listed.size() && listed[e].triangle == listed[b].triangle && listed[e].level == listed[b].level) ++e;
      // [b, e): one triangle's candidates at one level, sorted by (i, j): the lower and the upper chain.
      chain.clear();
      auto build = [&](auto begin, auto end) {
        const size_t base = chain.size();
        for (auto it = begin; it != end; ++it) {
          const size_t q = *it;
          while (chain.size() >= base + 2 &&
                 Cross(listed[chain[chain.size() - 2]].ij, listed[chain.back()].ij, listed[q].ij) <= 0) {
            chain.pop_back();
          }
          chain.push_back(q);
        }
      };
      order.clear();
      for (size_t q = b; q < e; ++q) {
        if (order.empty() || listed[order.back()].ij != listed[q].ij) order.push_back(q);
      }
      if (order.size() <= 2) {
        for (size_t q : order) keep[q] = 1;
      } else {
        build(order.begin(), order.end());
        build(order.rbegin(), order.rend());
        for (size_t q : chain) keep[q] = 1;
      }
      b = e;
    }
    // The sphere's list order, without the grid points left out.
    for (uint32_t k = v0; k < v1; ++k) {
      const uint32_t p = set.vertices[k];
      bool kept = p < svc;
      if (!kept) {
        const PiecePoint& g = set.piece_points[p - svc];
        const Listed probe{g.triangle, g.level, {g.i, g.j}, p};
        const auto at = std::lower_bound(listed.begin(), listed.end(), probe, by_key);
        kept = keep[size_t(at - listed.begin())] != 0;
      }
      if (kept) points->push_back(p);
    }
    offsets->push_back(static_cast<uint32_t>(points->size()));
  }
}

// RefitRestData's reach groups (refit_job.h): the set's, else one per sphere (its radius and
// reach), which gives the one-group bound bit for bit; per sphere the offset of its groups'
// reaches; and Σ_k m_gk per group, summed in float with k ascending (the sum the kernels formed
// every frame before it was kept here, so the same bits).
struct ReachGroups {
  std::vector<uint32_t> offsets;
  std::vector<float> radii, reach, blend, deviation;
  std::vector<uint32_t> reach_offsets;
  std::vector<float> blend_sum;
};

ReachGroups ReachGroupsOf(const SphereSet& set, const std::vector<float>& radii_fast, const std::vector<float>& reach) {
  ReachGroups out;
  out.reach_offsets.resize(set.size() + 1);
  if (!set.reach_group_offsets.empty()) {
    out.offsets = set.reach_group_offsets;
    out.radii = set.reach_group_radii;
    out.reach = set.reach_group_weights;
    out.blend = set.reach_group_blend;
    out.deviation = set.reach_group_deviation;
  } else {
    out.offsets.resize(set.size() + 1);
    for (size_t s = 0; s <= set.size(); ++s) out.offsets[s] = static_cast<uint32_t>(s);
    out.radii = radii_fast;
    out.reach = reach;
  }
  for (size_t s = 0, base = 0; s < set.size(); ++s) {
    out.reach_offsets[s] = static_cast<uint32_t>(base);
    base += size_t{out.offsets[s + 1] - out.offsets[s]} * (set.influence_offsets[s + 1] - set.influence_offsets[s]);
    out.reach_offsets[s + 1] = static_cast<uint32_t>(base);
  }
  if (!out.blend.empty()) {
    out.blend_sum.assign(out.radii.size(), 0.0f);
    for (size_t s = 0; s < set.size(); ++s) {
      const uint32_t k_count = set.influence_offsets[s + 1] - set.influence_offsets[s];
      for (uint32_t g = out.offsets[s]; g < out.offsets[s + 1]; ++g) {
        const float* m = out.blend.data() + out.reach_offsets[s] + size_t{g - out.offsets[s]} * k_count;
        float sum = 0.0f;
        for (uint32_t k = 0; k < k_count; ++k) sum += m[k];
        out.blend_sum[g] = sum;
      }
    }
  }
  return out;
}

}  // namespace

RefitRestData::RefitRestData() : data_(std::make_unique<Data>()) {}
RefitRestData::~RefitRestData() = default;
RefitRestData::RefitRestData(const RefitRestData& other)
    : data_(std::make_unique<Data>(other.data_ ? *other.data_ : Data{})) {}
RefitRestData& RefitRestData::operator=(const RefitRestData& other) {
  if (this != &other) data_ = std::make_unique<Data>(other.data_ ? *other.data_ : Data{});
  return *this;
}
RefitRestData::RefitRestData(RefitRestData&&) noexcept = default;
RefitRestData& RefitRestData::operator=(RefitRestData&&) noexcept = default;

size_t RefitRestData::sphere_count() const { return data_->sphere_count; }
size_t RefitRestData::joint_count() const { return data_->rest_linear_inverse.size(); }
size_t RefitRestData::influence_count() const { return data_->center_in_joint.size(); }
size_t RefitRestData::source_vertex_count() const { return data_->source_vertex_count; }
std::span<const Eigen::Vector3f> RefitRestData::center_in_joint() const { return data_->center_in_joint; }
std::span<const float> RefitRestData::weights() const { return data_->weights; }
std::span<const float> RefitRestData::reach() const { return data_->reach; }
std::span<const float> RefitRestData::radii_fast() const { return data_->radii_fast; }
bool RefitRestData::bind_reference() const { return data_->bind_reference; }
std::span<const uint32_t> RefitRestData::group_offsets() const { return data_->group_offsets; }
std::span<const float> RefitRestData::group_radii() const { return data_->group_radii; }
std::span<const float> RefitRestData::group_reach() const { return data_->group_reach; }
std::span<const uint32_t> RefitRestData::group_reach_offsets() const { return data_->group_reach_offsets; }
std::span<const float> RefitRestData::group_blend() const { return data_->group_blend; }
std::span<const float> RefitRestData::group_deviation() const { return data_->group_deviation; }
std::span<const float> RefitRestData::group_blend_sum() const { return data_->group_blend_sum; }
std::span<const Eigen::Matrix3f> RefitRestData::rest_linear_inverse() const { return data_->rest_linear_inverse; }
std::span<const float> RefitRestData::rest_inverse_rows() const { return data_->rest_inverse_rows; }
std::span<const uint32_t> RefitRestData::exact_point_offsets() const { return data_->exact_point_offsets; }
std::span<const uint32_t> RefitRestData::exact_points() const { return data_->exact_points; }
size_t RefitRestData::point_count() const { return data_->point_count; }

Result<RefitRestData> RefitRestData::Create(const SphereSet& set) {
  if (auto err = set.Validate()) {
    return MakeError(err->code, "RefitRestData: sphere set '" + set.source_file + "': " + err->message);
  }
  RefitRestData rest;
  Data& d = internal::RestDataAccess::Of(rest);
  d.sphere_count = set.size();
  d.source_vertex_count = set.source_vertex_count;
  const size_t joints = set.joint_count();
  auto ref = StoredReference(set);
  if (!ref.ok()) return ref.error();
  d.weights.resize(set.influence_joints.size());
  for (size_t s = 0; s < set.size(); ++s) {
    const uint32_t k0 = set.influence_offsets[s], k1 = set.influence_offsets[s + 1];
    if (k0 == k1) {
      return MakeError(ErrorCode::kInvalidData, "RefitRestData: sphere set '" + set.source_file + "': sphere " +
                                                    std::to_string(s) + " has no joint influence");
    }
    double wsum = 0.0;
    for (uint32_t k = k0; k < k1; ++k) wsum += set.influence_weights[k];
    if (!(wsum > 0.0)) {
      return MakeError(ErrorCode::kInvalidData, "RefitRestData: sphere set '" + set.source_file + "': sphere " +
                                                    std::to_string(s) + " has influence weights summing to 0");
    }
    for (uint32_t k = k0; k < k1; ++k) d.weights[k] = static_cast<float>(set.influence_weights[k] / wsum);
  }
  // The reach (sphere_set.h): stored, else the mesh's, else 1 (the bound without it).
  if (!set.influence_reach.empty()) {
    d.reach = set.influence_reach;
  } else if (set.has_mesh()) {
    auto from_mesh = InfluenceReachFromMesh(set);  // cannot fail on a set Validate() passed
    if (!from_mesh.ok()) {
      return MakeError(from_mesh.error().code,
                       "RefitRestData: sphere set '" + set.source_file + "': " + from_mesh.error().message);
    }
    d.reach = std::move(*from_mesh);
  } else {
    d.reach.assign(set.influence_joints.size(), 1.0f);
  }
  d.bind_reference = !set.fast_reference_inverse.empty();
  d.radii_fast = ref->radius;
  ReachGroups groups = ReachGroupsOf(set, d.radii_fast, d.reach);
  d.group_offsets = std::move(groups.offsets);
  d.group_radii = std::move(groups.radii);
  d.group_reach = std::move(groups.reach);
  d.group_blend = std::move(groups.blend);
  d.group_deviation = std::move(groups.deviation);
  d.group_reach_offsets = std::move(groups.reach_offsets);
  d.group_blend_sum = std::move(groups.blend_sum);
  d.rest_linear_inverse.resize(joints);
  d.rest_inverse_rows.assign(12 * joints, 0.0f);
  for (size_t j = 0; j < joints; ++j) {
    d.rest_linear_inverse[j] = ref->inverse[j].topLeftCorner<3, 3>().cast<float>();
    for (int r = 0; r < 3; ++r) {
      for (int c = 0; c < 3; ++c) d.rest_inverse_rows[12 * j + 4 * r + c] = d.rest_linear_inverse[j](r, c);
    }
  }
  d.center_in_joint.resize(set.influence_joints.size());
  for (size_t s = 0; s < set.size(); ++s) {
    for (uint32_t k = set.influence_offsets[s]; k < set.influence_offsets[s + 1]; ++k) {
      const size_t j = set.influence_joints[k];
      const Eigen::Vector3d q = (ref->inverse[j] * ref->center[s]).head<3>();
      // The refit carries q by the joint's world transform in float: near the rest pose each product
      // within 1e24, so that rounding leaves the centre near its 1e18 and the squared spread finite
      // (a rest transform scaled by 1e-30 puts a centre at 1e10 at 1e40, inf in float, and every
      // frame's radius at inf).
      const double rest_scale = std::max(1.0, double(set.joint_rest_world[j].topRows<3>().cwiseAbs().maxCoeff()));
      if (!(std::max(1.0, q.cwiseAbs().maxCoeff()) * rest_scale <= 1e24)) {
        return MakeError(ErrorCode::kInvalidData,
                         "RefitRestData: sphere set '" + set.source_file + "': sphere " + std::to_string(s) +
                             "'s centre in the reference frame of joint " + std::to_string(j) +
                             " is out of the refit's float range (beyond 1e24 with that joint's rest transform)");
      }
      d.center_in_joint[k] = q.cast<float>();
    }
  }
  d.point_count = set.source_vertex_count + set.piece_points.size();
  if (set.has_pieces()) ExactPoints(set, &d.exact_point_offsets, &d.exact_points);
  return rest;
}

}  // namespace skinspheres::runtime
