// The crowd calls' batch: consecutive instances of one asset in fast mode, refitted several at a time
// in vector lanes (16 at AVX-512, 8 at AVX2, 4 at SSE2 and portable; refit/refit_internal.h: the same
// bits as each alone) and, for an asset of up to 256
// spheres, queried at once too (crowd/crowd_query.h: the same sphere pairs as each alone); then each
// one's narrow phase if asked. A friend of CharacterAsset and CharacterInstance (api/character.h).
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

#include "refit/refit_internal.h"
#include "skinspheres/runtime/api/character.h"

namespace skinspheres::runtime {

struct CharacterFrameInput;

namespace internal {
// The pairs the filter allows, (i << 16) | j sorted, for the batched query (sets of up to 256
// spheres; empty otherwise: the instances then query one by one). CharacterAsset::Create keeps them.
std::vector<uint32_t> CrowdPairs(const PairFilter& filter);
}  // namespace internal

struct CrowdBatch {
  static constexpr size_t kLanes = internal::kRefitBatchLanes;  // the most lanes of any level
  // FindSpherePairs (AfterUpdate), then FindContacts when asked: mode (a) with the input's positions in exact
  // mode, mode (b) in fast mode. The instance's status() after it.
  static FrameStatus AfterUpdate(CharacterInstance& inst, RefitMode mode, const CharacterFrameInput& input,
                                 bool find_contacts);
  static FrameStatus AfterQuery(CharacterInstance& inst, RefitMode mode, const CharacterFrameInput& input,
                                bool find_contacts);
  // The batch's spheres lanes side by side (RefitFastBatch's soa), per thread: room for the largest
  // set batched, 64-byte aligned (each lane vector one cache line), made by the thread's first batch
  // and kept for its life (not on the stack: engines run jobs on small stacks).
  static float* SoaScratch();
  // FindSpherePairs of the instances in `lanes` at once: what FindSpherePairs() gives each, from soa. Lanes whose
  // spheres the broad phase would refuse (beyond kMaxMagnitude) are left out of the returned mask,
  // for their own FindSpherePairs() to report.
  static uint32_t QueryBatch(const CharacterAsset& asset, const float* soa, uint32_t lanes,
                             CharacterInstance* const inst[kLanes]);
  // Instances [begin, end) with their inputs; true when all succeeded. In fast mode, consecutive
  // instances of one asset are refitted together, RefitBatchLanes() at a time; the others one by one
  // (CrowdStep).
  static bool Run(std::span<CharacterInstance* const> instances, std::span<const CharacterFrameInput> inputs,
                  RefitMode mode, bool find_contacts, size_t begin, size_t end);
};

}  // namespace skinspheres::runtime
