// Self-collision broad phase, sort and sweep (broad_phase.h has the contract).
//
// Per frame, for n spheres:
//   1. keys: interval start on the sweep axis, s = c_axis - r - pad, gathered in the previous
//      frame's order (and every value checked: finite centre, finite radius >= 0);
//   2. sort: insertion sort on that order (near-linear under coherent motion) with a move budget,
//      falling back to std::sort when the order is new or too scrambled;
//   3. gather: x, y, z, r, start, end into structure-of-arrays in sweep order;
//   4. sweep: sphere a against b = a+1, a+2, ... while start_b <= end_a, W candidates per SIMD
//      step (SSE2: 4, AVX2: 8); each sphere hit is checked against the PairFilter bit row of a
//      (the exclusion is applied inside the query) and emitted with its depth;
//   5. contacts sorted by (i, j).
// pad = (|c_axis| + r) * 2^-18 (+ a denormal floor) makes the interval test strictly more generous
// than the float sphere test: |c_a - c_b| <= (r_a + r_b)(1 + ~4u) when the sphere test passes,
// and the interval test itself rounds by ~2u(|c| + r) on each side, u = 2^-24.
#include <algorithm>
#include <cmath>

#include <emmintrin.h>
#if SKINSPHERES_AVX2
#include <immintrin.h>
#endif

#include "broad_phase_internal.h"
#include "skinspheres/runtime/broad_phase.h"

