// Step 3 (and 5) of the tightening pass: spheres of one part that nearly coincide become one. See
// sphere_tightener.h.
#include <algorithm>

#include "tightener.h"

namespace skinspheres::lib {

// When the minimum ball of two spheres' vertices is at most kMergeSlack times the larger radius,
// the pair becomes that ball (the splitting that follows then cuts the region once instead of
// leaving stacked spheres that each hide the others' surface).
int Tightener::MergeStacked() {
  int merges = 0;
  for (size_t a = 0; a < sp_.size(); ++a) {
    for (size_t b = a + 1; b < sp_.size(); ++b) {
      if (sp_[a].triangles.empty() || sp_[b].triangles.empty() || sp_[a].part != sp_[b].part) continue;
      const float big = std::max(sp_[a].radius, sp_[b].radius);
      // Cheap test first: the smaller sphere must lie nearly inside the larger one.
      if (!Stacked({sp_[a].center, sp_[a].radius}, {sp_[b].center, sp_[b].radius})) continue;
      std::vector<Eigen::Vector3f> both = pts_[a];
      both.insert(both.end(), pts_[b].begin(), pts_[b].end());
      const Ball m = MinimumBall(both);
      if (m.radius > kMergeSlack * big) continue;
      sp_[a].triangles.insert(sp_[a].triangles.end(), sp_[b].triangles.begin(), sp_[b].triangles.end());
      sp_[b].triangles.clear();
      sp_[a].center = m.center;
      sp_[a].reference_radius = std::max(sp_[a].reference_radius, sp_[b].reference_radius);
      Refresh(a);
      Refresh(b);
      ++merges;
    }
  }
  return merges;
}

}  // namespace skinspheres::lib
