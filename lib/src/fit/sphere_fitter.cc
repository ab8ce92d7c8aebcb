// FitSpheres: the fitter's stages in order (sphere_fitter.h; each stage in fit_stages.h and its own
// file).
#include "skinspheres/lib/fit/sphere_fitter.h"

#include <Eigen/Geometry>
#include <chrono>
#include <cstdint>
#include <optional>

#include "fit_stages.h"
#include "skinspheres/lib/geometry/mesh_helpers.h"
#include "skinspheres/runtime/refit/refit_job.h"
#include "skinspheres/skinning/local_to_model_job.h"

namespace skinspheres::lib {

namespace {

// Whether the reach groups' blends (runtime docs/REFIT.md#group-blends) tighten the fast spheres
// enough to pay for the fast refit's extra work (about 50-75%): the fast radii summed over eight
// fixed poses (every joint turned by 0.2-0.8 rad about an axis drawn from its index, by integer
// hashing, so the same poses on every platform and thread count) must be at least 0.75% smaller
// with them than without. Measured (with / without): CesiumMan 0.903, Soldier 0.948,
// RobotExpressive 0.974 and the built-in character 0.991 keep them; Xbot (0.994), whose spheres
// barely blend joints (1% fewer fast sphere pairs on its clips; its 10,000-instance crowd is the
// fast refit's heaviest user), does not.
bool GroupBlendsPay(const RawCharacter& ch, const runtime::SphereSet& set) {
  if (set.reach_group_blend.empty()) return false;
  runtime::SphereSet without = set;
  without.reach_group_blend.clear();
  without.reach_group_deviation.clear();
  auto with_rest = runtime::RefitRestData::Create(set);
  auto without_rest = runtime::RefitRestData::Create(without);
  if (!with_rest.ok() || !without_rest.ok()) return false;
  const size_t joints = ch.skeleton.size();
  std::vector<skinning::Transform> local;
  std::vector<Mat4f> world(joints);
  std::vector<Vec4f> a(set.size()), b(set.size());
  double sum_with = 0.0, sum_without = 0.0;
  const auto unit = [](uint32_t h) { return static_cast<float>(h % 2001u) / 1000.0f - 1.0f; };  // [-1, 1]
  for (uint32_t pose = 0; pose < 8; ++pose) {
    local = ch.skeleton.rest_local;
    for (size_t j = 0; j < joints; ++j) {
      const uint32_t h = static_cast<uint32_t>(j) * 2654435761u + pose * 40503u + 1u;
      Eigen::Vector3f axis(unit(h), unit(h * 7919u + 17u), unit(h * 104729u + 31u));
      if (axis.norm() < 1e-3f) axis = Eigen::Vector3f::UnitX();
      const float angle = 0.2f + 0.6f * static_cast<float>((h >> 8) % 1001u) / 1000.0f;
      local[j].rotation = (local[j].rotation * Quatf(Eigen::AngleAxisf(angle, axis.normalized()))).normalized();
    }
    if (!skinning::LocalToModelJob{&ch.skeleton, Mat4f::Identity(), local, world}.Run()) return false;
    if (!runtime::RefitJob{runtime::RefitMode::kFast, &set, &*with_rest, world, {}, a}.Run() ||
        !runtime::RefitJob{runtime::RefitMode::kFast, &without, &*without_rest, world, {}, b}.Run()) {
      return false;
    }
    for (size_t s = 0; s < set.size(); ++s) sum_with += a[s].w(), sum_without += b[s].w();
  }
  return sum_with < 0.9925 * sum_without;
}

}  // namespace

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

  // The set: what it describes and its spheres, 5. fast-refit data, 6. the mesh (and the
  // influences' reach and the fast refit's reference frame, which need it), 7. the contact rules.
  WriteSetHeader(ch, parts, settings, rest_world, &out.spheres);
  WriteOwnedSpheres(ch, parts, *owned, &out.spheres, &out.report);
  WriteFastRefitData(ch, rest_world, &out.spheres);
  WriteSetMesh(ch, &out.spheres);
  WriteInfluenceReach(&out.spheres);
  HoldMeshCopies(&out.spheres);
  WriteFastReference(&out.spheres);
  WriteReachGroups(&out.spheres);
  if (!settings.group_blends || !GroupBlendsPay(ch, out.spheres)) {
    out.spheres.reach_group_blend.clear();
    out.spheres.reach_group_deviation.clear();
  }
  // 7. The contact rules, on the mesh's triangles.
  if (auto error = WriteContactRules(settings, &out.spheres)) return *error;

  // The self-check: a consistent set, every triangle inside its owner in the bind pose.
  if (auto error = CheckFittedSet(ch, out.spheres)) return *error;
  SummarisePartReports(*paper, out.spheres, &out.report);  // reads the pieces: after Validate()
  out.report.triangles_covered = static_cast<int>(ch.triangle_count());
  out.report.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return out;
}

}  // namespace skinspheres::lib
