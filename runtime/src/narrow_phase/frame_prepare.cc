// A frame's spheres and cluster boxes (internal.h, frame steps 1 and 3).
#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstring>
#include <vector>

#include "narrow_phase/internal.h"
#include "simd/float4.h"

namespace skinspheres::runtime::narrow_phase {

void Involved(std::span<const SpherePair> pairs, NarrowPhaseContext& ctx) {
  Of(ctx).involved.clear();
  for (const SpherePair& p : pairs) {
    for (uint32_t s : {p.i, p.j}) {
      if (Of(ctx).sphere_seen[s] != Of(ctx).frame_stamp) {
        Of(ctx).sphere_seen[s] = Of(ctx).frame_stamp;
        Of(ctx).involved.push_back(s);
      }
    }
  }
}

bool PrepareClusters(const Frame& f, NarrowPhaseContext& ctx, const ParallelFor& parallel_for) {
  const NarrowPhaseData& d = f.data;
  std::atomic<bool> ok{true};
  parallel_for(Of(ctx).involved.size(), 4, [&](size_t begin, size_t end) {
    bool good = true;
    for (size_t k = begin; k < end; ++k) {
      const uint32_t s = Of(ctx).involved[k];
      for (uint32_t c = Of(d).cluster_offsets[s]; c < Of(d).cluster_offsets[s + 1]; ++c) {
        good &= PositionBox(f.set, d, f.pos, c, &Of(ctx).cluster_box[c], Of(ctx).grid_pos.data());
      }
      UniteClusters(d, s, ctx);
    }
    if (!good) ok.store(false, std::memory_order_relaxed);
  });
  for (uint32_t s : Of(ctx).involved)
    Of(ctx).stats.clusters_bounded += Of(d).cluster_offsets[s + 1] - Of(d).cluster_offsets[s];
  return ok.load();
}

void UniteClusters(const NarrowPhaseData& d, uint32_t s, NarrowPhaseContext& ctx) {
  Box all{{INFINITY, INFINITY, INFINITY}, {-INFINITY, -INFINITY, -INFINITY}, s};
  for (uint32_t c = Of(d).cluster_offsets[s]; c < Of(d).cluster_offsets[s + 1]; ++c) {
    for (int k = 0; k < 3; ++k) {
      all.lo[k] = std::min(all.lo[k], Of(ctx).cluster_box[c].lo[k]);
      all.hi[k] = std::max(all.hi[k], Of(ctx).cluster_box[c].hi[k]);
    }
  }
  Of(ctx).sphere_box[s] = all;
}

}  // namespace skinspheres::runtime::narrow_phase
