// The fitted set's spheres from the owned triangles: each sphere's radius is the holding radius of
// the vertices of the triangles it owns (growing where the paper's sphere left part of its patch
// outside, Figure 23, shrinking where it was larger). See fit_stages.h.
#include <algorithm>
#include <map>
#include <tuple>

#include "fit_stages.h"
#include "skinspheres/lib/geometry/mesh_helpers.h"

namespace skinspheres::lib {

void WriteOwnedSpheres(const RawCharacter& ch, const BodyParts& parts, const OwnedSpheres& owned,
                       runtime::SphereSet* set, FitReport* report) {
  const size_t joints = ch.skeleton.size();
  const uint32_t source_vertices = static_cast<uint32_t>(ch.vertex_count());
  report->body_height = BodyHeight(ch.positions_rest);
  const float height = report->body_height > 0.0f ? report->body_height : 1.0f;
  UniqueVertices unique(ch.triangles, ch.vertex_count());
  set->vertex_offsets = {0};
  set->triangle_offsets = {0};
  const bool with_pieces =
      std::any_of(owned.pieces.begin(), owned.pieces.end(), [](const auto& list) { return !list.empty(); });
  set->piece_points.clear();
  set->pieces.clear();
  set->piece_offsets.assign(with_pieces ? 1 : 0, 0);
  std::map<std::tuple<uint32_t, uint16_t, uint8_t, uint8_t>, uint32_t> point_index;  // grid point -> point id
  double growth_sum = 0.0;
  std::vector<int> joint_tris(joints, 0);
  std::vector<uint32_t> vlist;
  for (size_t s = 0; s < owned.spheres.size(); ++s) {
    const std::vector<uint32_t>& triangles = owned.triangles[s];
    static const std::vector<runtime::TrianglePiece> kNone;
    const std::vector<runtime::TrianglePiece>& pieces = owned.pieces.empty() ? kNone : owned.pieces[s];
    if (triangles.empty() && pieces.empty()) {
      ++report->spheres_dropped;
      continue;
    }
    const Eigen::Vector3f c = owned.spheres[s].ball.center;
    vlist = unique.Indices(triangles);
    double max_sq = 0.0;
    for (uint32_t v : vlist)
      max_sq = std::max(max_sq, (ch.positions_rest[v].cast<double>() - c.cast<double>()).squaredNorm());
    for (const runtime::TrianglePiece& piece : pieces) {  // its corners: source vertices or grid points
      const Eigen::Vector3i& tri = ch.triangles[piece.triangle];
      uint8_t corners[3][2];
      runtime::PieceCorners(piece.level, piece.index, corners);
      for (const auto& g : corners) {
        const uint8_t i = g[0], j = g[1];
        uint32_t point;
        if (const int corner = runtime::GridCorner(piece.level, i, j); corner >= 0) {
          point = static_cast<uint32_t>(tri[corner]);
        } else {
          auto [it, added] = point_index.emplace(std::make_tuple(piece.triangle, piece.level, i, j),
                                                 source_vertices + static_cast<uint32_t>(set->piece_points.size()));
          if (added) set->piece_points.push_back({piece.triangle, piece.level, i, j});
          point = it->second;
        }
        vlist.push_back(point);
        const Eigen::Vector3f p = runtime::GridPoint(ch.positions_rest[tri[0]], ch.positions_rest[tri[1]],
                                                     ch.positions_rest[tri[2]], piece.level, i, j);
        max_sq = std::max(max_sq, (p.cast<double>() - c.cast<double>()).squaredNorm());
      }
    }
    std::sort(vlist.begin(), vlist.end());
    vlist.erase(std::unique(vlist.begin(), vlist.end()), vlist.end());
    const float radius = HoldingRadius(max_sq);
    const float fit_r = owned.spheres[s].ball.radius;
    if (radius > fit_r * (1.0f + 1e-5f)) {
      ++report->spheres_grown;
      const float g = (radius - fit_r) / height;
      report->growth_max = std::max(report->growth_max, g);
      growth_sum += g;
    } else if (radius < fit_r * (1.0f - 1e-5f)) {
      ++report->spheres_shrunk;
    }
    // Dominant joint: the joint owning most of its triangles and pieces (ties: lowest index).
    for (uint32_t t : triangles) ++joint_tris[parts.triangle_joint[t]];
    for (const runtime::TrianglePiece& piece : pieces) ++joint_tris[parts.triangle_joint[piece.triangle]];
    int dom = 0;
    for (size_t j = 0; j < joints; ++j) {
      if (joint_tris[j] > joint_tris[dom]) dom = static_cast<int>(j);
    }
    std::fill(joint_tris.begin(), joint_tris.end(), 0);

    set->centers_rest.push_back(c);
    set->radii_rest.push_back(radius);
    set->sphere_part.push_back(owned.part[s]);
    set->sphere_joint.push_back(static_cast<uint16_t>(dom));
    set->sphere_level.push_back(owned.spheres[s].level);
    set->vertices.insert(set->vertices.end(), vlist.begin(), vlist.end());
    set->vertex_offsets.push_back(static_cast<uint32_t>(set->vertices.size()));
    set->triangles.insert(set->triangles.end(), triangles.begin(), triangles.end());
    set->triangle_offsets.push_back(static_cast<uint32_t>(set->triangles.size()));
    if (with_pieces) {
      set->pieces.insert(set->pieces.end(), pieces.begin(), pieces.end());
      set->piece_offsets.push_back(static_cast<uint32_t>(set->pieces.size()));
    }
  }
  report->growth_mean = report->spheres_grown ? static_cast<float>(growth_sum / report->spheres_grown) : 0.0f;
}

}  // namespace skinspheres::lib
