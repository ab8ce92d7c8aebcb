// Broad-phase kernels, AVX-512 level: 16 lanes, compiled for AVX-512F whatever the build's flags
// and picked at run time when the CPU has it. See broad_phase/kernels.h.
#include "broad_phase/kernels.h"

#if defined(SKINSPHERES_X86_64)
#include <immintrin.h>

#include "simd/target_begin_avx512.inc"

namespace skinspheres::runtime::kernels {
namespace avx512 {
namespace F = simd::sse;
namespace {

struct Simd {
  using V = __m512;
  static constexpr unsigned kWidth = 16;
  static V Set1(float v) { return _mm512_set1_ps(v); }
  static V Load(const float* p) { return _mm512_loadu_ps(p); }
  static void Store(float* p, V v) { _mm512_storeu_ps(p, v); }
  static V Add(V a, V b) { return _mm512_add_ps(a, b); }
  static V Sub(V a, V b) { return _mm512_sub_ps(a, b); }
  static V Mul(V a, V b) { return _mm512_mul_ps(a, b); }
  static V Max(V a, V b) { return _mm512_max_ps(a, b); }
  static V Sqrt(V a) { return _mm512_sqrt_ps(a); }
  static unsigned Le(V a, V b) { return static_cast<unsigned>(_mm512_cmp_ps_mask(a, b, _CMP_LE_OQ)); }
  // Spheres index[0..16) (4 floats each) transposed into x, y, z, w: 128-bit lanes hold spheres
  // (k, k + 4, k + 8, k + 12), then the 4x4 transpose runs in all four lanes at once.
  static void LoadSpheres(const float* base, const uint32_t* index, V& x, V& y, V& z, V& w) {
    const auto quad = [&](int k) {
      __m512 t = _mm512_castps128_ps512(_mm_loadu_ps(base + 4 * size_t{index[k]}));
      t = _mm512_insertf32x4(t, _mm_loadu_ps(base + 4 * size_t{index[k + 4]}), 1);
      t = _mm512_insertf32x4(t, _mm_loadu_ps(base + 4 * size_t{index[k + 8]}), 2);
      return _mm512_insertf32x4(t, _mm_loadu_ps(base + 4 * size_t{index[k + 12]}), 3);
    };
    const __m512 t0 = quad(0), t1 = quad(1), t2 = quad(2), t3 = quad(3);
    const __m512 u0 = _mm512_unpacklo_ps(t0, t1);
    const __m512 u1 = _mm512_unpackhi_ps(t0, t1);
    const __m512 u2 = _mm512_unpacklo_ps(t2, t3);
    const __m512 u3 = _mm512_unpackhi_ps(t2, t3);
    x = _mm512_shuffle_ps(u0, u2, _MM_SHUFFLE(1, 0, 1, 0));
    y = _mm512_shuffle_ps(u0, u2, _MM_SHUFFLE(3, 2, 3, 2));
    z = _mm512_shuffle_ps(u1, u3, _MM_SHUFFLE(1, 0, 1, 0));
    w = _mm512_shuffle_ps(u1, u3, _MM_SHUFFLE(3, 2, 3, 2));
  }
};

}  // namespace

#include "broad_phase/kernels.inc"

}  // namespace avx512

const Kernels& Avx512Kernels() { return avx512::KernelTable(); }

}  // namespace skinspheres::runtime::kernels

#include "simd/target_end.inc"
#endif  // SKINSPHERES_X86_64
