// Broad-phase kernels, AVX2 level: 8 lanes, compiled for AVX2 whatever the build's flags and
// picked at run time when the CPU has it. See broad_phase/kernels.h.
#include "broad_phase/kernels.h"

#if defined(SKINSPHERES_X86_64)
#include <immintrin.h>

#include "simd/target_begin_avx2.inc"

namespace skinspheres::runtime::kernels {
namespace avx2 {
namespace F = simd::sse;
namespace {

struct Simd {
  using V = __m256;
  static constexpr unsigned kWidth = 8;
  static V Set1(float v) { return _mm256_set1_ps(v); }
  static V Load(const float* p) { return _mm256_loadu_ps(p); }
  static void Store(float* p, V v) { _mm256_storeu_ps(p, v); }
  static V Add(V a, V b) { return _mm256_add_ps(a, b); }
  static V Sub(V a, V b) { return _mm256_sub_ps(a, b); }
  static V Mul(V a, V b) { return _mm256_mul_ps(a, b); }
  static V Max(V a, V b) { return _mm256_max_ps(a, b); }
  static V Sqrt(V a) { return _mm256_sqrt_ps(a); }
  static unsigned Le(V a, V b) { return static_cast<unsigned>(_mm256_movemask_ps(_mm256_cmp_ps(a, b, _CMP_LE_OQ))); }
  // Spheres index[0..8) (4 floats each) transposed into x, y, z, w: 128-bit lanes hold spheres
  // (k, k + 4), then the 4x4 transpose runs in both lanes at once.
  static void LoadSpheres(const float* base, const uint32_t* index, V& x, V& y, V& z, V& w) {
    const auto pair = [&](int k) {
      return _mm256_insertf128_ps(_mm256_castps128_ps256(_mm_loadu_ps(base + 4 * size_t{index[k]})),
                                  _mm_loadu_ps(base + 4 * size_t{index[k + 4]}), 1);
    };
    const __m256 t0 = pair(0), t1 = pair(1), t2 = pair(2), t3 = pair(3);
    const __m256 u0 = _mm256_unpacklo_ps(t0, t1);  // x0 x1 y0 y1 | x4 x5 y4 y5
    const __m256 u1 = _mm256_unpackhi_ps(t0, t1);  // z0 z1 w0 w1 | ...
    const __m256 u2 = _mm256_unpacklo_ps(t2, t3);  // x2 x3 y2 y3 | ...
    const __m256 u3 = _mm256_unpackhi_ps(t2, t3);
    x = _mm256_shuffle_ps(u0, u2, _MM_SHUFFLE(1, 0, 1, 0));
    y = _mm256_shuffle_ps(u0, u2, _MM_SHUFFLE(3, 2, 3, 2));
    z = _mm256_shuffle_ps(u1, u3, _MM_SHUFFLE(1, 0, 1, 0));
    w = _mm256_shuffle_ps(u1, u3, _MM_SHUFFLE(3, 2, 3, 2));
  }
};

}  // namespace

#include "broad_phase/kernels.inc"

}  // namespace avx2

const Kernels& Avx2Kernels() { return avx2::KernelTable(); }

}  // namespace skinspheres::runtime::kernels

#include "simd/target_end.inc"
#endif  // SKINSPHERES_X86_64
