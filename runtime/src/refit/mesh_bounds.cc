// What the refit's bounds need from the set's mesh: the reach of each influence, each point's
// reference copies and the smallest sound fast radii (refit/mesh_bounds.h).
#include "skinspheres/runtime/refit/mesh_bounds.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <optional>
#include <string>
#include <vector>

#include "format/affine_inverse.h"
#include "format/sphere_set_checks.h"

namespace skinspheres::runtime {

using internal::Affine34;
using internal::Compose;
using internal::FromFloat;
using internal::Invalid;
using internal::PointName;
using internal::ScalarAffineInverse;

namespace {

// One bind entry b of a point's skin: the point is Σ_b weight_b · G_joint(b) · IBM_b · q_b.
struct PointEntry {
  uint32_t bind;
  float weight;  // rounded up from `exact` for a grid point
  double exact;  // the weight in double (a source vertex's float weight)
  double q[3];
};

// The skin of point k of the point lists (SphereSet::vertices) with weight above 0, in a fixed order.
// A source vertex: its bind entries and its bind position. A grid point (i, j) of level L of the
// triangle p0 p1 p2, with barycentric weights β = ((L-i-j)/L, i/L, j/L): skinning is linear, so the
// point is Σ_v β_v Σ_b w_vb M_b p_v = Σ_b W_b M_b q_b over the union of the vertices' bind entries,
// W_b = Σ_v β_v w_vb and q_b = Σ_v β_v w_vb p_v / W_b: a convex blend of copies like a vertex's, with
// one position per entry (the fast bound's derivation holds as for a vertex, refit_job.h). W_b is
// summed in double and rounded up to float (at most 1), q_b in double, vertices in triangle order.
void PointEntries(const SphereSet& set, uint32_t k, std::vector<PointEntry>* out) {
  const skinning::SkinnedMesh& mesh = set.mesh;
  out->clear();
  if (k < set.source_vertex_count) {
    const Eigen::Vector3f& p = mesh.positions_bind[k];
    for (uint32_t q = mesh.influence_offsets[k]; q < mesh.influence_offsets[k + 1]; ++q) {
      if (!(mesh.influence_weights[q] > 0.0f)) continue;
      out->push_back(
          {mesh.influence_binds[q], mesh.influence_weights[q], mesh.influence_weights[q], {p.x(), p.y(), p.z()}});
    }
    return;
  }
  const PiecePoint& g = set.piece_points[k - set.source_vertex_count];
  const uint32_t* tri = set.triangle_vertices.data() + 3 * size_t{g.triangle};
  const double level = g.level;
  const double beta[3] = {double(g.level - g.i - g.j) / level, double(g.i) / level, double(g.j) / level};
  std::vector<double> sum;  // per entry of *out: W_b in double
  for (int c = 0; c < 3; ++c) {
    if (beta[c] == 0.0) continue;
    const uint32_t v = tri[c];
    const Eigen::Vector3f& p = mesh.positions_bind[v];
    for (uint32_t q = mesh.influence_offsets[v]; q < mesh.influence_offsets[v + 1]; ++q) {
      if (!(mesh.influence_weights[q] > 0.0f)) continue;
      const double w = beta[c] * double(mesh.influence_weights[q]);
      size_t e = 0;
      while (e < out->size() && (*out)[e].bind != mesh.influence_binds[q]) ++e;
      if (e == out->size()) {
        out->push_back({mesh.influence_binds[q], 0.0f, 0.0, {0.0, 0.0, 0.0}});
        sum.push_back(0.0);
      }
      sum[e] += w;
      for (int a = 0; a < 3; ++a) (*out)[e].q[a] += w * double(p[a]);
    }
  }
  for (size_t e = 0; e < out->size(); ++e) {
    PointEntry& entry = (*out)[e];
    for (int a = 0; a < 3; ++a) entry.q[a] /= sum[e];
    entry.exact = sum[e];
    float up = static_cast<float>(sum[e]);
    if (double(up) < sum[e]) up = std::nextafter(up, std::numeric_limits<float>::infinity());
    entry.weight = std::min(up, 1.0f);
  }
}

}  // namespace

void RepeatedInfluenceEntries(const SphereSet& set, size_t s, std::vector<uint8_t>* repeated) {
  const uint32_t k0 = set.influence_offsets[s], k1 = set.influence_offsets[s + 1];
  repeated->assign(k1 - k0, 0);
  for (uint32_t k = k0; k < k1; ++k) {
    for (uint32_t q = k0; q < k && !(*repeated)[k - k0]; ++q) {
      (*repeated)[k - k0] = set.influence_joints[q] == set.influence_joints[k];
    }
  }
}

Result<std::vector<float>> InfluenceReachFromMesh(const SphereSet& set) {
  const skinning::SkinnedMesh& mesh = set.mesh;
  std::vector<float> reach(set.influence_joints.size(), 0.0f);
  // entry_of[j]: the current sphere's first influence entry on joint j (UINT32_MAX: none); total:
  // per entry of the current sphere, the current vertex's weight on its joint.
  std::vector<uint32_t> entry_of(set.joint_count(), UINT32_MAX);
  std::vector<float> total;
  std::vector<PointEntry> entries;
  for (size_t s = 0; s < set.size(); ++s) {
    const uint32_t k0 = set.influence_offsets[s], k1 = set.influence_offsets[s + 1];
    for (uint32_t k = k1; k-- > k0;) entry_of[set.influence_joints[k]] = k;
    total.assign(k1 - k0, 0.0f);
    for (uint32_t i = set.vertex_offsets[s]; i < set.vertex_offsets[s + 1]; ++i) {
      PointEntries(set, set.vertices[i], &entries);
      for (const PointEntry& e : entries) {
        const int32_t j = mesh.binds[e.bind].joint;
        if (entry_of[j] == UINT32_MAX) {
          return Invalid("sphere " + std::to_string(s) + ": its " + PointName(set, set.vertices[i]) +
                         " is weighted on joint " + std::to_string(j) + ", which is not among the sphere's influences");
        }
        total[entry_of[j] - k0] += e.weight;
      }
      for (const PointEntry& e : entries) {  // each joint's total, once (a second entry finds 0)
        const uint32_t k = entry_of[mesh.binds[e.bind].joint];
        reach[k] = std::max(reach[k], std::min(total[k - k0], 1.0f));  // a float sum may pass 1 by an ulp
        total[k - k0] = 0.0f;
      }
    }
    for (uint32_t k = k0; k < k1; ++k) reach[k] = reach[entry_of[set.influence_joints[k]]];  // repeated joints
    for (uint32_t k = k0; k < k1; ++k) entry_of[set.influence_joints[k]] = UINT32_MAX;
  }
  return reach;
}

Result<FastBoundVertices> FastBoundVerticesFromMesh(const SphereSet& set) {
  const skinning::SkinnedMesh& mesh = set.mesh;
  const bool stored = !set.fast_reference_inverse.empty();
  // Per bind entry: R_j · IBM_b, carrying a bind-space vertex to its copy in reference space (R_j the
  // stored reference's, else G_j(rest)). Plain double arithmetic in a fixed order: the same bits on
  // every platform.
  std::vector<Affine34> copy_of(mesh.binds.size());
  for (size_t b = 0; b < mesh.binds.size(); ++b) {
    const size_t j = static_cast<size_t>(mesh.binds[b].joint);
    std::optional<Affine34> to_reference = FromFloat(set.joint_rest_world[j]);
    if (stored) to_reference = ScalarAffineInverse(FromFloat(set.fast_reference_inverse[j]));
    if (!to_reference) {
      return Invalid("joint " + std::to_string(j) + "'s fast reference transform is not invertible");
    }
    copy_of[b] = Compose(*to_reference, FromFloat(mesh.binds[b].inverse_bind));
  }
  // One weight per (point, influence) of each sphere: a product of two counts a file gives, so it
  // is bounded before anything is allocated (a real character needs a few million at most).
  constexpr size_t kMaxWeights = size_t{1} << 28;
  size_t weight_count = 0;
  for (size_t s = 0; s < set.size(); ++s) {
    weight_count += size_t{set.vertex_offsets[s + 1] - set.vertex_offsets[s]} *
                    (set.influence_offsets[s + 1] - set.influence_offsets[s]);
    if (weight_count > kMaxWeights) {
      return Invalid("the spheres' points times their influences exceed " + std::to_string(kMaxWeights) + " (sphere " +
                     std::to_string(s) + ")");
    }
  }
  FastBoundVertices out;
  out.radius.resize(set.vertices.size());
  out.weight_offsets.resize(set.size());
  weight_count = 0;
  for (size_t s = 0; s < set.size(); ++s) {
    out.weight_offsets[s] = static_cast<uint32_t>(weight_count);
    weight_count += size_t{set.vertex_offsets[s + 1] - set.vertex_offsets[s]} *
                    (set.influence_offsets[s + 1] - set.influence_offsets[s]);
  }
  out.weights.assign(weight_count, 0.0f);
  std::vector<uint32_t> entry_of(set.joint_count(), UINT32_MAX);  // the sphere's first entry per joint
  std::vector<PointEntry> entries;
  for (size_t s = 0; s < set.size(); ++s) {
    const Vec4f& ref = stored ? set.fast_reference_spheres[s] : Vec4f::Zero();
    const Eigen::Vector3f& centre = stored ? Eigen::Vector3f(ref.head<3>()) : set.centers_rest[s];
    const double c[3] = {centre.x(), centre.y(), centre.z()};
    const uint32_t k0 = set.influence_offsets[s], k1 = set.influence_offsets[s + 1];
    for (uint32_t k = k1; k-- > k0;) entry_of[set.influence_joints[k]] = k;
    for (uint32_t i = set.vertex_offsets[s]; i < set.vertex_offsets[s + 1]; ++i) {
      const uint32_t v = set.vertices[i];
      PointEntries(set, v, &entries);
      float* w = out.weights.data() + out.weight_offsets[s] + size_t{i - set.vertex_offsets[s]} * (k1 - k0);
      // A point (source vertex or grid point) needs the weighted mean of its copies' distances,
      // Σ_b w_b |p_b - c| (docs/REFIT.md#fast-mode), taken over Σ_b w_b (1 up to float rounding of
      // the weights): where a point's copies coincide it is their distance, the farthest copy's, as
      // files written before store it, and it is never below the sum where the weights fall short
      // of 1 (where they pass 1 by ulps the refit's margin covers the difference, as it did when
      // every vertex took the farthest copy). The farthest copy's where rounding puts the mean above.
      double r2 = 0.0, mean = 0.0, weight = 0.0;
      for (const PointEntry& e : entries) {
        const int32_t j = mesh.binds[e.bind].joint;
        if (entry_of[j] == UINT32_MAX) {
          return Invalid("sphere " + std::to_string(s) + ": its " + PointName(set, v) + " is weighted on joint " +
                         std::to_string(j) + ", which is not among the sphere's influences");
        }
        w[entry_of[j] - k0] += e.weight;
        const Affine34& m = copy_of[e.bind];
        const double* p = e.q;
        double d2 = 0.0;
        for (int r = 0; r < 3; ++r) {
          const double d = (((m[r][0] * p[0] + m[r][1] * p[1]) + m[r][2] * p[2]) + m[r][3]) - c[r];
          d2 += d * d;
        }
        r2 = std::max(r2, d2);
        mean += e.exact * std::sqrt(d2);
        weight += e.exact;
      }
      if (entries.empty()) {
        return Invalid("sphere " + std::to_string(s) + ": its " + PointName(set, v) + " has no weight above 0");
      }
      // Each joint's total (a float sum may pass 1 by an ulp), copied to its repeated entries.
      for (uint32_t k = k0; k < k1; ++k) w[k - k0] = std::min(w[entry_of[set.influence_joints[k]] - k0], 1.0f);
      out.radius[i] = std::nextafter(static_cast<float>(std::min(mean / weight, std::sqrt(r2))),
                                     std::numeric_limits<float>::infinity());
    }
    for (uint32_t k = k0; k < k1; ++k) entry_of[set.influence_joints[k]] = UINT32_MAX;
  }
  return out;
}

Result<std::vector<float>> FastReferenceRadiiFromMesh(const SphereSet& set) {
  // The largest of the points' radii (each already rounded up).
  auto vertices = FastBoundVerticesFromMesh(set);
  if (!vertices.ok()) return vertices.error();
  std::vector<float> radii(set.size(), std::nextafter(0.0f, 1.0f));
  for (size_t s = 0; s < set.size(); ++s) {
    for (uint32_t i = set.vertex_offsets[s]; i < set.vertex_offsets[s + 1]; ++i) {
      radii[s] = std::max(radii[s], vertices->radius[i]);
    }
  }
  return radii;
}

}  // namespace skinspheres::runtime
