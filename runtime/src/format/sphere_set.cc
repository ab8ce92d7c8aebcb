#include "skinspheres/runtime/format/sphere_set.h"

#include <algorithm>
#include <array>
#include <cfloat>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <limits>
#include <optional>
#include <string>
#include <vector>

namespace skinspheres::runtime {

const char* ToString(ExclusionReason reason) {
  switch (reason) {
    case ExclusionReason::kSameJoint: return "same_joint";
    case ExclusionReason::kAdjacentJoints: return "adjacent_joints";
    case ExclusionReason::kBindOverlap: return "bind_overlap";
  }
  return "unknown";
}

std::optional<ExclusionReason> ExclusionReasonFromString(std::string_view text) {
  if (text == "same_joint") return ExclusionReason::kSameJoint;
  if (text == "adjacent_joints") return ExclusionReason::kAdjacentJoints;
  if (text == "bind_overlap") return ExclusionReason::kBindOverlap;
  return std::nullopt;
}

namespace {

Error Invalid(const std::string& what) { return MakeError(ErrorCode::kInvalidData, what); }

// A float in as many digits as tell it from its neighbours (a reach one ulp too small must read so).
std::string Digits(float x) {
  char text[32];
  std::snprintf(text, sizeof text, "%.9g", static_cast<double>(x));
  return text;
}

using skinning::kWeightSumTolerance;  // skinned_mesh.h

// Offsets of a CSR list: n+1 entries, starting at 0, non-decreasing, ending at the list's size.
bool CsrOk(const std::vector<uint32_t>& offsets, size_t n, size_t list_size) {
  if (offsets.size() != n + 1 || offsets.front() != 0 || offsets.back() != list_size) return false;
  for (size_t s = 0; s < n; ++s) {
    if (offsets[s] > offsets[s + 1]) return false;
  }
  return true;
}

// The version-2 mesh: sizes, index ranges, finite values, and every vertex of a triangle a sphere
// owns among that sphere's source vertices (what the refit bounds is what a triangle test reads).
std::optional<Error> ValidateMesh(const SphereSet& set) {
  const skinning::SkinnedMesh& mesh = set.mesh;
  if (!set.has_mesh()) {
    if (mesh.vertex_count() != 0 || !mesh.binds.empty() || !mesh.influence_binds.empty()) {
      return Invalid("the mesh has vertices or bind entries but no triangles");
    }
    return std::nullopt;
  }
  const size_t vertices = set.source_vertex_count;
  if (set.triangle_vertices.size() != 3 * static_cast<size_t>(set.source_triangle_count)) {
    return Invalid("the mesh has " + std::to_string(set.triangle_vertices.size()) + " triangle indices, expected 3 x " +
                   std::to_string(set.source_triangle_count));
  }
  for (size_t k = 0; k < set.triangle_vertices.size(); ++k) {
    if (set.triangle_vertices[k] >= vertices) {
      return Invalid("mesh triangle " + std::to_string(k / 3) + " names vertex " +
                     std::to_string(set.triangle_vertices[k]) + " out of range");
    }
  }
  if (mesh.vertex_count() != vertices) {
    return Invalid("the mesh has " + std::to_string(mesh.vertex_count()) + " vertices, expected " +
                   std::to_string(vertices));
  }
  for (size_t v = 0; v < vertices; ++v) {
    if (!mesh.positions_bind[v].allFinite()) return Invalid("mesh vertex " + std::to_string(v) + " is not finite");
  }
  for (size_t b = 0; b < mesh.binds.size(); ++b) {
    if (mesh.binds[b].joint < 0 || static_cast<size_t>(mesh.binds[b].joint) >= set.joint_count()) {
      return Invalid("mesh bind entry " + std::to_string(b) + " names joint " + std::to_string(mesh.binds[b].joint) +
                     " out of range");
    }
    if (!mesh.binds[b].inverse_bind.allFinite()) {
      return Invalid("mesh bind entry " + std::to_string(b) + " has a non-finite inverse bind matrix");
    }
  }
  if (!CsrOk(mesh.influence_offsets, vertices, mesh.influence_binds.size()) ||
      mesh.influence_weights.size() != mesh.influence_binds.size()) {
    return Invalid("mesh influence lists are malformed");
  }
  for (size_t k = 0; k < mesh.influence_binds.size(); ++k) {
    if (mesh.influence_binds[k] >= mesh.binds.size())
      return Invalid("a mesh influence names a bind entry out of range");
    if (!(mesh.influence_weights[k] >= 0.0f) || !std::isfinite(mesh.influence_weights[k])) {
      return Invalid("a mesh influence weight is negative or not finite");
    }
  }
  // Each vertex's weights sum to 1 (the importers normalise them in double; float leaves a few
  // ulps): skinning is then a convex blend, which the fast bound's derivation needs (refit_job.h).
  double sum = 0.0;
  if (const size_t v = skinning::FirstVertexNotSummingToOne(mesh.influence_offsets, mesh.influence_weights, &sum);
      v != std::numeric_limits<size_t>::max()) {
    return Invalid("mesh vertex " + std::to_string(v) + " has skin weights summing to " + Digits(float(sum)) +
                   ", not 1");
  }
  std::vector<uint32_t> marked(vertices, UINT32_MAX);  // marked[v] == s: v is a source vertex of sphere s
  for (size_t s = 0; s < set.size(); ++s) {
    for (uint32_t k = set.vertex_offsets[s]; k < set.vertex_offsets[s + 1]; ++k)
      marked[set.vertices[k]] = static_cast<uint32_t>(s);
    for (uint32_t k = set.triangle_offsets[s]; k < set.triangle_offsets[s + 1]; ++k) {
      const uint32_t t = set.triangles[k];
      for (int c = 0; c < 3; ++c) {
        if (marked[set.triangle_vertices[3 * size_t{t} + c]] != s) {
          return Invalid("sphere " + std::to_string(s) + " owns triangle " + std::to_string(t) +
                         " but not its vertex " + std::to_string(set.triangle_vertices[3 * size_t{t} + c]));
        }
      }
    }
  }
  return std::nullopt;
}

}  // namespace

namespace {

// The skeleton: arrays that agree, parents first, finite rest transforms.
std::optional<Error> CheckSkeleton(const SphereSet& set) {
  [[maybe_unused]] const size_t n = set.size();
  [[maybe_unused]] const size_t joints = set.joint_count();
  if (set.joint_parents.size() != joints || set.joint_rest_world.size() != joints) {
    return Invalid("skeleton arrays disagree in size");
  }
  for (size_t j = 0; j < joints; ++j) {
    if (set.joint_parents[j] < -1 || set.joint_parents[j] >= static_cast<int32_t>(j)) {
      return Invalid("joint " + std::to_string(j) + " has parent " + std::to_string(set.joint_parents[j]) +
                     " (parents must come first)");
    }
    if (!set.joint_rest_world[j].allFinite())
      return Invalid("joint " + std::to_string(j) + " rest transform is not finite");
  }
  return std::nullopt;
}

// The parts: named, once each, naming joints in range.
std::optional<Error> CheckParts(const SphereSet& set) {
  [[maybe_unused]] const size_t n = set.size();
  [[maybe_unused]] const size_t joints = set.joint_count();
  // Part names are what a report says ("torso - arm_l") and what an engine looks a part up by:
  // each is non-empty and names one part.
  for (size_t p = 0; p < set.parts.size(); ++p) {
    if (set.parts[p].name.empty()) return Invalid("part " + std::to_string(p) + " has an empty name");
    for (size_t q = 0; q < p; ++q) {
      if (set.parts[q].name == set.parts[p].name) {
        return Invalid("parts " + std::to_string(q) + " and " + std::to_string(p) + " are both named '" +
                       set.parts[p].name + "'");
      }
    }
  }
  for (const auto& part : set.parts) {
    for (uint32_t j : part.joints) {
      if (j >= joints) return Invalid("part " + part.name + " names joint " + std::to_string(j) + " out of range");
    }
  }
  return std::nullopt;
}

// The per-sphere arrays and the CSR lists agree in size.
std::optional<Error> CheckSphereArrays(const SphereSet& set) {
  [[maybe_unused]] const size_t n = set.size();
  [[maybe_unused]] const size_t joints = set.joint_count();
  if (set.radii_rest.size() != n || set.radii_fast.size() != n || set.sphere_part.size() != n ||
      set.sphere_joint.size() != n || set.sphere_level.size() != n) {
    return Invalid("per-sphere arrays disagree in size");
  }
  if (!CsrOk(set.vertex_offsets, n, set.vertices.size())) return Invalid("sphere vertex lists are malformed");
  if (!CsrOk(set.triangle_offsets, n, set.triangles.size())) return Invalid("sphere triangle lists are malformed");
  if (!CsrOk(set.influence_offsets, n, set.influence_joints.size()) ||
      set.influence_weights.size() != set.influence_joints.size()) {
    return Invalid("sphere influence lists are malformed");
  }
  return std::nullopt;
}

// Each sphere: finite, positive, within reach of the broad phase, its part and joint in range.
std::optional<Error> CheckSpheres(const SphereSet& set) {
  [[maybe_unused]] const size_t n = set.size();
  [[maybe_unused]] const size_t joints = set.joint_count();
  for (size_t s = 0; s < n; ++s) {
    const std::string id = "sphere " + std::to_string(s);
    if (!set.centers_rest[s].allFinite() || !std::isfinite(set.radii_rest[s]))
      return Invalid(id + " has a non-finite centre or radius");
    // A sphere owns at least one triangle and holds it: a radius of zero or less holds nothing
    // (a set of zero radii came from zero inverse bind matrices and failed every frame).
    if (!(set.radii_rest[s] > 0.0f))
      return Invalid(id + " has radius " + std::to_string(set.radii_rest[s]) + " (must be > 0)");
    // The broad phase refuses magnitudes beyond 1e18 (its sums must stay finite): say so here.
    if (set.centers_rest[s].cwiseAbs().maxCoeff() > 1e18f || set.radii_fast[s] > 1e18f) {
      return Invalid(id + " lies beyond 1e18 units from the origin or is larger than that");
    }
    if (!std::isfinite(set.radii_fast[s]) || set.radii_fast[s] < set.radii_rest[s]) {
      return Invalid(id + " has a fast radius below its radius");
    }
    if (set.sphere_part[s] >= set.parts.size())
      return Invalid(id + " names part " + std::to_string(set.sphere_part[s]) + " out of range");
    if (set.sphere_joint[s] >= joints)
      return Invalid(id + " names joint " + std::to_string(set.sphere_joint[s]) + " out of range");
  }
  return std::nullopt;
}

// The vertices and triangles the spheres name, and each triangle owned once.
std::optional<Error> CheckOwnership(const SphereSet& set) {
  [[maybe_unused]] const size_t n = set.size();
  [[maybe_unused]] const size_t joints = set.joint_count();
  for (uint32_t v : set.vertices) {
    if (v >= set.source_vertex_count) return Invalid("a sphere names vertex " + std::to_string(v) + " out of range");
  }
  for (uint32_t t : set.triangles) {
    if (t >= set.source_triangle_count)
      return Invalid("a sphere names triangle " + std::to_string(t) + " out of range");
  }
  // Every source triangle is owned by exactly one sphere: what makes a contact anywhere on the
  // mesh visible to the broad phase (and what --verify checks). The lists then hold exactly
  // source_triangle_count entries, compared before the per-triangle table is allocated (the count
  // comes from the file). A fast-only set (sphere_set_binary.h) has no lists to check: they were
  // checked when the whole set was written, and nothing that reads triangles accepts it.
  if (n == 0) return Invalid("the set has no spheres");
  if (!set.fast_only && set.triangles.size() != set.source_triangle_count) {
    return Invalid("the spheres own " + std::to_string(set.triangles.size()) + " triangle entries for " +
                   std::to_string(set.source_triangle_count) + " triangles (each must be owned by exactly one sphere)");
  }
  std::vector<uint32_t> owner(set.fast_only ? 0 : set.source_triangle_count, UINT32_MAX);
  for (size_t s = 0; s < n; ++s) {
    for (uint32_t k = set.triangle_offsets[s]; k < set.triangle_offsets[s + 1]; ++k) {
      uint32_t& o = owner[set.triangles[k]];
      if (o != UINT32_MAX) {
        return Invalid("triangle " + std::to_string(set.triangles[k]) + " is owned by spheres " + std::to_string(o) +
                       " and " + std::to_string(s) + " (each must be owned by exactly one)");
      }
      o = static_cast<uint32_t>(s);
    }
  }
  return std::nullopt;
}

// The influences: joints in range, weights >= 0, and the reach (when stored) in [0, 1] summing to >= 1 per sphere.
std::optional<Error> CheckInfluences(const SphereSet& set) {
  [[maybe_unused]] const size_t n = set.size();
  [[maybe_unused]] const size_t joints = set.joint_count();
  for (size_t k = 0; k < set.influence_joints.size(); ++k) {
    if (set.influence_joints[k] >= joints) return Invalid("a sphere influence names joint out of range");
    if (!(set.influence_weights[k] >= 0.0f) || !std::isfinite(set.influence_weights[k]))
      return Invalid("a sphere influence weight is negative or not finite");
  }
  if (!set.influence_reach.empty()) {
    if (set.influence_reach.size() != set.influence_joints.size()) {
      return Invalid("the spheres have " + std::to_string(set.influence_reach.size()) +
                     " influence reach entries for " + std::to_string(set.influence_joints.size()) +
                     " influences (one each, or none)");
    }
    for (size_t s = 0; s < n; ++s) {
      for (uint32_t k = set.influence_offsets[s]; k < set.influence_offsets[s + 1]; ++k) {
        if (!(set.influence_reach[k] >= 0.0f && set.influence_reach[k] <= 1.0f)) {
          return Invalid("sphere " + std::to_string(s) + " has influence reach " + Digits(set.influence_reach[k]) +
                         " on joint " + std::to_string(set.influence_joints[k]) + " (must be within [0, 1])");
        }
      }
      // Any one source vertex's weights sum to 1 over joints among the sphere's influences, each at
      // most its reach: the reaches sum to at least 1. Checked for sets with no mesh too (fast-only
      // and version-1 files), where nothing else can check the reach.
      double sum = 0.0;
      for (uint32_t k = set.influence_offsets[s]; k < set.influence_offsets[s + 1]; ++k) sum += set.influence_reach[k];
      if (!(sum >= 1.0 - kWeightSumTolerance)) {
        return Invalid("sphere " + std::to_string(s) + " has influence reaches summing to " + Digits(float(sum)) +
                       ", below 1 (one source vertex's weights alone sum to 1)");
      }
    }
  }
  return std::nullopt;
}

// The excluded pairs: i < j < n, sorted, unique.
std::optional<Error> CheckExclusions(const SphereSet& set) {
  [[maybe_unused]] const size_t n = set.size();
  [[maybe_unused]] const size_t joints = set.joint_count();
  for (size_t k = 0; k < set.excluded_pairs.size(); ++k) {
    const auto& p = set.excluded_pairs[k];
    if (p.i >= p.j || p.j >= n) return Invalid("excluded pair " + std::to_string(k) + " is not i < j < sphere count");
    if (k > 0) {
      const auto& q = set.excluded_pairs[k - 1];
      if (q.i > p.i || (q.i == p.i && q.j >= p.j)) return Invalid("excluded pairs are not sorted and unique");
    }
  }
  return std::nullopt;
}

// The mesh (version 2), and the stored reach against the weights it gives.
std::optional<Error> CheckMesh(const SphereSet& set) {
  [[maybe_unused]] const size_t n = set.size();
  [[maybe_unused]] const size_t joints = set.joint_count();
  if (set.fast_only && (!set.vertices.empty() || !set.triangles.empty() || set.has_mesh())) {
    return Invalid("a fast-only set has vertex or triangle lists or a mesh");
  }
  if (auto err = ValidateMesh(set)) return err;
  if (!set.has_mesh()) return std::nullopt;
  // The fast bound's premises the mesh can check: every weighted joint of a source vertex is among
  // its sphere's influences, and a stored reach is no smaller than the weights (a smaller one from a
  // hostile file would give spheres that miss vertices).
  auto from_mesh = InfluenceReachFromMesh(set);
  if (!from_mesh.ok()) return from_mesh.error();
  if (set.influence_reach.empty()) return std::nullopt;
  for (size_t s = 0; s < n; ++s) {
    for (uint32_t k = set.influence_offsets[s]; k < set.influence_offsets[s + 1]; ++k) {
      if (set.influence_reach[k] < (*from_mesh)[k]) {
        return Invalid("sphere " + std::to_string(s) + " has influence reach " + Digits(set.influence_reach[k]) +
                       " on joint " + std::to_string(set.influence_joints[k]) + ", below the weight " +
                       Digits((*from_mesh)[k]) + " one of its source vertices gives that joint");
      }
    }
  }
  return std::nullopt;
}

// A 3x4 affine transform in double, row-major: row r is (m[r][0], m[r][1], m[r][2], m[r][3]).
using Affine34 = std::array<std::array<double, 4>, 3>;

Affine34 FromFloat(const Mat4f& g) {
  Affine34 m;
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 4; ++c) m[r][c] = static_cast<double>(g(r, c));
  }
  return m;
}

