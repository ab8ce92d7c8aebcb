// The crowd calls' batch (crowd/crowd_batch.h): instances of one asset refitted, and queried, several
// at a time in vector lanes (16 at AVX-512, 8 at AVX2, 4 at SSE2 and portable), each with the bits it
// gets alone; the switch and counter the tests use.
#include "crowd/crowd_batch.h"

#include <algorithm>
#include <atomic>
#include <bit>
#include <cstdint>
#include <vector>

#include "broad_phase/sphere_test.h"
#include "crowd/crowd_query.h"
#include "refit/refit_internal.h"
#include "skinspheres/runtime/crowd/crowd.h"

namespace skinspheres::runtime {
namespace {

// Sets of up to this many spheres are queried a batch at a time in the crowd calls (all the allowed
// pairs of the batch's instances in one vector test each); larger sets query one by one, where the
// candidate cache tests far fewer pairs than all of them.
constexpr size_t kCrowdQueryMaxSpheres = 256;

std::atomic<bool> crowd_batched{true};
std::atomic<bool> crowd_query_batched{true};
thread_local uint64_t batched_queries = 0;  // batches queried at once on this thread (tests)

// BatchTestPairs of the level in use (the level the batch was refitted at: the same lanes).
size_t TestPairs(const float* soa, const uint32_t* pairs, size_t begin, size_t end, uint32_t lanes,
                 internal::BatchHits* hits) {
  switch (internal::RefitSimdInUse()) {
#if defined(SKINSPHERES_X86_64)
    case internal::RefitSimd::kAvx512: return internal::avx512::BatchTestPairs(soa, pairs, begin, end, lanes, hits);
    case internal::RefitSimd::kAvx2: return internal::avx2::BatchTestPairs(soa, pairs, begin, end, lanes, hits);
    case internal::RefitSimd::kSse2: return internal::sse2::BatchTestPairs(soa, pairs, begin, end, lanes, hits);
#endif
    default: return internal::portable::BatchTestPairs(soa, pairs, begin, end, lanes, hits);
  }
}

}  // namespace

namespace internal {
std::vector<uint32_t> CrowdPairs(const PairFilter& filter) {
  std::vector<uint32_t> pairs;
  const size_t n = filter.size();
  if (n < 2 || n > kCrowdQueryMaxSpheres) return pairs;
  for (uint32_t i = 0; i < n; ++i) {
    for (uint32_t j = i + 1; j < n; ++j) {
      if (!filter.excluded(i, j)) pairs.push_back(i << 16 | j);
    }
  }
  return pairs;
}

void SetCrowdBatched(bool batched) { crowd_batched.store(batched, std::memory_order_relaxed); }
bool CrowdBatched() { return crowd_batched.load(std::memory_order_relaxed); }
void SetCrowdQueryBatched(bool batched) { crowd_query_batched.store(batched, std::memory_order_relaxed); }
bool CrowdQueryBatched() { return crowd_query_batched.load(std::memory_order_relaxed); }
uint64_t CrowdQueryBatches() { return batched_queries; }
}  // namespace internal

FrameStatus CrowdBatch::AfterUpdate(CharacterInstance& inst, RefitMode mode, const CharacterFrameInput& input,
                                    bool find_contacts) {
  inst.FindSpherePairs();
  return AfterQuery(inst, mode, input, find_contacts);
}

FrameStatus CrowdBatch::AfterQuery(CharacterInstance& inst, RefitMode mode, const CharacterFrameInput& input,
                                   bool find_contacts) {
  if (inst.status().ok() && find_contacts) {
    inst.FindContacts(mode == RefitMode::kExact ? input.skinned_positions : std::span<const Eigen::Vector3f>());
  }
  return inst.status();
}

// The batch's spheres lanes side by side (RefitFastBatch's soa), per thread: room for the largest
// set batched, 64-byte aligned (each lane vector one cache line), made by the thread's first batch
// and kept for its life (not on the stack: engines run jobs on small stacks).
float* CrowdBatch::SoaScratch() {
  constexpr size_t kAlign = 64 / sizeof(float);
  thread_local std::vector<float> soa(kCrowdQueryMaxSpheres * 4 * kLanes + kAlign);
  const uintptr_t address = reinterpret_cast<uintptr_t>(soa.data());
  return soa.data() + ((64 - address % 64) % 64) / sizeof(float);
}

// FindSpherePairs of the instances in `lanes` at once: what FindSpherePairs() gives each, from soa. Lanes whose
// spheres the broad phase would refuse (beyond kMaxMagnitude) are left out of the returned mask,
// for their own FindSpherePairs() to report.
uint32_t CrowdBatch::QueryBatch(const CharacterAsset& asset, const float* soa, uint32_t lanes,
                                CharacterInstance* const inst[kLanes]) {
  const size_t n = asset.size();
  switch (internal::RefitSimdInUse()) {
#if defined(SKINSPHERES_X86_64)
    case internal::RefitSimd::kAvx512: lanes &= internal::avx512::BatchValuesOk(soa, n, internal::kMaxMagnitude); break;
    case internal::RefitSimd::kAvx2: lanes &= internal::avx2::BatchValuesOk(soa, n, internal::kMaxMagnitude); break;
    case internal::RefitSimd::kSse2: lanes &= internal::sse2::BatchValuesOk(soa, n, internal::kMaxMagnitude); break;
#endif
    default: lanes &= internal::portable::BatchValuesOk(soa, n, internal::kMaxMagnitude); break;
  }
  if (lanes == 0) return 0;
  for (uint32_t m = lanes; m != 0; m &= m - 1) inst[std::countr_zero(m)]->sphere_pairs_.clear();
  constexpr size_t kHits = 16;
  alignas(64) float depth[internal::kBatchDepthStride * kHits];
  uint32_t pair[kHits];
  uint16_t mask[kHits];
  internal::BatchHits hits{pair, mask, depth, kHits, 0};
  const uint32_t* pairs = asset.crowd_pairs_.data();
  const size_t count = asset.crowd_pairs_.size();
  const PairFilter& filter = asset.filter();
  for (size_t pos = 0; pos < count;) {
    hits.count = 0;
    pos = TestPairs(soa, pairs, pos, count, lanes, &hits);
    for (size_t h = 0; h < hits.count; ++h) {
      const uint32_t i = pair[h] >> 16, j = pair[h] & 0xFFFFu;
      const uint16_t part_i = filter.part(i), part_j = filter.part(j);
      for (uint32_t m = mask[h]; m != 0; m &= m - 1) {
        const int b = std::countr_zero(m);
        inst[b]->sphere_pairs_.push_back(SpherePair{i, j, depth[internal::kBatchDepthStride * h + b], part_i, part_j});
      }
    }
  }
  for (uint32_t m = lanes; m != 0; m &= m - 1) {
    CharacterInstance& one = *inst[std::countr_zero(m)];
    one.queried_ = true;
    one.query_ok_ = true;
    one.status_ = {};
    // The cache stays exact without this (its check is against its own build), but its motion
    // statistics (frames since the build) would be wrong: a query alone then starts afresh.
    one.context_.Invalidate();
  }
  ++batched_queries;
  return lanes;
}

// Instances [begin, end) with their inputs; true when all succeeded. In fast mode, consecutive
// instances of one asset are refitted together, RefitBatchLanes() at a time; the others one by one
// (CrowdStep).
bool CrowdBatch::Run(std::span<CharacterInstance* const> instances, std::span<const CharacterFrameInput> inputs,
                     RefitMode mode, bool find_contacts, size_t begin, size_t end) {
  bool all_ok = true;
  const size_t width = internal::RefitBatchLanes();
  for (size_t i = begin; i < end;) {
    const CharacterAsset* asset = instances[i]->asset_.get();
    size_t last = i + 1;  // the run of instances of this asset, at most width, none listed twice
    while (last < end && last - i < width && instances[last]->asset_.get() == asset &&
           std::find(instances.begin() + i, instances.begin() + last, instances[last]) == instances.begin() + last) {
      ++last;
    }
    if (mode != RefitMode::kFast || last - i < 2 || !internal::CrowdBatched() || !internal::RefitBatchUsable()) {
      for (; i < last; ++i) all_ok &= CrowdStep(*instances[i], mode, inputs[i], find_contacts).ok();
      continue;
    }
    // Check each instance's inputs as Update does; the ones refused drop out of the batch.
    RefitJob jobs[kLanes];
    bool prepared[kLanes] = {};
    size_t lane_of[kLanes];
    const float* world[kLanes];
    float* out[kLanes];
    CharacterInstance* lane_inst[kLanes];
    size_t lanes = 0;
    for (size_t k = i; k < last; ++k) {
      CharacterInstance& inst = *instances[k];
      RefitJob& job = jobs[k - i];
      if (!inst.PrepareUpdate(mode, inputs[k].joint_world, inputs[k].skinned_positions, &job)) {
        all_ok = false;
        continue;
      }
      prepared[k - i] = true;
      lane_of[k - i] = lanes;
      world[lanes] = reinterpret_cast<const float*>(job.joint_world.data());
      out[lanes] = reinterpret_cast<float*>(job.out.data());
      lane_inst[lanes] = &inst;
      ++lanes;
    }
    uint32_t finite = 0;
    float* soa = nullptr;
    if (lanes > 0) {
      for (size_t b = lanes; b < width; ++b) {  // idle lanes repeat the first (same bits, written twice)
        world[b] = world[0];
        out[b] = out[0];
      }
      if (!asset->crowd_pairs_.empty() && internal::CrowdQueryBatched()) soa = SoaScratch();
      finite = internal::RefitFastBatch(asset->sphere_set(), asset->rest(), world, out, soa);
    }
    uint32_t updated = 0;  // lanes refitted and recorded
    for (size_t k = i; k < last; ++k) {
      if (!prepared[k - i]) continue;  // refused: status_ says why
      const bool ok = (finite >> lane_of[k - i]) & 1u;
      if (!instances[k]->FinishUpdate(ok, jobs[k - i].joint_world, /*keep_joints=*/find_contacts).ok()) {
        all_ok = false;
        continue;
      }
      updated |= 1u << lane_of[k - i];
    }
    const uint32_t queried = soa != nullptr && updated != 0 ? QueryBatch(*asset, soa, updated, lane_inst) : 0;
    for (size_t k = i; k < last; ++k) {
      if (!prepared[k - i] || !((updated >> lane_of[k - i]) & 1u)) continue;
      CharacterInstance& inst = *instances[k];
      const bool done = (queried >> lane_of[k - i]) & 1u;
      all_ok &=
          (done ? AfterQuery(inst, mode, inputs[k], find_contacts) : AfterUpdate(inst, mode, inputs[k], find_contacts))
              .ok();
    }
    i = last;
  }
  return all_ok;
}

}  // namespace skinspheres::runtime
