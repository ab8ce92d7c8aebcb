// Stage 4 of the fitter, beyond the paper (tightness): the owned spheres through the tightening
// pass (tighten/sphere_tightener.h) and back. See fit_stages.h.
#include <algorithm>
#include <string>

#include "fit_stages.h"
#include "skinspheres/lib/tighten/sphere_tightener.h"

namespace skinspheres::lib {

std::optional<Error> CheckSphereBudget(const RawCharacter& ch, const OwnedSpheres& owned, const FitSettings& settings) {
  std::vector<uint16_t> parts;
  for (size_t s = 0; s < owned.spheres.size(); ++s) {
    if (!owned.triangles[s].empty()) parts.push_back(owned.part[s]);
  }
  std::sort(parts.begin(), parts.end());
  const size_t needed = static_cast<size_t>(std::unique(parts.begin(), parts.end()) - parts.begin());
  if (static_cast<size_t>(settings.max_spheres) >= needed) return std::nullopt;
  return MakeError(ErrorCode::kInvalidArgument, ch.Name() + ": max spheres " + std::to_string(settings.max_spheres) +
                                                    " is below its " + std::to_string(needed) +
                                                    " body parts with triangles (each needs a sphere)");
}

void TightenOwnedSpheres(const RawCharacter& ch, const FitSettings& settings, OwnedSpheres* owned, FitReport* report) {
  int dropped = 0;
  std::vector<TightSphere> tight;
  for (size_t s = 0; s < owned->spheres.size(); ++s) {
    if (owned->triangles[s].empty()) {
      ++dropped;
      continue;
    }
    TightSphere t;
    t.center = owned->spheres[s].ball.center;
    t.reference_radius = owned->spheres[s].ball.radius;
    t.part = owned->part[s];
    t.origin = static_cast<uint32_t>(s);
    t.triangles = std::move(owned->triangles[s]);
    tight.push_back(std::move(t));
  }
  TightenSettings ts;
  ts.max_spheres = settings.max_spheres;
  ts.split_gain = settings.split_gain;
  ts.split_rounds = settings.split_rounds;
  ts.target_standoff = settings.target_standoff;
  ts.budget_only = !settings.tighten;
  const TightenReport tr = TightenSpheres(ch, ts, &tight);

  // Each tightened sphere keeps what its origin carried (level, F) with its new centre and the
  // radius its growth is measured against.
  OwnedSpheres next;
  for (auto& t : tight) {
    CandidateSphere c = owned->spheres[t.origin];
    c.ball.center = t.center;
    c.ball.radius = t.reference_radius;
    next.spheres.push_back(c);
    next.part.push_back(t.part);
    next.triangles.push_back(std::move(t.triangles));
  }
  *owned = std::move(next);

  report->spheres_dropped = dropped + tr.dropped;
  report->spheres_split = tr.splits;
  report->split_rounds = tr.split_rounds;
  report->triangles_handed_over = tr.triangles_handed_over;
  report->spheres_merged = tr.merges;
  report->spheres_merged_for_budget = tr.budget_merges;
  report->standoff_before = static_cast<float>(tr.standoff_before);
  report->standoff_after = static_cast<float>(tr.standoff_after);
}

}  // namespace skinspheres::lib
