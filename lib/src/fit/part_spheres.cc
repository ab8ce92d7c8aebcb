// Stages 1-3 of the fitter, per body part: the disk's path and traversal (paper §4.1, §5), then
// each level's spheres and the levels kept (level_spheres.cc). See fit_stages.h.
#include <algorithm>
#include <optional>

#include "fit_stages.h"
#include "skinspheres/lib/geometry/mesh_helpers.h"
#include "skinspheres/lib/geometry/triangle_bvh.h"

namespace skinspheres::lib {

Result<PartSpheres> FitPartSpheres(const RawCharacter& ch, const BodyPart& part, std::span<const Mat4f> rest_world,
                                   const FitSettings& settings) {
  PartSpheres result;
  result.report.name = part.name;
  result.report.triangles = static_cast<int>(part.triangles.size());
  if (part.triangles.empty()) return result;

  // The path: the part's bone chain in the rest pose, extended over its vertices.
  const std::vector<Eigen::Vector3f> verts =
      UniqueVertices(ch.triangles, ch.vertex_count()).Positions(ch.positions_rest, part.triangles);
  std::vector<Eigen::Vector3f> chain;
  for (int32_t j : part.chain) chain.push_back(rest_world[j].topRightCorner<3, 1>());
  const DiskPath path = BuildDiskPath(chain, verts);

  // The traversal: the disk's rays against the part's own triangles R, step δ.
  std::vector<int32_t> subset(part.triangles.begin(), part.triangles.end());
  auto bvh = TriangleBvh::Build(ch.positions_rest, ch.triangles, subset);
  if (!bvh.ok()) return bvh.error();
  Eigen::Vector3f lo = verts[0], hi = verts[0];
  for (const auto& v : verts) {
    lo = lo.cwiseMin(v);
    hi = hi.cwiseMax(v);
  }
  DiskSettings disk;
  disk.rays = settings.rays;
  disk.step = std::max(settings.step * path.length(), 1e-6f * (hi - lo).norm());  // δ
  disk.ray_length = 2.0f * (hi - lo).norm() + 1e-6f;
  const std::vector<DiskLevel> levels = TraverseDisk(*bvh, path, disk);
  result.report.levels_traversed = static_cast<int>(levels.size());

  // The spheres: p per level on the torso (the non-tubular case), 1 on tubular parts.
  const bool tubular = part.kind != PartKind::kTorso;
  const int p = (tubular && !settings.per_level_all_parts) ? 1 : settings.per_level;
  SelectLevels(levels, p, settings, &result);
  if (result.spheres.empty()) {
    // No ray met the part (a sliver, a flat patch in the disk plane): one sphere holds it all.
    CandidateSphere s;
    s.ball = MinimumBall(verts);
    result.spheres.push_back(s);
  }
  return result;
}

Result<std::vector<PartSpheres>> FitPaperSpheres(const RawCharacter& ch, const BodyParts& parts,
                                                 std::span<const Mat4f> rest_world, const FitSettings& settings) {
  std::vector<std::optional<Result<PartSpheres>>> fitted(parts.parts.size());
  ParallelIndices(parts.parts.size(),
                  [&](size_t k) { fitted[k] = FitPartSpheres(ch, parts.parts[k], rest_world, settings); });
  std::vector<PartSpheres> out;
  out.reserve(fitted.size());
  for (auto& f : fitted) {
    if (!f->ok()) return MakeError(f->error().code, ch.Name() + ": " + f->error().message);
    out.push_back(std::move(**f));
  }
  return out;
}

}  // namespace skinspheres::lib
