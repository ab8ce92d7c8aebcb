// TightenSpheres: the fitter's tightening pass, beyond the paper. Spheres that already own and hold
// triangles (every triangle of the input owned by exactly one sphere of its part) are moved, split,
// and handed triangles so the union of the spheres stands closer to the body, keeping ownership
// exact at every step (each sphere's radius is always the unpadded holding radius of the vertices of
// the triangles it owns: HoldingRadius(..., pad = 0) of geometry/enclosing_sphere.h; the fitter
// holds the spheres it keeps again with the pad).
//
// Objective, the EXPOSURE of a sphere S = (c, r): the part of its surface that lies inside no
// other sphere, weighted by how far it stands from the mesh,
//     E(S) = Σ_k [c + r·u_k inside no other sphere] · D(c + r·u_k) · 4πr²/N
// over N Fibonacci directions u_k (geometry/fibonacci_directions.h), D the distance to the mesh.
// Σ_S E(S) is a sampled integral of the distance from the union's boundary to the surface, the
// figure metrics/fit_metrics.h reports (there area-normalised and exact); a smaller sphere, or one whose
// surface follows the body or hides inside its neighbours, exposes less.
//
// D is a DistanceField (geometry/distance_field.h): the nearest voxel's closest point while searching, the
// distance to that voxel's closest triangle (closer to exact) where the pass reports or stops.
//
// Steps (part of stage 4 of fit/sphere_fitter.h), each in its own file under lib/src/tighten/:
//  1. Centre search: each sphere in turn moves its centre by pattern search (14 directions: the
//     axes and the diagonals, step 1/4 of its radius halved whenever no move lowers E, `passes`
//     times), its radius following as the holding radius of its triangles. A minimum ball puts the
//     centre in the middle of its patch; pushing it into the body flattens the outer cap.
//  2. Hand-over: a triangle on a sphere's rim (farthest vertex beyond 0.9 r) that another sphere of
//     its part already holds whole moves to that sphere, which does not grow; the first shrinks.
//  3. Merge: two spheres of a part whose joint minimum ball is within 5% of the larger radius
//     become that ball (stacked spheres hide each other's surface, so splitting one alone never
//     pays). Spheres left with no triangle are dropped.
//  3b. Budget: while more than `max_spheres` spheres are left, the pair of one part whose joint
//     minimum ball adds least volume to what the pair covers, vol(ball) - vol(a ∪ b), becomes that
//     ball (a part keeps at least one sphere; the fitter refuses a budget below its part count).
//  4. Splitting, the most exposed sphere not yet tried first: its triangles are cut in two across
//     the principal axes of their centroids (median cuts); the `searched_cuts` cuts whose halves'
//     minimum balls expose least have both halves centre-searched against each other, and the
//     best is taken when it exposes at most `split_gain` times the sphere. If none pays (a shell,
//     such as a head's surface, whose halves keep the whole's minimum ball) the sphere is cut into
//     6 patches instead (k-means on the centroids from farthest-point seeds), under the same test.
//     A sphere a split left more exposed may be tried again. Splitting stops at `max_spheres`, or
//     once the union's mean standoff Σ E / Σ exposed area is at most `target_standoff` of the body
//     height (extent along +Y), or when nothing pays.
//  5. Centre search, hand-over and merge again.
//  Steps 4 and 5 are repeated, at most `split_rounds` times in all, while the last round split
//  something and did not reach the target standoff: moved, merged and handed over, the spheres offer
//  splits that did not pay before, and merges free some of the budget. A further round is kept only
//  when it lowers the estimated mean standoff (Σ E / Σ exposed area) by 1%; otherwise it is undone
//  and the rounds stop. Each round is greedy; together they spend the budget where one greedy loop
//  stops early (docs/FIT_REPORT.md, "Split rounds").
// Guarantees: every input triangle ends up owned by exactly one sphere of its own part, and inside
// it (radius = max distance from the float centre to its vertices, computed in double and rounded
// up to float); at most max(max_spheres, parts with triangles) spheres are left; the result is a pure
// function of the inputs (sequential, no randomness), so independent of threads.
// Cost: Xbot (49k triangles, 84 spheres in) ~100 ms on one core, most of it the field and the
// searches (bench/fitter_bench.cc).
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <vector>

#include "skinspheres/lib/character/raw_character.h"

namespace skinspheres::lib {

struct TightSphere {
  Eigen::Vector3f center = Eigen::Vector3f::Zero();
  float radius = 0.0f;            // holding radius of `triangles` around `center` (recomputed)
  float reference_radius = 0.0f;  // what growth is measured against: the paper's radius in, the
                                  // minimum ball of a half for spheres made by a split
  uint16_t part = 0;
  uint32_t origin = 0;              // index of the input sphere it descends from
  std::vector<uint32_t> triangles;  // owned triangles (ascending on output)
};

struct TightenSettings {
  int max_spheres = 200;     // the budget (all parts together): merged down to it, split up to it
  bool budget_only = false;  // only step 3b (the fitter without its tightening pass)
  // Splitting also stops once the union's estimated mean standoff, Σ E / Σ exposed area, is at
  // most this fraction of the body height (extent along +Y); 0: split while it pays.
  float target_standoff = 0.0125f;
  float split_gain = 0.9f;    // take a split when the halves expose <= this x the sphere; 0: never
  int search_rounds = 1;      // centre-search rounds before and after splitting (0: no search)
  int split_rounds = 8;       // rounds of steps 4-5 at most (1: one greedy split loop)
  int passes = 5;             // pattern-search passes per centre search
  int split_passes = 3;       // the same for the halves of a tentative split
  int searched_cuts = 2;      // of the 3 median cuts, how many (least exposed first) are searched
  int samples = 48;           // N, directions per sphere for the exposure
  int field_resolution = 64;  // DistanceField voxels along the body's largest extent
};

struct TightenReport {
  int splits = 0;         // spheres added by splitting, over the rounds kept (a later merge may undo some)
  int split_rounds = 0;   // rounds of steps 4-5 kept
  int merges = 0;         // stacked pairs merged (steps 3 and 5, over the rounds kept)
  int budget_merges = 0;  // pairs merged to meet max_spheres (step 3b)
  int triangles_handed_over = 0;
  int dropped = 0;               // spheres removed for owning nothing (after hand-over or merge)
  double exposure_before = 0.0;  // Σ E over the input spheres (model units³)
  double exposure_after = 0.0;
  double standoff_before = 0.0;  // Σ E / Σ exposed area, relative to the body height
  double standoff_after = 0.0;
};

// Tightens `spheres` in place (see above). Spheres without triangles are removed; triangles of the
// input must index `character.triangles`. Returns what it did.
TightenReport TightenSpheres(const RawCharacter& character, const TightenSettings& settings,
                             std::vector<TightSphere>* spheres);

}  // namespace skinspheres::lib
