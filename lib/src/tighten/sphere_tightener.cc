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
  // 4. Splitting, 5. centre search, hand-over and merge again (one round).
  auto step5 = [&](TightenReport* r) {
    for (int search = 0; search < settings.search_rounds; ++search) t.SearchAll();
    r->triangles_handed_over += t.HandOver();
    r->merges += t.MergeStacked();
    r->dropped += t.DropEmpty();
  };
  bool reached_target = false;
  int splits = t.SplitLoop(&reached_target);
  rep.splits += splits;
  rep.split_rounds = 1;
  step5(&rep);
  // Further rounds, while the last one split something without reaching the target: the spheres
  // have moved and merged since, so splits that did not pay may pay now. A round is kept only when
  // it lowers the estimated mean standoff by kRoundGain; otherwise it is undone and the rounds stop.
  double standoff = 0.0;
  if (splits > 0 && !reached_target && settings.split_rounds > 1) standoff = t.TotalExposure().second;
  for (int round = 1; round < settings.split_rounds && splits > 0 && !reached_target; ++round) {
    Tightener::Snapshot before = t.Save();
    TightenReport r;
    splits = t.SplitLoop(&reached_target);
    if (splits == 0) {
      t.Restore(std::move(before));
      break;
    }
    r.splits = splits;
    step5(&r);
    const double after = t.TotalExposure().second;
    if (!(after <= (1.0 - kRoundGain) * standoff)) {
      t.Restore(std::move(before));
      break;
    }
    standoff = after;
    rep.splits += r.splits;
    rep.triangles_handed_over += r.triangles_handed_over;
    rep.merges += r.merges;
    rep.dropped += r.dropped;
    ++rep.split_rounds;
  }
  t.Finish();
  std::tie(rep.exposure_after, rep.standoff_after) = t.TotalExposure();
  return rep;
}

}  // namespace skinspheres::lib