// The inverse of an affine transform by cofactors, each operation written out in a fixed order, so
// that every platform computes the same bits (what a stored radius is compared with must not
// depend on how a compiler vectorises Eigen); nullopt when singular, as internal::AffineInverse.
std::optional<Affine34> ScalarAffineInverse(const Affine34& m) {
  const double c00 = m[1][1] * m[2][2] - m[1][2] * m[2][1], c01 = m[1][2] * m[2][0] - m[1][0] * m[2][2],
               c02 = m[1][0] * m[2][1] - m[1][1] * m[2][0];
  const double det = (m[0][0] * c00 + m[0][1] * c01) + m[0][2] * c02;
  double scale = 0.0;
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) scale = std::max(scale, std::fabs(m[r][c]));
  }
  if (!(std::fabs(det) > 1e-12 * scale * scale * scale) || !std::isfinite(det)) return std::nullopt;
  const double inv_det = 1.0 / det;
  Affine34 out;
  out[0] = {c00 * inv_det, (m[0][2] * m[2][1] - m[0][1] * m[2][2]) * inv_det,
            (m[0][1] * m[1][2] - m[0][2] * m[1][1]) * inv_det, 0.0};
  out[1] = {c01 * inv_det, (m[0][0] * m[2][2] - m[0][2] * m[2][0]) * inv_det,
            (m[0][2] * m[1][0] - m[0][0] * m[1][2]) * inv_det, 0.0};
  out[2] = {c02 * inv_det, (m[0][1] * m[2][0] - m[0][0] * m[2][1]) * inv_det,
            (m[0][0] * m[1][1] - m[0][1] * m[1][0]) * inv_det, 0.0};
  for (int r = 0; r < 3; ++r) {
    out[r][3] = -((out[r][0] * m[0][3] + out[r][1] * m[1][3]) + out[r][2] * m[2][3]);
  }
  return out;
}

