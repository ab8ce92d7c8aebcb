// SkinningJob: linear blend skinning of positions, p' = Σ_k w_k · M_{b_k} · p (skinned_mesh.h).
//
// Inputs:
//  - joint_matrices: one skinning matrix per bind entry, M_b = G_joint(b) · IBM_b (see
//    SkinningMatricesJob, or an engine's own matrices). Affine: the last row is ignored.
//  - positions: strided float buffers, so an engine's interleaved vertex buffer works. Vertex v
//    is (x, y, z) at byte v * stride. Strides are >= 12 and a multiple of 4. Each buffer holds
//    >= (vertex_count - 1) * stride / 4 + 3 floats. Output is written at each vertex's own index;
//    everything else in the output buffer is left alone.
//  - influences, either
//      CSR (skinned_mesh.h): influence_offsets (vertex_count + 1), influence_binds and
//      influence_weights (>= influence_offsets[vertex_count]); any count per vertex, a vertex
//      with none gets (0, 0, 0); plus an optional subset of vertex indices to skin only those;
//    or `prepared` (prepared_influences.h, built once for the mesh or a subset): the fast path
//      (about 3x the plain loop with AVX2, 1.7-2.4x with SSE2 only), validated in O(1); the CSR
//      fields and subset must then be empty. The CSR path is for one-off use: it re-checks every
//      influence it reads and runs ~1.2-1.3x the plain loop.
// Work: WorkSize() items (subset entries, vertices, or prepared slots). RunRange(begin, end) skins
// items [begin, end) so any scheduler can split the job; RunRanges() skins a list of such ranges
// (e.g. the runs of a prepared subset that a frame needs) for one validation of the job;
// RunParallel() does it through a
// ParallelFor (an engine's job system, or TBB). Each vertex is computed by the same instructions whatever the split, so
// results are bit-identical for any thread count and grain.
// Validate() refuses every job that could read or write out of bounds (null or short spans, bad
// strides, bind or subset indices out of range, decreasing CSR offsets, ...). It is O(1) for a
// prepared job and O(influences) for a CSR job. A default job is invalid. Run()/RunRange()/
// RunRanges() validate (RunRange(s) only what their ranges read), never allocate, never throw.
// SIMD: SSE2 on every x86-64; AVX2 chosen at run time when the CPU has it (or always, when built
// with SKINSPHERES_AVX2); the portable level elsewhere (aarch64, ...). `simd` can force a level
// (tests, benchmarks; simd_level.h). Every level, on every platform, gives the same bits: the same float
// operations in the same order, no fused multiply-add (platform.h).
#pragma once

#include <Eigen/Core>
#include <cstddef>
#include <cstdint>
#include <span>
#include <utility>

#include "skinspheres/skinning/math_types.h"
#include "skinspheres/skinning/parallel_for.h"
#include "skinspheres/skinning/prepared_influences.h"
#include "skinspheres/skinning/simd_level.h"

namespace skinspheres::skinning {

// The level the skinning kernels run at for `level` (simd_level.h; SimdLevelSupported says which
// this CPU runs): kAuto -> the best supported one; kAvx512 -> kAvx2 (no AVX-512 copy); any other
// level unchanged.
SimdLevel ResolveSimdLevel(SimdLevel level);

struct SkinningJob {
  std::span<const Mat4f> joint_matrices;  // M_b per bind entry, > every bind index used

  size_t vertex_count = 0;              // vertices addressable in the buffers
  std::span<const float> in_positions;  // see the size rule above
  size_t in_stride_bytes = 3 * sizeof(float);
  std::span<float> out_positions;  // see the size rule above
  size_t out_stride_bytes = 3 * sizeof(float);

  // CSR influences.
  std::span<const uint32_t> influence_offsets;  // vertex_count + 1
  std::span<const uint16_t> influence_binds;    // >= influence_offsets[vertex_count]
  std::span<const float> influence_weights;     // >= influence_offsets[vertex_count]
  std::span<const uint32_t> subset;             // optional: only these vertices (< vertex_count)

  // Prepared influences (instead of CSR + subset).
  const PreparedInfluences* prepared = nullptr;

  SimdLevel simd = SimdLevel::kAuto;

  size_t WorkSize() const;
  bool Validate() const;
  bool Run() const;
  bool RunRange(size_t begin, size_t end) const;
  // Items [first, second) of every range, in order; ranges may be empty, unordered or overlap. The
  // job and every range are checked before any vertex is written: false (nothing skinned) when
  // RunRange would refuse one of them. For a prepared job, the job is checked once (O(1)) and each
  // range in O(1), where a RunRange call per range re-checks the whole job.
  bool RunRanges(std::span<const std::pair<uint32_t, uint32_t>> ranges) const;
  // Validates once, then runs [0, WorkSize()) through parallel_for (parallel_for.h; TBB by default)
  // in chunks of >= grain items.
  bool RunParallel(const ParallelFor& parallel_for = DefaultParallelFor(), size_t grain = 2048) const;
};

// The oracle: the plain loop (per vertex, per influence, Matrix4f · Vector4f, accumulate
// weighted), for CSR jobs only (prepared jobs are refused). Validates like SkinningJob.
bool SkinReference(const SkinningJob& job);

}  // namespace skinspheres::skinning
