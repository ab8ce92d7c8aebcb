// Step 1 (and 5) of the tightening pass: pattern search on each sphere's centre, its radius
// following as the holding radius of its vertices. A minimum ball puts the centre in the middle of
// its patch; pushing it into the body flattens the outer cap. See sphere_tightener.h.
#include <algorithm>
#include <cmath>

#include "tightener.h"

namespace skinspheres::lib {
namespace {

// The 14 pattern-search directions: the 6 axes and the 8 diagonals.
const std::vector<Eigen::Vector3f>& SearchDirections() {
  static const std::vector<Eigen::Vector3f> dirs = [] {
    std::vector<Eigen::Vector3f> d;
    for (int x = -1; x <= 1; ++x) {
      for (int y = -1; y <= 1; ++y) {
        for (int z = -1; z <= 1; ++z) {
          const int nonzero = (x != 0) + (y != 0) + (z != 0);
          if (nonzero == 1 || nonzero == 3) d.push_back(Eigen::Vector3f(float(x), float(y), float(z)).normalized());
        }
      }
    }
    return d;
  }();
  return dirs;
}

// The search's estimate: the largest distance in float (Refresh recomputes the exact holding
// radius of whatever is kept).
float Reach(const std::vector<Eigen::Vector3f>& pts, const Eigen::Vector3f& c) {
  float m = 0.0f;
  for (const auto& p : pts) m = std::max(m, (p - c).squaredNorm());
  return std::sqrt(m);
}

}  // namespace

void Tightener::SearchAll() {
  for (size_t s = 0; s < sp_.size(); ++s) {
    if (pts_[s].empty()) continue;
    Search(pts_[s], &sp_[s].center, &sp_[s].radius, static_cast<long>(s), -1, {}, st_.passes);
  }
}

void Tightener::Search(const std::vector<Eigen::Vector3f>& pts, Eigen::Vector3f* c, float* r, long skip_a, long skip_b,
                       std::span<const Ball> extras, int passes) {
  *r = Reach(pts, *c);
  float step = 0.25f * *r;
  Neighbours(*c, *r + 2.0f * step, skip_a, skip_b, &nbrs_, extras);
  double best = Exposure(*c, *r, nbrs_);
  for (int pass = 0; pass < passes && step > 0.0f; ++pass) {
    Neighbours(*c, *r + 2.0f * step, skip_a, skip_b, &nbrs_, extras);
    // From c + step·d the farthest point is one at least r - 2·step from c (|p - c'| is within
    // step of |p - c|): only those are measured.
    const float lo = std::max(0.0f, *r - 2.0f * step);
    rim_.clear();
    for (const auto& p : pts) {
      if ((p - *c).squaredNorm() >= lo * lo) rim_.push_back(p);
    }
    Eigen::Vector3f best_c = *c;
    float best_r = *r;
    for (const auto& d : SearchDirections()) {
      const Eigen::Vector3f cc = *c + step * d;
      const float rr = Reach(rim_, cc);
      const double e = Exposure(cc, rr, nbrs_);
      if (e < best) best = e, best_c = cc, best_r = rr;
    }
    if (best_c == *c) {
      step *= 0.5f;
    } else {
      *c = best_c;
      *r = best_r;
    }
  }
}

}  // namespace skinspheres::lib
