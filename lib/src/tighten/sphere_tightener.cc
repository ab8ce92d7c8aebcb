// TightenSpheres: the tightening pass's steps in order (sphere_tightener.h; the steps in
// tightener.h and their own files).
#include "skinspheres/lib/tighten/sphere_tightener.h"

#include <algorithm>
#include <tuple>

#include "tightener.h"

namespace skinspheres::lib {

TightenReport TightenSpheres(const RawCharacter& character, const TightenSettings& settings,
                             std::vector<TightSphere>* spheres) {
  TightenReport rep;
  Tightener t(character, settings, *spheres);
  rep.dropped += t.DropEmpty();
  if (settings.budget_only) {  // 3b alone
    rep.budget_merges = t.MergeToBudget(static_cast<size_t>(std::max(1, settings.max_spheres)));
    rep.dropped += t.DropEmpty();
    t.Finish();
    return rep;
  }
  std::tie(rep.exposure_before, rep.standoff_before) = t.TotalExposure();
  // 1. Centre search, 2. hand-over, 3. merge (spheres left with nothing are dropped).
  for (int round = 0; round < settings.search_rounds; ++round) t.SearchAll();
  rep.triangles_handed_over += t.HandOver();
  rep.merges = t.MergeStacked();
  rep.dropped += t.DropEmpty();
  // 3b. The budget.
  rep.budget_merges = t.MergeToBudget(static_cast<size_t>(std::max(1, settings.max_spheres)));
  rep.dropped += t.DropEmpty();
  // 4. Splitting, 5. centre search, hand-over and merge again. Repeated while a round split
  // something and did not reach the target standoff: the spheres have moved and merged since, so
  // splits that did not pay may pay now, and merges may have freed some of the budget.
  for (int round = 0; round < std::max(1, settings.split_rounds); ++round) {
    bool reached_target = false;
    const int splits = t.SplitLoop(&reached_target);
    rep.splits += splits;
    ++rep.split_rounds;
    for (int search = 0; search < settings.search_rounds; ++search) t.SearchAll();
    rep.triangles_handed_over += t.HandOver();
    rep.merges += t.MergeStacked();
    rep.dropped += t.DropEmpty();
    if (splits == 0 || reached_target) break;
  }
  t.Finish();
  std::tie(rep.exposure_after, rep.standoff_after) = t.TotalExposure();
  return rep;
}

}  // namespace skinspheres::lib
