// The fitter's tightening pass: exposure-driven centre search, hand-over and splitting. See
// sphere_tightener.h.
#include "skinspheres/lib/tighten/sphere_tightener.h"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <span>
#include <tuple>
#include <utility>

#include "skinspheres/lib/geometry/distance_field.h"
#include "skinspheres/lib/geometry/enclosing_sphere.h"
#include "skinspheres/lib/geometry/fibonacci_directions.h"
#include "skinspheres/lib/geometry/mesh_helpers.h"

namespace skinspheres::lib {
namespace {

constexpr float kRimFraction = 0.9f;  // hand-over looks at triangles beyond this share of the radius
constexpr float kMergeSlack = 1.05f;  // merge two spheres of a part whose joint ball is this close
constexpr int kPatches = 6;           // a shell that a cut in two does not help is cut into this many

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

// One ball (nearly) inside the other: such a pair hides each other's surface, so their exposure
// under-counts what the union stands off; the pass neither makes nor keeps such pairs.
bool Stacked(const Ball& a, const Ball& b) {
  return (a.center - b.center).norm() + std::min(a.radius, b.radius) <= kMergeSlack * std::max(a.radius, b.radius);
}

class Tightener {
 public:
  Tightener(const RawCharacter& ch, const TightenSettings& settings, std::vector<TightSphere>& spheres)
      : ch_(ch), st_(settings), sp_(spheres), unique_(ch.triangles, ch.vertex_count()) {
    field_ = DistanceField::Build(ch.positions_rest, ch.triangles, settings.field_resolution);
    unit_ = FibonacciDirections(std::max(1, settings.samples));
    height_ = BodyHeight(ch.positions_rest);
    pts_.resize(sp_.size());
    for (size_t s = 0; s < sp_.size(); ++s) Refresh(s);
  }

  // Σ E (accurate distances) and the mean standoff Σ E / Σ exposed area relative to the height.
  std::pair<double, double> TotalExposure() {
    double area = 0.0, acc = 0.0;
    for (size_t s = 0; s < sp_.size(); ++s) {
      double a = 0.0, x = 0.0;
      ExposureOf(s, &a, &x);
      area += a;
      acc += x;
    }
    return {acc, area > 0.0 && height_ > 0.0f ? acc / area / height_ : 0.0};
  }

  void SearchAll() {
    for (size_t s = 0; s < sp_.size(); ++s) {
      if (pts_[s].empty()) continue;
      Search(pts_[s], &sp_[s].center, &sp_[s].radius, static_cast<long>(s), -1, {}, st_.passes);
    }
  }

  // Step 2. Returns the number of triangles handed over.
  int HandOver() {
    std::vector<size_t> order(sp_.size());
    for (size_t k = 0; k < order.size(); ++k) order[k] = k;
    std::stable_sort(order.begin(), order.end(), [&](size_t a, size_t b) { return sp_[a].radius > sp_[b].radius; });
    int moved = 0;
    std::vector<uint32_t> keep;
    for (size_t s : order) {
      if (sp_[s].triangles.empty()) continue;
      keep.clear();
      const float rim2 = kRimFraction * kRimFraction * sp_[s].radius * sp_[s].radius;
      for (uint32_t t : sp_[s].triangles) {
        const Eigen::Vector3f* v[3] = {&ch_.positions_rest[ch_.triangles[t][0]], &ch_.positions_rest[ch_.triangles[t][1]],
                                       &ch_.positions_rest[ch_.triangles[t][2]]};
        float need2 = 0.0f;
        for (const auto* p : v) need2 = std::max(need2, (*p - sp_[s].center).squaredNorm());
        long dest = -1;
        if (need2 > rim2) {
          for (size_t o = 0; o < sp_.size() && dest < 0; ++o) {
            if (o == s || sp_[o].part != sp_[s].part || sp_[o].triangles.empty()) continue;
            const float r2 = sp_[o].radius * sp_[o].radius;
            bool inside = true;
            for (const auto* p : v) inside = inside && (*p - sp_[o].center).squaredNorm() <= r2;
            if (inside) dest = static_cast<long>(o);
          }
        }
        if (dest >= 0) {
          sp_[dest].triangles.push_back(t);
          ++moved;
        } else {
          keep.push_back(t);
        }
      }
      sp_[s].triangles.swap(keep);
      Refresh(s);  // at once: later spheres must not hand triangles back to its old, larger radius
    }
    // Radii become the holding radii of what each sphere now owns: a receiving sphere held its new
    // triangles already, so it does not grow; a giving one may shrink.
    for (size_t s = 0; s < sp_.size(); ++s) Refresh(s);
    return moved;
  }

  // Removes spheres that own nothing. Returns how many.
  int DropEmpty() {
    size_t out = 0;
    for (size_t s = 0; s < sp_.size(); ++s) {
      if (sp_[s].triangles.empty()) continue;
      if (out != s) {
        sp_[out] = std::move(sp_[s]);
        pts_[out] = std::move(pts_[s]);
      }
      ++out;
    }
    const int dropped = static_cast<int>(sp_.size() - out);
    sp_.resize(out);
    pts_.resize(out);
    return dropped;
  }

