// Broad-phase kernels, SSE2 level (the x86-64 baseline): 4 lanes. See broad_phase/kernels.h.
#include "broad_phase/kernels.h"

#if defined(SKINSPHERES_X86_64)
#include <emmintrin.h>

namespace skinspheres::runtime::kernels {
namespace sse2 {
namespace F = simd::sse;
namespace {

struct Simd {
  using V = __m128;
  static constexpr unsigned kWidth = 4;
  static V Set1(float v) { return _mm_set1_ps(v); }
  static V Load(const float* p) { return _mm_loadu_ps(p); }
  static void Store(float* p, V v) { _mm_storeu_ps(p, v); }
  static V Add(V a, V b) { return _mm_add_ps(a, b); }
  static V Sub(V a, V b) { return _mm_sub_ps(a, b); }
  static V Mul(V a, V b) { return _mm_mul_ps(a, b); }
  static V Max(V a, V b) { return _mm_max_ps(a, b); }
  static V Sqrt(V a) { return _mm_sqrt_ps(a); }
  static unsigned Le(V a, V b) { return static_cast<unsigned>(_mm_movemask_ps(_mm_cmple_ps(a, b))); }
  // Spheres index[0..4) (4 floats each) transposed into x, y, z, w.
  static void LoadSpheres(const float* base, const uint32_t* index, V& x, V& y, V& z, V& w) {
    __m128 a0 = _mm_loadu_ps(base + 4 * size_t{index[0]});
    __m128 a1 = _mm_loadu_ps(base + 4 * size_t{index[1]});
    __m128 a2 = _mm_loadu_ps(base + 4 * size_t{index[2]});
    __m128 a3 = _mm_loadu_ps(base + 4 * size_t{index[3]});
    _MM_TRANSPOSE4_PS(a0, a1, a2, a3);
    x = a0;
    y = a1;
    z = a2;
    w = a3;
  }
};

}  // namespace

#include "broad_phase/kernels.inc"

}  // namespace sse2

const Kernels& Sse2Kernels() { return sse2::KernelTable(); }

}  // namespace skinspheres::runtime::kernels
#endif  // SKINSPHERES_X86_64
