// What a fitted set describes: its source, the settings, the skeleton and the parts. See
// fit_stages.h.
#include "fit_stages.h"

namespace skinspheres::lib {

void WriteSetHeader(const RawCharacter& ch, const BodyParts& parts, const FitSettings& settings,
                    std::span<const Mat4f> rest_world, runtime::SphereSet* set) {
  set->source_file = ch.source_file;
  set->source_vertex_count = static_cast<uint32_t>(ch.vertex_count());
  set->source_triangle_count = static_cast<uint32_t>(ch.triangle_count());
  set->params_json = settings.ToJson();
  set->joint_names = ch.skeleton.joint_names;
  set->joint_parents = ch.skeleton.parents;
  set->joint_rest_world.assign(rest_world.begin(), rest_world.end());
  for (const auto& p : parts.parts) {
    runtime::SpherePart sp;
    sp.name = p.name;
    for (int32_t j : p.joints) {
      if (j >= 0) sp.joints.push_back(static_cast<uint32_t>(j));
    }
    set->parts.push_back(std::move(sp));
  }
}

}  // namespace skinspheres::lib
