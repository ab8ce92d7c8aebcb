// The crowd calls (crowd/crowd.h): each range of instances a ParallelFor hands out runs as
// CrowdRange, through CrowdBatch (crowd/crowd_batch.h) where the CPU batches, one instance at a time
// (CrowdStep) elsewhere.
#include "skinspheres/runtime/crowd/crowd.h"

#include <algorithm>
#include <atomic>

#include "crowd/crowd_batch.h"
#include "crowd/crowd_query.h"

namespace skinspheres::runtime {

FrameStatus CrowdStep(CharacterInstance& inst, RefitMode mode, const CharacterFrameInput& input, bool find_contacts) {
  const FrameStatus st = inst.Update(mode, input.joint_world, input.skinned_positions, /*keep_joints=*/find_contacts);
  if (!st.ok()) return st;
  return CrowdBatch::AfterUpdate(inst, mode, input, find_contacts);
}

namespace {

// The caller errors of the crowd calls: spans of different sizes, a null instance.
FrameStatus CheckCrowd(std::span<CharacterInstance* const> instances, std::span<const CharacterFrameInput> inputs) {
  if (instances.size() != inputs.size()) {
    return {ErrorCode::kInvalidArgument, "instances and inputs differ in count"};
  }
  for (CharacterInstance* inst : instances) {
    if (inst == nullptr) return {ErrorCode::kInvalidArgument, "null instance"};
  }
  return {};
}

constexpr FrameStatus kSomeFailed{ErrorCode::kInvalidData, "at least one instance failed; see its status()"};

// Update + FindSpherePairs (+ FindContacts) of every instance through parallel_for, each range as CrowdRange.
FrameStatus RunCrowd(std::span<CharacterInstance* const> instances, std::span<const CharacterFrameInput> inputs,
                     RefitMode mode, bool find_contacts, const ParallelFor& parallel_for) {
  if (const FrameStatus st = CheckCrowd(instances, inputs); !st.ok()) return st;
  std::atomic<bool> all_ok{true};
  // Blocks of CrowdBlock instances: no range the loop hands out cuts a batch short (a range of 8
  // instances would fill half the lanes).
  const size_t block = CrowdBlock(mode, find_contacts);
  const size_t count = instances.size();
  parallel_for((count + block - 1) / block, 1, [&](size_t begin, size_t end) {
    if (!CrowdBatch::Run(instances, inputs, mode, find_contacts, begin * block, std::min(end * block, count))) {
      all_ok.store(false, std::memory_order_relaxed);
    }
  });
  if (!all_ok.load()) return kSomeFailed;
  return {};
}

}  // namespace

size_t CrowdBlock(RefitMode mode, bool find_contacts) {
  return mode == RefitMode::kFast && !find_contacts && internal::CrowdBatched() && internal::RefitBatchUsable()
             ? internal::RefitBatchLanes()
             : 1;
}

FrameStatus CrowdRange(std::span<CharacterInstance* const> instances, std::span<const CharacterFrameInput> inputs,
                       RefitMode mode, bool find_contacts) {
  if (const FrameStatus st = CheckCrowd(instances, inputs); !st.ok()) return st;
  if (!CrowdBatch::Run(instances, inputs, mode, find_contacts, 0, instances.size())) return kSomeFailed;
  return {};
}

FrameStatus CrowdUpdateAndFindSpherePairs(std::span<CharacterInstance* const> instances,
                                          std::span<const CharacterFrameInput> inputs, RefitMode mode,
                                          const ParallelFor& parallel_for) {
  return RunCrowd(instances, inputs, mode, /*find_contacts=*/false, parallel_for);
}

FrameStatus CrowdUpdateAndFindContacts(std::span<CharacterInstance* const> instances,
                                       std::span<const CharacterFrameInput> inputs, RefitMode mode,
                                       const ParallelFor& parallel_for) {
  return RunCrowd(instances, inputs, mode, /*find_contacts=*/true, parallel_for);
}

}  // namespace skinspheres::runtime
