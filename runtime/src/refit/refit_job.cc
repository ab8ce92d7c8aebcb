// Per-frame sphere refit (refit_job.h). Exact mode: centre c' = Σ w_j T_j c, radius = max distance
// to the skinned source vertices. Fast mode: Kavan & Žára's bound r' = s_max·radius_fast +
// max_j |T_j c - c'|, its second term capped by Σ_j W_j |T_j c - c'| (derivation in the header).
#include "skinspheres/runtime/refit/refit_job.h"

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
#include "skinspheres/skinning/platform.h"

namespace skinspheres::runtime {

// Unaligned double types (math_types.h: no Eigen type of 32 bytes or more is aligned here).
using internal::Mat4d;
using internal::Vec4d;

const char* ToString(RefitMode mode) {
  switch (mode) {
    case RefitMode::kExact: return "exact";
    case RefitMode::kFast: return "fast";
  }
  return "unknown";
}

static_assert(internal::kKernelReachGroups == kMaxReachGroups, "the kernels keep one sum per reach group");

namespace {

using internal::AffineInverse;

// A frame of reference of the fast refit (refit_job.h, "Reference frame"): per joint the inverse of
// its reference transform, per sphere its centre in reference space and its radius there (each
// source vertex's weighted mean reference copy distance, FastReferenceRadiiFromMesh).
struct Reference {
  std::vector<Mat4d> inverse;  // per joint: G_j(rest)^-1, or the stored R_j^-1
  std::vector<Vec4d> center;   // per sphere, homogeneous
  std::vector<float> radius;   // per sphere
};

// The reference the set stores (sphere_set.h), else its rest pose. An error names a joint whose
// rest transform cannot be inverted.
Result<Reference> StoredReference(const SphereSet& set) {
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

}  // namespace

Result<RefitRestData> RefitRestData::Create(const SphereSet& set) {
  if (auto err = set.Validate()) {
    return MakeError(err->code, "RefitRestData: sphere set '" + set.source_file + "': " + err->message);
  }
  RefitRestData d;
  d.sphere_count_ = set.size();
  d.source_vertex_count_ = set.source_vertex_count;
  const size_t joints = set.joint_count();
  auto ref = StoredReference(set);
  if (!ref.ok()) return ref.error();
  d.weights_.resize(set.influence_joints.size());
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
    for (uint32_t k = k0; k < k1; ++k) d.weights_[k] = static_cast<float>(set.influence_weights[k] / wsum);
  }
  // The reach (sphere_set.h): stored, else the mesh's, else 1 (the bound without it).
  if (!set.influence_reach.empty()) {
    d.reach_ = set.influence_reach;
  } else if (set.has_mesh()) {
    auto from_mesh = InfluenceReachFromMesh(set);  // cannot fail on a set Validate() passed
    if (!from_mesh.ok()) {
      return MakeError(from_mesh.error().code,
                       "RefitRestData: sphere set '" + set.source_file + "': " + from_mesh.error().message);
    }
    d.reach_ = std::move(*from_mesh);
  } else {
    d.reach_.assign(set.influence_joints.size(), 1.0f);
  }
  d.bind_reference_ = !set.fast_reference_inverse.empty();
  d.radii_fast_ = ref->radius;
  // The reach groups: the set's, else one per sphere (its radius and reach), which gives the
  // one-group bound bit for bit.
  d.group_reach_offsets_.resize(set.size() + 1);
  if (!set.reach_group_offsets.empty()) {
    d.group_offsets_ = set.reach_group_offsets;
    d.group_radii_ = set.reach_group_radii;
    d.group_reach_ = set.reach_group_weights;
    d.group_blend_ = set.reach_group_blend;
    d.group_deviation_ = set.reach_group_deviation;
  } else {
    d.group_offsets_.resize(set.size() + 1);
    for (size_t s = 0; s <= set.size(); ++s) d.group_offsets_[s] = static_cast<uint32_t>(s);
    d.group_radii_ = d.radii_fast_;
    d.group_reach_ = d.reach_;
  }
  for (size_t s = 0, base = 0; s < set.size(); ++s) {
    d.group_reach_offsets_[s] = static_cast<uint32_t>(base);
    base += size_t{d.group_offsets_[s + 1] - d.group_offsets_[s]} *
            (set.influence_offsets[s + 1] - set.influence_offsets[s]);
    d.group_reach_offsets_[s + 1] = static_cast<uint32_t>(base);
  }
  // Σ_k m_gk per group, summed in float with k ascending: the sum the kernels formed every frame
  // before it was kept here, so the same bits.
  if (!d.group_blend_.empty()) {
    d.group_blend_sum_.assign(d.group_radii_.size(), 0.0f);
    for (size_t s = 0; s < set.size(); ++s) {
      const uint32_t k_count = set.influence_offsets[s + 1] - set.influence_offsets[s];
      for (uint32_t g = d.group_offsets_[s]; g < d.group_offsets_[s + 1]; ++g) {
        const float* m = d.group_blend_.data() + d.group_reach_offsets_[s] + size_t{g - d.group_offsets_[s]} * k_count;
        float sum = 0.0f;
        for (uint32_t k = 0; k < k_count; ++k) sum += m[k];
        d.group_blend_sum_[g] = sum;
      }
    }
  }
  d.rest_linear_inverse_.resize(joints);
  d.rest_inverse_rows_.assign(12 * joints, 0.0f);
  for (size_t j = 0; j < joints; ++j) {
    d.rest_linear_inverse_[j] = ref->inverse[j].topLeftCorner<3, 3>().cast<float>();
    for (int r = 0; r < 3; ++r) {
      for (int c = 0; c < 3; ++c) d.rest_inverse_rows_[12 * j + 4 * r + c] = d.rest_linear_inverse_[j](r, c);
    }
  }
  d.center_in_joint_.resize(set.influence_joints.size());
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
      d.center_in_joint_[k] = q.cast<float>();
    }
  }
  d.point_count_ = set.source_vertex_count + set.piece_points.size();
  if (set.has_pieces()) ExactPoints(set, &d.exact_point_offsets_, &d.exact_points_);
  return d;
}

