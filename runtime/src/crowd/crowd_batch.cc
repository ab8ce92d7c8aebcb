// The crowd calls' batch (crowd/crowd_batch.h): instances of one asset refitted, and queried, several
// at a time in vector lanes (16 at AVX-512, 8 at AVX2, 4 at SSE2 and portable), each with the bits it
// gets alone; the switch and counter the tests use.
#include "crowd/crowd_batch.h"

#include <algorithm>
#include <atomic>
#include <bit>
#include <cstdint>
#include <vector>

#include "broad_phase/frame.h"
#include "broad_phase/sphere_test.h"
#include "crowd/crowd_query.h"
#include "refit/refit_internal.h"
#include "skinspheres/runtime/crowd/crowd.h"

namespace skinspheres::runtime {
namespace {

std::atomic<bool> crowd_batched{true};
std::atomic<bool> crowd_query_batched{true};
thread_local uint64_t batched_queries = 0;  // batches queried at once on this thread (tests)

}  // namespace

void CrowdBatch::ListPairs(CharacterAsset* asset) {
  const PairFilter& filter = asset->filter_;
  std::vector<uint32_t>& pairs = asset->crowd_pairs_;
  std::vector<uint32_t>& groups = asset->crowd_groups_;
  size_t& part_count = asset->crowd_part_count_;
  pairs.clear();
  groups.clear();
  asset->crowd_sorted_pairs_.clear();
  part_count = 0;
  const size_t n = filter.size();
  if (n < 2 || n > internal::kCrowdQueryMaxSpheres) return;
  // Grouped: row i, then the spheres j > i of each part, ascending.
  for (uint32_t i = 0; i < n; ++i) part_count = std::max<size_t>(part_count, filter.part(i) + size_t{1});
  std::vector<std::vector<uint32_t>> members(part_count);
  for (uint32_t i = 0; i < n; ++i) members[filter.part(i)].push_back(i);
  for (uint32_t i = 0; i < n; ++i) {
    for (uint32_t part = 0; part < part_count; ++part) {
      const auto begin = static_cast<uint32_t>(pairs.size());
      for (auto it = std::upper_bound(members[part].begin(), members[part].end(), i); it != members[part].end(); ++it) {
        if (!filter.excluded(i, *it)) pairs.push_back(i << 16 | *it);
      }
      const auto end = static_cast<uint32_t>(pairs.size());
      if (end > begin) groups.insert(groups.end(), {begin, end, part});
    }
  }
  asset->crowd_pairs_sorted_ = std::is_sorted(pairs.begin(), pairs.end());
  if (n <= internal::kCrowdAllPairsMaxSpheres) {
    asset->crowd_sorted_pairs_ = pairs;
    std::sort(asset->crowd_sorted_pairs_.begin(), asset->crowd_sorted_pairs_.end());
  }
}

namespace internal {

const CrowdQueryKernels& CrowdQueryKernelsFor(SimdLevel level) {
  switch (level) {
#if defined(SKINSPHERES_X86_64)
    case SimdLevel::kAvx512: return avx512::CrowdQueryKernelTable();
    case SimdLevel::kAvx2: return avx2::CrowdQueryKernelTable();
    case SimdLevel::kSse2: return sse2::CrowdQueryKernelTable();
#endif
    default: return portable::CrowdQueryKernelTable();
  }
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

// Per-thread scratch of at least `floats` floats, 64-byte aligned (each lane vector one cache line),
// grown when a batch needs more and kept for the thread's life (not on the stack: engines run jobs
// on small stacks). Two of them: the batch's spheres (RefitFastBatch's soa) and its parts' boxes.
float* CrowdBatch::SoaScratch(size_t floats) {
  thread_local std::vector<float> soa;
  return Aligned(soa, floats);
}
float* CrowdBatch::BoxScratch(size_t floats) {
  thread_local std::vector<float> boxes;
  return Aligned(boxes, floats);
}
float* CrowdBatch::Aligned(std::vector<float>& buffer, size_t floats) {
  constexpr size_t kAlign = 64 / sizeof(float);
  if (buffer.size() < floats + kAlign) buffer.resize(floats + kAlign);
  const uintptr_t address = reinterpret_cast<uintptr_t>(buffer.data());
  return buffer.data() + ((64 - address % 64) % 64) / sizeof(float);
}

// The hits of a batch into its instances' sphere pairs (BatchFlush; context: the QueryBatch's lanes).
void CrowdBatch::AppendHits(void* context, const internal::BatchHits& hits) {
  const auto& to = *static_cast<const HitTarget*>(context);
  for (size_t h = 0; h < hits.count; ++h) {
    const uint32_t i = hits.pair[h] >> 16, j = hits.pair[h] & 0xFFFFu;
    const uint16_t part_i = to.filter->part(i), part_j = to.filter->part(j);
    for (uint32_t m = hits.mask[h]; m != 0; m &= m - 1) {
      const int b = std::countr_zero(m);
      to.inst[b]->sphere_pairs_.push_back(
          SpherePair{i, j, hits.depth[internal::kBatchDepthStride * h + b], part_i, part_j});
    }
  }
}

// The groups come row by row (i ascending), each row's parts one after another, j ascending in each:
// sorting each row by j (an insertion sort: a row is a few runs of a few pairs) gives (i, j) order.
void CrowdBatch::SortRows(std::vector<SpherePair>& found) {
  for (size_t begin = 0; begin < found.size();) {
    size_t end = begin + 1;
    while (end < found.size() && found[end].sphere_i == found[begin].sphere_i) ++end;
    for (size_t k = begin + 1; k < end; ++k) {
      const SpherePair p = found[k];
      size_t at = k;
      for (; at > begin && found[at - 1].sphere_j > p.sphere_j; --at) found[at] = found[at - 1];
      found[at] = p;
    }
    begin = end;
  }
}

// FindSpherePairs of the instances in `lanes` at once: what FindSpherePairs() gives each, from soa. Lanes whose
// spheres the broad phase would refuse (beyond kMaxMagnitude) are left out of the returned mask,
// for their own FindSpherePairs() to report.
uint32_t CrowdBatch::QueryBatch(const CharacterAsset& asset, SimdLevel level, const float* soa, uint32_t lanes,
                                CharacterInstance* const inst[kLanes]) {
  const internal::CrowdQueryKernels& kernels = internal::CrowdQueryKernelsFor(level);
  const size_t n = asset.size();
  lanes &= kernels.values_ok(soa, n, internal::kMaxMagnitude);
  if (lanes == 0) return 0;
  for (uint32_t m = lanes; m != 0; m &= m - 1) inst[std::countr_zero(m)]->sphere_pairs_.clear();
  constexpr size_t kHits = 16;
  alignas(64) float depth[internal::kBatchDepthStride * kHits];
  uint32_t pair[kHits];
  uint16_t mask[kHits];
  internal::BatchHits hits{pair, mask, depth, kHits, 0};
  HitTarget target{&asset.filter(), inst};
  const std::vector<uint32_t>& sorted = asset.crowd_sorted_pairs_;
  if (kernels.width == internal::kRefitBatchLanes && !sorted.empty()) {
    for (size_t pos = 0; pos < sorted.size();) {  // every pair, in (i, j) order, no boxes
      hits.count = 0;
      pos = kernels.test_pairs(soa, sorted.data(), pos, sorted.size(), lanes, &hits);
      AppendHits(&target, hits);
    }
  } else {
    const std::vector<uint32_t>& pairs = asset.crowd_pairs_;
    float* boxes = BoxScratch(6 * kernels.width * asset.crowd_part_count_);
    kernels.part_boxes(soa, asset.filter().parts().data(), n, asset.crowd_part_count_, boxes);
    kernels.test_groups(soa, pairs.data(), asset.crowd_groups_.data(), asset.crowd_groups_.size() / 3, boxes, lanes,
                        internal::BatchSink{&hits, &AppendHits, &target});
    AppendHits(&target, hits);
    if (!asset.crowd_pairs_sorted_) {  // each instance's pairs in the order of its own query: by (i, j)
      for (uint32_t m = lanes; m != 0; m &= m - 1) SortRows(inst[std::countr_zero(m)]->sphere_pairs_);
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
  // The level and width, read once: the refit and the query of every batch below use the same.
  const SimdLevel level = internal::RefitSimdInUse();
  const size_t width = internal::RefitBatchLanes(level);
  for (size_t i = begin; i < end;) {
    const CharacterAsset* asset = instances[i]->asset_.get();
    size_t last = i + 1;  // the run of instances of this asset, at most width, none listed twice
    while (last < end && last - i < width && instances[last]->asset_.get() == asset &&
           std::find(instances.begin() + i, instances.begin() + last, instances[last]) == instances.begin() + last) {
      ++last;
    }
    if (mode != RefitMode::kFast || last - i < 2 || !internal::CrowdBatched() || width < 2) {
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
      if (!asset->crowd_pairs_.empty() && internal::CrowdQueryBatched()) soa = SoaScratch(4 * width * asset->size());
      finite = internal::RefitFastBatch(asset->sphere_set(), asset->rest(), world, out, soa, level);
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
    const uint32_t queried = soa != nullptr && updated != 0 ? QueryBatch(*asset, level, soa, updated, lane_inst) : 0;
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
