// The crowd calls' broad phase of several instances of one asset at once, one instance per vector
// lane (crowd_query.inc: 16 lanes at AVX-512, 8 at AVX2, 4 at SSE2 and portable, as the batched fast
// refit before it, refit/refit_internal.h). Lanes across instances share every sphere pair and its
// exclusion, so the asset's allowed pairs are tested for all lanes at once, with the oracle's
// arithmetic (broad_phase/sphere_test.h) lane by lane: each instance gets exactly the sphere pairs,
// in the same (i, j) order and with the same depth bits, as its own SelfCollisionJob, whose cache
// only ever reproduces the oracle. Plain arrays only: no Eigen or standard-library template is
// instantiated in the code compiled for AVX2 or AVX-512 (the linker could keep that copy for the
// whole program).
#pragma once

#include <cstddef>
#include <cstdint>

#include "skinspheres/skinning/platform.h"

namespace skinspheres::runtime::internal {

// Spheres of W lanes (W = refit/refit_internal.h's RefitBatchLanes()), structure of arrays: sphere s
// at soa + 4 W s, as x[W], y[W], z[W], r[W] (lane b: instance b of the batch).
// The pairs of a batch that touch in at least one lane, in the order tested: pair[h] (i << 16 | j),
// mask[h] the lanes where they touch, depth[kBatchDepthStride h + b] the depth in lane b
// (r_i + r_j - |c_i - c_j|).
inline constexpr size_t kBatchDepthStride = 16;
struct BatchHits {
  uint32_t* pair = nullptr;
  uint16_t* mask = nullptr;
  float* depth = nullptr;
  size_t capacity = 0;
  size_t count = 0;
};

// Whether the crowd calls batch at all (the default), or run every instance one at a time (CrowdStep):
// the baseline the batch is measured against. For tests and benchmarks: not to be called while a
// crowd call runs.
void SetCrowdBatched(bool batched);
bool CrowdBatched();
// Whether the crowd calls query a batch at once (the default) or, after the batched refit, each
// instance through its own SelfCollisionJob (the same sphere pairs). For tests and benchmarks: not to
// be called while a crowd call runs.
void SetCrowdQueryBatched(bool batched);
bool CrowdQueryBatched();
// How many batches the calling thread has queried at once (tests: that the batched query ran).
uint64_t CrowdQueryBatches();

// Per level, for its W lanes (crowd_query.inc):
// BatchValuesOk: the lanes whose spheres [0, n) all have |x|, |y|, |z|, r <= max_magnitude and
// r >= 0 (the broad phase's value check; the refit already refused non-finite spheres).
// BatchTestPairs: tests pairs[begin, end) (i << 16 | j, i < j, sorted) in every lane of `lanes`,
// appending the pairs that touch somewhere to *hits. Returns the position reached: end, or the first
// pair not tested because hits was full.
namespace portable {  // 4 lanes
uint32_t BatchValuesOk(const float* soa, size_t n, float max_magnitude);
size_t BatchTestPairs(const float* soa, const uint32_t* pairs, size_t begin, size_t end, uint32_t lanes,
                      BatchHits* hits);
}  // namespace portable
#if defined(SKINSPHERES_X86_64)
namespace sse2 {  // 4 lanes
uint32_t BatchValuesOk(const float* soa, size_t n, float max_magnitude);
size_t BatchTestPairs(const float* soa, const uint32_t* pairs, size_t begin, size_t end, uint32_t lanes,
                      BatchHits* hits);
}  // namespace sse2
namespace avx2 {  // 8 lanes
uint32_t BatchValuesOk(const float* soa, size_t n, float max_magnitude);
size_t BatchTestPairs(const float* soa, const uint32_t* pairs, size_t begin, size_t end, uint32_t lanes,
                      BatchHits* hits);
}  // namespace avx2
namespace avx512 {  // 16 lanes
uint32_t BatchValuesOk(const float* soa, size_t n, float max_magnitude);
size_t BatchTestPairs(const float* soa, const uint32_t* pairs, size_t begin, size_t end, uint32_t lanes,
                      BatchHits* hits);
}  // namespace avx512
#endif

}  // namespace skinspheres::runtime::internal
