// The fast refit's vector code (refit_fast.inc), compiled once in portable C++ (every platform:
// refit_fast_portable.cc) and, on x86-64, once for SSE2 (refit_fast_sse2.cc) and once for AVX2
// (refit_fast_avx2.cc), and the choice between them at run time; and the crowd calls' refit of 16
// instances at once in AVX-512 lanes (crowd/refit_batch_avx512.cc), used when the CPU has AVX-512F.
// All of them evaluate the header's formula with the same float operations in the same order, so
// they give the same bits (tests/runtime/refit_job_tests.cc compares each with the scalar formula);
// the choice is a matter of speed only, and RefitJob has no field for it. Tests and benchmarks pin a level here.
// With -DSKINSPHERES_AVX2=ON the whole runtime is compiled for AVX2, and the "SSE2" copy is then
// VEX code too: compare the two levels in the default build.
#pragma once

#include <cstddef>
#include <cstdint>

#include "skinspheres/runtime/simd_level.h"
#include "skinspheres/skinning/platform.h"

namespace skinspheres::runtime {
class RefitRestData;
struct SphereSet;
}  // namespace skinspheres::runtime

namespace skinspheres::runtime::internal {

// The most reach groups a sphere has (SphereSet's kMaxReachGroups; refit_job.cc checks they agree):
// the kernels keep one sum per group on the stack.
inline constexpr uint32_t kKernelReachGroups = 4;
// The group blends' rounding allowance (docs/REFIT.md#group-blends): kBlendRounding ·
// (Σ_k |T_j c - c'| + Σ_k m_gk · max|c'_xyz|) added to |Σ_k m_gk d_k| + Σ_k e_gk |d_k|.
inline constexpr float kBlendRounding = 32.0f * 1.1920928955078125e-7f;  // 32 FLT_EPSILON

// What the fast refit of one range reads and writes, as plain arrays (no Eigen types in the code
// compiled for AVX2: an inline Eigen function instantiated there could be the copy the linker keeps
// for the whole program).
struct FastRefitArrays {
  const float* world = nullptr;  // G_j(t): 16 floats per joint, column-major
  size_t joint_count = 0;
  const float* center_in_joint = nullptr;       // 3 floats per influence entry
  const float* weights = nullptr;               // per influence entry
  const float* reach = nullptr;                 // per influence entry
  const float* rest_inverse_rows = nullptr;     // 12 floats per joint (RefitRestData)
  const uint32_t* influence_offsets = nullptr;  // per sphere, CSR
  const uint16_t* influence_joints = nullptr;   // per influence entry
  const float* radii_fast = nullptr;            // per sphere
  // The reach groups (RefitRestData::group_offsets etc.): per sphere CSR over groups, per group a
  // radius, per sphere the start of its groups' reaches (K_s per group).
  const uint32_t* group_offsets = nullptr;
  const float* group_radii = nullptr;
  const float* group_reach = nullptr;
  const uint32_t* group_reach_offsets = nullptr;
  // The groups' blends and deviations (docs/REFIT.md#group-blends), laid out as group_reach; both
  // null when the set has none: the kernels then skip that term (the same bits as with m = 0, e = W).
  const float* group_blend = nullptr;
  const float* group_deviation = nullptr;
  // Per group (laid out as group_radii): Σ_k m_gk (RefitRestData::group_blend_sum); null with them.
  const float* group_blend_sum = nullptr;
  float* out = nullptr;  // 4 floats per sphere: centre, radius
};

// kAvx512: the crowd calls refit 16 instances of one set at once (RefitFastBatch), one instance
// alone at AVX2; not a level of RefitJob.
// kPortable: the portable copy (what every platform but x86-64 runs; on x86-64 for tests).

// The level the fast refit runs at: the one pinned by PinRefitSimd, else AVX-512 when the CPU has it
// (so the crowd batches), else AVX2, else SSE2; off x86-64, kPortable.
SimdLevel RefitSimdInUse();
// Pins the level for the whole process (kAuto: unpin); false, and nothing changes, when the CPU
// lacks it. For tests and benchmarks: not to be called while a refit runs.
bool PinRefitSimd(SimdLevel level);
// ToString(level), with AVX-512 said to batch crowds only.
const char* RefitLevelName(SimdLevel level);
// The level of the copy that ran the calling thread's latest fast refit (kAuto: none yet), so that a
// test can tell which ran (they give the same bits). Each copy calls NoteRefitSimdRun.
SimdLevel LastRefitSimdRun();
void NoteRefitSimdRun(SimdLevel level);

namespace portable {  // refit_fast_portable.cc
bool RefitFastRange(const FastRefitArrays& a, size_t begin, size_t end);
}
#if defined(SKINSPHERES_X86_64)
namespace sse2 {  // refit_fast_sse2.cc
bool RefitFastRange(const FastRefitArrays& a, size_t begin, size_t end);
}
namespace avx2 {  // refit_fast_avx2.cc
bool RefitFastRange(const FastRefitArrays& a, size_t begin, size_t end);
}
#endif

// The fast refit of up to kRefitBatchLanes instances of one set at once (crowd/refit_batch.inc), the
// crowd calls' batch: RefitBatchLanes() lanes, by level: 16 at AVX-512 (refit_batch_avx512.cc), 8 at
// AVX2 (refit_batch_avx2.cc), 4 at SSE2 (refit_batch_sse2.cc) and portable (refit_batch_portable.cc:
// what aarch64 runs). Lane b reads world[b] (a's world is not read) and writes out[b], with the same
// bits as RefitFastRange(a, 0, sphere_count) for that instance alone. Returns the mask of lanes whose
// spheres are finite (RefitFastRange's result per lane). A lane may repeat another's world and out
// (the same bits are written twice). soa, unless null, also receives the spheres lanes side by side
// (4 RefitBatchLanes() floats per sphere: x, y, z, r of the lanes; crowd/crowd_query.h).
constexpr size_t kRefitBatchLanes = 16;
// The lanes of the crowd's batch at `level` (kAuto: the level in use, RefitSimdInUse()).
size_t RefitBatchLanes(SimdLevel level = SimdLevel::kAuto);
// Whether the crowd calls refit several instances at a time (always, today: every level batches),
// and the call that does it (refit_job.cc; world[b]: 16 floats per set joint, out[b]: 4 floats per
// sphere, for b < RefitBatchLanes()), which the caller makes only when RefitBatchUsable() said yes,
// having checked every lane's inputs as RefitJob::Validate does.
bool RefitBatchUsable();
// `level`: as RefitBatchLanes (a caller that sized its lanes by a level passes that level, so that
// a pin changed meanwhile cannot widen the batch).
uint32_t RefitFastBatch(const SphereSet& set, const RefitRestData& rest, const float* const world[kRefitBatchLanes],
                        float* const out[kRefitBatchLanes], float* soa = nullptr, SimdLevel level = SimdLevel::kAuto);
namespace portable {  // 4 lanes
uint32_t RefitFastBatch(const FastRefitArrays& a, size_t sphere_count, const float* const world[], float* const out[],
                        float* soa);
}
#if defined(SKINSPHERES_X86_64)
namespace sse2 {  // 4 lanes
uint32_t RefitFastBatch(const FastRefitArrays& a, size_t sphere_count, const float* const world[], float* const out[],
                        float* soa);
}
namespace avx2 {  // 8 lanes
uint32_t RefitFastBatch(const FastRefitArrays& a, size_t sphere_count, const float* const world[], float* const out[],
                        float* soa);
}
namespace avx512 {  // 16 lanes
uint32_t RefitFastBatch(const FastRefitArrays& a, size_t sphere_count, const float* const world[], float* const out[],
                        float* soa);
}
#endif

}  // namespace skinspheres::runtime::internal
