// Broad-phase kernels, portable level: 4 lanes as plain arrays of floats, on every platform (the
// only level off x86-64: aarch64, 32-bit x86, ...). Each lane computes exactly what the SIMD
// levels compute, so the sphere pairs are the same bits. See broad_phase/kernels.h.
#include "broad_phase/kernels.h"

namespace skinspheres::runtime::kernels {
namespace portable {
namespace F = simd::portable;
namespace {

struct Simd {
  struct V {
    float v[4];
  };
  static constexpr unsigned kWidth = 4;
  static V Set1(float x) { return {{x, x, x, x}}; }
  static V Load(const float* p) { return {{p[0], p[1], p[2], p[3]}}; }
  static void Store(float* p, V a) {
    for (int k = 0; k < 4; ++k) p[k] = a.v[k];
  }
  static V Add(V a, V b) { return {{a.v[0] + b.v[0], a.v[1] + b.v[1], a.v[2] + b.v[2], a.v[3] + b.v[3]}}; }
  static V Sub(V a, V b) { return {{a.v[0] - b.v[0], a.v[1] - b.v[1], a.v[2] - b.v[2], a.v[3] - b.v[3]}}; }
  static V Mul(V a, V b) { return {{a.v[0] * b.v[0], a.v[1] * b.v[1], a.v[2] * b.v[2], a.v[3] * b.v[3]}}; }
  static V Max(V a, V b) {  // SSE's rule: a > b ? a : b
    V r;
    for (int k = 0; k < 4; ++k) r.v[k] = a.v[k] > b.v[k] ? a.v[k] : b.v[k];
    return r;
  }
  static V Sqrt(V a) { return {{std::sqrt(a.v[0]), std::sqrt(a.v[1]), std::sqrt(a.v[2]), std::sqrt(a.v[3])}}; }
  static unsigned Le(V a, V b) {
    return unsigned{a.v[0] <= b.v[0]} | (unsigned{a.v[1] <= b.v[1]} << 1) | (unsigned{a.v[2] <= b.v[2]} << 2) |
           (unsigned{a.v[3] <= b.v[3]} << 3);
  }
  // Spheres index[0..4) (4 floats each) as x, y, z, w.
  static void LoadSpheres(const float* base, const uint32_t* index, V& x, V& y, V& z, V& w) {
    for (int k = 0; k < 4; ++k) {
      const float* s = base + 4 * size_t{index[k]};
      x.v[k] = s[0];
      y.v[k] = s[1];
      z.v[k] = s[2];
      w.v[k] = s[3];
    }
  }
};

}  // namespace

#include "broad_phase/kernels.inc"

}  // namespace portable

const Kernels& PortableKernels() { return portable::KernelTable(); }

}  // namespace skinspheres::runtime::kernels
