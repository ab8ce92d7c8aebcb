// The tightening pass's state and its stages (tighten/sphere_tightener.h), internal to lib/.
//
// A Tightener holds the spheres being tightened (each with its owned triangles and those triangles'
// vertices), the distance field D that scores them, and the N sampling directions of the exposure
// E(S) = Σ_k [c + r·u_k inside no other sphere] · D(c + r·u_k) · 4πr²/N. Each sphere's radius is
// always the unpadded holding radius of its vertices (Refresh). The stages, each in its own file:
//   exposure.cc       Neighbours, Exposure and its sums (what every decision is scored on)
//   centre_search.cc  step 1 (and 5): pattern search on each centre
//   hand_over.cc      step 2 (and 5): rim triangles to a sphere of the part that already holds them
//   merge.cc          step 3 (and 5): stacked spheres of a part become one; empty ones are dropped
//   split.cc          step 4: the most exposed sphere cut in two (or into patches) while it pays
// sphere_tightener.cc runs them in order. Sequential and deterministic.
#pragma once

#include <Eigen/Core>
#include <algorithm>
#include <cstdint>
#include <span>
#include <utility>
#include <vector>

#include "skinspheres/lib/geometry/distance_field.h"
#include "skinspheres/lib/geometry/enclosing_sphere.h"
#include "skinspheres/lib/geometry/mesh_helpers.h"
#include "skinspheres/lib/tighten/sphere_tightener.h"

namespace skinspheres::lib {

inline constexpr float kRimFraction = 0.9f;  // hand-over looks at triangles beyond this share of the radius
inline constexpr float kMergeSlack = 1.05f;  // merge two spheres of a part whose joint ball is this close
inline constexpr int kPatches = 6;           // a shell that a cut in two does not help is cut into this many
inline constexpr double kRoundGain = 0.01;   // a split round after the first must lower the standoff this much

// One ball (nearly) inside the other: such a pair hides each other's surface, so their exposure
// under-counts what the union stands off; the pass neither makes nor keeps such pairs.
inline bool Stacked(const Ball& a, const Ball& b) {
  return (a.center - b.center).norm() + std::min(a.radius, b.radius) <= kMergeSlack * std::max(a.radius, b.radius);
}

class Tightener {
 public:
  // Builds the distance field and the directions, and gives every sphere its vertices and radius.
  Tightener(const RawCharacter& ch, const TightenSettings& settings, std::vector<TightSphere>& spheres);

  // Σ E (accurate distances) and the mean standoff Σ E / Σ exposed area relative to the height.
  std::pair<double, double> TotalExposure();
  // Step 1: every sphere's centre searched in turn (centre_search.cc).
  void SearchAll();
  // Step 2. Returns the number of triangles handed over (hand_over.cc).
  int HandOver();
  // Step 3: merges spheres of one part that nearly coincide. Returns the number of merges.
  int MergeStacked();
  // Step 3b: merges the cheapest pairs of a part until at most `budget` spheres own triangles (or
  // one is left per part). Returns the number of merges (merge.cc).
  int MergeToBudget(size_t budget);
  // Removes spheres that own nothing. Returns how many.
  int DropEmpty();
  // Step 4. Returns the number of spheres added by splits (split.cc); *reached_target tells whether
  // it stopped at the target standoff (rather than at the budget or because no split paid).
  int SplitLoop(bool* reached_target);
  // Sorts every sphere's triangles (the output contract).
  void Finish();
  // The spheres and their vertices, to try a round of changes and take it back.
  struct Snapshot {
    std::vector<TightSphere> spheres;
    std::vector<std::vector<Eigen::Vector3f>> points;
  };
  Snapshot Save() const { return {sp_, pts_}; }
  void Restore(Snapshot&& s) {
    sp_ = std::move(s.spheres);
    pts_ = std::move(s.points);
  }

 private:
  // Spheres (other than skip_a / skip_b) whose surface a ball within `reach` of c can meet, as
  // structure-of-arrays padded to a multiple of 8 with balls that cover nothing (r² = -1), so the
  // coverage test in Exposure is a branch-free loop the compiler vectorises.
  struct Nbrs {
    std::vector<float> x, y, z, r2;
    void clear() { x.clear(), y.clear(), z.clear(), r2.clear(); }
    void push(const Eigen::Vector3f& c, float r) {
      x.push_back(c.x()), y.push_back(c.y()), z.push_back(c.z()), r2.push_back(r * r);
    }
    void pad() {
      while (x.size() % 8 != 0) push(Eigen::Vector3f::Zero(), 0.0f), r2.back() = -1.0f;
    }
    size_t size() const { return x.size(); }
  };
  // One piece of a sphere being split: its triangles, its searched centre, and the radius its
  // growth is measured against (the minimum ball of its vertices).
  struct Piece {
    std::vector<uint32_t> triangles;
    Eigen::Vector3f center = Eigen::Vector3f::Zero();
    float reference_radius = 0.0f;
  };

  // Sphere s's vertices and its holding radius, after its triangles or centre changed.
  void Refresh(size_t s);
  // The vertices of `tris`, once each, in first-seen order.
  std::vector<Eigen::Vector3f> Points(const std::vector<uint32_t>& tris);

  // exposure.cc
  void Neighbours(const Eigen::Vector3f& c, float reach, long skip_a, long skip_b, Nbrs* out,
                  std::span<const Ball> extras = {}) const;
  // E(c, r) from the fast distance lookup. Optionally *exposed_area gets the area of its surface
  // inside no neighbour, and *accurate the same E with the closer TriangleDistance.
  double Exposure(const Eigen::Vector3f& c, float r, const Nbrs& nbrs, double* exposed_area = nullptr,
                  double* accurate = nullptr) const;
  double ExposureOf(size_t s, double* exposed_area = nullptr, double* accurate = nullptr);
  // Exposure of balls that together replace sphere s, each covering the others.
  double GroupExposure(std::span<const Ball> group, size_t s);
  double PairExposure(const Ball& a, const Ball& b, size_t s);

  // centre_search.cc: step 1 for one ball holding `pts`, pattern search on its centre (its radius
  // following as the largest distance to `pts`), against the other spheres (but skip_a, skip_b)
  // and `extras`.
  void Search(const std::vector<Eigen::Vector3f>& pts, Eigen::Vector3f* c, float* r, long skip_a, long skip_b,
              std::span<const Ball> extras, int passes);

  // split.cc
  bool TrySplitInTwo(size_t s, double before);
  int TrySplitIntoPatches(size_t s, double before, int k);
  // Sphere s becomes pieces[0]; the other pieces are appended with its part and origin. Each gets
  // its vertices and holding radius.
  void ReplaceWithPieces(size_t s, std::vector<Piece> pieces);

  const RawCharacter& ch_;
  const TightenSettings& st_;
  std::vector<TightSphere>& sp_;
  DistanceField field_;  // empty in budget-only mode (TightenSettings::budget_only), which reads none
  std::vector<Eigen::Vector3f> unit_;
  std::vector<std::vector<Eigen::Vector3f>> pts_;  // each sphere's vertices, once each
  Nbrs nbrs_;                                      // scratch
  std::vector<Eigen::Vector3f> rim_;               // scratch
  UniqueVertices unique_;                          // for Points()
  float height_ = 0.0f;                            // body extent along +Y
};

}  // namespace skinspheres::lib
