// Step 4 of the tightening pass: the most exposed sphere not yet tried is cut in two across a
// principal axis of its triangles' centroids (median cuts), or into patches when it is a shell,
// and the cut is taken when the searched pieces expose at most split_gain of the sphere. See
// sphere_tightener.h.
#include <Eigen/Eigenvalues>
#include <algorithm>
#include <limits>

#include "tightener.h"

namespace skinspheres::lib {

int Tightener::SplitLoop(bool* reached_target) {
  *reached_target = false;
  if (!(st_.split_gain > 0.0f)) return 0;
  int splits = 0;
  std::vector<uint8_t> tried(sp_.size(), 0);
  // Exposures are cached; a split refreshes the two halves and the spheres around them.
  // The stopping test sums the accurate exposure (TriangleDistance); the ranking uses the fast one.
  std::vector<double> exposure(sp_.size()), area(sp_.size()), accurate(sp_.size());
  double sum_e = 0.0, sum_a = 0.0;
  for (size_t s = 0; s < sp_.size(); ++s) {
    exposure[s] = ExposureOf(s, &area[s], &accurate[s]);
    sum_e += accurate[s];
    sum_a += area[s];
  }
  const double target = static_cast<double>(st_.target_standoff) * height_;
  while (sp_.size() < static_cast<size_t>(std::max(0, st_.max_spheres))) {
    // Σ E / Σ exposed area: the mean distance from the union's boundary to the mesh.
    if (target > 0.0 && sum_a > 0.0 && sum_e <= target * sum_a) {
      *reached_target = true;
      break;
    }
    size_t best = sp_.size();
    for (size_t s = 0; s < sp_.size(); ++s) {
      if (tried[s] || sp_[s].triangles.size() < 2 || !(exposure[s] > 0.0)) continue;
      if (best == sp_.size() || exposure[s] > exposure[best]) best = s;
    }
    if (best == sp_.size()) break;
    const Ball old{sp_[best].center, sp_[best].radius};
    const size_t count_before = sp_.size();
    int added = TrySplitInTwo(best, exposure[best]) ? 1 : 0;
    if (!added && sp_.size() + kPatches - 1 <= static_cast<size_t>(st_.max_spheres)) {
      added = TrySplitIntoPatches(best, exposure[best], kPatches);
    }
    if (added) {
      splits += added;
      tried.resize(sp_.size(), 0);
      exposure.resize(sp_.size(), 0.0);
      area.resize(sp_.size(), 0.0);
      accurate.resize(sp_.size(), 0.0);
      // The spheres whose exposure the split can change: those meeting the old sphere or a piece.
      auto meets = [&](size_t o, const Eigen::Vector3f& c, float r) {
        const float lim = sp_[o].radius + r;
        return (sp_[o].center - c).squaredNorm() < lim * lim;
      };
      for (size_t o = 0; o < sp_.size(); ++o) {
        bool touched = o == best || o >= count_before || meets(o, old.center, old.radius) ||
                       meets(o, sp_[best].center, sp_[best].radius);
        for (size_t n = count_before; n < sp_.size() && !touched; ++n) touched = meets(o, sp_[n].center, sp_[n].radius);
        if (touched) {
          double a = 0.0, x = 0.0;
          const double e = ExposureOf(o, &a, &x);
          // A sphere the split left more exposed is worth another try.
          if (e > exposure[o]) tried[o] = 0;
          sum_e += x - accurate[o];
          sum_a += a - area[o];
          exposure[o] = e;
          area[o] = a;
          accurate[o] = x;
        }
      }
    } else {
      tried[best] = 1;
    }
  }
  return splits;
}

// Each principal axis gives a median cut. The `searched_cuts` cuts whose halves, as minimum balls,
// expose least have both halves centre-searched against each other; the best is taken if it pays
// and its halves are not stacked.
bool Tightener::TrySplitInTwo(size_t s, double before) {
  const auto& tris = sp_[s].triangles;
  std::vector<Eigen::Vector3f> cen(tris.size());
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (size_t k = 0; k < tris.size(); ++k) {
    const auto& tri = ch_.triangles[tris[k]];
    cen[k] = (ch_.positions_rest[tri[0]] + ch_.positions_rest[tri[1]] + ch_.positions_rest[tri[2]]) / 3.0f;
    mean += cen[k].cast<double>();
  }
  mean /= static_cast<double>(tris.size());
  Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
  for (const auto& c : cen) cov += (c.cast<double>() - mean) * (c.cast<double>() - mean).transpose();
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(cov);

  struct Cut {
    std::vector<uint32_t> a, b;
    std::vector<Eigen::Vector3f> pa, pb;
    Ball ma, mb;
    double exposure = std::numeric_limits<double>::infinity();
  };
  std::vector<Cut> cuts;
  std::vector<std::pair<double, uint32_t>> order(tris.size());
  for (int axis = 2; axis >= 0; --axis) {  // the longest axis first (stable sort keeps it on ties)
    const Eigen::Vector3d dir = eig.eigenvectors().col(axis);
    for (size_t k = 0; k < tris.size(); ++k) order[k] = {(cen[k].cast<double>() - mean).dot(dir), tris[k]};
    std::sort(order.begin(), order.end());
    Cut c;
    for (size_t k = 0; k < order.size(); ++k) (2 * k < order.size() ? c.a : c.b).push_back(order[k].second);
    if (c.a.empty() || c.b.empty()) continue;
    c.pa = Points(c.a);
    c.pb = Points(c.b);
    c.ma = MinimumBall(c.pa);
    c.mb = MinimumBall(c.pb);
    c.exposure = PairExposure(c.ma, c.mb, s);
    cuts.push_back(std::move(c));
  }
  std::stable_sort(cuts.begin(), cuts.end(), [](const Cut& x, const Cut& y) { return x.exposure < y.exposure; });
  if (cuts.size() > static_cast<size_t>(std::max(1, st_.searched_cuts)))
    cuts.resize(static_cast<size_t>(std::max(1, st_.searched_cuts)));
  double best = st_.split_gain * before;
  bool found = false;
  std::vector<uint32_t> best_a, best_b;
  Ball best_ba{}, best_bb{};
  float ref_a = 0.0f, ref_b = 0.0f;
  for (auto& c : cuts) {
    Ball ba = c.ma, bb = c.mb;
    for (int round = 0; round < 2; ++round) {
      Search(c.pa, &ba.center, &ba.radius, static_cast<long>(s), -1, std::span<const Ball>(&bb, 1), st_.split_passes);
      Search(c.pb, &bb.center, &bb.radius, static_cast<long>(s), -1, std::span<const Ball>(&ba, 1), st_.split_passes);
    }
    if (Stacked(ba, bb)) continue;
    const double after = PairExposure(ba, bb, s);
    if (after < best) {
      best = after;
      found = true;
      best_a = std::move(c.a);
      best_b = std::move(c.b);
      best_ba = ba;
      best_bb = bb;
      ref_a = c.ma.radius;
      ref_b = c.mb.radius;
    }
  }
  if (!found) return false;
  std::vector<Piece> pieces(2);
  pieces[0] = {std::move(best_a), best_ba.center, ref_a};
  pieces[1] = {std::move(best_b), best_bb.center, ref_b};
  ReplaceWithPieces(s, std::move(pieces));
  return true;
}

// A sphere whose triangles form a shell (a head's surface: any half has the same minimum ball)
// does not gain from a cut in two: it is cut into k patches instead (k-means on the triangle
// centroids from farthest-point seeds, 6 rounds), each patch's minimum ball centre-searched
// against the others; taken when the patches expose at most split_gain of the sphere.
// Returns the number of spheres added (k - 1) or 0.
int Tightener::TrySplitIntoPatches(size_t s, double before, int k) {
  const auto& tris = sp_[s].triangles;
  if (tris.size() < static_cast<size_t>(k)) return 0;
  std::vector<Eigen::Vector3f> cen(tris.size());
  Eigen::Vector3f mean = Eigen::Vector3f::Zero();
  for (size_t i = 0; i < tris.size(); ++i) {
    const auto& tri = ch_.triangles[tris[i]];
    cen[i] = (ch_.positions_rest[tri[0]] + ch_.positions_rest[tri[1]] + ch_.positions_rest[tri[2]]) / 3.0f;
    mean += cen[i];
  }
  mean /= static_cast<float>(tris.size());
  std::vector<Eigen::Vector3f> seeds;
  std::vector<float> d2(tris.size(), std::numeric_limits<float>::infinity());
  Eigen::Vector3f from = mean;
  while (seeds.size() < static_cast<size_t>(k)) {
    size_t far = 0;
    for (size_t i = 0; i < tris.size(); ++i) {
      d2[i] = std::min(d2[i], (cen[i] - from).squaredNorm());
      if (d2[i] > d2[far]) far = i;
    }
    if (seeds.empty()) d2.assign(tris.size(), std::numeric_limits<float>::infinity());
    seeds.push_back(cen[far]);
    from = cen[far];
  }
  std::vector<int> label(tris.size(), 0);
  for (int round = 0; round < 6; ++round) {
    for (size_t i = 0; i < tris.size(); ++i) {
      float best = std::numeric_limits<float>::infinity();
      for (int j = 0; j < k; ++j) {
        const float d = (cen[i] - seeds[j]).squaredNorm();
        if (d < best) best = d, label[i] = j;
      }
    }
    std::vector<Eigen::Vector3f> sum(k, Eigen::Vector3f::Zero());
    std::vector<int> count(k, 0);
    for (size_t i = 0; i < tris.size(); ++i) sum[label[i]] += cen[i], ++count[label[i]];
    for (int j = 0; j < k; ++j) {
      if (count[j] > 0) seeds[j] = sum[j] / static_cast<float>(count[j]);
    }
  }
  std::vector<std::vector<uint32_t>> groups(k);
  for (size_t i = 0; i < tris.size(); ++i) groups[label[i]].push_back(tris[i]);
  groups.erase(std::remove_if(groups.begin(), groups.end(), [](const auto& g) { return g.empty(); }), groups.end());
  if (groups.size() < 2) return 0;
  std::vector<std::vector<Eigen::Vector3f>> pts(groups.size());
  std::vector<Ball> balls(groups.size());
  std::vector<float> refs(groups.size());
  for (size_t j = 0; j < groups.size(); ++j) {
    pts[j] = Points(groups[j]);
    balls[j] = MinimumBall(pts[j]);
    refs[j] = balls[j].radius;
  }
  std::vector<Ball> others;
  for (size_t j = 0; j < groups.size(); ++j) {
    others = balls;
    others.erase(others.begin() + static_cast<std::ptrdiff_t>(j));
    Search(pts[j], &balls[j].center, &balls[j].radius, static_cast<long>(s), -1, others, st_.split_passes);
  }
  for (size_t i = 0; i < balls.size(); ++i) {
    for (size_t j = i + 1; j < balls.size(); ++j) {
      if (Stacked(balls[i], balls[j])) return 0;
    }
  }
  if (GroupExposure(balls, s) > st_.split_gain * before) return 0;
  std::vector<Piece> pieces(groups.size());
  for (size_t j = 0; j < groups.size(); ++j) pieces[j] = {std::move(groups[j]), balls[j].center, refs[j]};
  ReplaceWithPieces(s, std::move(pieces));
  return static_cast<int>(groups.size()) - 1;
}

void Tightener::ReplaceWithPieces(size_t s, std::vector<Piece> pieces) {
  const uint16_t part = sp_[s].part;
  const uint32_t origin = sp_[s].origin;
  sp_[s].triangles = std::move(pieces[0].triangles);
  sp_[s].center = pieces[0].center;
  sp_[s].reference_radius = pieces[0].reference_radius;
  Refresh(s);
  for (size_t j = 1; j < pieces.size(); ++j) {
    TightSphere t;
    t.part = part;
    t.origin = origin;
    t.triangles = std::move(pieces[j].triangles);
    t.center = pieces[j].center;
    t.reference_radius = pieces[j].reference_radius;
    sp_.push_back(std::move(t));
    pts_.emplace_back();
    Refresh(sp_.size() - 1);
  }
}

}  // namespace skinspheres::lib
