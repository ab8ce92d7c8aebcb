// The crowd's broad phase of 16 instances at once (crowd/crowd_query.h), compiled for AVX-512F
// whatever the build's flags; called only when the CPU has it (the batched refit decides). Every
// test is the oracle's ((dx*dx + dy*dy) + dz*dz) <= (r_i + r_j)^2 with dx = x_j - x_i, and every
// depth (r_i + r_j) - sqrt(d^2), lane by lane (-ffp-contract=off: no fused multiply-add), so the
// sphere pairs are bit for bit those of each instance's own query. Stack: a few hundred bytes.
#include "crowd/crowd_query.h"

#if defined(SKINSPHERES_X86_64)
#include <immintrin.h>

// GCC takes the target from the pragma; clang ignores it and needs the attribute on every function;
// MSVC emits any intrinsic anywhere and needs neither.
#if defined(__clang__)
#pragma clang attribute push(__attribute__((target("avx512f"))), apply_to = function)
#elif defined(__GNUC__)
#pragma GCC push_options
#pragma GCC target("avx512f")
#endif

namespace skinspheres::runtime::internal::avx512 {

uint32_t BatchValuesOk(const float* soa, size_t n, float max_magnitude) {
  const __m512 limit = _mm512_set1_ps(max_magnitude);
  const __m512 zero = _mm512_setzero_ps();
  __mmask16 ok = 0xFFFF;
  for (size_t s = 0; s < n; ++s) {
    const float* p = soa + kBatchSphereFloats * s;
    const __m512 r = _mm512_loadu_ps(p + 48);
    ok &= _mm512_cmp_ps_mask(_mm512_abs_ps(_mm512_loadu_ps(p)), limit, _CMP_LE_OQ) &
          _mm512_cmp_ps_mask(_mm512_abs_ps(_mm512_loadu_ps(p + 16)), limit, _CMP_LE_OQ) &
          _mm512_cmp_ps_mask(_mm512_abs_ps(_mm512_loadu_ps(p + 32)), limit, _CMP_LE_OQ) &
          _mm512_cmp_ps_mask(r, limit, _CMP_LE_OQ) & _mm512_cmp_ps_mask(r, zero, _CMP_GE_OQ);
  }
  return ok;
}

size_t BatchTestPairs(const float* soa, const uint32_t* pairs, size_t begin, size_t end, uint32_t lanes,
                      BatchHits* hits) {
  const __mmask16 active = static_cast<__mmask16>(lanes);
  size_t count = hits->count;
  const size_t capacity = hits->capacity;
  uint32_t row = UINT32_MAX;
  __m512 ax = _mm512_setzero_ps(), ay = ax, az = ax, ar = ax;
  size_t p = begin;
  for (; p < end; ++p) {
    const uint32_t ij = pairs[p];
    const uint32_t i = ij >> 16;
    if (i != row) {
      const float* a = soa + kBatchSphereFloats * i;
      ax = _mm512_loadu_ps(a);
      ay = _mm512_loadu_ps(a + 16);
      az = _mm512_loadu_ps(a + 32);
      ar = _mm512_loadu_ps(a + 48);
      row = i;
    }
    const float* b = soa + kBatchSphereFloats * (ij & 0xFFFFu);
    const __m512 dx = _mm512_sub_ps(_mm512_loadu_ps(b), ax);
    const __m512 dy = _mm512_sub_ps(_mm512_loadu_ps(b + 16), ay);
    const __m512 dz = _mm512_sub_ps(_mm512_loadu_ps(b + 32), az);
    const __m512 d2 = _mm512_add_ps(_mm512_add_ps(_mm512_mul_ps(dx, dx), _mm512_mul_ps(dy, dy)), _mm512_mul_ps(dz, dz));
    const __m512 rs = _mm512_add_ps(ar, _mm512_loadu_ps(b + 48));
    const __mmask16 hit = _mm512_mask_cmp_ps_mask(active, d2, _mm512_mul_ps(rs, rs), _CMP_LE_OQ);
    if (hit == 0) continue;
    if (count == capacity) break;
    hits->pair[count] = ij;
    hits->mask[count] = hit;
    _mm512_storeu_ps(hits->depth + 16 * count, _mm512_sub_ps(rs, _mm512_sqrt_ps(d2)));
    ++count;
  }
  hits->count = count;
  return p;
}

}  // namespace skinspheres::runtime::internal::avx512

#if defined(__clang__)
#pragma clang attribute pop
#elif defined(__GNUC__)
#pragma GCC pop_options
#endif
#endif  // x86
