// Per-frame sphere refit (refit_job.h). Exact mode: centre c' = Σ w_j T_j c, radius = max distance
// to the skinned source vertices. Fast mode: Kavan & Žára's bound r' = s_max·radius_fast +
// max_j |T_j c - c'|, its second term capped by Σ_j W_j |T_j c - c'| (derivation in the header).
#include "skinspheres/runtime/refit_job.h"


#include <Eigen/LU>
#include <algorithm>
#include <atomic>
#include <cfloat>
#include <cmath>
#include <limits>
#include <string>
#include <type_traits>

#include <emmintrin.h>

namespace skinspheres::runtime {

// Unaligned double types (math_types.h: no Eigen type of 32 bytes or more is aligned here).
using Mat4d = Eigen::Matrix<double, 4, 4, Eigen::ColMajor | Eigen::DontAlign>;
using Vec4d = Eigen::Matrix<double, 4, 1, Eigen::ColMajor | Eigen::DontAlign>;

const char* ToString(RefitMode mode) {
  switch (mode) {
    case RefitMode::kExact:
      return "exact";
    case RefitMode::kFast:
      return "fast";
  }
  return "unknown";
}

Result<RefitRestData> RefitRestData::Create(const SphereSet& set) {
  if (auto err = set.Validate()) {
    return MakeError(err->code, "RefitRestData: sphere set '" + set.source_file + "': " + err->message);
  }
  RefitRestData d;
  d.sphere_count_ = set.size();
  d.source_vertex_count_ = set.source_vertex_count;
  const size_t joints = set.joint_count();
  std::vector<Mat4d> inverse(joints);
  d.rest_linear_inverse_.resize(joints);
  for (size_t j = 0; j < joints; ++j) {
    const Mat4d g = set.joint_rest_world[j].cast<double>();
    const double det = g.topLeftCorner<3, 3>().determinant();
    const double scale = g.topLeftCorner<3, 3>().cwiseAbs().maxCoeff();
    if (!(std::abs(det) > 1e-12 * scale * scale * scale) || !std::isfinite(det)) {
      return MakeError(ErrorCode::kInvalidData, "RefitRestData: sphere set '" + set.source_file + "': rest transform of joint " +
                                                    std::to_string(j) + " '" + set.joint_names[j] + "' is not invertible");
    }
    Mat4d inv = Mat4d::Identity();
    const Eigen::Matrix3d li = g.topLeftCorner<3, 3>().inverse();
    inv.topLeftCorner<3, 3>() = li;
    inv.topRightCorner<3, 1>() = -li * g.topRightCorner<3, 1>();
    inverse[j] = inv;
    d.rest_linear_inverse_[j] = li.cast<float>();
  }
  d.rest_inverse_rows_.assign(12 * joints, 0.0f);
  for (size_t j = 0; j < joints; ++j) {
    for (int r = 0; r < 3; ++r) {
      for (int c = 0; c < 3; ++c) d.rest_inverse_rows_[12 * j + 4 * r + c] = d.rest_linear_inverse_[j](r, c);
    }
  }
  d.center_in_joint_.resize(set.influence_joints.size());
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
    const Vec4d c(set.centers_rest[s].x(), set.centers_rest[s].y(), set.centers_rest[s].z(), 1.0);
    for (uint32_t k = k0; k < k1; ++k) {
      d.center_in_joint_[k] = (inverse[set.influence_joints[k]] * c).head<3>().cast<float>();
      d.weights_[k] = static_cast<float>(set.influence_weights[k] / wsum);
    }
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
  return d;
}

bool RefitJob::Validate() const {
  if (spheres == nullptr) return false;
  const size_t n = spheres->size();
  if (out.size() < n) return false;
  if (spheres->vertex_offsets.size() != n + 1 || spheres->influence_offsets.size() != n + 1) return false;
  const bool need_joints = mode == RefitMode::kFast || !joint_world.empty();
  if (need_joints) {
    if (rest == nullptr) return false;
    if (rest->sphere_count() != n || rest->joint_count() != spheres->joint_count() ||
        rest->influence_count() != spheres->influence_joints.size() || rest->reach().size() != rest->influence_count() ||
        spheres->influence_weights.size() != spheres->influence_joints.size() ||
        spheres->radii_fast.size() != n) {
      return false;
    }
    if (joint_world.size() < spheres->joint_count()) return false;
  }
  if (mode == RefitMode::kExact) {
    if (spheres->fast_only) return false;  // no vertex lists to bound
    if (positions.size() < spheres->source_vertex_count) return false;
    // The set's vertex indices were checked against source_vertex_count when the rest data was
    // built; without rest data check the CSR end at least (O(1)).
    if (spheres->vertex_offsets[n] > spheres->vertices.size()) return false;
    if (rest != nullptr && rest->source_vertex_count() != spheres->source_vertex_count) return false;
  } else if (mode != RefitMode::kFast) {
    return false;
  }
  return true;
}

namespace {

// 16 ulps of the coordinates: covers float rounding of c', the distances and the caller's skinning.
inline float Margin(const Eigen::Vector3f& c, float r) {
  return 16.0f * FLT_EPSILON * (c.cwiseAbs().maxCoeff() + r);
}

inline Eigen::Vector3f Apply(const Mat4f& g, const Eigen::Vector3f& p) {
  return g.topLeftCorner<3, 3>() * p + g.topRightCorner<3, 1>();
}

// c' = Σ_k w_k G_j(k)(t) · (G_j(k)(rest)^-1 c); also returns k0, k1.
inline Eigen::Vector3f BlendedCentre(const RefitJob& job, size_t s) {
  const auto& set = *job.spheres;
  const auto q = job.rest->center_in_joint();
  const auto w = job.rest->weights();
  Eigen::Vector3f c = Eigen::Vector3f::Zero();
  for (uint32_t k = set.influence_offsets[s]; k < set.influence_offsets[s + 1]; ++k) {
    c += w[k] * Apply(job.joint_world[set.influence_joints[k]], q[k]);
  }
  return c;
}

bool RefitExact(const RefitJob& job, size_t begin, size_t end) {
  const auto& set = *job.spheres;
  const bool joints = !job.joint_world.empty();
  bool ok = true;
  for (size_t s = begin; s < end; ++s) {
    const uint32_t v0 = set.vertex_offsets[s], v1 = set.vertex_offsets[s + 1];
    Eigen::Vector3f c;
    if (joints) {
      c = BlendedCentre(job, s);
    } else if (v0 == v1) {
      c = set.centers_rest[s];
    } else {
      Eigen::Vector3f lo = job.positions[set.vertices[v0]], hi = lo;
      for (uint32_t k = v0 + 1; k < v1; ++k) {
        const Eigen::Vector3f& p = job.positions[set.vertices[k]];
        lo = lo.cwiseMin(p);
        hi = hi.cwiseMax(p);
      }
      c = 0.5f * (lo + hi);
    }
    float d2max = 0.0f;
    bool finite = c.allFinite();
    for (uint32_t k = v0; k < v1; ++k) {
      const float d2 = (job.positions[set.vertices[k]] - c).squaredNorm();
      finite &= d2 <= FLT_MAX;  // false for NaN and Inf (std::max would drop a NaN)
      d2max = std::max(d2max, d2);
    }
    const float r = std::sqrt(d2max);
    const float radius = r + Margin(c, r);
    job.out[s] = Vec4f(c.x(), c.y(), c.z(), radius);
    ok &= finite && std::isfinite(radius);
  }
  return ok;
}

// s_max^2 of joint j: max_i Σ_k |(A_jᵀ A_j)_ik| with A_j = linear(G_j(t)) · R_j, R_j =
// linear(G_j(rest)^-1) given by rows (rest_inverse_rows). Four lanes, in the order in which Eigen
// evaluates the scalar expression (each 3-term sum as a0 + (a1 + a2)), so the same bits:
//   row m of A:  a_m = R_0 G(m,0) + (R_1 G(m,1) + R_2 G(m,2))     (lane k: A(m,k))
//   column k of AᵀA: a_0 A(0,k) + (a_1 A(1,k) + a_2 A(2,k))        (lane i: (AᵀA)(i,k))
//   row sums: |col 0| + (|col 1| + |col 2|), then the largest of lanes 0..2.
inline float JointStretch2(const Mat4f& world, const float* rows) {
  const float* g = world.data();  // column-major: G(m, c) at 4 c + m
  const __m128 r0 = _mm_loadu_ps(rows), r1 = _mm_loadu_ps(rows + 4), r2 = _mm_loadu_ps(rows + 8);
  const auto row_of_a = [&](int m) {
    return _mm_add_ps(_mm_mul_ps(r0, _mm_set1_ps(g[m])),
                      _mm_add_ps(_mm_mul_ps(r1, _mm_set1_ps(g[4 + m])), _mm_mul_ps(r2, _mm_set1_ps(g[8 + m]))));
  };
  const __m128 a0 = row_of_a(0), a1 = row_of_a(1), a2 = row_of_a(2);
  const __m128 sign = _mm_set1_ps(-0.0f);
  const auto abs_column = [&](auto lane) {
    constexpr int k = decltype(lane)::value;
    constexpr int mask = k | (k << 2) | (k << 4) | (k << 6);
    const __m128 col = _mm_add_ps(_mm_mul_ps(a0, _mm_shuffle_ps(a0, a0, mask)),
                                  _mm_add_ps(_mm_mul_ps(a1, _mm_shuffle_ps(a1, a1, mask)),
                                             _mm_mul_ps(a2, _mm_shuffle_ps(a2, a2, mask))));
    return _mm_andnot_ps(sign, col);
  };
  const __m128 sums = _mm_add_ps(abs_column(std::integral_constant<int, 0>()),
                                 _mm_add_ps(abs_column(std::integral_constant<int, 1>()),
                                            abs_column(std::integral_constant<int, 2>())));
  if ((_mm_movemask_ps(_mm_cmpunord_ps(sums, sums)) & 7) != 0) return std::numeric_limits<float>::quiet_NaN();
  alignas(16) float lanes[4];
  _mm_store_ps(lanes, sums);
  return std::max(std::max(lanes[0], lanes[1]), lanes[2]);
}

// G · (q, 1) in four lanes (lane 3 is G's last row, ignored): (g0 qx + (g1 qy + g2 qz)) + g3 per
// lane, the order in which Eigen evaluates Apply() (a 3-term inner product sums as a0 + (a1 + a2)),
// so the bits are Apply()'s; the refit tests compare the two bit for bit.
inline __m128 ApplySse(const Mat4f& g, const Eigen::Vector3f& q) {
  const float* m = g.data();  // column-major: columns at 0, 4, 8, 12
  const __m128 x = _mm_mul_ps(_mm_loadu_ps(m), _mm_set1_ps(q.x()));
  const __m128 y = _mm_mul_ps(_mm_loadu_ps(m + 4), _mm_set1_ps(q.y()));
  const __m128 z = _mm_mul_ps(_mm_loadu_ps(m + 8), _mm_set1_ps(q.z()));
  return _mm_add_ps(_mm_add_ps(x, _mm_add_ps(y, z)), _mm_loadu_ps(m + 12));
}

// |d|^2 of lanes 0..2 as Eigen's squaredNorm of a Vector3f sums them: d0^2 + (d1^2 + d2^2).
inline float SquaredNorm3(__m128 d) {
  const __m128 sq = _mm_mul_ps(d, d);
  const __m128 s12 = _mm_add_ss(_mm_shuffle_ps(sq, sq, 1), _mm_shuffle_ps(sq, sq, 2));
  return _mm_cvtss_f32(_mm_add_ss(sq, s12));
}

// Fast mode, four lanes per transformed point (SSE2, every x86-64): the same operations in the
// same order as the scalar formula in the header, so the same bits on every build. Each joint's
// s_max^2 is computed once per call (on first use, on the stack for up to kJointCache joints).
bool RefitFast(const RefitJob& job, size_t begin, size_t end) {
  const auto& set = *job.spheres;
  const Eigen::Vector3f* q = job.rest->center_in_joint().data();
  const float* w = job.rest->weights().data();
  const float* reach = job.rest->reach().data();
  const float* rinv_rows = job.rest->rest_inverse_rows().data();
  const uint32_t* offsets = set.influence_offsets.data();
  const uint16_t* joints = set.influence_joints.data();
  const float* radii = set.radii_fast.data();
  const Mat4f* world = job.joint_world.data();
  constexpr size_t kJointCache = 256;
  const bool cache = set.joint_count() <= kJointCache;
  float joint_row[kJointCache];  // -1: not computed yet (a stretch is >= 0 or NaN)
  if (cache) std::fill_n(joint_row, set.joint_count(), -1.0f);
  constexpr uint32_t kPointCache = 16;  // T_j c per influence of one sphere, when it has at most this many
  alignas(16) float moved[kPointCache * 4];
  bool ok = true;
  for (size_t s = begin; s < end; ++s) {
    const uint32_t k0 = offsets[s], k1 = offsets[s + 1];
    const bool keep = k1 - k0 <= kPointCache;
    __m128 c = _mm_setzero_ps();
    for (uint32_t k = k0; k < k1; ++k) {
      const __m128 p = ApplySse(world[joints[k]], q[k]);
      if (keep) _mm_store_ps(moved + 4 * (k - k0), p);
      c = _mm_add_ps(c, _mm_mul_ps(_mm_set1_ps(w[k]), p));
    }
    float spread2 = 0.0f;  // max_j |T_j c - c'|^2
    float reached = 0.0f;  // Σ_j W_j |T_j c - c'|
    float s2 = 0.0f;       // s_max^2
    bool finite = true;
    for (uint32_t k = k0; k < k1; ++k) {
      const uint16_t j = joints[k];
      const __m128 p = keep ? _mm_load_ps(moved + 4 * (k - k0)) : ApplySse(world[j], q[k]);
      const float d2 = SquaredNorm3(_mm_sub_ps(p, c));
      float row;
      if (cache) {
        if (joint_row[j] < 0.0f) joint_row[j] = JointStretch2(world[j], rinv_rows + 12 * size_t(j));
        row = joint_row[j];
      } else {
        row = JointStretch2(world[j], rinv_rows + 12 * size_t(j));
      }
      finite &= (d2 <= FLT_MAX) & (row <= FLT_MAX);
      spread2 = std::max(spread2, d2);
      reached += reach[k] * std::sqrt(d2);
      s2 = std::max(s2, row);
    }
    alignas(16) float cc[4];
    _mm_store_ps(cc, c);
    const Eigen::Vector3f centre(cc[0], cc[1], cc[2]);
    const float r = std::sqrt(s2) * radii[s] + std::min(std::sqrt(spread2), reached);
    const float radius = r + Margin(centre, r);
    job.out[s] = Vec4f(cc[0], cc[1], cc[2], radius);
    ok &= finite && centre.allFinite() && std::isfinite(radius);
  }
  return ok;
}

}  // namespace

bool RefitJob::RunRange(size_t begin, size_t end) const {
  if (!Validate() || begin > end || end > spheres->size()) return false;
  return mode == RefitMode::kExact ? RefitExact(*this, begin, end) : RefitFast(*this, begin, end);
}

bool RefitJob::Run() const {
  if (!Validate()) return false;
  return RunRange(0, spheres->size());
}

bool RefitParallel(const RefitJob& job, size_t grain, const ParallelFor& parallel_for) {
  if (!job.Validate()) return false;
  std::atomic<bool> ok{true};
  parallel_for(job.spheres->size(), std::max<size_t>(grain, 1), [&](size_t begin, size_t end) {
    const bool good = job.mode == RefitMode::kExact ? RefitExact(job, begin, end) : RefitFast(job, begin, end);
    if (!good) ok.store(false, std::memory_order_relaxed);
  });
  return ok.load();
}

}  // namespace skinspheres::runtime