// a · b for affine a, b (the last rows 0 0 0 1), in a fixed order.
Affine34 Compose(const Affine34& a, const Affine34& b) {
  Affine34 out;
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 4; ++c) {
      out[r][c] = (a[r][0] * b[0][c] + a[r][1] * b[1][c]) + a[r][2] * b[2][c];
    }
    out[r][3] += a[r][3];
  }
  return out;
}

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
// copies (FastBoundVerticesFromMesh), to 1e-4 of the radius: a file shrunk by hand would give fast
// spheres that miss vertices, while files written before the fitter raised radius_fast to the
// runtime's own figures (HoldMeshCopies) fall short of them by float rounding only.
std::optional<Error> CheckFastRadii(const SphereSet& set) {
  if (!set.has_mesh() || set.fast_only || !set.fast_reference_spheres.empty()) return std::nullopt;
  auto vertices = FastBoundVerticesFromMesh(set);
  if (!vertices.ok()) return vertices.error();
  for (size_t s = 0; s < set.size(); ++s) {
    for (uint32_t i = set.vertex_offsets[s]; i < set.vertex_offsets[s + 1]; ++i) {
      if (set.radii_fast[s] < vertices->radius[i] * (1.0f - 1e-4f)) {
        return Invalid("sphere " + std::to_string(s) + " has fast radius " + Digits(set.radii_fast[s]) +
                       ", below the " + Digits(vertices->radius[i]) + " its source vertex " +
                       std::to_string(set.vertices[i]) + "'s rest copies need");
      }
    }
  }
  return std::nullopt;
}

