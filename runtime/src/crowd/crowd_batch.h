// The crowd calls' batch: consecutive instances of one asset in fast mode, refitted several at a time
// in vector lanes (16 at AVX-512, 8 at AVX2, 4 at SSE2 and portable; refit/refit_internal.h: the same
// bits as each alone) and, for an asset of up to 1024 spheres, queried at once too (crowd/crowd_query.h: the same
// sphere pairs as each alone); then each one's narrow phase if asked. A friend of CharacterAsset and CharacterInstance
// (api/character.h).
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

#include "crowd/crowd_query.h"
#include "refit/refit_internal.h"
#include "skinspheres/runtime/api/character.h"

namespace skinspheres::runtime {

struct CharacterFrameInput;

struct CrowdBatch {
 private:
  static float* Aligned(std::vector<float>& buffer, size_t floats);

 public:
  static constexpr size_t kLanes = internal::kRefitBatchLanes;  // the most lanes of any level
  // The asset's lists for the batched query (CharacterAsset::crowd_pairs_ and the rest; see
  // crowd/crowd_query.h): every allowed pair grouped by row and part, and sorted too for sets of up
  // to 160 spheres; none past 1024. CharacterAsset::Create calls it.
  static void ListPairs(CharacterAsset* asset);
  // FindSpherePairs (AfterUpdate), then FindContacts when asked: mode (a) with the input's positions in exact
  // mode, mode (b) in fast mode. The instance's status() after it.
  static FrameStatus AfterUpdate(CharacterInstance& inst, RefitMode mode, const CharacterFrameInput& input,
                                 bool find_contacts);
  static FrameStatus AfterQuery(CharacterInstance& inst, RefitMode mode, const CharacterFrameInput& input,
                                bool find_contacts);
  // Per-thread scratch of at least `floats` floats, 64-byte aligned, grown when a batch needs more
  // and kept for the thread's life: the batch's spheres lanes side by side (RefitFastBatch's soa) and
  // its parts' boxes (grouped query).
  static float* SoaScratch(size_t floats);
  static float* BoxScratch(size_t floats);
  // FindSpherePairs of the instances in `lanes` at once, refitted at `level`: what FindSpherePairs() gives each, from
  // soa. Lanes whose spheres the broad phase would refuse (beyond kMaxMagnitude) are left out of the returned mask, for
  // their own FindSpherePairs() to report.
  static uint32_t QueryBatch(const CharacterAsset& asset, SimdLevel level, const float* soa, uint32_t lanes,
                             CharacterInstance* const inst[kLanes]);
  // The hits of a batch into its instances' sphere pairs (a BatchFlush; context: a HitTarget).
  struct HitTarget {
    const PairFilter* filter;
    CharacterInstance* const* inst;
  };
  // Each instance's pairs from the grouped query into (i, j) order (rows already ascending).
  static void SortRows(std::vector<SpherePair>& found);
  static void AppendHits(void* context, const internal::BatchHits& hits);
  // Instances [begin, end) with their inputs; true when all succeeded. In fast mode, consecutive
  // instances of one asset are refitted together, RefitBatchLanes() at a time; the others one by one
  // (CrowdStep).
  static bool Run(std::span<CharacterInstance* const> instances, std::span<const CharacterFrameInput> inputs,
                  RefitMode mode, bool find_contacts, size_t begin, size_t end);
};

}  // namespace skinspheres::runtime
