// Stage 6 of the fitter: what the runtime's fast refit needs (runtime/sphere_set.h). See
// fit_stages.h.
#include <algorithm>

#include "fit_stages.h"
#include "skinspheres/runtime/refit/refit_job.h"

namespace skinspheres::lib {

void WriteFastRefitData(const RawCharacter& ch, std::span<const Mat4f> rest_world, runtime::SphereSet* set) {
  const size_t joints = ch.skeleton.size();
  // M_b(rest) = G_joint(b)(rest) · IBM_b: where each bind entry carries a bind-space vertex at rest.
  std::vector<Eigen::Matrix4d> bind_rest(ch.skin.binds.size());
  for (size_t b = 0; b < ch.skin.binds.size(); ++b) {
    bind_rest[b] = (rest_world[ch.skin.binds[b].joint] * ch.skin.binds[b].inverse_bind).cast<double>();
  }
  const bool have_skin = ch.skin.influence_offsets.size() == ch.vertex_count() + 1;
  set->influence_offsets = {0};
  std::vector<double> joint_weight(joints, 0.0);
  for (size_t s = 0; s < set->size(); ++s) {
    const Eigen::Vector3f c = set->centers_rest[s];
    const std::span<const uint32_t> vlist =
        std::span(set->vertices).subspan(set->vertex_offsets[s], set->vertex_offsets[s + 1] - set->vertex_offsets[s]);
    // Joints influencing the source vertices (mean weights) and the radius holding every rest copy
    // M_b(rest)·p_bind of every source vertex for each of its entries, and the vertices themselves.
    double fast_sq = 0.0;
    for (uint32_t v : vlist)
      fast_sq = std::max(fast_sq, (ch.positions_rest[v].cast<double>() - c.cast<double>()).squaredNorm());
    if (have_skin) {
      for (uint32_t v : vlist) {
        const Eigen::Vector4d pb(ch.skin.positions_bind[v].x(), ch.skin.positions_bind[v].y(),
                                 ch.skin.positions_bind[v].z(), 1.0);
        for (uint32_t k = ch.skin.influence_offsets[v]; k < ch.skin.influence_offsets[v + 1]; ++k) {
          const uint16_t b = ch.skin.influence_binds[k];
          joint_weight[ch.skin.binds[b].joint] += ch.skin.influence_weights[k];
          const Eigen::Vector3d copy = (bind_rest[b] * pb).head<3>();
          fast_sq = std::max(fast_sq, (copy - c.cast<double>()).squaredNorm());
        }
      }
    }
    double wsum = 0.0;
    for (size_t j = 0; j < joints; ++j) wsum += joint_weight[j];
    if (wsum <= 0.0) {  // no weights: the sphere follows its dominant joint
      joint_weight[set->sphere_joint[s]] = 1.0;
      wsum = 1.0;
    }
    for (size_t j = 0; j < joints; ++j) {
      if (joint_weight[j] > 0.0) {
        set->influence_joints.push_back(static_cast<uint16_t>(j));
        set->influence_weights.push_back(static_cast<float>(joint_weight[j] / wsum));
        joint_weight[j] = 0.0;
      }
    }
    set->influence_offsets.push_back(static_cast<uint32_t>(set->influence_joints.size()));
    set->radii_fast.push_back(std::max(set->radii_rest[s], HoldingRadius(fast_sq)));
  }
}

void WriteInfluenceReach(runtime::SphereSet* set) {
  if (!set->has_mesh()) return;  // no skin: no reach, fast refit takes 1 (runtime/sphere_set.h)
  // The runtime's own computation, so SphereSet::Validate's comparison with the mesh holds bit for
  // bit. It fails only for a vertex weighted on a joint outside its sphere's influences, which
  // WriteFastRefitData never leaves (and the self-check would refuse).
  if (auto reach = runtime::InfluenceReachFromMesh(*set); reach.ok()) set->influence_reach = std::move(*reach);
}

void WriteFastReference(runtime::SphereSet* set) {
  // The runtime's own choice (refit_job.h, "Reference frame"), stored so that the set, its JSON and
  // its fast-only binary file refit alike. An unsound set is left without one: the self-check
  // refuses it with its own message.
  if (!runtime::ChooseFastReference(set).ok()) {
    set->fast_reference_inverse.clear();
    set->fast_reference_spheres.clear();
  }
}

}  // namespace skinspheres::lib
