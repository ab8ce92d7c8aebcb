// Private: the linear blend skinning kernels behind SkinningJob, one namespace per SIMD level.
// The same body (skinning_kernel_body.inc) is compiled once per level, so every level skins a
// vertex with one fixed sequence of operations: blend the influencing matrices' columns,
//   C_j = Σ_k w_k · M_{b_k}.col(j)   (even k and odd k in two chains, then added: shorter latency)
// then p' = C_0 x + C_1 y + C_2 z + C_3
// (3 columns blended per influence would not save work: Eigen stores columns of 4 floats).
#pragma once

#include <cstddef>
#include <cstdint>

#include "skinspheres/skinning/math_types.h"
#include "skinspheres/skinning/platform.h"
#include "skinspheres/skinning/prepared_influences.h"

namespace skinspheres::skinning::kernels {

struct Buffers {
  const float* matrices = nullptr;  // Mat4f array (column-major, 16 floats each)
  const char* in = nullptr;
  size_t in_stride = 0;
  char* out = nullptr;
  size_t out_stride = 0;
};

struct Csr {
  const uint32_t* offsets = nullptr;
  const uint16_t* binds = nullptr;
  const float* weights = nullptr;
  const uint32_t* subset = nullptr;  // null: items are vertices
};

#define SKINSPHERES_DECLARE_KERNELS(ns)                                                                   \
  namespace ns {                                                                                          \
  void RunCsr(const Buffers& buffers, const Csr& csr, size_t begin, size_t end);                          \
  void RunPrepared(const Buffers& buffers, const PreparedInfluences& prepared, size_t begin, size_t end); \
  }
SKINSPHERES_DECLARE_KERNELS(scalar)
#if defined(SKINSPHERES_X86_64)
SKINSPHERES_DECLARE_KERNELS(sse2)
SKINSPHERES_DECLARE_KERNELS(avx2)
#endif
#undef SKINSPHERES_DECLARE_KERNELS

}  // namespace skinspheres::skinning::kernels
