// Stage 5 of the fitter: the sphere pairs the broad phase never reports. See fit_stages.h.
#include <limits>

#include "fit_stages.h"

namespace skinspheres::lib {
namespace {

// Skeleton distance (bones) between every pair of joints.
std::vector<std::vector<int>> JointHops(const std::vector<int32_t>& parents) {
  const size_t n = parents.size();
  std::vector<std::vector<int>> adj(n);
  for (size_t j = 0; j < n; ++j) {
    if (parents[j] >= 0) {
      adj[j].push_back(parents[j]);
      adj[parents[j]].push_back(static_cast<int>(j));
    }
  }
  std::vector<std::vector<int>> hops(n, std::vector<int>(n, std::numeric_limits<int>::max()));
  std::vector<int> queue;
  for (size_t s = 0; s < n; ++s) {
    hops[s][s] = 0;
    queue.assign(1, static_cast<int>(s));
    for (size_t head = 0; head < queue.size(); ++head) {
      const int u = queue[head];
      for (int v : adj[u]) {
        if (hops[s][v] == std::numeric_limits<int>::max()) {
          hops[s][v] = hops[s][u] + 1;
          queue.push_back(v);
        }
      }
    }
  }
  return hops;
}

}  // namespace

void WriteExcludedPairs(const skinning::Skeleton& skeleton, const FitSettings& settings, runtime::SphereSet* set) {
  const auto hops = JointHops(skeleton.parents);
  for (uint32_t i = 0; i < set->size(); ++i) {
    for (uint32_t j = i + 1; j < set->size(); ++j) {
      const int a = set->sphere_joint[i], b = set->sphere_joint[j];
      std::optional<runtime::ExclusionReason> reason;
      if (a == b) {
        reason = runtime::ExclusionReason::kSameJoint;
      } else if (hops[a][b] <= settings.adjacent_hops) {
        reason = runtime::ExclusionReason::kAdjacentJoints;
      } else if (settings.exclude_bind_overlaps &&
                 (set->centers_rest[i] - set->centers_rest[j]).norm() < set->radii_rest[i] + set->radii_rest[j]) {
        reason = runtime::ExclusionReason::kBindOverlap;
      }
      if (reason) set->excluded_pairs.push_back({i, j, *reason});
    }
  }
}

}  // namespace skinspheres::lib
