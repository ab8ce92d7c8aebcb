// Private: four floats in one value, with an SSE body (x86-64) and a portable body (plain C++ over
// an array, every platform; on x86-64 too, so the host's tests run the code aarch64 runs) side by
// side. Each operation gives the same bits in both bodies, lane by lane: IEEE add, sub, mul and
// sqrt are exactly rounded, nothing is fused (the runtime is compiled without contraction), and
// Min and Max keep SSE's rule (the second operand when the comparison is false, NaN included).
//
// A kernel body (refit/refit_fast.inc, broad_phase/kernels.inc) is written once against the names
// below and included once per body: `namespace F = simd::sse` or `namespace F = simd::portable`
// before it. Code that does not pin a body uses simd::native: SSE on x86-64, portable elsewhere.
//
// Only <cstdint>, <cstring>, <cmath> and the SSE intrinsics are included: no inline function of a
// shared header may be compiled with a wider instruction set (a kernel file compiled for AVX2 that
// includes this one gets its own copies, in its own anonymous namespace).
#pragma once

#include <cmath>
#include <cstdint>
#include <cstring>

#include "skinspheres/skinning/platform.h"

#if defined(SKINSPHERES_X86_64)
#include <emmintrin.h>
#endif

namespace skinspheres::runtime::simd {

namespace portable {

struct Float4 {
  float v[4];
};
// Lane masks: all bits set (true) or clear per lane.
struct Mask4 {
  uint32_t m[4];
};

namespace {

inline Float4 Load4(const float* p) { return {{p[0], p[1], p[2], p[3]}}; }
// x, y, z from p (3 floats, nothing read past them), lane 3 zero.
inline Float4 Load3(const float* p) { return {{p[0], p[1], p[2], 0.0f}}; }
inline void Store4(float* p, Float4 a) {
  for (int k = 0; k < 4; ++k) p[k] = a.v[k];
}
inline Float4 Set1(float x) { return {{x, x, x, x}}; }
inline Float4 Zero() { return Set1(0.0f); }
inline Float4 Add(Float4 a, Float4 b) { return {{a.v[0] + b.v[0], a.v[1] + b.v[1], a.v[2] + b.v[2], a.v[3] + b.v[3]}}; }
inline Float4 Sub(Float4 a, Float4 b) { return {{a.v[0] - b.v[0], a.v[1] - b.v[1], a.v[2] - b.v[2], a.v[3] - b.v[3]}}; }
inline Float4 Mul(Float4 a, Float4 b) { return {{a.v[0] * b.v[0], a.v[1] * b.v[1], a.v[2] * b.v[2], a.v[3] * b.v[3]}}; }
inline Float4 Sqrt(Float4 a) { return {{std::sqrt(a.v[0]), std::sqrt(a.v[1]), std::sqrt(a.v[2]), std::sqrt(a.v[3])}}; }
inline Float4 Min(Float4 a, Float4 b) {  // SSE's minps: a < b ? a : b
  Float4 r;
  for (int k = 0; k < 4; ++k) r.v[k] = a.v[k] < b.v[k] ? a.v[k] : b.v[k];
  return r;
}
inline Float4 Max(Float4 a, Float4 b) {  // SSE's maxps: a > b ? a : b
  Float4 r;
  for (int k = 0; k < 4; ++k) r.v[k] = a.v[k] > b.v[k] ? a.v[k] : b.v[k];
  return r;
}
inline Float4 Abs(Float4 a) {  // clears the sign bit, NaN kept
  Float4 r;
  for (int k = 0; k < 4; ++k) {
    uint32_t u;
    std::memcpy(&u, &a.v[k], 4);
    u &= 0x7fffffffu;
    std::memcpy(&r.v[k], &u, 4);
  }
  return r;
}
// Lane k of a in every lane.
template <int k>
inline Float4 Splat(Float4 a) {
  return Set1(a.v[k]);
}
template <int k>
inline float Lane(Float4 a) {
  return a.v[k];
}

inline Mask4 MaskOf(bool b0, bool b1, bool b2, bool b3) {
  return {{b0 ? ~0u : 0u, b1 ? ~0u : 0u, b2 ? ~0u : 0u, b3 ? ~0u : 0u}};
}
inline Mask4 LessEqual(Float4 a, Float4 b) {
  return MaskOf(a.v[0] <= b.v[0], a.v[1] <= b.v[1], a.v[2] <= b.v[2], a.v[3] <= b.v[3]);
}
inline Mask4 Less(Float4 a, Float4 b) {
  return MaskOf(a.v[0] < b.v[0], a.v[1] < b.v[1], a.v[2] < b.v[2], a.v[3] < b.v[3]);
}
inline Mask4 Greater(Float4 a, Float4 b) {
  return MaskOf(a.v[0] > b.v[0], a.v[1] > b.v[1], a.v[2] > b.v[2], a.v[3] > b.v[3]);
}
// a != b, true for NaN (SSE's cmpneq).
inline Mask4 NotEqual(Float4 a, Float4 b) {
  return MaskOf(!(a.v[0] == b.v[0]), !(a.v[1] == b.v[1]), !(a.v[2] == b.v[2]), !(a.v[3] == b.v[3]));
}
// Either lane is NaN.
inline Mask4 Unordered(Float4 a, Float4 b) {
  return MaskOf(a.v[0] != a.v[0] || b.v[0] != b.v[0], a.v[1] != a.v[1] || b.v[1] != b.v[1],
                a.v[2] != a.v[2] || b.v[2] != b.v[2], a.v[3] != a.v[3] || b.v[3] != b.v[3]);
}
inline Mask4 NoLanes() { return MaskOf(false, false, false, false); }
inline Mask4 Or(Mask4 a, Mask4 b) { return {{a.m[0] | b.m[0], a.m[1] | b.m[1], a.m[2] | b.m[2], a.m[3] | b.m[3]}}; }
// Bit k set when lane k is true (SSE's movemask).
inline unsigned Bits(Mask4 a) {
  return (a.m[0] >> 31) | ((a.m[1] >> 31) << 1) | ((a.m[2] >> 31) << 2) | ((a.m[3] >> 31) << 3);
}

}  // namespace
}  // namespace portable

#if defined(SKINSPHERES_X86_64)
namespace sse {

struct Float4 {
  __m128 v;
};
struct Mask4 {
  __m128 m;
};

namespace {

inline Float4 Load4(const float* p) { return {_mm_loadu_ps(p)}; }
inline Float4 Load3(const float* p) {
  // _mm_loadl_epi64 reads x, y through an unaligned, may-alias type; z alone.
  const __m128 xy = _mm_castsi128_ps(_mm_loadl_epi64(reinterpret_cast<const __m128i*>(p)));
  return {_mm_movelh_ps(xy, _mm_load_ss(p + 2))};
}
inline void Store4(float* p, Float4 a) { _mm_storeu_ps(p, a.v); }
inline Float4 Set1(float x) { return {_mm_set1_ps(x)}; }
inline Float4 Zero() { return {_mm_setzero_ps()}; }
inline Float4 Add(Float4 a, Float4 b) { return {_mm_add_ps(a.v, b.v)}; }
inline Float4 Sub(Float4 a, Float4 b) { return {_mm_sub_ps(a.v, b.v)}; }
inline Float4 Mul(Float4 a, Float4 b) { return {_mm_mul_ps(a.v, b.v)}; }
inline Float4 Sqrt(Float4 a) { return {_mm_sqrt_ps(a.v)}; }
inline Float4 Min(Float4 a, Float4 b) { return {_mm_min_ps(a.v, b.v)}; }
inline Float4 Max(Float4 a, Float4 b) { return {_mm_max_ps(a.v, b.v)}; }
inline Float4 Abs(Float4 a) { return {_mm_andnot_ps(_mm_set1_ps(-0.0f), a.v)}; }
template <int k>
inline Float4 Splat(Float4 a) {
  return {_mm_shuffle_ps(a.v, a.v, k | (k << 2) | (k << 4) | (k << 6))};
}
template <int k>
inline float Lane(Float4 a) {
  if constexpr (k == 0) {
    return _mm_cvtss_f32(a.v);
  } else {
    return _mm_cvtss_f32(_mm_shuffle_ps(a.v, a.v, k));
  }
}

inline Mask4 LessEqual(Float4 a, Float4 b) { return {_mm_cmple_ps(a.v, b.v)}; }
inline Mask4 Less(Float4 a, Float4 b) { return {_mm_cmplt_ps(a.v, b.v)}; }
inline Mask4 Greater(Float4 a, Float4 b) { return {_mm_cmpgt_ps(a.v, b.v)}; }
inline Mask4 NotEqual(Float4 a, Float4 b) { return {_mm_cmpneq_ps(a.v, b.v)}; }
inline Mask4 Unordered(Float4 a, Float4 b) { return {_mm_cmpunord_ps(a.v, b.v)}; }
inline Mask4 NoLanes() { return {_mm_setzero_ps()}; }
inline Mask4 Or(Mask4 a, Mask4 b) { return {_mm_or_ps(a.m, b.m)}; }
inline unsigned Bits(Mask4 a) { return static_cast<unsigned>(_mm_movemask_ps(a.m)); }

}  // namespace
}  // namespace sse
namespace native = sse;
#else
namespace native = portable;
#endif

}  // namespace skinspheres::runtime::simd