// The reach groups (all three arrays empty, or: 1 to kMaxReachGroups groups per sphere, each with a
// finite positive radius and a reach per influence entry in [0, 1] summing to at least 1); with a
// mesh, every source vertex dominated by one of its sphere's groups (a group that misses a vertex
// would give fast spheres that miss it).
std::optional<Error> CheckReachGroups(const SphereSet& set) {
  const size_t n = set.size();
  if (set.reach_group_offsets.empty() && set.reach_group_radii.empty() && set.reach_group_weights.empty()) {
    return std::nullopt;
  }
  if (!CsrOk(set.reach_group_offsets, n, set.reach_group_radii.size())) {
    return Invalid("the reach groups' offsets are malformed (one per sphere plus one, from 0 to the group count)");
  }
  size_t weights = 0;
  for (size_t s = 0; s < n; ++s) {
    const uint32_t groups = set.reach_group_offsets[s + 1] - set.reach_group_offsets[s];
    if (groups < 1 || groups > kMaxReachGroups) {
      return Invalid("sphere " + std::to_string(s) + " has " + std::to_string(groups) + " reach groups (1 to " +
                     std::to_string(kMaxReachGroups) + ")");
    }
    weights += size_t{groups} * (set.influence_offsets[s + 1] - set.influence_offsets[s]);
  }
  if (set.reach_group_weights.size() != weights) {
    return Invalid("the reach groups have " + std::to_string(set.reach_group_weights.size()) + " reach entries for " +
                   std::to_string(weights) + " (one per group and influence)");
  }
  for (size_t s = 0, base = 0; s < n; ++s) {
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
  if (!set.has_mesh() || set.fast_only) return std::nullopt;
  auto vertices = FastBoundVerticesFromMesh(set);
  if (!vertices.ok()) return vertices.error();
  for (size_t s = 0, base = 0; s < n; ++s) {
    const uint32_t k_count = set.influence_offsets[s + 1] - set.influence_offsets[s];
    const uint32_t g0 = set.reach_group_offsets[s], g1 = set.reach_group_offsets[s + 1];
    for (uint32_t i = set.vertex_offsets[s]; i < set.vertex_offsets[s + 1]; ++i) {
      const float* w =
          vertices->weights.data() + vertices->weight_offsets[s] + size_t{i - set.vertex_offsets[s]} * k_count;
      bool dominated = false;
      for (uint32_t g = g0; g < g1 && !dominated; ++g) {
        const float* group = set.reach_group_weights.data() + base + size_t{g - g0} * k_count;
        dominated = set.reach_group_radii[g] >= vertices->radius[i];
        for (uint32_t k = 0; k < k_count && dominated; ++k) dominated = group[k] >= w[k];
      }
      if (!dominated) {
        return Invalid("sphere " + std::to_string(s) + "'s source vertex " + std::to_string(set.vertices[i]) +
                       " is in none of its reach groups (reference radius " + Digits(vertices->radius[i]) +
                       " or a weight above every group's)");
      }
    }
    base += size_t{g1 - g0} * k_count;
  }
  return std::nullopt;
}

}  // namespace

