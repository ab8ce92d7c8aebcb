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
#include "refit/rest_data.h"
#include "skinspheres/runtime/refit/mesh_bounds.h"
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

bool RefitJob::Validate() const {
  if (set == nullptr) return false;
  const size_t n = set->size();
  if (out.size() < n) return false;
  if (set->vertex_offsets.size() != n + 1 || set->influence_offsets.size() != n + 1) return false;
  const bool need_joints = mode == RefitMode::kFast || !joint_world.empty();
  if (need_joints) {
    if (rest == nullptr) return false;
    const RefitRestData::Data& r = internal::RestOf(*rest);
    if (r.sphere_count != n || r.rest_linear_inverse.size() != set->joint_count() ||
        r.center_in_joint.size() != set->influence_joints.size() || r.reach.size() != r.center_in_joint.size() ||
        set->influence_weights.size() != set->influence_joints.size() || set->radii_fast.size() != n ||
        r.group_offsets.size() != n + 1 || r.group_reach_offsets.size() != n + 1) {
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
    const RefitRestData::Data* r = rest != nullptr ? &internal::RestOf(*rest) : nullptr;
    if (r != nullptr && (r->source_vertex_count != set->source_vertex_count ||
                         r->point_count != set->source_vertex_count + set->piece_points.size() ||
                         (!r->exact_point_offsets.empty() && r->exact_point_offsets.size() != n + 1))) {
      return false;
    }
  } else if (mode != RefitMode::kFast) {
    return false;
  }
  return true;
}

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
  const std::span<const Eigen::Vector3f> q = internal::RestOf(*job.rest).center_in_joint;
  const std::span<const float> w = internal::RestOf(*job.rest).weights;
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
  const bool reduced = job.rest != nullptr && !internal::RestOf(*job.rest).exact_point_offsets.empty();
  const uint32_t* offsets =
      reduced ? internal::RestOf(*job.rest).exact_point_offsets.data() : set.vertex_offsets.data();
  const uint32_t* list = reduced ? internal::RestOf(*job.rest).exact_points.data() : set.vertices.data();
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
internal::FastRefitArrays SharedArrays(const SphereSet& set, const RefitRestData& rest_data) {
  const RefitRestData::Data& rest = internal::RestOf(rest_data);
  static_assert(sizeof(Mat4f) == 16 * sizeof(float) && sizeof(Eigen::Vector3f) == 3 * sizeof(float) &&
                sizeof(Vec4f) == 4 * sizeof(float));
  internal::FastRefitArrays a;  // (casts, not ->data(): a span of an empty set may hold a null pointer)
  a.joint_count = set.joint_count();
  a.center_in_joint = reinterpret_cast<const float*>(rest.center_in_joint.data());
  a.weights = rest.weights.data();
  a.reach = rest.reach.data();
  a.rest_inverse_rows = rest.rest_inverse_rows.data();
  a.influence_offsets = set.influence_offsets.data();
  a.influence_joints = set.influence_joints.data();
  a.radii_fast = rest.radii_fast.data();
  a.group_offsets = rest.group_offsets.data();
  a.group_radii = rest.group_radii.data();
  a.group_reach = rest.group_reach.data();
  a.group_reach_offsets = rest.group_reach_offsets.data();
  if (!rest.group_blend.empty()) {
    a.group_blend = rest.group_blend.data();
    a.group_deviation = rest.group_deviation.data();
    a.group_blend_sum = rest.group_blend_sum.data();
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
    case SimdLevel::kAvx512:  // one instance alone: the AVX2 copy (the crowd batches)
    case SimdLevel::kAvx2: return internal::avx2::RefitFastRange(a, begin, end);
    case SimdLevel::kSse2: return internal::sse2::RefitFastRange(a, begin, end);
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

uint32_t RefitFastBatch(const SphereSet& set, const RefitRestData& rest, const float* const world[kRefitBatchLanes],
                        float* const out[kRefitBatchLanes], float* soa, SimdLevel level) {
  const FastRefitArrays a = SharedArrays(set, rest);
  switch (level == SimdLevel::kAuto ? RefitSimdInUse() : level) {
#if defined(SKINSPHERES_X86_64)
    case SimdLevel::kAvx512: return avx512::RefitFastBatch(a, set.size(), world, out, soa);
    case SimdLevel::kAvx2: return avx2::RefitFastBatch(a, set.size(), world, out, soa);
    case SimdLevel::kSse2: return sse2::RefitFastBatch(a, set.size(), world, out, soa);
#endif
    default: return portable::RefitFastBatch(a, set.size(), world, out, soa);
  }
}

}  // namespace internal

}  // namespace skinspheres::runtime