bool RefitJob::Validate() const {
  if (set == nullptr) return false;
  const size_t n = set->size();
  if (out.size() < n) return false;
  if (set->vertex_offsets.size() != n + 1 || set->influence_offsets.size() != n + 1) return false;
  const bool need_joints = mode == RefitMode::kFast || !joint_world.empty();
  if (need_joints) {
    if (rest == nullptr) return false;
    if (rest->sphere_count() != n || rest->joint_count() != set->joint_count() ||
        rest->influence_count() != set->influence_joints.size() || rest->reach().size() != rest->influence_count() ||
        set->influence_weights.size() != set->influence_joints.size() || set->radii_fast.size() != n ||
        rest->group_offsets().size() != n + 1 || rest->group_reach_offsets().size() != n + 1) {
      return false;
    }
    if (joint_world.size() < set->joint_count()) return false;
  }
  if (mode == RefitMode::kExact) {
    if (set->fast_only) return false;  // no vertex lists to bound
    if (positions.size() < set->source_vertex_count) return false;
    // The set's point indices (source vertices and grid points) were checked when the rest data
    // was built; without rest data check the CSR end at least (O(1)).
    if (set->vertex_offsets[n] > set->vertices.size()) return false;
    if (rest != nullptr && (rest->source_vertex_count() != set->source_vertex_count ||
                            rest->point_count() != set->source_vertex_count + set->piece_points.size() ||
                            (!rest->exact_point_offsets().empty() && rest->exact_point_offsets().size() != n + 1))) {
      return false;
    }
  } else if (mode != RefitMode::kFast) {
    return false;
  }
  return true;
}

namespace internal {

namespace {
std::atomic<RefitSimd> g_pinned{RefitSimd::kAuto};
}  // namespace

bool RefitSimdSupported(RefitSimd level) {
  switch (level) {
    case RefitSimd::kAuto:
    case RefitSimd::kPortable: return true;
#if defined(SKINSPHERES_X86_64)
    case RefitSimd::kSse2: return true;
    case RefitSimd::kAvx2: return HostCpu().avx2;
    case RefitSimd::kAvx512: return HostCpu().avx512f;
#endif
    default: return false;
  }
}

namespace {
thread_local RefitSimd t_last_run = RefitSimd::kAuto;
}  // namespace

RefitSimd LastRefitSimdRun() { return t_last_run; }
void NoteRefitSimdRun(RefitSimd level) { t_last_run = level; }

RefitSimd RefitSimdInUse() {
  const RefitSimd pinned = g_pinned.load(std::memory_order_relaxed);
  if (pinned != RefitSimd::kAuto) return pinned;
  static const RefitSimd best = RefitSimdSupported(RefitSimd::kAvx512) ? RefitSimd::kAvx512
                                : RefitSimdSupported(RefitSimd::kAvx2) ? RefitSimd::kAvx2
                                : RefitSimdSupported(RefitSimd::kSse2) ? RefitSimd::kSse2
                                                                       : RefitSimd::kPortable;
  return best;
}

bool PinRefitSimd(RefitSimd level) {
  if (!RefitSimdSupported(level)) return false;
  g_pinned.store(level, std::memory_order_relaxed);
  return true;
}

const char* ToString(RefitSimd level) {
  switch (level) {
    case RefitSimd::kAuto: return "auto";
    case RefitSimd::kSse2: return "sse2";
    case RefitSimd::kAvx2: return "avx2";
    case RefitSimd::kAvx512: return "avx512 (crowd batches; avx2 alone)";
    case RefitSimd::kPortable: return "portable";
  }
  return "unknown";
}

}  // namespace internal

