// Every pair of spheres the filter allows, every item (triangle or piece) against every item: rule 3 at set-up
// (setup.cc) and the brute-force oracle (FindContactsBruteForce, narrow_phase.h).
#include <algorithm>
#include <cmath>
#include <cstring>
#include <vector>

#include "narrow_phase/depth.h"
#include "narrow_phase/internal.h"

namespace skinspheres::runtime::narrow_phase {

bool AllPairs(const Frame& f, const PairFilter& filter, std::vector<Hit>* hits) {
  const size_t n = f.set.size();
  // Each sphere's triangle boxes and their union.
  std::vector<std::vector<Box>> boxes(n);
  std::vector<Box> whole(n);
  bool ok = true;
  for (size_t s = 0; s < n; ++s) {
    Box all{{INFINITY, INFINITY, INFINITY}, {-INFINITY, -INFINITY, -INFINITY}, 0};
    const NarrowPhaseData::Layout& layout = Of(f.data);
    for (uint32_t k = layout.sphere_item_offsets[s]; k < layout.sphere_item_offsets[s + 1]; ++k) {
      Box box;
      ok &= TriangleBox(f, layout.sphere_items[k], &box);
      for (int d = 0; d < 3; ++d) {
        all.lo[d] = std::min(all.lo[d], box.lo[d]);
        all.hi[d] = std::max(all.hi[d], box.hi[d]);
      }
      boxes[s].push_back(box);
    }
    whole[s] = all;
  }
  Chunk chunk;
  const float slack = Slack(f.margin);
  for (uint32_t i = 0; i < n; ++i) {
    for (uint32_t j = i + 1; j < n; ++j) {
      if (boxes[i].empty() || boxes[j].empty() || filter.excluded(i, j) || !BoxesMeet(whole[i], whole[j], slack))
        continue;
      for (const Box& a : boxes[i]) {
        for (const Box& b : boxes[j]) Test(f, i, j, a, b, chunk);
      }
    }
  }
  hits->insert(hits->end(), chunk.hits.begin(), chunk.hits.end());
  return ok;
}

}  // namespace skinspheres::runtime::narrow_phase