std::optional<Error> SphereSet::Validate() const {
  for (const auto check : {CheckSkeleton, CheckParts, CheckSphereArrays, CheckSpheres, CheckOwnership, CheckInfluences,
                           CheckExclusions, CheckMesh, CheckFastRadii, CheckFastReference, CheckReachGroups}) {
    if (auto err = check(*this)) return err;
  }
  return std::nullopt;
}

Result<std::vector<float>> InfluenceReachFromMesh(const SphereSet& set) {
  const skinning::SkinnedMesh& mesh = set.mesh;
  std::vector<float> reach(set.influence_joints.size(), 0.0f);
  // entry_of[j]: the current sphere's first influence entry on joint j (UINT32_MAX: none); total:
  // per entry of the current sphere, the current vertex's weight on its joint.
  std::vector<uint32_t> entry_of(set.joint_count(), UINT32_MAX);
  std::vector<float> total;
  for (size_t s = 0; s < set.size(); ++s) {
    const uint32_t k0 = set.influence_offsets[s], k1 = set.influence_offsets[s + 1];
    for (uint32_t k = k1; k-- > k0;) entry_of[set.influence_joints[k]] = k;
    total.assign(k1 - k0, 0.0f);
    for (uint32_t i = set.vertex_offsets[s]; i < set.vertex_offsets[s + 1]; ++i) {
      const uint32_t v = set.vertices[i];
      const uint32_t q0 = mesh.influence_offsets[v], q1 = mesh.influence_offsets[v + 1];
      for (uint32_t q = q0; q < q1; ++q) {
        if (!(mesh.influence_weights[q] > 0.0f)) continue;
        const int32_t j = mesh.binds[mesh.influence_binds[q]].joint;
        if (entry_of[j] == UINT32_MAX) {
          return Invalid("sphere " + std::to_string(s) + ": its source vertex " + std::to_string(v) +
                         " is weighted on joint " + std::to_string(j) + ", which is not among the sphere's influences");
        }
        total[entry_of[j] - k0] += mesh.influence_weights[q];
      }
      for (uint32_t q = q0; q < q1; ++q) {  // each joint's total, once (a second entry finds 0)
        const uint32_t k = entry_of[mesh.binds[mesh.influence_binds[q]].joint];
        if (k == UINT32_MAX) continue;                                 // weight 0
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
  FastBoundVertices out;
  out.radius.resize(set.vertices.size());
  out.weight_offsets.resize(set.size());
  size_t weight_count = 0;
  for (size_t s = 0; s < set.size(); ++s) {
    out.weight_offsets[s] = static_cast<uint32_t>(weight_count);
    weight_count += size_t{set.vertex_offsets[s + 1] - set.vertex_offsets[s]} *
                    (set.influence_offsets[s + 1] - set.influence_offsets[s]);
  }
  out.weights.assign(weight_count, 0.0f);
  std::vector<uint32_t> entry_of(set.joint_count(), UINT32_MAX);  // the sphere's first entry per joint
  for (size_t s = 0; s < set.size(); ++s) {
    const Vec4f& ref = stored ? set.fast_reference_spheres[s] : Vec4f::Zero();
    const Eigen::Vector3f& centre = stored ? Eigen::Vector3f(ref.head<3>()) : set.centers_rest[s];
    const double c[3] = {centre.x(), centre.y(), centre.z()};
    const uint32_t k0 = set.influence_offsets[s], k1 = set.influence_offsets[s + 1];
    for (uint32_t k = k1; k-- > k0;) entry_of[set.influence_joints[k]] = k;
    for (uint32_t i = set.vertex_offsets[s]; i < set.vertex_offsets[s + 1]; ++i) {
      const uint32_t v = set.vertices[i];
      const double p[3] = {mesh.positions_bind[v].x(), mesh.positions_bind[v].y(), mesh.positions_bind[v].z()};
      float* w = out.weights.data() + out.weight_offsets[s] + size_t{i - set.vertex_offsets[s]} * (k1 - k0);
      double r2 = 0.0;
      bool weighted = false;
      for (uint32_t q = mesh.influence_offsets[v]; q < mesh.influence_offsets[v + 1]; ++q) {
        if (!(mesh.influence_weights[q] > 0.0f)) continue;
        weighted = true;
        const int32_t j = mesh.binds[mesh.influence_binds[q]].joint;
        if (entry_of[j] == UINT32_MAX) {
          return Invalid("sphere " + std::to_string(s) + ": its source vertex " + std::to_string(v) +
                         " is weighted on joint " + std::to_string(j) + ", which is not among the sphere's influences");
        }
        w[entry_of[j] - k0] += mesh.influence_weights[q];
        const Affine34& m = copy_of[mesh.influence_binds[q]];
        double d2 = 0.0;
        for (int r = 0; r < 3; ++r) {
          const double d = (((m[r][0] * p[0] + m[r][1] * p[1]) + m[r][2] * p[2]) + m[r][3]) - c[r];
          d2 += d * d;
        }
        r2 = std::max(r2, d2);
      }
      if (!weighted) {
        return Invalid("sphere " + std::to_string(s) + ": its source vertex " + std::to_string(v) +
                       " has no weight above 0");
      }
      // Each joint's total (a float sum may pass 1 by an ulp), copied to its repeated entries.
      for (uint32_t k = k0; k < k1; ++k) w[k - k0] = std::min(w[entry_of[set.influence_joints[k]] - k0], 1.0f);
      out.radius[i] = std::nextafter(static_cast<float>(std::sqrt(r2)), std::numeric_limits<float>::infinity());
    }
    for (uint32_t k = k0; k < k1; ++k) entry_of[set.influence_joints[k]] = UINT32_MAX;
  }
  return out;
}

Result<std::vector<float>> FastReferenceRadiiFromMesh(const SphereSet& set) {
  // The largest of the vertices' radii: rounding up is monotone, so this is the radius of the
  // farthest copy rounded up.
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
