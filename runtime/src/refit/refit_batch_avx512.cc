// The fast refit of 16 instances of one sphere set at once, one instance per AVX-512 lane
// (refit_internal.h), compiled for AVX-512F whatever the build's flags and used by the crowd calls
// when the CPU has it. Every lane evaluates the same float operations in the same order as the
// one-instance loop (refit_fast.inc), so each instance gets the same bits as when refitted alone;
// the speed comes from the lanes sharing everything but the joint matrices (the same spheres, the
// same influences, so no lane idles and no branch depends on an instance).
//
// Per influence, the 16 instances' matrices G_j(t) are transposed into 16 vectors (element e of
// every instance in one vector), so that a point transform, a joint's stretch or a distance is
// one vector operation for all 16. Joints' stretches are kept in a small direct-mapped table
// (kStretchSlots joints, 64 bytes each: consecutive spheres share their joints), recomputed on a
// miss with the same bits. Stack: 3.6 KB (GCC 12 -O3 -fstack-usage: the table, kPointCache moved
// points, temporaries), for engines whose jobs run on small fibre stacks.
#include "crowd/crowd_query.h"
#include "refit/refit_internal.h"

#if defined(SKINSPHERES_X86_64)
#include <immintrin.h>

#include <cfloat>
#include <cstdint>
#include <limits>

// GCC takes the target from the pragma; clang ignores it and needs the attribute on every function;
// MSVC emits any intrinsic anywhere and needs neither.
#if defined(__clang__)
#pragma clang attribute push(__attribute__((target("avx512f"))), apply_to = function)
#elif defined(__GNUC__)
#pragma GCC push_options
#pragma GCC target("avx512f")
#endif

