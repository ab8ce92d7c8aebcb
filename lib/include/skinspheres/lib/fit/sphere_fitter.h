// FitSpheres: RawCharacter + BodyParts -> SphereSet, by the disk-of-rays method of the paper
// "Sphere Approximation for Non-tubular Objects" (section numbers below are its sections), plus
// safety and tightness passes of our own.
//
// The stages, in the order FitSpheres runs them (each in its own file under lib/src/fit/):
//  0. Validate the input: settings, the character (RawCharacter::Validate), finite coordinates within 1e18,
//     parts that partition the triangles and name existing joints; then the rest pose, refused
//     as degenerate when a joint's rest transform or a skinned vertex's rest skinning matrix is
//     singular (the runtime inverts them) or the mesh has no extent or no height.
// Per part (torso, head, arms, legs, or chains), parts in parallel:
//  1. Disk traversal (§4.1, §5; disk_traversal.h): Nr rays, step δ = step × the part's path length.
//  2. Spheres per level (§4.2-4.4): the level's contact points are split into p contiguous angular
//     sectors of the disk (p = 1, 2 or 4; sectors are centred on the principal axes of the
//     section so an ellipse is cut across its long axis), and each sector gets a sphere by
//     M1 (centroid), M2 (Welzl's minimum ball) or M1-A (M1 adjusted, §4.4)
//     (geometry/enclosing_sphere.h). Tubular parts (limbs, head) use p = 1 unless
//     `per_level_all_parts`; the torso, the non-tubular case, uses `per_level`.
//  3. Levels (§4.3): walking the disk levels in order, a level is kept when its spheres overlap the
//     last kept level's by at most the penetration depth PD: when the distance along the path d
//     satisfies d >= (1 - PD)(r̄_prev + r̄_new), r̄ the mean radius of a level's spheres (PD = 0:
//     spheres just touch; 0.5: they overlap by half). The path's last level is always kept.
// Then for the whole character:
//  4. Beyond the paper, safety (ownership): every triangle of a part is owned by exactly one sphere
//     of that part, the nearest: the one whose centre is closest to the triangle's farthest vertex
//     (ties: lowest index; preferring least growth instead lets one large sphere swallow its
//     neighbours' triangles and measured looser on every character). Then `refine_iterations`
//     rounds move each sphere to the minimum ball of the vertices it owns and redo the ownership
//     (tighter; the paper's spheres are the starting point and what F is reported on). Then, unless
//     `tighten` is off, the tightening pass (tighten/sphere_tightener.h) lowers the union's
//     exposure (its surface outside the other spheres, weighted by the distance to the mesh):
//     centre search, hand-over of rim triangles another sphere of the part already holds, merging
//     of stacked spheres, merging down to the budget max_spheres when there are more, and
//     splitting while it pays by split_gain, up to max_spheres. Spheres
//     that own nothing are dropped. Each kept sphere's radius is the holding radius
//     (geometry/enclosing_sphere.h) of the vertices of its triangles: growing where the paper's
//     sphere left part of its patch outside (Figure 23), shrinking where it was larger than its
//     patch. Its source vertices are those vertices.
//  5. Fast-refit data: per sphere, the joints influencing its source vertices with their mean
//     weights, and radius_fast covering every rest copy of every source vertex carried rigidly by
//     each of its bind entries (see runtime/sphere_set.h).
//  6. The mesh: the character's skin (bind positions, bind entries, influences) and its triangles,
//     so the runtime can test triangles and skin single vertices (sphere-set version 2); and from
//     it each sphere influence's reach, the largest weight a source vertex gives that joint, which
//     tightens the fast refit (runtime/sphere_set.h, influence_reach).
//  7. The contact rules (runtime narrow_phase/contact_rules.h), stated on the mesh's triangles: rule 2
//     at `contact_hops`, rule 3's rest gap of `rest_gap` of the rest height, and the sphere pairs rule 2 excludes whole
//     (the only pairs the broad phase never reports).
// Finally a self-check proves, in double precision, every triangle inside its owner in the bind
// pose. The result does not depend on the thread count.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "skinspheres/lib/body_parts/body_parts.h"
#include "skinspheres/lib/character/raw_character.h"
#include "skinspheres/runtime/error.h"
#include "skinspheres/runtime/format/sphere_set.h"