namespace {

// Exact mode's arithmetic in plain floats, in a fixed order (Eigen's own order on x86-64, where it
// was written with Eigen): Eigen picks its evaluation per target (NEON has 2-float packets that SSE
// lacks, so a Vector3f norm would sum in another order on aarch64), and the refit must give the
// same bits on every platform (skinspheres/skinning/platform.h).

// 16 ulps of the coordinates: covers float rounding of c', the distances and the caller's skinning.
inline float Margin(const float c[3], float r) {
  return 16.0f * FLT_EPSILON * (std::max(std::fabs(c[0]), std::max(std::fabs(c[1]), std::fabs(c[2]))) + r);
}

// out += w · (G · (p, 1)), each row (g0 p0 + (g1 p1 + g2 p2)) + g3.
inline void AddApplied(const Mat4f& g, const Eigen::Vector3f& p, float w, float out[3]) {
  const float* m = g.data();  // column-major
  for (int r = 0; r < 3; ++r) {
    const float row = (m[r] * p.x() + (m[4 + r] * p.y() + m[8 + r] * p.z())) + m[12 + r];
    out[r] = out[r] + w * row;
  }
}

// |p - c|^2 as d0^2 + (d1^2 + d2^2).
inline float SquaredDistance(const Eigen::Vector3f& p, const float c[3]) {
  const float d0 = p.x() - c[0], d1 = p.y() - c[1], d2 = p.z() - c[2];
  return d0 * d0 + (d1 * d1 + d2 * d2);
}

// c' = Σ_k w_k G_j(k)(t) · (G_j(k)(rest)^-1 c).
inline void BlendedCentre(const RefitJob& job, size_t s, float c[3]) {
  const auto& set = *job.set;
  const auto q = job.rest->center_in_joint();
  const auto w = job.rest->weights();
  c[0] = c[1] = c[2] = 0.0f;
  for (uint32_t k = set.influence_offsets[s]; k < set.influence_offsets[s + 1]; ++k) {
    AddApplied(job.joint_world[set.influence_joints[k]], q[k], w[k], c);
  }
}

// The centre of the box of the points list[v0, v1) (v0 < v1).
inline void BoxCentre(const RefitJob& job, const uint32_t* list, uint32_t v0, uint32_t v1, float c[3]) {
  const auto& set = *job.set;
  float lo[3], hi[3];
  const Eigen::Vector3f first = internal::PointAt(set, list[v0], job.positions.data());
  for (int a = 0; a < 3; ++a) lo[a] = hi[a] = first[a];
  for (uint32_t k = v0 + 1; k < v1; ++k) {
    const Eigen::Vector3f p = internal::PointAt(set, list[k], job.positions.data());
    for (int a = 0; a < 3; ++a) {
      lo[a] = std::min(lo[a], p[a]);
      hi[a] = std::max(hi[a], p[a]);
    }
  }
  for (int a = 0; a < 3; ++a) c[a] = 0.5f * (lo[a] + hi[a]);
}

bool RefitExact(const RefitJob& job, size_t begin, size_t end) {
  const auto& set = *job.set;
  const bool joints = !job.joint_world.empty();
  // The points to bound: the set's lists, or the rest data's, without the grid points no centre
  // can have farthest (RefitRestData::exact_points).
  const bool reduced = job.rest != nullptr && !job.rest->exact_point_offsets().empty();
  const uint32_t* offsets = reduced ? job.rest->exact_point_offsets().data() : set.vertex_offsets.data();
  const uint32_t* list = reduced ? job.rest->exact_points().data() : set.vertices.data();
  bool ok = true;
  for (size_t s = begin; s < end; ++s) {
    const uint32_t v0 = offsets[s], v1 = offsets[s + 1];
    float c[3];
    if (joints) {
      BlendedCentre(job, s, c);
    } else if (v0 == v1) {
      for (int a = 0; a < 3; ++a) c[a] = set.centers_rest[s][a];
    } else {
      BoxCentre(job, list, v0, v1, c);
    }
    float d2max = 0.0f;
    bool finite = std::isfinite(c[0]) && std::isfinite(c[1]) && std::isfinite(c[2]);
    for (uint32_t k = v0; k < v1; ++k) {
      const float d2 = SquaredDistance(internal::PointAt(set, list[k], job.positions.data()), c);
      finite &= d2 <= FLT_MAX;  // false for NaN and Inf (std::max would drop a NaN)
      d2max = std::max(d2max, d2);
    }
    const float r = std::sqrt(d2max);
    const float radius = r + Margin(c, r);
    job.out[s] = Vec4f(c[0], c[1], c[2], radius);
    ok &= finite && std::isfinite(radius);
  }
  return ok;
}

// The arrays of the fast refit of one set (world and out left to the caller).
internal::FastRefitArrays SharedArrays(const SphereSet& set, const RefitRestData& rest) {
  static_assert(sizeof(Mat4f) == 16 * sizeof(float) && sizeof(Eigen::Vector3f) == 3 * sizeof(float) &&
                sizeof(Vec4f) == 4 * sizeof(float));
  internal::FastRefitArrays a;  // (casts, not ->data(): a span of an empty set may hold a null pointer)
  a.joint_count = set.joint_count();
  a.center_in_joint = reinterpret_cast<const float*>(rest.center_in_joint().data());
  a.weights = rest.weights().data();
  a.reach = rest.reach().data();
  a.rest_inverse_rows = rest.rest_inverse_rows().data();
  a.influence_offsets = set.influence_offsets.data();
  a.influence_joints = set.influence_joints.data();
  a.radii_fast = rest.radii_fast().data();
  a.group_offsets = rest.group_offsets().data();
  a.group_radii = rest.group_radii().data();
  a.group_reach = rest.group_reach().data();
  a.group_reach_offsets = rest.group_reach_offsets().data();
  if (!rest.group_blend().empty()) {
    a.group_blend = rest.group_blend().data();
    a.group_deviation = rest.group_deviation().data();
    a.group_blend_sum = rest.group_blend_sum().data();
  }
  return a;
}

// Fast mode: the vector loop of refit_fast.inc at the level RefitSimdInUse() picks (same bits).
bool RefitFast(const RefitJob& job, size_t begin, size_t end) {
  internal::FastRefitArrays a = SharedArrays(*job.set, *job.rest);
  a.world = reinterpret_cast<const float*>(job.joint_world.data());
  a.out = reinterpret_cast<float*>(job.out.data());
  switch (internal::RefitSimdInUse()) {
#if defined(SKINSPHERES_X86_64)
    case internal::RefitSimd::kAvx512:  // one instance alone: the AVX2 copy (the crowd batches)
    case internal::RefitSimd::kAvx2: return internal::avx2::RefitFastRange(a, begin, end);
    case internal::RefitSimd::kSse2: return internal::sse2::RefitFastRange(a, begin, end);
#endif
    default: return internal::portable::RefitFastRange(a, begin, end);
  }
}

}  // namespace

