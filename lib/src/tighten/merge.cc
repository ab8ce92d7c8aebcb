// Step 3 (and 5) of the tightening pass: spheres of one part that nearly coincide become one. See
// sphere_tightener.h.
#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>

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

namespace {

double BallVolume(double r) { return 4.0 / 3.0 * std::numbers::pi * r * r * r; }

// The volume two balls share (a lens; the smaller ball when one holds the other).
double SharedVolume(double ra, double rb, double d) {
  if (d >= ra + rb) return 0.0;
  if (d <= std::abs(ra - rb)) return BallVolume(std::min(ra, rb));
  const double s = ra + rb - d, t = ra - rb;
  return std::numbers::pi * s * s * (d * d + 2.0 * d * (ra + rb) - 3.0 * t * t) / (12.0 * d);
}

}  // namespace

// The budget (sphere_tightener.h, step 3b): while there are more than `budget` spheres, the pair
// of one part whose joint ball adds least volume to what the two already cover,
// vol(joint ball) - vol(a ∪ b), becomes that ball. The joint ball is the minimum ball of both
// spheres' vertices, so ownership stays exact. Costs are cached per pair and recomputed only for
// the sphere a merge changed; ties go to the lowest (part, a, b). O(P² · V) for the first scan (P
// spheres in a part, V vertices per sphere), O(P · V) per merge after.
int Tightener::MergeToBudget(size_t budget) {
  size_t alive = 0;
  for (const auto& s : sp_) alive += s.triangles.empty() ? 0 : 1;
  if (alive <= budget) return 0;
  // The spheres of each part (ascending), and per part a cache of its pairs' joint balls.
  std::vector<std::vector<size_t>> groups;
  {
    std::vector<uint16_t> parts;
    for (const auto& s : sp_) parts.push_back(s.part);
    std::sort(parts.begin(), parts.end());
    parts.erase(std::unique(parts.begin(), parts.end()), parts.end());
    groups.resize(parts.size());
    for (size_t s = 0; s < sp_.size(); ++s) {
      const size_t g = static_cast<size_t>(std::lower_bound(parts.begin(), parts.end(), sp_[s].part) - parts.begin());
      groups[g].push_back(s);
    }
  }
  struct Joint {
    double cost = std::numeric_limits<double>::quiet_NaN();  // NaN: not computed yet
    Ball ball;
  };
  std::vector<std::vector<Joint>> cache(groups.size());
  for (size_t g = 0; g < groups.size(); ++g) cache[g].resize(groups[g].size() * groups[g].size());
  auto joint_of = [&](size_t g, size_t i, size_t j) -> Joint& {  // i < j, members of group g
    Joint& joint = cache[g][i * groups[g].size() + j];
    if (std::isnan(joint.cost)) {
      const size_t a = groups[g][i], b = groups[g][j];
      std::vector<Eigen::Vector3f> both = pts_[a];
      both.insert(both.end(), pts_[b].begin(), pts_[b].end());
      joint.ball = MinimumBall(both);
      const double d = (sp_[a].center - sp_[b].center).cast<double>().norm();
      const double ra = sp_[a].radius, rb = sp_[b].radius;
      joint.cost = BallVolume(joint.ball.radius) - (BallVolume(ra) + BallVolume(rb) - SharedVolume(ra, rb, d));
    }
    return joint;
  };
  int merges = 0;
  while (alive > budget) {
    size_t best_g = groups.size(), best_i = 0, best_j = 0;
    double best = std::numeric_limits<double>::infinity();
    for (size_t g = 0; g < groups.size(); ++g) {
      const auto& members = groups[g];
      for (size_t i = 0; i < members.size(); ++i) {
        if (sp_[members[i]].triangles.empty()) continue;
        for (size_t j = i + 1; j < members.size(); ++j) {
          if (sp_[members[j]].triangles.empty()) continue;
          const double c = joint_of(g, i, j).cost;
          if (c < best) best = c, best_g = g, best_i = i, best_j = j;
        }
      }
    }
    if (best_g == groups.size()) break;  // one sphere per part left: the fitter refuses budgets below that
    const size_t a = groups[best_g][best_i], b = groups[best_g][best_j];
    const Ball m = cache[best_g][best_i * groups[best_g].size() + best_j].ball;
    sp_[a].triangles.insert(sp_[a].triangles.end(), sp_[b].triangles.begin(), sp_[b].triangles.end());
    sp_[b].triangles.clear();
    sp_[a].center = m.center;
    sp_[a].reference_radius = m.radius;
    Refresh(a);
    Refresh(b);
    const size_t k = groups[best_g].size();
    for (size_t other = 0; other < k; ++other) {  // a changed: its pairs are stale
      cache[best_g][std::min(other, best_i) * k + std::max(other, best_i)].cost =
          std::numeric_limits<double>::quiet_NaN();
    }
    --alive;
    ++merges;
  }
  return merges;
}

}  // namespace skinspheres::lib
