// Stage 7 of the fitter: the mesh itself in the set (sphere-set version 2), for triangle-level tests
// and per-vertex skinning at run time. See fit_stages.h.
#include "fit_stages.h"

namespace skinspheres::lib {

void WriteSetMesh(const RawCharacter& ch, runtime::SphereSet* set) {
  const bool have_skin = ch.skin.influence_offsets.size() == ch.vertex_count() + 1;
  if (!have_skin || ch.triangle_count() == 0) return;
  set->mesh = ch.skin;
  set->triangle_vertices.reserve(3 * ch.triangle_count());
  for (const Eigen::Vector3i& t : ch.triangles) {
    for (int c = 0; c < 3; ++c) set->triangle_vertices.push_back(static_cast<uint32_t>(t[c]));
  }
}

}  // namespace skinspheres::lib
