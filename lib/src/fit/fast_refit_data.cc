// Stage 6 of the fitter: what the runtime's fast refit needs (runtime/sphere_set.h). See
// fit_stages.h.
#include <algorithm>
#include <limits>

#include "fit_stages.h"
#include "skinspheres/runtime/format/sphere_set.h"
#include "skinspheres/runtime/refit/mesh_bounds.h"
#include "skinspheres/runtime/refit/refit_job.h"

namespace skinspheres::lib {

void WriteFastRefitData(const RawCharacter& ch, std::span<const Mat4f> rest_world, runtime::SphereSet* set) {
  const size_t joints = ch.skeleton.size();
  // M_b(rest) = G_joint(b)(rest) · IBM_b: where each bind entry carries a bind-space vertex at rest.
  std::vector<Eigen::Matrix4d> bind_rest(ch.skin.binds.size());
  for (size_t b = 0; b < ch.skin.binds.size(); ++b) {
    // Composed in double (in float, a large inverse bind matrix's rounding could leave a copy a few
    // ulps of the radius outside: the reach groups, measured in double, must never exceed this).
    bind_rest[b] = rest_world[ch.skin.binds[b].joint].cast<double>() * ch.skin.binds[b].inverse_bind.cast<double>();
  }
  const bool have_skin = ch.skin.influence_offsets.size() == ch.vertex_count() + 1;
  set->influence_offsets = {0};
  std::vector<double> joint_weight(joints, 0.0);
  for (size_t s = 0; s < set->size(); ++s) {
    const Eigen::Vector3f c = set->centers_rest[s];
    const std::span<const uint32_t> vlist =
        std::span(set->vertices).subspan(set->vertex_offsets[s], set->vertex_offsets[s + 1] - set->vertex_offsets[s]);
    // Joints influencing the source vertices (mean weights) and the radius holding the vertices
    // themselves and, for each source vertex, the weighted mean distance of its rest copies
    // M_b(rest)·p_bind through its entries (docs/REFIT.md#fast-mode; at most the farthest copy's).
    double fast_sq = 0.0;
    const size_t source_vertices = ch.vertex_count();
    for (uint32_t v : vlist) {
      if (v >= source_vertices) {
        // A grid point of a cut triangle (docs/TRIANGLE_PIECES.md): its rest position here, its
        // joints through its triangle's vertices by their barycentric weights; its copies' radius
        // is the runtime's own (HoldMeshCopies).
        const runtime::PiecePoint& g = set->piece_points[v - source_vertices];
        const Eigen::Vector3i& tri = ch.triangles[g.triangle];
        const Eigen::Vector3f p = runtime::GridPoint(ch.positions_rest[tri[0]], ch.positions_rest[tri[1]],
                                                     ch.positions_rest[tri[2]], g.level, g.i, g.j);
        fast_sq = std::max(fast_sq, (p.cast<double>() - c.cast<double>()).squaredNorm());
        if (!have_skin) continue;
        const double beta[3] = {double(g.level - g.i - g.j) / g.level, double(g.i) / g.level, double(g.j) / g.level};
        for (int corner = 0; corner < 3; ++corner) {
          const auto u = static_cast<uint32_t>(tri[corner]);
          for (uint32_t k = ch.skin.influence_offsets[u]; k < ch.skin.influence_offsets[u + 1]; ++k) {
            joint_weight[ch.skin.binds[ch.skin.influence_binds[k]].joint] +=
                beta[corner] * ch.skin.influence_weights[k];
          }
        }
        continue;
      }
      fast_sq = std::max(fast_sq, (ch.positions_rest[v].cast<double>() - c.cast<double>()).squaredNorm());
      if (!have_skin) continue;
      const Eigen::Vector4d pb(ch.skin.positions_bind[v].x(), ch.skin.positions_bind[v].y(),
                               ch.skin.positions_bind[v].z(), 1.0);
      double mean = 0.0, weight = 0.0, farthest = 0.0;
      for (uint32_t k = ch.skin.influence_offsets[v]; k < ch.skin.influence_offsets[v + 1]; ++k) {
        const uint16_t b = ch.skin.influence_binds[k];
        joint_weight[ch.skin.binds[b].joint] += ch.skin.influence_weights[k];
        const Eigen::Vector3d copy = (bind_rest[b] * pb).head<3>();
        const double d = (copy - c.cast<double>()).norm();
        farthest = std::max(farthest, d);
        if (ch.skin.influence_weights[k] > 0.0f) {
          mean += double(ch.skin.influence_weights[k]) * d;
          weight += double(ch.skin.influence_weights[k]);
        }
      }
      const double need = weight > 0.0 ? std::min(mean / weight, farthest) : farthest;
      fast_sq = std::max(fast_sq, need * need);
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

void HoldMeshCopies(runtime::SphereSet* set) {
  if (!set->has_mesh()) return;
  // The rest copies as the runtime's own figures give them, from the set's mesh (whose bind entries
  // for rigid meshes hold a float inverse of the rest transform): radius_fast at least their
  // radius, so that it holds what the runtime skins, and no reach group ever exceeds it.
  auto vertices = runtime::FastBoundVerticesFromMesh(*set);
  if (!vertices.ok()) return;  // an unsound set: the self-check refuses it with its own message
  for (size_t s = 0; s < set->size(); ++s) {
    for (uint32_t i = set->vertex_offsets[s]; i < set->vertex_offsets[s + 1]; ++i) {
      set->radii_fast[s] = std::max(set->radii_fast[s], vertices->radius[i]);
    }
  }
}

void WriteFastReference(runtime::SphereSet* set) {
  // The runtime's own choice (docs/REFIT.md#reference-frame), stored so that the set, its JSON and
  // its fast-only binary file refit alike. An unsound set is left without one: the self-check
  // refuses it with its own message.
  if (!runtime::ChooseFastReference(set).ok()) {
    set->fast_reference_inverse.clear();
    set->fast_reference_spheres.clear();
  }
}

namespace {

// The k-means groups of one sphere's source vertices by their weight vectors (rows of `w`, k_count
// floats each): at most kMaxReachGroups, the first centre the first vertex, each next the vertex
// farthest from the centres so far (the first of equals), then 10 rounds of assignment to the
// nearest centre (the first of equals) and centres moved to their members' mean. Plain double
// arithmetic in a fixed order: the same groups on every platform. Returns each vertex's group.
std::vector<uint32_t> GroupByWeights(const float* w, size_t vertex_count, size_t k_count) {
  const size_t m = std::min<size_t>(runtime::kMaxReachGroups, vertex_count);
  auto dist2 = [&](size_t v, const std::vector<double>& c) {
    double d2 = 0.0;
    for (size_t k = 0; k < k_count; ++k) {
      const double d = double(w[v * k_count + k]) - c[k];
      d2 += d * d;
    }
    return d2;
  };
  auto row = [&](size_t v) { return std::vector<double>(w + v * k_count, w + (v + 1) * k_count); };
  std::vector<std::vector<double>> centres = {row(0)};
  while (centres.size() < m) {
    size_t farthest = 0;
    double best = -1.0;
    for (size_t v = 0; v < vertex_count; ++v) {
      double nearest = std::numeric_limits<double>::infinity();
      for (const auto& c : centres) nearest = std::min(nearest, dist2(v, c));
      if (nearest > best) best = nearest, farthest = v;
    }
    if (best <= 0.0) break;  // fewer distinct weight vectors than groups
    centres.push_back(row(farthest));
  }
  std::vector<uint32_t> group(vertex_count, 0);
  for (int round = 0; round < 10; ++round) {
    for (size_t v = 0; v < vertex_count; ++v) {
      double best = std::numeric_limits<double>::infinity();
      for (size_t g = 0; g < centres.size(); ++g) {
        const double d2 = dist2(v, centres[g]);
        if (d2 < best) best = d2, group[v] = static_cast<uint32_t>(g);
      }
    }
    std::vector<double> count(centres.size(), 0.0);
    for (auto& c : centres) std::fill(c.begin(), c.end(), 0.0);
    for (size_t v = 0; v < vertex_count; ++v) {
      count[group[v]] += 1.0;
      for (size_t k = 0; k < k_count; ++k) centres[group[v]][k] += double(w[v * k_count + k]);
    }
    for (size_t g = 0; g < centres.size(); ++g) {
      if (count[g] > 0.0) {
        for (double& x : centres[g]) x /= count[g];
      }
    }
  }
  return group;
}

}  // namespace

void WriteReachGroups(runtime::SphereSet* set) {
  set->ClearReachGroups();
  if (!set->has_mesh()) return;  // nothing to group: one group per sphere (runtime/sphere_set.h)
  // The runtime's own per-vertex figures (in the set's reference frame), so that Validate()'s
  // domination check holds bit for bit. An unsound set is left without groups: the self-check
  // refuses it with its own message.
  auto vertices = runtime::FastBoundVerticesFromMesh(*set);
  if (!vertices.ok()) return;
  std::vector<uint32_t> offsets = {0};
  std::vector<float> radii, weights, blends, deviations;
  for (size_t s = 0; s < set->size(); ++s) {
    const uint32_t v0 = set->vertex_offsets[s], v1 = set->vertex_offsets[s + 1];
    const size_t k_count = set->influence_offsets[s + 1] - set->influence_offsets[s];
    const size_t n = v1 - v0;
    const float* w = vertices->weights.data() + vertices->weight_offsets[s];
    // One joint: the spread is 0 and groups cannot help; else the k-means groups.
    const std::vector<uint32_t> group =
        k_count < 2 || n < 2 ? std::vector<uint32_t>(n, 0) : GroupByWeights(w, n, k_count);
    const uint32_t groups = n == 0 ? 1 : *std::max_element(group.begin(), group.end()) + 1;
    std::vector<float> radius(groups, 0.0f), reach(groups * k_count, 0.0f);
    std::vector<float> lowest(groups * k_count, 1.0f);  // the members' least weight per entry
    std::vector<bool> used(groups, false);
    for (size_t i = 0; i < n; ++i) {
      const uint32_t g = group[i];
      used[g] = true;
      radius[g] = std::max(radius[g], vertices->radius[v0 + i]);
      for (size_t k = 0; k < k_count; ++k) {
        reach[g * k_count + k] = std::max(reach[g * k_count + k], w[i * k_count + k]);
        lowest[g * k_count + k] = std::min(lowest[g * k_count + k], w[i * k_count + k]);
      }
    }
    // The blend (docs/REFIT.md#group-blends): per entry the midpoint of the members' weights and
    // the largest distance from it, rounded up (Validate() compares |w - m| <= e in float); 0 and 0
    // on an entry that repeats an earlier entry's joint (runtime::RepeatedInfluenceEntries, the
    // entries Validate() requires it of; the fitter writes none: kept for safety).
    std::vector<uint8_t> repeated;
    runtime::RepeatedInfluenceEntries(*set, s, &repeated);
    std::vector<float> blend(groups * k_count, 0.0f), deviation(groups * k_count, 0.0f);
    for (size_t i = 0; i < n; ++i) {
      for (size_t k = 0; k < k_count; ++k) {
        if (repeated[k]) continue;
        const size_t at = group[i] * k_count + k;
        blend[at] = 0.5f * (lowest[at] + reach[at]);
      }
    }
    for (size_t i = 0; i < n; ++i) {
      for (size_t k = 0; k < k_count; ++k) {
        if (repeated[k]) continue;
        const size_t at = group[i] * k_count + k;
        deviation[at] = std::max(deviation[at], std::fabs(w[i * k_count + k] - blend[at]));
      }
    }
    for (float& e : deviation) {
      if (e > 0.0f) e = std::min(std::nextafter(e, 2.0f), 1.0f);
    }
    for (uint32_t g = 0; g < groups; ++g) {
      if (!used[g] && n > 0) continue;
      // Never above the reference radius, which holds every member's mean copy distance from the same figures
      // (HoldMeshCopies; the stored reference's): no group's bound exceeds the one-group bound.
      const float reference_radius =
          set->fast_reference_spheres.empty() ? set->radii_fast[s] : set->fast_reference_spheres[s].w();
      radii.push_back(n == 0 ? reference_radius : radius[g]);
      for (size_t k = 0; k < k_count; ++k) weights.push_back(n == 0 ? 1.0f : reach[g * k_count + k]);
      // A sphere without points: blend 0, deviation 1 (the reach's own bound).
      for (size_t k = 0; k < k_count; ++k) blends.push_back(n == 0 ? 0.0f : blend[g * k_count + k]);
      for (size_t k = 0; k < k_count; ++k) deviations.push_back(n == 0 ? 1.0f : deviation[g * k_count + k]);
    }
    offsets.push_back(static_cast<uint32_t>(radii.size()));
  }
  set->reach_group_offsets = std::move(offsets);
  set->reach_group_radii = std::move(radii);
  set->reach_group_weights = std::move(weights);
  set->reach_group_blend = std::move(blends);
  set->reach_group_deviation = std::move(deviations);
}

}  // namespace skinspheres::lib
