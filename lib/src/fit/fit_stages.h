// The stages of FitSpheres (fit/sphere_fitter.h), in the order it runs them. Internal to lib/.
//
//   0. ValidateFitInput, then          validate_input.cc
//      ValidateRestPose (on rest_world)
//   1-3. FitPaperSpheres, per part:     part_spheres.cc (§4.1 disk traversal: fit/disk_traversal.h;
//        §4.2 and §4.4 LevelSpheres, §4.3 SelectLevels: level_spheres.cc)
//   4. AssignOwnership (and refine)     ownership.cc
//      TightenOwnedSpheres              tightening.cc (the pass itself: tighten/sphere_tightener.h)
//   the set: WriteSetHeader             set_header.cc
//            WriteOwnedSpheres          owned_spheres.cc (holding radii, source vertices)
//   5. WriteFastRefitData               fast_refit_data.cc
//   6. WriteSetMesh                     set_mesh.cc
//      WriteInfluenceReach              fast_refit_data.cc
//      HoldMeshCopies                   fast_refit_data.cc
//      WriteFastReference               fast_refit_data.cc
//      WriteReachGroups                 fast_refit_data.cc
//   report: SummarisePartReports        fit_report.cc
//   self-check: CheckFittedSet          bind_pose_check.cc
#pragma once

#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "skinspheres/lib/fit/disk_traversal.h"
#include "skinspheres/lib/fit/sphere_fitter.h"
#include "skinspheres/lib/geometry/enclosing_sphere.h"
#include "skinspheres/runtime/format/sphere_set.h"
#include "skinspheres/skinning/math_types.h"
#include "skinspheres/skinning/parallel_for.h"

