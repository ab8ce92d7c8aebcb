// Triangle pieces for the fit (docs/TRIANGLE_PIECES.md): long triangles cut into the pieces of a
// regular grid, fitted as a finer mesh, and the ownership mapped back. See fit_stages.h.
#include <algorithm>
#include <cmath>
#include <map>

#include "fit_stages.h"
#include "skinspheres/lib/geometry/mesh_helpers.h"

namespace skinspheres::lib {

CutMesh CutLongTriangles(const RawCharacter& ch, const BodyParts& parts, float max_edge) {
  CutMesh cut;
  cut.ch.source_file = ch.source_file;
  cut.ch.skeleton = ch.skeleton;
  cut.ch.positions_rest = ch.positions_rest;
  cut.parts = parts;
  for (BodyPart& part : cut.parts.parts) part.triangles.clear();
  cut.parts.triangle_part.clear();
  cut.parts.triangle_joint.clear();
  auto add = [&](const Eigen::Vector3i& tri, uint32_t t, uint16_t level, uint16_t index) {
    const uint32_t id = static_cast<uint32_t>(cut.ch.triangles.size());
    cut.ch.triangles.push_back(tri);
    cut.origin.push_back({t, level, index});
    cut.parts.triangle_part.push_back(parts.triangle_part[t]);
    cut.parts.triangle_joint.push_back(parts.triangle_joint[t]);
    cut.parts.parts[static_cast<size_t>(parts.triangle_part[t])].triangles.push_back(id);
  };
  std::map<std::pair<uint8_t, uint8_t>, int32_t> vertex_at;  // this triangle's grid point -> cut vertex
  for (uint32_t t = 0; t < ch.triangle_count(); ++t) {
    const Eigen::Vector3i& tri = ch.triangles[t];
    const Eigen::Vector3f p[3] = {ch.positions_rest[tri[0]], ch.positions_rest[tri[1]], ch.positions_rest[tri[2]]};
    const float longest = std::max({(p[1] - p[0]).norm(), (p[2] - p[1]).norm(), (p[0] - p[2]).norm()});
    uint16_t level = 1;
    if (max_edge > 0.0f && longest > max_edge) {
      level = static_cast<uint16_t>(std::min<double>(std::ceil(double(longest) / max_edge), runtime::kMaxPieceLevel));
    }
    if (level < 2) {
      add(tri, t, 0, 0);
      continue;
    }
    vertex_at.clear();
    auto vertex = [&](uint8_t i, uint8_t j) -> int32_t {
      if (const int corner = runtime::GridCorner(level, i, j); corner >= 0) return tri[corner];
      auto [it, added] = vertex_at.emplace(std::make_pair(i, j), 0);
      if (added) {
        it->second = static_cast<int32_t>(cut.ch.positions_rest.size());
        cut.ch.positions_rest.push_back(runtime::GridPoint(p[0], p[1], p[2], level, i, j));
        cut.points.push_back({t, level, i, j});
      }
      return it->second;
    };
    for (uint16_t index = 0; index < level * level; ++index) {
      uint8_t c[3][2];
      runtime::PieceCorners(level, index, c);
      add(Eigen::Vector3i(vertex(c[0][0], c[0][1]), vertex(c[1][0], c[1][1]), vertex(c[2][0], c[2][1])), t, level,
          index);
    }
  }
  return cut;
}

void MapPiecesBack(const CutMesh& cut, OwnedSpheres* owned) {
  const size_t n = owned->spheres.size();
  // owner[k]: the sphere owning cut triangle k.
  std::vector<int32_t> owner(cut.origin.size(), -1);
  for (size_t s = 0; s < n; ++s) {
    for (uint32_t k : owned->triangles[s]) owner[k] = static_cast<int32_t>(s);
    owned->triangles[s].clear();
  }
  owned->pieces.assign(n, {});
  // A cut triangle's pieces are consecutive cut triangles, index 0 first; one owned by a single
  // sphere is owned whole.
  for (size_t k = 0; k < cut.origin.size();) {
    const runtime::TrianglePiece& o = cut.origin[k];
    const size_t count = o.level == 0 ? 1 : size_t{o.level} * o.level;
    bool one_owner = true;
    for (size_t q = k + 1; q < k + count; ++q) one_owner &= owner[q] == owner[k];
    if (one_owner) {
      owned->triangles[static_cast<size_t>(owner[k])].push_back(o.triangle);
    } else {
      for (size_t q = k; q < k + count; ++q) owned->pieces[static_cast<size_t>(owner[q])].push_back(cut.origin[q]);
    }
    k += count;
  }
}

}  // namespace skinspheres::lib
