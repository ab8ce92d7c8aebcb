// The fitted set's spheres from the owned triangles: each sphere's radius is the holding radius of
// the vertices of the triangles it owns (growing where the paper's sphere left part of its patch
// outside, Figure 23, shrinking where it was larger). See fit_stages.h.
#include <algorithm>

#include "fit_stages.h"
#include "skinspheres/lib/geometry/mesh_helpers.h"

namespace skinspheres::lib {

void WriteOwnedSpheres(const RawCharacter& ch, const BodyParts& parts, const OwnedSpheres& owned,
                       runtime::SphereSet* set, FitReport* report) {
  const size_t joints = ch.skeleton.size();
  report->body_height = BodyHeight(ch.positions_rest);
  const float height = report->body_height > 0.0f ? report->body_height : 1.0f;
  UniqueVertices unique(ch.triangles, ch.vertex_count());
  set->vertex_offsets = {0};
  set->triangle_offsets = {0};
  double growth_sum = 0.0;
  std::vector<int> joint_tris(joints, 0);
  for (size_t s = 0; s < owned.spheres.size(); ++s) {
    const std::vector<uint32_t>& triangles = owned.triangles[s];
    if (triangles.empty()) {
      ++report->spheres_dropped;
      continue;
    }
    const Eigen::Vector3f c = owned.spheres[s].ball.center;
    std::vector<uint32_t> vlist = unique.Indices(triangles);
    std::sort(vlist.begin(), vlist.end());
    double max_sq = 0.0;
    for (uint32_t v : vlist)
      max_sq = std::max(max_sq, (ch.positions_rest[v].cast<double>() - c.cast<double>()).squaredNorm());
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
    // Dominant joint: the joint owning most of its triangles (ties: lowest index).
    for (uint32_t t : triangles) ++joint_tris[parts.triangle_joint[t]];
    int dom = 0;
    for (size_t j = 0; j < joints; ++j) {
      if (joint_tris[j] > joint_tris[dom]) dom = static_cast<int>(j);
    }
    for (uint32_t t : triangles) joint_tris[parts.triangle_joint[t]] = 0;

    set->centers_rest.push_back(c);
    set->radii_rest.push_back(radius);
    set->sphere_part.push_back(owned.part[s]);
    set->sphere_joint.push_back(static_cast<uint16_t>(dom));
    set->sphere_level.push_back(owned.spheres[s].level);
    set->vertices.insert(set->vertices.end(), vlist.begin(), vlist.end());
    set->vertex_offsets.push_back(static_cast<uint32_t>(set->vertices.size()));
    set->triangles.insert(set->triangles.end(), triangles.begin(), triangles.end());
    set->triangle_offsets.push_back(static_cast<uint32_t>(set->triangles.size()));
  }
  report->growth_mean = report->spheres_grown ? static_cast<float>(growth_sum / report->spheres_grown) : 0.0f;
}

}  // namespace skinspheres::lib