namespace skinspheres::lib {

enum class SphereMethod { kM1, kM2, kM1A };
const char* ToString(SphereMethod method);  // "m1", "m2", "m1a"; "?" outside the enum

struct FitSettings {
  int rays = 80;                     // Nr (α = 360°/Nr), 3..65535
  int per_level = 2;                 // p for the torso (non-tubular): 1, 2 or 4
  bool per_level_all_parts = false;  // also use p for limbs and head (the paper's comparison)
  SphereMethod method = SphereMethod::kM1A;
  float overlap = 0.3f;  // PD in [0, 1)
  float step = 0.02f;    // δ as a fraction of each part's path length, (0, 1]
  // The contact rules (runtime narrow_phase/contact_rules.h): triangles whose joints are at most
  // contact_hops bones apart (0..2) are never a contact, nor triangles closer than rest_gap of the
  // rest height at rest ([0, runtime::kMaxRestGapShare]).
  int contact_hops = 1;
  float rest_gap = 0.01f;
  // Refinement after ownership: rounds of "each sphere becomes the minimum ball of the vertices it
  // owns, then ownership is redone" (0 keeps the paper's centres and only grows/shrinks radii).
  int refine_iterations = 2;
  // The tightening pass (tighten/sphere_tightener.h): centre search, hand-over, merging, then
  // splitting. A sphere is split when its searched halves expose at most split_gain of what it
  // exposes (0: never split), the most exposed sphere first, until there are max_spheres spheres.
  // max_spheres is a budget: when the paper's spheres are more, the pairs of a part whose joint
  // ball adds least volume are merged down to it first (also with tighten off); it must be at
  // least the number of body parts that have triangles (each needs a sphere). false: the paper's
  // spheres after ownership and refine only (docs/FIT_REPORT.md compares both). Splitting stops early once the union
  // stands off the body by target_standoff of the body height on average (as the pass estimates it; 0: split while it
  // pays): tight enough for a mean standoff of 1.5% of the height (the target tests/lib/metrics/tightness_tests.cc
  // holds the fit to) with margin, without spending spheres (and run time) where they buy little.
  // Splitting runs in rounds (sphere_tightener.h): after a round that split something without
  // reaching target_standoff, the spheres are searched, handed triangles and merged, and splitting is
  // tried again; such a round is kept only when it lowers the estimated standoff by 1%. At most
  // split_rounds rounds in all (1..64; 1: one greedy loop).
  bool tighten = true;
  float split_gain = 0.9f;
  int split_rounds = 8;
  int max_spheres = 200;
  float target_standoff = 0.0125f;
  // Triangle pieces (docs/TRIANGLE_PIECES.md): a triangle whose longest edge at rest exceeds this
  // share of the body height is cut into the pieces of a regular grid (at most 16 x 16), which
  // spheres may own apart; 0: every triangle stays whole.
  float piece_edge = 0.0f;
  // The reach groups' blends (runtime docs/REFIT.md#group-blends): tighter fast spheres where a
  // sphere's vertices blend joints (fast sphere pairs per frame: CesiumMan -43%, Soldier -24%), for
  // a fast refit about 50-75% slower (about +1 µs for Xbot's 77 spheres; a 10,000-Xbot crowd
  // 10-20% more CPU, docs/PERFORMANCE.md). true: stored where they pay, i.e. where they make the
  // fast radii summed over eight fixed poses at least 0.75% smaller (CesiumMan, Soldier,
  // RobotExpressive, the built-in character; not Xbot); false: never.
  bool group_blends = true;

  // The first reason the settings are refused (kInvalidArgument; the message names the setting by the
  // tool's flag, `--split-rounds`, its range and the value given), or nullopt when they are fine.
  std::optional<Error> Validate() const;
  std::string ToJson() const;  // the "params" object of the sphere-set file
};

struct PartFitReport {
  std::string name;
  int levels_traversed = 0;  // disk positions
  int levels_kept = 0;
  int spheres = 0;
  int triangles = 0;
  int rays_cast = 0, rays_hit = 0;
  float f_mean = 0.0f, f_max = 0.0f;  // the paper's F over the kept levels' contact points
};

struct FitReport {
  std::vector<PartFitReport> parts;
  float body_height = 0.0f;   // extent along +Y of the rest-pose mesh
  int triangles_covered = 0;  // triangles proven inside their owner sphere
  int spheres_grown = 0;      // spheres whose radius grew to hold their triangles
  float growth_max = 0.0f;    // largest growth, relative to body height
  float growth_mean = 0.0f;   // mean growth over the grown spheres, relative to body height
  int spheres_shrunk = 0;
  int spheres_dropped = 0;        // owned no triangle
  int spheres_split = 0;          // splits taken by the tightening pass, over its rounds (merges may undo some)
  int split_rounds = 0;           // its rounds of splitting kept (FitSettings::split_rounds)
  int triangles_handed_over = 0;  // triangles it moved to another sphere that already held them
  int spheres_merged = 0;
  int spheres_merged_for_budget = 0;  // pairs merged to meet max_spheres
  // The union's mean standoff from the body as the tightening pass estimates it (relative to the
  // body height; fit_metrics.h measures it exactly): before and after the pass (0 without it).
  float standoff_before = 0.0f, standoff_after = 0.0f;
  float f_mean = 0.0f, f_max = 0.0f;
  double seconds = 0.0;
};

struct FitResult {
  runtime::SphereSet spheres;
  FitReport report;
};

// Fits the character. Errors, each message naming the character (or "fit settings"):
// kInvalidArgument (settings), kInvalidData (an invalid character, a degenerate rest pose, parts
// that do not belong to it, or a fitted set that fails SphereSet::Validate), kCheckFailed (the bind-pose check found a
// triangle outside its sphere: a bug, reported rather than hidden).
Result<FitResult> FitSpheres(const RawCharacter& character, const BodyParts& parts, const FitSettings& settings);

// The bind-pose proof: every triangle's three vertices inside its owner sphere, and every piece's
// three corners of a cut triangle inside the piece's owner (in double, with a relative tolerance of
// 1e-6 of the radius). Returns the number of triangles outside (0 = sound);
// `first_bad` gets the first offending triangle. Triangles owned by no sphere count as outside.
int CountUncoveredTriangles(const RawCharacter& character, const runtime::SphereSet& spheres, int* first_bad = nullptr);

}  // namespace skinspheres::lib
