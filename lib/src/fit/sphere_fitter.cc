// FitSpheres: the fitter's stages in order (sphere_fitter.h; each stage in fit_stages.h and its own
// file).
#include "skinspheres/lib/fit/sphere_fitter.h"

#include <chrono>
#include <optional>

#include "fit_stages.h"
#include "skinspheres/lib/geometry/mesh_helpers.h"

namespace skinspheres::lib {

Result<FitResult> FitSpheres(const RawCharacter& ch, const BodyParts& parts, const FitSettings& settings) {
  const auto start = std::chrono::steady_clock::now();
  if (auto error = ValidateFitInput(ch, parts, settings)) return *error;
  std::vector<Mat4f> rest_world(ch.skeleton.size());
  ch.skeleton.RestWorld(rest_world);
  if (auto error = ValidateRestPose(ch, rest_world)) return *error;

  // 0b. Long triangles cut into pieces: stages 1-4 fit the cut mesh, whose ownership is then
  // mapped back (docs/TRIANGLE_PIECES.md).
  std::optional<CutMesh> cut;
  if (settings.piece_edge > 0.0f) {
    cut = CutLongTriangles(ch, parts, settings.piece_edge * BodyHeight(ch.positions_rest));
    if (cut->points.empty()) cut.reset();  // nothing that long
  }
  const RawCharacter& fitted = cut ? cut->ch : ch;
  const BodyParts& fitted_parts = cut ? cut->parts : parts;

  // 1-3. The paper's spheres, part by part.
  auto paper = FitPaperSpheres(fitted, fitted_parts, rest_world, settings);
  if (!paper.ok()) return paper.error();
  // 4. Ownership and refinement, then the tightening pass.
  auto owned = AssignOwnership(fitted, fitted_parts, *paper, settings.refine_iterations);
  if (!owned.ok()) return owned.error();
  if (auto error = CheckSphereBudget(fitted, *owned, settings)) return *error;
  FitResult out;
  if (settings.tighten || owned->spheres.size() > static_cast<size_t>(settings.max_spheres)) {
    TightenOwnedSpheres(fitted, settings, &*owned, &out.report);  // (with tighten off: the budget only)
  }
  if (cut) MapPiecesBack(*cut, &*owned);

  // The set: what it describes and its spheres, 5. excluded pairs, 6. fast-refit data, 7. the mesh
  // (and the influences' reach and the fast refit's reference frame, which need it).
  WriteSetHeader(ch, parts, settings, rest_world, &out.spheres);
  WriteOwnedSpheres(ch, parts, *owned, &out.spheres, &out.report);
  WriteExcludedPairs(ch.skeleton, settings, &out.spheres);
  WriteFastRefitData(ch, rest_world, &out.spheres);
  WriteSetMesh(ch, &out.spheres);
  WriteInfluenceReach(&out.spheres);
  HoldMeshCopies(&out.spheres);
  WriteFastReference(&out.spheres);
  WriteReachGroups(&out.spheres);

  // The self-check: a consistent set, every triangle inside its owner in the bind pose.
  if (auto error = CheckFittedSet(ch, out.spheres)) return *error;
  SummarisePartReports(*paper, out.spheres, &out.report);  // reads the pieces: after Validate()
  out.report.triangles_covered = static_cast<int>(ch.triangle_count());
  out.report.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return out;
}

}  // namespace skinspheres::lib
