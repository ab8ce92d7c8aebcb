// The sphere set's checks of what fast refit relies on: the stored fast radii, the fast reference
// frame and the reach groups, each against what the mesh gives (sphere_set_checks.h, mesh_bounds.h).
#include <algorithm>
#include <cfloat>
#include <cmath>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "format/affine_inverse.h"
#include "format/sphere_set_checks.h"
#include "skinspheres/runtime/refit/mesh_bounds.h"

namespace skinspheres::runtime::internal {

using skinning::kWeightSumTolerance;  // skinned_mesh.h

// The fast refit's reference frame (both arrays empty, or sized per joint and per sphere): finite,
// invertible transforms, finite centres, positive radii; with a mesh, each radius at least the one
// its source vertices' reference copies need (a smaller one from a hostile file would give fast
// spheres that miss vertices).
std::optional<Error> CheckFastReference(const SphereSet& set) {
  if (set.fast_reference_inverse.empty() && set.fast_reference_spheres.empty()) return std::nullopt;
  if (set.fast_reference_inverse.size() != set.joint_count() || set.fast_reference_spheres.size() != set.size()) {
    return Invalid("the fast reference has " + std::to_string(set.fast_reference_inverse.size()) + " transforms and " +
                   std::to_string(set.fast_reference_spheres.size()) + " spheres for " +
                   std::to_string(set.joint_count()) + " joints and " + std::to_string(set.size()) +
                   " spheres (one each, or none)");
  }
  for (size_t j = 0; j < set.joint_count(); ++j) {
    const Mat4f& m = set.fast_reference_inverse[j];
    // Bounded as joint transforms are in practice (a scale of 1e20 would overflow the fast bound's
    // stretch every frame instead of being refused here).
    if (!m.allFinite() || m.cwiseAbs().maxCoeff() > 1e9f || !ScalarAffineInverse(FromFloat(m))) {
      return Invalid("joint " + std::to_string(j) +
                     "'s fast reference transform is not finite, has an entry beyond 1e9, or is not invertible");
    }
  }
  for (size_t s = 0; s < set.size(); ++s) {
    const Vec4f& r = set.fast_reference_spheres[s];
    if (!r.allFinite() || !(r.w() > 0.0f) || r.cwiseAbs().maxCoeff() > 1e18f) {
      return Invalid("sphere " + std::to_string(s) + "'s fast reference sphere is not finite, has a radius <= 0 or " +
                     "lies beyond 1e18 units");
    }
    // At the rest pose the fast refit carries the reference centre by G_j(rest) · R_j^-1 per
    // influence and stretches the radius by that transform's scale: within the broad phase's 1e18,
    // as the rest spheres are, and the products the refit forms that transform from in float within
    // 1e24 (each bound above alone lets a 1e9 scale carry a centre at 1e18 to 1e27, and the
    // refit's squared spread overflow to inf at every pose).
    for (uint32_t k = set.influence_offsets[s]; k < set.influence_offsets[s + 1]; ++k) {
      const size_t j = set.influence_joints[k];
      const Affine34 t = Compose(FromFloat(set.joint_rest_world[j]), FromFloat(set.fast_reference_inverse[j]));
      double frobenius2 = 0.0, farthest = 0.0;
      for (int row = 0; row < 3; ++row) {
        for (int c = 0; c < 3; ++c) frobenius2 += t[row][c] * t[row][c];
        farthest =
            std::max(farthest, std::fabs(((t[row][0] * r.x() + t[row][1] * r.y()) + t[row][2] * r.z()) + t[row][3]));
      }
      const double stretch = std::sqrt(frobenius2);
      const double products = double(set.joint_rest_world[j].topRows<3>().cwiseAbs().maxCoeff()) *
                              double(set.fast_reference_inverse[j].topRows<3>().cwiseAbs().maxCoeff());
      if (!(farthest <= 1e18) || !(stretch <= 1e10) || !(stretch * r.w() <= 1e18) || !(products <= 1e24)) {
        return Invalid("sphere " + std::to_string(s) + "'s fast reference sphere, carried to the rest pose by joint " +
                       std::to_string(j) + ", lies beyond 1e18 units or is stretched beyond 1e10 (or 1e18 units)");
      }
    }
  }
  if (!set.has_mesh() || set.fast_only) return std::nullopt;
  auto needed = FastReferenceRadiiFromMesh(set);
  if (!needed.ok()) return needed.error();
  for (size_t s = 0; s < set.size(); ++s) {
    if (set.fast_reference_spheres[s].w() < (*needed)[s]) {
      return Invalid("sphere " + std::to_string(s) + " has fast reference radius " +
                     Digits(set.fast_reference_spheres[s].w()) + ", below the " + Digits((*needed)[s]) +
                     " its source vertices need");
    }
  }
  return std::nullopt;
}

// With a mesh and the rest pose as the reference, each radius_fast holds its source vertices' rest
// copies (FastBoundVerticesFromMesh), to 2 ulps of the radius: a file shrunk by hand would give fast
// spheres that miss vertices. The fitter stores the runtime's own figures (HoldMeshCopies), so its
// files pass exactly; the 2 ulps (well inside the refit's margin of 16·FLT_EPSILON·(|c'| + r),
// refit_job.h) are for a figure computed elsewhere and rounded once more. A looser tolerance, such
// as 1e-4 of the radius, would accept a Soldier file shrunk within it that leaves a vertex 1.45e-6
// outside its fast sphere at the worst pose; every file in the fuzz corpus, back to layout 1,
// passes the 2 ulps.
std::optional<Error> CheckFastRadii(const SphereSet& set) {
  if (!set.has_mesh() || set.fast_only || !set.fast_reference_spheres.empty()) return std::nullopt;
  auto vertices = FastBoundVerticesFromMesh(set);
  if (!vertices.ok()) return vertices.error();
  for (size_t s = 0; s < set.size(); ++s) {
    for (uint32_t i = set.vertex_offsets[s]; i < set.vertex_offsets[s + 1]; ++i) {
      if (set.radii_fast[s] < vertices->radius[i] * (1.0f - 2.0f * FLT_EPSILON)) {
        return Invalid("sphere " + std::to_string(s) + " has fast radius " + Digits(set.radii_fast[s]) +
                       ", below the " + Digits(vertices->radius[i]) + " its " + PointName(set, set.vertices[i]) +
                       "'s rest copies need");
      }
    }
  }
  return std::nullopt;
}

namespace {

// The reach groups' counts: 1 to kMaxReachGroups per sphere, one reach per group and influence;
// *weights: that count of reaches.
std::optional<Error> CheckReachGroupCounts(const SphereSet& set, size_t* weights) {
  const size_t n = set.size();
  if (!CsrOk(set.reach_group_offsets, n, set.reach_group_radii.size())) {
    return Invalid("the reach groups' offsets are malformed (one per sphere plus one, from 0 to the group count)");
  }
  *weights = 0;
  for (size_t s = 0; s < n; ++s) {
    const uint32_t groups = set.reach_group_offsets[s + 1] - set.reach_group_offsets[s];
    if (groups < 1 || groups > kMaxReachGroups) {
      return Invalid("sphere " + std::to_string(s) + " has " + std::to_string(groups) + " reach groups (1 to " +
                     std::to_string(kMaxReachGroups) + ")");
    }
    *weights += size_t{groups} * (set.influence_offsets[s + 1] - set.influence_offsets[s]);
  }
  if (set.reach_group_weights.size() != *weights) {
    return Invalid("the reach groups have " + std::to_string(set.reach_group_weights.size()) + " reach entries for " +
                   std::to_string(*weights) + " (one per group and influence)");
  }
  return std::nullopt;
}

// Each group: a finite positive radius, reaches within [0, 1] summing to at least 1.
std::optional<Error> CheckReachGroupReaches(const SphereSet& set) {
  for (size_t s = 0, base = 0; s < set.size(); ++s) {
    const uint32_t k_count = set.influence_offsets[s + 1] - set.influence_offsets[s];
    for (uint32_t g = set.reach_group_offsets[s]; g < set.reach_group_offsets[s + 1]; ++g, base += k_count) {
      const float r = set.reach_group_radii[g];
      if (!(r > 0.0f) || !(r <= 1e18f)) {
        return Invalid("sphere " + std::to_string(s) + "'s reach group " + std::to_string(g) + " has radius " +
                       Digits(r) + " (must be > 0 and finite)");
      }
      double sum = 0.0;
      for (uint32_t k = 0; k < k_count; ++k) {
        const float w = set.reach_group_weights[base + k];
        if (!(w >= 0.0f && w <= 1.0f)) {
          return Invalid("sphere " + std::to_string(s) + "'s reach group " + std::to_string(g) + " has reach " +
                         Digits(w) + " (must be within [0, 1])");
        }
        sum += w;
      }
      if (!(sum >= 1.0 - kWeightSumTolerance)) {
        return Invalid("sphere " + std::to_string(s) + "'s reach group " + std::to_string(g) +
                       " has reaches summing to " + Digits(float(sum)) + ", below 1");
      }
    }
  }
  return std::nullopt;
}

// The groups' blends (present): each within [0, 1], 0 on an entry that repeats an earlier entry's
// joint, and some weights summing to 1 within each deviation of each blend.
std::optional<Error> CheckReachGroupBlends(const SphereSet& set) {
  std::vector<uint8_t> repeated;  // per entry of the sphere: its joint appeared at an earlier entry
  for (size_t s = 0, base = 0; s < set.size(); ++s) {
    RepeatedInfluenceEntries(set, s, &repeated);
    const uint32_t k_count = set.influence_offsets[s + 1] - set.influence_offsets[s];
    for (uint32_t g = set.reach_group_offsets[s]; g < set.reach_group_offsets[s + 1]; ++g, base += k_count) {
      for (uint32_t k = 0; k < k_count; ++k) {
        const float m = set.reach_group_blend[base + k], e = set.reach_group_deviation[base + k];
        if (!(m >= 0.0f && m <= 1.0f) || !(e >= 0.0f && e <= 1.0f)) {
          return Invalid("sphere " + std::to_string(s) + "'s reach group " + std::to_string(g) + " has blend " +
                         Digits(m) + " and deviation " + Digits(e) + " (each must be within [0, 1])");
        }
        if (repeated[k] && (m != 0.0f || e != 0.0f)) {
          return Invalid("sphere " + std::to_string(s) + "'s reach group " + std::to_string(g) +
                         " blends influence entry " + std::to_string(k) +
                         ", which repeats an earlier entry's joint (its blend and deviation must be 0)");
        }
      }
      // Some weights summing to 1 lie within e of m (checked without a mesh too, as the reach's sum).
      double highest = 0.0, lowest = 0.0;
      for (uint32_t k = 0; k < k_count; ++k) {
        if (repeated[k]) continue;
        const double m = set.reach_group_blend[base + k], e = set.reach_group_deviation[base + k];
        highest += std::min(m + e, 1.0);
        lowest += std::max(m - e, 0.0);
      }
      if (!(highest >= 1.0 - kWeightSumTolerance) || !(lowest <= 1.0 + kWeightSumTolerance)) {
        return Invalid("sphere " + std::to_string(s) + "'s reach group " + std::to_string(g) +
                       " has blends and deviations that no weights summing to 1 fit (from " + Digits(float(lowest)) +
                       " to " + Digits(float(highest)) + ")");
      }
    }
  }
  return std::nullopt;
}

// With a mesh: every source vertex dominated by one of its sphere's groups (its reference radius,
// its weights, and with blends its weights within each deviation of each blend).
std::optional<Error> CheckReachGroupsCoverMesh(const SphereSet& set, bool blends) {
  auto vertices = FastBoundVerticesFromMesh(set);
  if (!vertices.ok()) return vertices.error();
  std::vector<uint8_t> repeated;
  for (size_t s = 0, base = 0; s < set.size(); ++s) {
    const uint32_t k_count = set.influence_offsets[s + 1] - set.influence_offsets[s];
    const uint32_t g0 = set.reach_group_offsets[s], g1 = set.reach_group_offsets[s + 1];
    if (blends) RepeatedInfluenceEntries(set, s, &repeated);
    for (uint32_t i = set.vertex_offsets[s]; i < set.vertex_offsets[s + 1]; ++i) {
      const float* w =
          vertices->weights.data() + vertices->weight_offsets[s] + size_t{i - set.vertex_offsets[s]} * k_count;
      bool dominated = false;
      for (uint32_t g = g0; g < g1 && !dominated; ++g) {
        const size_t at = base + size_t{g - g0} * k_count;
        const float* group = set.reach_group_weights.data() + at;
        dominated = set.reach_group_radii[g] >= vertices->radius[i];
        for (uint32_t k = 0; k < k_count && dominated; ++k) dominated = group[k] >= w[k];
        for (uint32_t k = 0; k < k_count && dominated && blends; ++k) {
          dominated =
              repeated[k] || std::fabs(w[k] - set.reach_group_blend[at + k]) <= set.reach_group_deviation[at + k];
        }
      }
      if (!dominated) {
        return Invalid("sphere " + std::to_string(s) + "'s " + PointName(set, set.vertices[i]) +
                       " is in none of its reach groups (reference radius " + Digits(vertices->radius[i]) +
                       ", a weight above every group's reach, or outside every group's blend and deviation)");
      }
    }
    base += size_t{g1 - g0} * k_count;
  }
  return std::nullopt;
}

}  // namespace

// The reach groups (all three arrays empty, or: 1 to kMaxReachGroups groups per sphere, each with a
// finite positive radius and a reach per influence entry in [0, 1] summing to at least 1); with a
// mesh, every source vertex dominated by one of its sphere's groups (a group that misses a vertex
// would give fast spheres that miss it).
std::optional<Error> CheckReachGroups(const SphereSet& set) {
  if (set.reach_group_offsets.empty() && set.reach_group_radii.empty() && set.reach_group_weights.empty()) {
    if (!set.reach_group_blend.empty() || !set.reach_group_deviation.empty()) {
      return Invalid("the reach groups' blends are given without the groups");
    }
    return std::nullopt;
  }
  size_t weights = 0;
  if (auto err = CheckReachGroupCounts(set, &weights)) return err;
  if (auto err = CheckReachGroupReaches(set)) return err;
  // The groups' blends: both arrays empty, or each as long as the reaches.
  const bool blends = !set.reach_group_blend.empty() || !set.reach_group_deviation.empty();
  if (blends && (set.reach_group_blend.size() != weights || set.reach_group_deviation.size() != weights)) {
    return Invalid("the reach groups have " + std::to_string(set.reach_group_blend.size()) + " blend and " +
                   std::to_string(set.reach_group_deviation.size()) + " deviation entries for " +
                   std::to_string(weights) + " (one each per group and influence, or none)");
  }
  if (blends) {
    if (auto err = CheckReachGroupBlends(set)) return err;
  }
  if (!set.has_mesh() || set.fast_only) return std::nullopt;
  return CheckReachGroupsCoverMesh(set, blends);
}

}  // namespace skinspheres::runtime::internal
