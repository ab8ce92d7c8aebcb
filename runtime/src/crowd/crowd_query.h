// The crowd calls' broad phase of several instances of one asset at once, one instance per vector
// lane (crowd_query.inc: 16 lanes at AVX-512, 8 at AVX2, 4 at SSE2 and portable, as the batched fast
// refit before it, refit/refit_internal.h). Lanes across instances share every sphere pair and its
// exclusion, so the asset's allowed pairs are tested for all lanes at once, with the oracle's
// arithmetic (broad_phase/sphere_test.h) lane by lane: each instance gets exactly the sphere pairs,
// in the same (i, j) order and with the same depth bits, as its own BroadPhaseJob, whose cache
// only ever reproduces the oracle. Plain arrays only: no Eigen or standard-library template is
// instantiated in the code compiled for AVX2 or AVX-512 (the linker could keep that copy for the
// whole program).
#pragma once

#include <cstddef>
#include <cstdint>

#include "refit/refit_internal.h"
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
// instance through its own BroadPhaseJob (the same sphere pairs). For tests and benchmarks: not to
// be called while a crowd call runs.
void SetCrowdQueryBatched(bool batched);
bool CrowdQueryBatched();
// How many batches the calling thread has queried at once (tests: that the batched query ran).
uint64_t CrowdQueryBatches();

// The batched query lists the allowed pairs (i << 16 | j) of sets of up to kCrowdQueryMaxSpheres
// spheres (larger ones query one instance at a time) in groups, each the pairs of one row i with the
// spheres j > i of one part (by row, then part, then j). A group is tested only where sphere i's box
// meets the part's box in some lane (BatchTestGroups), so the cost follows the parts that come near
// each other, not the square of the sphere count; at 16 lanes, sets of up to
// kCrowdAllPairsMaxSpheres test every pair instead (BatchTestPairs over the whole list: measured
// faster there, bench/runtime_bench.cc BM_CrowdFast). Either way each instance's pairs come out by
// (i, j), sorted after the query when the groups' order is not that.
inline constexpr size_t kCrowdAllPairsMaxSpheres = 160;
inline constexpr size_t kCrowdQueryMaxSpheres = 1024;

// Where the grouped query's hits go: into *hits, handed to flush(context, *hits) whenever it is full
// (then emptied); the hits left at the end stay in *hits.
using BatchFlush = void (*)(void* context, const BatchHits& hits);
struct BatchSink {
  BatchHits* hits;
  BatchFlush flush;
  void* context;
};

// One level's batched query, for its `width` lanes (crowd_query.inc):
struct CrowdQueryKernels {
  size_t width;
  // The lanes whose spheres [0, n) all have |x|, |y|, |z|, r <= max_magnitude and r >= 0 (the
  // broad phase's value check; the refit already refused non-finite spheres).
  uint32_t (*values_ok)(const float* soa, size_t n, float max_magnitude);
  // Tests pairs[begin, end) (i << 16 | j, i < j, sorted) in every lane of `lanes`, appending the
  // pairs that touch somewhere to *hits. Returns the position reached: end, or the first pair not
  // tested because hits was full.
  size_t (*test_pairs)(const float* soa, const uint32_t* pairs, size_t begin, size_t end, uint32_t lanes,
                       BatchHits* hits);
  // Each part's box per lane, grown by a margin that covers the rounding of every value the pair test
  // compares (crowd_query.inc): boxes + 6 width p holds min x, y, z then max x, y, z of part p, width
  // floats each. sphere_part: n parts, each < part_count.
  void (*part_boxes)(const float* soa, const uint16_t* sphere_part, size_t n, size_t part_count, float* boxes);
  // Tests the groups (begin, end, part: 3 values each, into pairs) whose row's sphere box meets the
  // part's box in a lane of `lanes`, every pair of such a group in every lane of `lanes` (as
  // test_pairs), into sink.
  void (*test_groups)(const float* soa, const uint32_t* pairs, const uint32_t* groups, size_t group_count,
                      const float* boxes, uint32_t lanes, const BatchSink& sink);
};

// The kernels of a refit level (refit/refit_internal.h: the level the batch was refitted at).
const CrowdQueryKernels& CrowdQueryKernelsFor(SimdLevel level);
namespace portable {
const CrowdQueryKernels& CrowdQueryKernelTable();  // 4 lanes
}
#if defined(SKINSPHERES_X86_64)
namespace sse2 {
const CrowdQueryKernels& CrowdQueryKernelTable();  // 4 lanes
}
namespace avx2 {
const CrowdQueryKernels& CrowdQueryKernelTable();  // 8 lanes
}
namespace avx512 {
const CrowdQueryKernels& CrowdQueryKernelTable();  // 16 lanes
}
#endif

}  // namespace skinspheres::runtime::internal