namespace skinspheres::lib {

// 0. Validate the input: the settings, then the character (RawCharacter::Validate, then finite
// coordinates within 1e18) and the parts (they partition the triangles, name existing joints).
// Messages name the character (the settings' begin with "fit settings: ").
std::optional<Error> ValidateFitInput(const RawCharacter& ch, const BodyParts& parts, const FitSettings& settings);
// 0. Then the rest pose (`rest_world`: the skeleton's rest world transforms), refused as degenerate
// (kInvalidData, "<character>: degenerate rest pose: <why>") when nothing can be fitted to it or the
// runtime could not refit what would be: a joint whose rest transform is singular, a skinned vertex
// whose rest skinning matrix is singular, or a mesh with no extent or no height.
std::optional<Error> ValidateRestPose(const RawCharacter& ch, std::span<const Mat4f> rest_world);

// f(k) for every k in [0, n), in parallel through the library's ParallelFor (TBB by default; a
// ThreadSanitizer build swaps in threads the checker can see). Each call writes only its own slots.
template <typename F>
void ParallelIndices(size_t n, F f) {
  DefaultParallelFor()(n, 1, [&f](size_t begin, size_t end) {
    for (size_t k = begin; k < end; ++k) f(k);
  });
}

// One sphere of a part before ownership.
struct CandidateSphere {
  Ball ball;  // as fitted by M1 / M2 / M1-A on its sector
  uint16_t level = 0;
  FitErrorStats f;  // the paper's F on its sector's contact points
  int points = 0;
};

// The paper's spheres of one part, levels in path order, and what it took.
struct PartSpheres {
  std::vector<CandidateSphere> spheres;
  PartFitReport report;
};

// 1-3. The paper's spheres of every part (parts in parallel, each in its own slot): the disk path
// and traversal (§4.1, §5), each level's spheres (§4.2, §4.4), the levels kept (§4.3).
Result<std::vector<PartSpheres>> FitPaperSpheres(const RawCharacter& ch, const BodyParts& parts,
                                                 std::span<const Mat4f> rest_world, const FitSettings& settings);
// The same for one part. A part no ray meets gets one sphere, the minimum ball of its vertices.
Result<PartSpheres> FitPartSpheres(const RawCharacter& ch, const BodyPart& part, std::span<const Mat4f> rest_world,
                                   const FitSettings& settings);

// §4.2 (and §4.4 for M1-A): the spheres of one disk level, its contact points split into p
// contiguous angular sectors of the rays, centred on the section's principal axes. Fewer than two
// contacts give none.
std::vector<CandidateSphere> LevelSpheres(const DiskLevel& level, int rays, int p, SphereMethod method);
// §4.3: walks the levels in path order and keeps a level's spheres when they overlap the last kept
// level's by at most PD (settings.overlap); the path's last level with spheres is always kept.
// Appends the kept spheres (numbered by kept level) to out->spheres and fills the report's ray, F
// and level counts.
void SelectLevels(std::span<const DiskLevel> levels, int p, const FitSettings& settings, PartSpheres* out);

// The spheres after ownership: per sphere its ball (centre: where it stands; radius: the radius its
// growth is measured against), its part and the triangles it owns (ascending; empty: dropped), and,
// once mapped back from a cut mesh (MapPiecesBack), the pieces of cut triangles it owns (pieces
// empty, or one list per sphere).
struct OwnedSpheres {
  std::vector<CandidateSphere> spheres;
  std::vector<uint16_t> part;
  std::vector<std::vector<uint32_t>> triangles;
  std::vector<std::vector<runtime::TrianglePiece>> pieces;
};

// 0b. Triangle pieces (docs/TRIANGLE_PIECES.md): every triangle whose longest rest edge exceeds
// max_edge (> 0) is cut at the smallest level L <= runtime::kMaxPieceLevel that brings its pieces'
// edges to at most max_edge, into the L² pieces of its grid; stages 1-4 then fit the cut mesh, on
// which a piece is a triangle and a grid point a vertex (its rest position runtime::GridPoint of the
// triangle's, as the runtime computes it). The cut character has the skeleton, rest positions and
// triangles only (no skin, no clips: stages 1-4 read nothing else); the parts are the same, each
// piece in its triangle's part and with its dominant joint.
struct CutMesh {
  RawCharacter ch;
  BodyParts parts;
  std::vector<runtime::TrianglePiece> origin;  // per cut triangle: source triangle, level (0: whole), index
  std::vector<runtime::PiecePoint> points;     // per cut vertex from the source's vertex count on
};
CutMesh CutLongTriangles(const RawCharacter& ch, const BodyParts& parts, float max_edge);
// The ownership of the cut mesh's triangles in source terms: a cut triangle whose pieces one sphere
// owns is owned whole, else each sphere owns its pieces (owned->pieces).
void MapPiecesBack(const CutMesh& cut, OwnedSpheres* owned);

// 4. Ownership: each triangle goes to the sphere of its part whose centre is nearest its farthest
// vertex; then `refine_iterations` rounds move each sphere to the minimum ball of the vertices it
// owns and redo the ownership, and a last re-centring on what each finally owns.
Result<OwnedSpheres> AssignOwnership(const RawCharacter& ch, const BodyParts& parts, std::span<const PartSpheres> paper,
                                     int refine_iterations);

// The budget is reachable: kInvalidArgument when settings.max_spheres is below the number of parts
// that own triangles (each keeps at least one sphere), naming the character and both counts.
std::optional<Error> CheckSphereBudget(const RawCharacter& ch, const OwnedSpheres& owned, const FitSettings& settings);

// 4, beyond the paper: the tightening pass on the owned spheres (those owning nothing are dropped
// first), or with settings.tighten off its budget step alone. Fills the report's dropped, split,
// hand-over, merge and standoff figures.
void TightenOwnedSpheres(const RawCharacter& ch, const FitSettings& settings, OwnedSpheres* owned, FitReport* report);

// What the set describes: source file, vertex and triangle counts, the settings (params_json), the
// skeleton (names, parents, rest world transforms) and the parts (names, joints).
void WriteSetHeader(const RawCharacter& ch, const BodyParts& parts, const FitSettings& settings,
                    std::span<const Mat4f> rest_world, runtime::SphereSet* set);
// The spheres that own triangles or pieces, in order: centre, holding radius (with the pad) of their
// points (the vertices of their whole triangles, the corners of their pieces: grid points listed in
// set->piece_points once each), those points (ascending), the triangles and pieces, the dominant
// joint (the joint owning most of its triangles and pieces; ties: lowest index), level and part.
// Fills the report's body height and growth figures, and counts the dropped spheres.
void WriteOwnedSpheres(const RawCharacter& ch, const BodyParts& parts, const OwnedSpheres& owned,
                       runtime::SphereSet* set, FitReport* report);
// 5. Fast-refit data: per sphere, the joints influencing its source vertices with their mean
// weights, and radius_fast holding, for every source vertex, the weighted mean distance of its rest
// copies carried rigidly by each of its bind entries (at least the sphere's radius; refit_job.h).
void WriteFastRefitData(const RawCharacter& ch, std::span<const Mat4f> rest_world, runtime::SphereSet* set);
// 6. The mesh (sphere-set version 2): the skin as imported and the triangles in file order, when
// the character has a skin and triangles.
void WriteSetMesh(const RawCharacter& ch, runtime::SphereSet* set);
// 7b. Per sphere influence, its reach from the mesh just written (runtime::InfluenceReachFromMesh:
// the largest weight any source vertex of the sphere gives that joint), which tightens the fast
// refit bound; none without a mesh.
void WriteInfluenceReach(runtime::SphereSet* set);

// 7b'. radius_fast raised, where it falls short, to each vertex's mean copy distance as the runtime
// computes it from the set's mesh (runtime::FastBoundVerticesFromMesh): a rigid mesh's bind entry holds a float
// inverse of its rest transform, whose rounding can put a copy a few ulps past the radius.
void HoldMeshCopies(runtime::SphereSet* set);

// 7c. The fast refit's reference frame (runtime::ChooseFastReference): the bind pose when the rest
// pose is not the bind pose and it bounds the spheres tighter; none otherwise.
void WriteFastReference(runtime::SphereSet* set);

// 7d. The fast bound's reach groups (runtime/sphere_set.h): per sphere of two or more joints, its
// source vertices in up to four k-means groups by their weights, each group's reference radius and
// reach the largest of its members'; one group otherwise. Never looser than one group.
void WriteReachGroups(runtime::SphereSet* set);

// 7. The contact rules (runtime::WriteContactRules, narrow_phase/contact_rules.h): rule 2 at
// settings.contact_hops, rule 3 with a rest gap of settings.rest_gap of the rest height, and the
// excluded sphere pairs (those rule 2 excludes whole). After the mesh: they
// are stated on its triangles. kInvalidData when the mesh cannot be skinned at rest.
std::optional<Error> WriteContactRules(const FitSettings& settings, runtime::SphereSet* set);

// The per-part reports with their final sphere counts, and the paper's F over all parts (weighted
// by the contact points).
void SummarisePartReports(std::span<const PartSpheres> paper, const runtime::SphereSet& set, FitReport* report);

// The self-check: the set is consistent (SphereSet::Validate: kInvalidData) and every triangle is
// inside its owner in the bind pose (CountUncoveredTriangles: kCheckFailed).
std::optional<Error> CheckFittedSet(const RawCharacter& ch, const runtime::SphereSet& set);

}  // namespace skinspheres::lib