namespace skinspheres::runtime::internal::avx512 {
namespace {

using V = __m512;

// r[b]: the 16 floats of instance b's matrix. After: r[e] holds element e of every instance.
inline void Transpose16(V r[16]) {
  V t[16];
  for (int i = 0; i < 8; ++i) {
    t[2 * i] = _mm512_unpacklo_ps(r[2 * i], r[2 * i + 1]);
    t[2 * i + 1] = _mm512_unpackhi_ps(r[2 * i], r[2 * i + 1]);
  }
  V s[16];  // s[4i + k], 128-bit lane L: element 4L + k of instances 4i..4i+3
  for (int i = 0; i < 4; ++i) {
    s[4 * i + 0] = _mm512_shuffle_ps(t[4 * i], t[4 * i + 2], _MM_SHUFFLE(1, 0, 1, 0));
    s[4 * i + 1] = _mm512_shuffle_ps(t[4 * i], t[4 * i + 2], _MM_SHUFFLE(3, 2, 3, 2));
    s[4 * i + 2] = _mm512_shuffle_ps(t[4 * i + 1], t[4 * i + 3], _MM_SHUFFLE(1, 0, 1, 0));
    s[4 * i + 3] = _mm512_shuffle_ps(t[4 * i + 1], t[4 * i + 3], _MM_SHUFFLE(3, 2, 3, 2));
  }
  for (int k = 0; k < 4; ++k) {
    const V v0 = _mm512_shuffle_f32x4(s[k], s[4 + k], 0x44), v1 = _mm512_shuffle_f32x4(s[k], s[4 + k], 0xEE);
    const V w0 = _mm512_shuffle_f32x4(s[8 + k], s[12 + k], 0x44), w1 = _mm512_shuffle_f32x4(s[8 + k], s[12 + k], 0xEE);
    r[k] = _mm512_shuffle_f32x4(v0, w0, 0x88);
    r[4 + k] = _mm512_shuffle_f32x4(v0, w0, 0xDD);
    r[8 + k] = _mm512_shuffle_f32x4(v1, w1, 0x88);
    r[12 + k] = _mm512_shuffle_f32x4(v1, w1, 0xDD);
  }
}

// std::max(a, b) and std::min(a, b) lane by lane, NaN included: (a < b) ? b : a and (b < a) ? b : a.
// _mm512_max_ps(x, y) is (x > y) ? x : y, so std::max(a, b) is _mm512_max_ps(b, a); likewise min.
inline V StdMax(V a, V b) { return _mm512_max_ps(b, a); }
inline V StdMin(V a, V b) { return _mm512_min_ps(b, a); }

// s_max^2 of one joint for every lane, as JointStretch2 in refit_fast.inc: g[4c + m] = G(m, c),
// rows: R = linear(G(rest)^-1) by rows (R(r, c) at 4r + c).
//   A(m, k) = R(0,k) G(m,0) + (R(1,k) G(m,1) + R(2,k) G(m,2))
//   M(i, k) = A(0,i) A(0,k) + (A(1,i) A(1,k) + A(2,i) A(2,k))
//   sum_i = |M(i,0)| + (|M(i,1)| + |M(i,2)|), then max(max(sum_0, sum_1), sum_2); NaN if a sum is.
inline V JointStretch2(const V g[16], const float* rows) {
  V a[3][3];
  for (int m = 0; m < 3; ++m) {
    for (int k = 0; k < 3; ++k) {
      a[m][k] = _mm512_add_ps(_mm512_mul_ps(_mm512_set1_ps(rows[k]), g[m]),
                              _mm512_add_ps(_mm512_mul_ps(_mm512_set1_ps(rows[4 + k]), g[4 + m]),
                                            _mm512_mul_ps(_mm512_set1_ps(rows[8 + k]), g[8 + m])));
    }
  }
  const auto product = [&](int i, int k) {  // (AᵀA)(i, k), summed in the order of the column form
    return _mm512_add_ps(_mm512_mul_ps(a[0][i], a[0][k]),
                         _mm512_add_ps(_mm512_mul_ps(a[1][i], a[1][k]), _mm512_mul_ps(a[2][i], a[2][k])));
  };
  V sums[3];
  for (int i = 0; i < 3; ++i) {
    sums[i] = _mm512_add_ps(_mm512_abs_ps(product(i, 0)),
                            _mm512_add_ps(_mm512_abs_ps(product(i, 1)), _mm512_abs_ps(product(i, 2))));
  }
  const __mmask16 nan = _mm512_cmp_ps_mask(sums[0], sums[0], _CMP_UNORD_Q) |
                        _mm512_cmp_ps_mask(sums[1], sums[1], _CMP_UNORD_Q) |
                        _mm512_cmp_ps_mask(sums[2], sums[2], _CMP_UNORD_Q);
  const V largest = StdMax(StdMax(sums[0], sums[1]), sums[2]);
  return _mm512_mask_mov_ps(largest, nan, _mm512_set1_ps(std::numeric_limits<float>::quiet_NaN()));
}

// The moved point G · (q, 1) of every lane, each coordinate (g0 q0 + (g1 q1 + g2 q2)) + g3 as ApplySse.
struct Point {
  V x, y, z;
};
inline Point Apply(const V g[16], const float* q) {
  const V q0 = _mm512_set1_ps(q[0]), q1 = _mm512_set1_ps(q[1]), q2 = _mm512_set1_ps(q[2]);
  const auto row = [&](int m) {
    return _mm512_add_ps(
        _mm512_add_ps(_mm512_mul_ps(g[m], q0), _mm512_add_ps(_mm512_mul_ps(g[4 + m], q1), _mm512_mul_ps(g[8 + m], q2))),
        g[12 + m]);
  };
  return {row(0), row(1), row(2)};
}

// 64-bit halves of a and b interleaved (the float pairs (x, y) and (z, r) into (x, y, z, r)).
inline V UnpackLo64(V a, V b) { return _mm512_castpd_ps(_mm512_unpacklo_pd(_mm512_castps_pd(a), _mm512_castps_pd(b))); }
inline V UnpackHi64(V a, V b) { return _mm512_castpd_ps(_mm512_unpackhi_pd(_mm512_castps_pd(a), _mm512_castps_pd(b))); }

}  // namespace

uint32_t RefitFastBatch16(const FastRefitArrays& a, size_t sphere_count, const float* const world[kRefitBatchLanes],
                          float* const out[kRefitBatchLanes], float* soa) {
  NoteRefitSimdRun(RefitSimd::kAvx512);
  constexpr size_t kStretchSlots = 16;  // joint j in slot j % kStretchSlots
  alignas(64) float stretch[kStretchSlots][kRefitBatchLanes];
  uint32_t slot_joint[kStretchSlots];
  for (uint32_t& j : slot_joint) j = UINT32_MAX;
  // The 16 matrices of joint j, transposed; its stretch into its slot unless there already.
  const auto joint = [&](uint32_t j, V g[16]) {
    for (size_t b = 0; b < kRefitBatchLanes; ++b) g[b] = _mm512_loadu_ps(world[b] + 16 * size_t{j});
    Transpose16(g);
    const size_t slot = j % kStretchSlots;
    if (slot_joint[slot] != j) {
      _mm512_store_ps(stretch[slot], JointStretch2(g, a.rest_inverse_rows + 12 * size_t{j}));
      slot_joint[slot] = j;
    }
  };
  // Moved points kept for spheres of up to this many influences (recomputed, same bits, past it).
  constexpr uint32_t kPointCache = 8;
  Point moved[kPointCache];
  const V flt_max = _mm512_set1_ps(FLT_MAX);
  const V zero = _mm512_setzero_ps();
  __mmask16 ok = 0xFFFF;
  for (size_t s = 0; s < sphere_count; ++s) {
    const uint32_t k0 = a.influence_offsets[s], k1 = a.influence_offsets[s + 1];
    const bool keep = k1 - k0 <= kPointCache;
    V cx = zero, cy = zero, cz = zero;
    V g[16];
    for (uint32_t k = k0; k < k1; ++k) {
      joint(a.influence_joints[k], g);
      const Point p = Apply(g, a.center_in_joint + 3 * size_t{k});
      if (keep) moved[k - k0] = p;
      const V w = _mm512_set1_ps(a.weights[k]);
      cx = _mm512_add_ps(cx, _mm512_mul_ps(w, p.x));
      cy = _mm512_add_ps(cy, _mm512_mul_ps(w, p.y));
      cz = _mm512_add_ps(cz, _mm512_mul_ps(w, p.z));
    }
    V spread2 = zero, reached = zero, s2 = zero;
    __mmask16 finite = 0xFFFF;
    for (uint32_t k = k0; k < k1; ++k) {
      const uint32_t j = a.influence_joints[k];
      Point p;
      if (keep && slot_joint[j % kStretchSlots] == j) {
        p = moved[k - k0];
      } else {  // a point not kept, or a stretch evicted by a later influence of this sphere
        joint(j, g);
        p = keep ? moved[k - k0] : Apply(g, a.center_in_joint + 3 * size_t{k});
      }
      const V dx = _mm512_sub_ps(p.x, cx), dy = _mm512_sub_ps(p.y, cy), dz = _mm512_sub_ps(p.z, cz);
      const V d2 = _mm512_add_ps(_mm512_mul_ps(dx, dx), _mm512_add_ps(_mm512_mul_ps(dy, dy), _mm512_mul_ps(dz, dz)));
      const V row = _mm512_load_ps(stretch[j % kStretchSlots]);
      finite &= _mm512_cmp_ps_mask(d2, flt_max, _CMP_LE_OQ) & _mm512_cmp_ps_mask(row, flt_max, _CMP_LE_OQ);
      spread2 = StdMax(spread2, d2);
      reached = _mm512_add_ps(reached, _mm512_mul_ps(_mm512_set1_ps(a.reach[k]), _mm512_sqrt_ps(d2)));
      s2 = StdMax(s2, row);
    }
    const V r = _mm512_add_ps(_mm512_mul_ps(_mm512_sqrt_ps(s2), _mm512_set1_ps(a.radii_fast[s])),
                              StdMin(_mm512_sqrt_ps(spread2), reached));
    // FastMargin: 16 FLT_EPSILON (max(|x|, max(|y|, |z|)) + r).
    const V largest = StdMax(_mm512_abs_ps(cx), StdMax(_mm512_abs_ps(cy), _mm512_abs_ps(cz)));
    const V radius = _mm512_add_ps(r, _mm512_mul_ps(_mm512_set1_ps(16.0f * FLT_EPSILON), _mm512_add_ps(largest, r)));
    // A NaN stretch fails `finite`; a NaN or infinite centre or radius fails here (x - x != 0).
    ok &= finite & _mm512_cmp_ps_mask(_mm512_sub_ps(cx, cx), zero, _CMP_EQ_OQ) &
          _mm512_cmp_ps_mask(_mm512_sub_ps(cy, cy), zero, _CMP_EQ_OQ) &
          _mm512_cmp_ps_mask(_mm512_sub_ps(cz, cz), zero, _CMP_EQ_OQ) &
          _mm512_cmp_ps_mask(_mm512_sub_ps(radius, radius), zero, _CMP_EQ_OQ);
    if (soa != nullptr) {  // the same values, lanes side by side, for the crowd's batched query
      float* q = soa + kBatchSphereFloats * s;
      _mm512_storeu_ps(q, cx);
      _mm512_storeu_ps(q + 16, cy);
      _mm512_storeu_ps(q + 32, cz);
      _mm512_storeu_ps(q + 48, radius);
    }
    // (x, y, z, radius) of the 16 lanes as 16 float4: v[k], 128-bit lane L is instance 4L + k.
    const V xy_lo = _mm512_unpacklo_ps(cx, cy), xy_hi = _mm512_unpackhi_ps(cx, cy);
    const V zr_lo = _mm512_unpacklo_ps(cz, radius), zr_hi = _mm512_unpackhi_ps(cz, radius);
    const V v[4] = {UnpackLo64(xy_lo, zr_lo), UnpackHi64(xy_lo, zr_lo), UnpackLo64(xy_hi, zr_hi),
                    UnpackHi64(xy_hi, zr_hi)};
    for (int k = 0; k < 4; ++k) {
      _mm_storeu_ps(out[k] + 4 * s, _mm512_castps512_ps128(v[k]));
      _mm_storeu_ps(out[4 + k] + 4 * s, _mm512_extractf32x4_ps(v[k], 1));
      _mm_storeu_ps(out[8 + k] + 4 * s, _mm512_extractf32x4_ps(v[k], 2));
      _mm_storeu_ps(out[12 + k] + 4 * s, _mm512_extractf32x4_ps(v[k], 3));
    }
  }
  return ok;
}

}  // namespace skinspheres::runtime::internal::avx512

#if defined(__clang__)
#pragma clang attribute pop
#elif defined(__GNUC__)
#pragma GCC pop_options
#endif
#endif  // x86