namespace skinspheres::runtime {
namespace {

#if SKINSPHERES_AVX2
struct Simd {
  using V = __m256;
  static constexpr int kWidth = 8;
  static constexpr int kAll = 0xFF;
  static V Set1(float v) { return _mm256_set1_ps(v); }
  static V Load(const float* p) { return _mm256_loadu_ps(p); }
  static V Add(V a, V b) { return _mm256_add_ps(a, b); }
  static V Sub(V a, V b) { return _mm256_sub_ps(a, b); }
  static V Mul(V a, V b) { return _mm256_mul_ps(a, b); }
  static V And(V a, V b) { return _mm256_and_ps(a, b); }
  static V Le(V a, V b) { return _mm256_cmp_ps(a, b, _CMP_LE_OQ); }
  static int Mask(V a) { return _mm256_movemask_ps(a); }
};
#else
struct Simd {
  using V = __m128;
  static constexpr int kWidth = 4;
  static constexpr int kAll = 0xF;
  static V Set1(float v) { return _mm_set1_ps(v); }
  static V Load(const float* p) { return _mm_loadu_ps(p); }
  static V Add(V a, V b) { return _mm_add_ps(a, b); }
  static V Sub(V a, V b) { return _mm_sub_ps(a, b); }
  static V Mul(V a, V b) { return _mm_mul_ps(a, b); }
  static V And(V a, V b) { return _mm_and_ps(a, b); }
  static V Le(V a, V b) { return _mm_cmple_ps(a, b); }
  static int Mask(V a) { return _mm_movemask_ps(a); }
};
#endif
static_assert(Simd::kWidth <= 8, "BroadPhaseContext::kPad must cover one SIMD read past the end");

constexpr float kPadRelative = 1.0f / 262144.0f;  // 2^-18
constexpr float kPadAbsolute = 1e-30f;

inline float IntervalPad(float c, float r) { return (std::fabs(c) + r) * kPadRelative + kPadAbsolute; }

// Variance of the centres along each axis (double sums: only used to pick an axis).
Eigen::Vector3d CenterVariance(std::span<const Vec4f> spheres) {
  Eigen::Vector3d sum = Eigen::Vector3d::Zero(), sum2 = Eigen::Vector3d::Zero();
  for (const Vec4f& s : spheres) {
    const Eigen::Vector3d c = s.head<3>().cast<double>();
    sum += c;
    sum2 += c.cwiseProduct(c);
  }
  const double n = std::max<double>(1.0, static_cast<double>(spheres.size()));
  const Eigen::Vector3d mean = sum / n;
  return sum2 / n - mean.cwiseProduct(mean);
}

}  // namespace

void BroadPhaseContext::Resize(size_t max_spheres) {
  max_spheres_ = max_spheres;
  order_.assign(max_spheres, SortItem{0.0f, 0});
  const size_t padded = max_spheres + kPad;
  x_.assign(padded, 0.0f);
  y_.assign(padded, 0.0f);
  z_.assign(padded, 0.0f);
  r_.assign(padded, 0.0f);
  start_.assign(padded, INFINITY);
  end_.assign(padded, -INFINITY);
  sphere_.assign(padded, 0);
  Invalidate();
  axis_ = -1;
  last_candidates_ = 0;
  last_full_sort_ = false;
}

bool SelfCollisionJob::Validate() const {
  if (filter == nullptr || context == nullptr || out == nullptr) return false;
  if (spheres.size() != filter->size()) return false;
  if (spheres.size() > context->max_spheres()) return false;
  if (spheres.data() == nullptr && !spheres.empty()) return false;
  return true;
}

bool SelfCollisionJob::Run() const {
  if (out != nullptr) out->clear();
  if (!Validate()) return false;
  BroadPhaseContext& ctx = *context;
  const size_t n = spheres.size();
  ctx.last_candidates_ = 0;
  ctx.last_full_sort_ = false;

  // Axis: chosen when the order is new, re-chosen every kAxisRefreshFrames with hysteresis.
  bool coherent = ctx.previous_count_ == n && ctx.previous_filter_ == filter && ctx.axis_ >= 0;
  if (!coherent || ctx.frame_ >= BroadPhaseContext::kAxisRefreshFrames) {
    const Eigen::Vector3d variance = CenterVariance(spheres);
    int best = 0;
    variance.maxCoeff(&best);
    if (!coherent || variance[best] > 1.25 * variance[ctx.axis_]) {
      if (coherent && best != ctx.axis_) coherent = false;
      ctx.axis_ = best;
    }
    ctx.frame_ = 0;
  }
  ++ctx.frame_;
  const int axis = ctx.axis_;
  BroadPhaseContext::SortItem* order = ctx.order_.data();
  if (!coherent) {
    for (size_t k = 0; k < n; ++k) order[k].sphere = static_cast<uint32_t>(k);
  }
  // The order stays a permutation whatever happens below; it is only trusted again once a frame
  // completes.
  ctx.previous_count_ = 0;

  // 1. Keys in the previous order, with the value check.
  // v - v is 0 for finite values and NaN otherwise (cmpneq is true for NaN); w must be >= 0.
  // |v| > kMaxMagnitude is refused too (as by SphereValuesOk), so no interval end overflows.
  const __m128 zero = _mm_setzero_ps();
  const __m128 abs_mask = _mm_castsi128_ps(_mm_set1_epi32(0x7fffffff));
  const __m128 limit = _mm_set1_ps(internal::kMaxMagnitude);
  __m128 not_finite = zero, negative = zero;
  for (size_t k = 0; k < n; ++k) {
    const Vec4f& s = spheres[order[k].sphere];
    const __m128 v = _mm_loadu_ps(s.data());
    not_finite = _mm_or_ps(not_finite, _mm_cmpneq_ps(_mm_sub_ps(v, v), zero));
    not_finite = _mm_or_ps(not_finite, _mm_cmpgt_ps(_mm_and_ps(v, abs_mask), limit));
    negative = _mm_or_ps(negative, _mm_cmplt_ps(v, zero));
    const float c = s[axis];
    order[k].key = c - s.w() - IntervalPad(c, s.w());
  }
  if (_mm_movemask_ps(not_finite) != 0 || (_mm_movemask_ps(negative) & 8) != 0) return false;

  // 2. Sort by interval start.
  const auto by_key = [](const BroadPhaseContext::SortItem& a, const BroadPhaseContext::SortItem& b) {
    return a.key < b.key;
  };
  bool full_sort = !coherent;
  if (coherent) {
    size_t moves = 0;
    const size_t budget = 4 * n + 64;
    for (size_t k = 1; k < n && moves <= budget; ++k) {
      const BroadPhaseContext::SortItem item = order[k];
      if (!(item.key < order[k - 1].key)) continue;
      size_t m = k;
      do {
        order[m] = order[m - 1];
        --m;
        ++moves;
      } while (m > 0 && item.key < order[m - 1].key);
      order[m] = item;
    }
    full_sort = moves > budget;
  }
  if (full_sort) std::sort(order, order + n, by_key);
  ctx.last_full_sort_ = full_sort;

  // 3. Gather in sweep order.
  float* x = ctx.x_.data();
  float* y = ctx.y_.data();
  float* z = ctx.z_.data();
  float* r = ctx.r_.data();
  float* start = ctx.start_.data();
  float* end = ctx.end_.data();
  uint32_t* sphere = ctx.sphere_.data();
  for (size_t k = 0; k < n; ++k) {
    const uint32_t s_index = order[k].sphere;
    const Vec4f& s = spheres[s_index];
    x[k] = s.x();
    y[k] = s.y();
    z[k] = s.z();
    r[k] = s.w();
    const float c = s[axis];
    start[k] = order[k].key;
    end[k] = c + s.w() + IntervalPad(c, s.w());
    sphere[k] = s_index;
  }
  for (size_t k = n; k < n + BroadPhaseContext::kPad; ++k) {
    x[k] = y[k] = z[k] = r[k] = 0.0f;
    start[k] = INFINITY;
    sphere[k] = 0;
  }

  // 4. Sweep.
  const uint64_t* bits = filter->bits();
  const size_t words_per_row = filter->words_per_row();
  size_t candidates = 0;
  for (size_t a = 0; a < n; ++a) {
    const Simd::V ax = Simd::Set1(x[a]);
    const Simd::V ay = Simd::Set1(y[a]);
    const Simd::V az = Simd::Set1(z[a]);
    const Simd::V ar = Simd::Set1(r[a]);
    const Simd::V aend = Simd::Set1(end[a]);
    const uint32_t sa = sphere[a];
    const uint64_t* row = bits + static_cast<size_t>(sa) * words_per_row;
    size_t b = a + 1;
    for (;; b += Simd::kWidth) {
      const Simd::V in_range = Simd::Le(Simd::Load(start + b), aend);
      const int range_mask = Simd::Mask(in_range);  // a prefix of the lanes: starts are sorted
      if (range_mask == 0) break;
      const Simd::V dx = Simd::Sub(Simd::Load(x + b), ax);
      const Simd::V dy = Simd::Sub(Simd::Load(y + b), ay);
      const Simd::V dz = Simd::Sub(Simd::Load(z + b), az);
      const Simd::V d2 = Simd::Add(Simd::Add(Simd::Mul(dx, dx), Simd::Mul(dy, dy)), Simd::Mul(dz, dz));
      const Simd::V rs = Simd::Add(Simd::Load(r + b), ar);
      unsigned hit = static_cast<unsigned>(Simd::Mask(Simd::And(Simd::Le(d2, Simd::Mul(rs, rs)), in_range)));
      if (hit != 0) {
        // Most hits of a fitted set are excluded neighbours: read the W exclusion bits without
        // branching, then emit only what is left (padding lanes read sphere 0, masked by hit).
        unsigned excluded = 0;
        for (int lane = 0; lane < Simd::kWidth; ++lane) {
          const uint32_t sb = sphere[b + static_cast<size_t>(lane)];
          excluded |= static_cast<unsigned>((row[sb >> 6] >> (sb & 63u)) & 1u) << lane;
        }
        hit &= ~excluded;
        while (hit != 0) {
          const uint32_t sb = sphere[b + static_cast<size_t>(__builtin_ctz(hit))];
          hit &= hit - 1;
          const uint32_t i = std::min(sa, sb);
          const uint32_t j = std::max(sa, sb);
          out->push_back(Contact{i, j, internal::PenetrationDepth(spheres[i], spheres[j]), filter->part(i),
                                 filter->part(j)});
        }
      }
      if (range_mask != Simd::kAll) {
        b += static_cast<size_t>(__builtin_ctz(~static_cast<unsigned>(range_mask)));
        break;
      }
    }
    candidates += b - a - 1;
  }
  ctx.last_candidates_ = candidates;

  // 5. Deterministic output order.
  std::sort(out->begin(), out->end(), [](const Contact& p, const Contact& q) {
    return p.i != q.i ? p.i < q.i : p.j < q.j;
  });
  ctx.previous_count_ = n;
  ctx.previous_filter_ = filter;
  return true;
}

}  // namespace skinspheres::runtime