bool RefitJob::RunRange(size_t begin, size_t end) const {
  if (!Validate() || begin > end || end > set->size()) return false;
  return mode == RefitMode::kExact ? RefitExact(*this, begin, end) : RefitFast(*this, begin, end);
}

bool RefitJob::Run() const {
  if (!Validate()) return false;
  return RunRange(0, set->size());
}

bool RefitJob::RunParallel(const ParallelFor& parallel_for, size_t grain) const {
  if (!Validate()) return false;
  std::atomic<bool> ok{true};
  parallel_for(set->size(), std::max<size_t>(grain, 1), [&](size_t begin, size_t end) {
    const bool good = mode == RefitMode::kExact ? RefitExact(*this, begin, end) : RefitFast(*this, begin, end);
    if (!good) ok.store(false, std::memory_order_relaxed);
  });
  return ok.load();
}

namespace internal {

size_t RefitBatchLanes(RefitSimd level) {
  switch (level == RefitSimd::kAuto ? RefitSimdInUse() : level) {
#if defined(SKINSPHERES_X86_64)
    case RefitSimd::kAvx512: return 16;
    case RefitSimd::kAvx2: return 8;
#endif
    default: return 4;  // SSE2 and portable
  }
}

bool RefitBatchUsable() { return RefitBatchLanes() > 1; }

uint32_t RefitFastBatch(const SphereSet& set, const RefitRestData& rest, const float* const world[kRefitBatchLanes],
                        float* const out[kRefitBatchLanes], float* soa, RefitSimd level) {
  const FastRefitArrays a = SharedArrays(set, rest);
  switch (level == RefitSimd::kAuto ? RefitSimdInUse() : level) {
#if defined(SKINSPHERES_X86_64)
    case RefitSimd::kAvx512: return avx512::RefitFastBatch(a, set.size(), world, out, soa);
    case RefitSimd::kAvx2: return avx2::RefitFastBatch(a, set.size(), world, out, soa);
    case RefitSimd::kSse2: return sse2::RefitFastBatch(a, set.size(), world, out, soa);
#endif
    default: return portable::RefitFastBatch(a, set.size(), world, out, soa);
  }
}

}  // namespace internal

}  // namespace skinspheres::runtime