  // Merges spheres of one part that nearly coincide: when the minimum ball of two spheres'
  // vertices is at most kMergeSlack times the larger radius, the pair becomes that ball (the
  // splitting that follows then cuts the region once instead of leaving stacked spheres that each
  // hide the others' surface). Returns the number of merges.
  int MergeStacked() {
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

  // Step 3. Returns the number of splits taken.
  int SplitLoop() {
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
      if (target > 0.0 && sum_a > 0.0 && sum_e <= target * sum_a) break;
      size_t best = sp_.size();
      for (size_t s = 0; s < sp_.size(); ++s) {
        if (tried[s] || sp_[s].triangles.size() < 2 || !(exposure[s] > 0.0)) continue;
        if (best == sp_.size() || exposure[s] > exposure[best]) best = s;
      }
      if (best == sp_.size()) break;
      const Ball old{sp_[best].center, sp_[best].radius};
      const size_t count_before = sp_.size();
      int added = TrySplit(best, exposure[best]) ? 1 : 0;
      if (!added && sp_.size() + kPatches - 1 <= static_cast<size_t>(st_.max_spheres)) {
        added = TrySplitK(best, exposure[best], kPatches);
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
          bool touched = o == best || o >= count_before || meets(o, old.center, old.radius) || meets(o, sp_[best].center, sp_[best].radius);
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

  void Finish() {
    for (auto& s : sp_) std::sort(s.triangles.begin(), s.triangles.end());
  }

 private:
  void Refresh(size_t s) {
    pts_[s] = Points(sp_[s].triangles);
    // The unpadded holding radius: the fitter holds the spheres it keeps again, with the pad.
    sp_[s].radius = pts_[s].empty() ? 0.0f : HoldingRadius(pts_[s], sp_[s].center, 0.0);
  }

  // The vertices of `tris`, once each, in first-seen order.
  std::vector<Eigen::Vector3f> Points(const std::vector<uint32_t>& tris) {
    return unique_.Positions(ch_.positions_rest, tris);
  }

  // The search's estimate: the largest distance in float (Refresh recomputes the exact holding
  // radius of whatever is kept).
  static float Reach(const std::vector<Eigen::Vector3f>& pts, const Eigen::Vector3f& c) {
    float m = 0.0f;
    for (const auto& p : pts) m = std::max(m, (p - c).squaredNorm());
    return std::sqrt(m);
  }

  // Spheres (other than skip_a / skip_b) whose surface a ball within `reach` of c can meet, as
  // structure-of-arrays padded to a multiple of 8 with balls that cover nothing (r² = -1), so the
  // coverage test below is a branch-free loop the compiler vectorises.
  struct Nbrs {
    std::vector<float> x, y, z, r2;
    void clear() { x.clear(), y.clear(), z.clear(), r2.clear(); }
    void push(const Eigen::Vector3f& c, float r) { x.push_back(c.x()), y.push_back(c.y()), z.push_back(c.z()), r2.push_back(r * r); }
    void pad() {
      while (x.size() % 8 != 0) push(Eigen::Vector3f::Zero(), 0.0f), r2.back() = -1.0f;
    }
    size_t size() const { return x.size(); }
  };
  void Neighbours(const Eigen::Vector3f& c, float reach, long skip_a, long skip_b, Nbrs* out,
                  std::span<const Ball> extras = {}) const {
    out->clear();
    for (const auto& e : extras) out->push(e.center, e.radius);
    for (size_t o = 0; o < sp_.size(); ++o) {
      if (static_cast<long>(o) == skip_a || static_cast<long>(o) == skip_b || sp_[o].triangles.empty()) continue;
      const float lim = sp_[o].radius + reach;
      if ((sp_[o].center - c).squaredNorm() < lim * lim) out->push(sp_[o].center, sp_[o].radius);
    }
    out->pad();
  }

  // E(c, r) from the fast distance lookup. Optionally *exposed_area gets the area of its surface
  // inside no neighbour, and *accurate the same E with the closer TriangleDistance.
  double Exposure(const Eigen::Vector3f& c, float r, const Nbrs& nbrs, double* exposed_area = nullptr,
                  double* accurate = nullptr) const {
    double acc = 0.0;
    double e = 0.0;
    int exposed = 0;
    const size_t n = nbrs.size();
    const float* nx = nbrs.x.data();
    const float* ny = nbrs.y.data();
    const float* nz = nbrs.z.data();
    const float* nr2 = nbrs.r2.data();
    for (const auto& u : unit_) {
      const Eigen::Vector3f q = c + r * u;
      const float qx = q.x(), qy = q.y(), qz = q.z();
      int hits = 0;
      for (size_t k = 0; k < n; ++k) {
        const float dx = qx - nx[k], dy = qy - ny[k], dz = qz - nz[k];
        hits += (dx * dx + dy * dy + dz * dz < nr2[k]) ? 1 : 0;
      }
      if (hits == 0) {
        e += field_.Distance(q);
        if (accurate) acc += field_.TriangleDistance(q);
        ++exposed;
      }
    }
    const double patch = 4.0 * std::numbers::pi * double(r) * r / static_cast<double>(unit_.size());
    if (exposed_area) *exposed_area = exposed * patch;
    if (accurate) *accurate = acc * patch;
    return e * patch;
  }

  double ExposureOf(size_t s, double* exposed_area = nullptr, double* accurate = nullptr) {
    Neighbours(sp_[s].center, sp_[s].radius, static_cast<long>(s), -1, &nbrs_);
    return Exposure(sp_[s].center, sp_[s].radius, nbrs_, exposed_area, accurate);
  }

  // Exposure of balls that together replace sphere s, each covering the others.
  double GroupExposure(std::span<const Ball> group, size_t s) {
    double e = 0.0;
    std::vector<Ball> others;
    for (size_t i = 0; i < group.size(); ++i) {
      others.assign(group.begin(), group.end());
      others.erase(others.begin() + static_cast<std::ptrdiff_t>(i));
      Neighbours(group[i].center, group[i].radius, static_cast<long>(s), -1, &nbrs_, others);
      e += Exposure(group[i].center, group[i].radius, nbrs_);
    }
    return e;
  }
  double PairExposure(const Ball& a, const Ball& b, size_t s) {
    const Ball g[2] = {a, b};
    return GroupExposure(g, s);
  }

  // Step 1 for one ball holding `pts`: pattern search on its centre (radius = holding radius).
  void Search(const std::vector<Eigen::Vector3f>& pts, Eigen::Vector3f* c, float* r, long skip_a, long skip_b,
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

  bool TrySplit(size_t s, double before) {
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

    // Each principal axis gives a median cut. The `searched_cuts` cuts whose halves, as minimum
    // balls, expose least have both halves centre-searched against each other; the best is taken
    // if it pays and its halves are not stacked.
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
    if (cuts.size() > static_cast<size_t>(std::max(1, st_.searched_cuts))) cuts.resize(static_cast<size_t>(std::max(1, st_.searched_cuts)));
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
    TightSphere second;
    second.part = sp_[s].part;
    second.origin = sp_[s].origin;
    second.triangles = std::move(best_b);
    second.center = best_bb.center;
    second.reference_radius = ref_b;
    sp_[s].triangles = std::move(best_a);
    sp_[s].center = best_ba.center;
    sp_[s].reference_radius = ref_a;
    Refresh(s);
    sp_.push_back(std::move(second));
    pts_.emplace_back();
    Refresh(sp_.size() - 1);
    return true;
  }

  // A sphere whose triangles form a shell (a head's surface: any half has the same minimum ball)
  // does not gain from a cut in two: it is cut into k patches instead (k-means on the triangle
  // centroids from farthest-point seeds, 6 rounds), each patch's minimum ball centre-searched
  // against the others; taken when the patches expose at most split_gain of the sphere.
  // Returns the number of spheres added (k - 1) or 0.
  int TrySplitK(size_t s, double before, int k) {
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
    sp_[s].triangles = std::move(groups[0]);
    sp_[s].center = balls[0].center;
    sp_[s].reference_radius = refs[0];
    Refresh(s);
    for (size_t j = 1; j < groups.size(); ++j) {
      TightSphere t;
      t.part = sp_[s].part;
      t.origin = sp_[s].origin;
      t.triangles = std::move(groups[j]);
      t.center = balls[j].center;
      t.reference_radius = refs[j];
      sp_.push_back(std::move(t));
      pts_.emplace_back();
      Refresh(sp_.size() - 1);
    }
    return static_cast<int>(groups.size()) - 1;
  }

  const RawCharacter& ch_;
  const TightenSettings& st_;
  std::vector<TightSphere>& sp_;
  DistanceField field_;
  std::vector<Eigen::Vector3f> unit_;
  std::vector<std::vector<Eigen::Vector3f>> pts_;  // each sphere's vertices, once each
  Nbrs nbrs_;                                      // scratch
  std::vector<Eigen::Vector3f> rim_;               // scratch
  UniqueVertices unique_;                          // for Points()
  float height_ = 0.0f;                            // body extent along +Y
};

}  // namespace

TightenReport TightenSpheres(const RawCharacter& character, const TightenSettings& settings,
                             std::vector<TightSphere>* spheres) {
  TightenReport rep;
  Tightener t(character, settings, *spheres);
  rep.dropped += t.DropEmpty();
  std::tie(rep.exposure_before, rep.standoff_before) = t.TotalExposure();
  for (int round = 0; round < settings.search_rounds; ++round) t.SearchAll();
  rep.triangles_handed_over += t.HandOver();
  rep.merges = t.MergeStacked();
  rep.dropped += t.DropEmpty();
  rep.splits = t.SplitLoop();
  for (int round = 0; round < settings.search_rounds; ++round) t.SearchAll();
  rep.triangles_handed_over += t.HandOver();
  rep.merges += t.MergeStacked();
  rep.dropped += t.DropEmpty();
  t.Finish();
  std::tie(rep.exposure_after, rep.standoff_after) = t.TotalExposure();
  return rep;
}

}  // namespace skinspheres::lib
