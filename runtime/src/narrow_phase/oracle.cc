// The brute-force oracle (FindContactsBruteForce, narrow_phase.h). Rules on triangles: every pair of
// the mesh's triangles whose boxes meet (box_grid.h), rules 1-3 as contact_rules.h states them, rule 3
// measured at rest here, then the exact test: no sphere anywhere. Rules on sphere pairs (older sets): every pair of
// spheres the filter allows, every item against every item.
#include <algorithm>
#include <cmath>
#include <cstring>
#include <vector>

#include "narrow_phase/box_grid.h"
#include "narrow_phase/depth.h"
#include "narrow_phase/internal.h"
#include "skinspheres/runtime/narrow_phase/triangle_contact.h"

namespace skinspheres::runtime::narrow_phase {

namespace {

bool TrianglePairs(const Frame& f, std::vector<Hit>* hits) {
  const NarrowPhaseData::Layout& d = Of(f.data);
  const uint32_t n = d.triangle_count;
  std::vector<GridBox> boxes(n);
  bool ok = true;
  for (uint32_t t = 0; t < n; ++t) {
    Box box;
    ok &= TriangleBox(f, t, &box);
    std::memcpy(boxes[t].lo, box.lo, sizeof box.lo);
    std::memcpy(boxes[t].hi, box.hi, sizeof box.hi);
  }
  if (!ok) return false;
  // Rule 3 at rest, from the rest positions: within the rest gap, or the margin when larger.
  const float rest_distance = std::max(f.set.rest_gap, f.margin);
  const Eigen::Vector3f* rest = d.rest_positions.data();
  const uint32_t* tv = f.set.triangle_vertices.data();
  Chunk chunk;
  TriangleContactGeometry g;
  const BoxGrid grid(boxes, Slack(f.margin));
  grid.ForEachPair([&](uint32_t t, uint32_t u) {
    if (f.data.ShareVertex(t, u) || d.near(d.triangle_joint[t], d.triangle_joint[u])) return;  // rules 1, 2
    if (!TriangleContactOf(Vertex(f, t, 0), Vertex(f, t, 1), Vertex(f, t, 2), Vertex(f, u, 0), Vertex(f, u, 1),
                           Vertex(f, u, 2), f.margin, &g)) {
      return;
    }
    TriangleContactGeometry at_rest;
    if (TriangleContactOf(rest[tv[3 * t]], rest[tv[3 * t + 1]], rest[tv[3 * t + 2]], rest[tv[3 * u]],
                          rest[tv[3 * u + 1]], rest[tv[3 * u + 2]], rest_distance, &at_rest)) {
      return;  // rule 3
    }
    hits->push_back(HitOf(t, u, g));
  });
  return true;
}

bool SpherePairs(const Frame& f, const PairFilter& filter, std::vector<Hit>* hits) {
  const size_t n = f.set.size();
  // Each sphere's item boxes and their union.
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
        for (const Box& b : boxes[j]) Test(f, a, b, chunk);
      }
    }
  }
  hits->insert(hits->end(), chunk.hits.begin(), chunk.hits.end());
  return ok;
}

}  // namespace

bool AllPairs(const Frame& f, const PairFilter& filter, std::vector<Hit>* hits) {
  return Of(f.data).rules == ContactRules::kTriangles ? TrianglePairs(f, hits) : SpherePairs(f, filter, hits);
}

}  // namespace skinspheres::runtime::narrow_phase
