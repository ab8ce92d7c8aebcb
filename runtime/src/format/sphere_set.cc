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

#include "format/grid_point.h"
#include "skinspheres/runtime/narrow_phase/contact_rules.h"

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

bool PieceCorners(uint16_t level, uint16_t index, uint8_t corners[3][2]) {
  if (level < 2 || level > kMaxPieceLevel || index >= uint32_t{level} * level) return false;
  const uint32_t up = uint32_t{level} * (level + 1) / 2;
  // Row j of the upward pieces holds level - j of them, row j of the downward ones level - 1 - j.
  const bool upward = index < up;
  uint32_t k = upward ? index : index - up;
  uint32_t j = 0;
  for (uint32_t row = upward ? level : level - 1u; k >= row; --row) {
    k -= row;
    ++j;
  }
  const auto i = static_cast<uint8_t>(k), jj = static_cast<uint8_t>(j);
  const uint8_t up_corners[3][2] = {{i, jj}, {uint8_t(i + 1), jj}, {i, uint8_t(jj + 1)}};
  const uint8_t down_corners[3][2] = {{uint8_t(i + 1), jj}, {uint8_t(i + 1), uint8_t(jj + 1)}, {i, uint8_t(jj + 1)}};
  for (int c = 0; c < 3; ++c) {
    for (int a = 0; a < 2; ++a) corners[c][a] = upward ? up_corners[c][a] : down_corners[c][a];
  }
  return true;
}

Eigen::Vector3f GridPoint(const Eigen::Vector3f& p0, const Eigen::Vector3f& p1, const Eigen::Vector3f& p2,
                          uint16_t level, uint8_t i, uint8_t j) {
  return internal::GridPointInline(p0, p1, p2, level, i, j);
}

namespace {

Error Invalid(const std::string& what) { return MakeError(ErrorCode::kInvalidData, what); }

std::string PointName(const SphereSet& set, uint32_t k);  // "source vertex 7", "grid point (1, 0) of ..."

// A grid point's key, ordered by triangle, level, i, j.
uint64_t PointKey(uint32_t triangle, uint16_t level, uint8_t i, uint8_t j) {
  return (uint64_t{triangle} << 32) | (uint64_t{level} << 16) | (uint64_t{i} << 8) | j;
}

// The source vertex at grid point (i, j) when it is one of the triangle's corners, else UINT32_MAX.
uint32_t CornerVertex(const SphereSet& set, uint32_t triangle, uint16_t level, uint8_t i, uint8_t j) {
  const int corner = GridCorner(level, i, j);
  return corner < 0 ? UINT32_MAX : set.triangle_vertices[3 * size_t{triangle} + static_cast<size_t>(corner)];
}

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
    // Affine, to float rounding (the importers' 4x4 inverse of a rigid mesh's joint transform ends in
    // 0.99999994): skinning multiplies the whole 4x4 (SkinningMatricesJob), while the fast bound's
    // checks and figures (FastBoundVerticesFromMesh) read its top three rows; a last row of, say,
    // 0 0 0 2 would skin vertices outside the fast spheres those checks passed.
    if (!((mesh.binds[b].inverse_bind.row(3) - Eigen::RowVector4f(0.0f, 0.0f, 0.0f, 1.0f)).cwiseAbs().maxCoeff() <=
          FLT_EPSILON)) {
      return Invalid("mesh bind entry " + std::to_string(b) +
                     "'s inverse bind matrix is not affine (its last row is not 0 0 0 1)");
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
  // marked[k] == s: point k (a source vertex, or grid point k - vertices) is in sphere s's list.
  std::vector<uint32_t> marked(vertices + set.piece_points.size(), UINT32_MAX);
  // The grid points by key (unique: CheckPieces), to find a piece corner's point.
  std::vector<std::pair<uint64_t, uint32_t>> point_of(set.piece_points.size());
  for (size_t k = 0; k < set.piece_points.size(); ++k) {
    const PiecePoint& g = set.piece_points[k];
    point_of[k] = {PointKey(g.triangle, g.level, g.i, g.j), static_cast<uint32_t>(vertices + k)};
  }
  std::sort(point_of.begin(), point_of.end());
  for (size_t s = 0; s < set.size(); ++s) {
    for (uint32_t k = set.vertex_offsets[s]; k < set.vertex_offsets[s + 1]; ++k)
      marked[set.vertices[k]] = static_cast<uint32_t>(s);
    for (const TrianglePiece& p : set.PiecesOf(s)) {
      uint8_t corners[3][2];
      PieceCorners(p.level, p.index, corners);  // in range: CheckPieces
      for (const auto& c : corners) {
        uint32_t point = CornerVertex(set, p.triangle, p.level, c[0], c[1]);
        if (point == UINT32_MAX) {
          const uint64_t key = PointKey(p.triangle, p.level, c[0], c[1]);
          const auto it = std::lower_bound(point_of.begin(), point_of.end(), std::pair<uint64_t, uint32_t>{key, 0});
          if (it != point_of.end() && it->first == key) point = it->second;
        }
        if (point == UINT32_MAX || marked[point] != s) {
          return Invalid("sphere " + std::to_string(s) + " owns piece " + std::to_string(p.index) + " of triangle " +
                         std::to_string(p.triangle) + " but not its grid point (" + std::to_string(c[0]) + ", " +
                         std::to_string(c[1]) + ") of level " + std::to_string(p.level));
        }
      }
    }
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
  // Pieces: no lists at all, or a CSR over them; grid points only with pieces to use them.
  if (set.piece_offsets.empty() ? (!set.pieces.empty() || !set.piece_points.empty())
                                : !CsrOk(set.piece_offsets, n, set.pieces.size()))
    return Invalid("sphere piece lists are malformed (grid points or pieces without per-sphere offsets)");
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

// The pieces and grid points (TrianglePiece): levels and indices in range, grid points unique and
// not triangle corners, and each cut triangle (not owned whole: owner[t] == UINT32_MAX on entry)
// cut at one level with every piece owned once, by spheres of one part; marks them owned.
std::optional<Error> CheckPieces(const SphereSet& set, std::vector<uint32_t>& owner) {
  if (!set.has_pieces()) return std::nullopt;
  if (set.fast_only || !set.has_mesh()) return Invalid("the set has triangle pieces but no mesh");
  std::vector<uint64_t> keys(set.piece_points.size());
  for (size_t k = 0; k < set.piece_points.size(); ++k) {
    const PiecePoint& g = set.piece_points[k];
    if (g.triangle >= set.source_triangle_count || g.level < 2 || g.level > kMaxPieceLevel ||
        uint32_t{g.i} + g.j > g.level || GridCorner(g.level, g.i, g.j) >= 0) {
      return Invalid("grid point " + std::to_string(k) + " (triangle " + std::to_string(g.triangle) + ", level " +
                     std::to_string(g.level) + ", " + std::to_string(g.i) + ", " + std::to_string(g.j) +
                     ") is out of range or a triangle corner");
    }
    keys[k] = PointKey(g.triangle, g.level, g.i, g.j);
  }
  std::sort(keys.begin(), keys.end());
  if (std::adjacent_find(keys.begin(), keys.end()) != keys.end()) return Invalid("a grid point is listed twice");
  // (triangle, index, sphere) of every piece, sorted.
  struct Owned {
    uint32_t triangle, index, sphere, level;
  };
  std::vector<Owned> owned;
  owned.reserve(set.pieces.size());
  for (size_t s = 0; s < set.size(); ++s) {
    for (uint32_t k = set.piece_offsets[s]; k < set.piece_offsets[s + 1]; ++k) {
      const TrianglePiece& p = set.pieces[k];
      uint8_t corners[3][2];
      if (p.triangle >= set.source_triangle_count || !PieceCorners(p.level, p.index, corners)) {
        return Invalid("sphere " + std::to_string(s) + " names piece " + std::to_string(p.index) + " of level " +
                       std::to_string(p.level) + " of triangle " + std::to_string(p.triangle) + " (out of range)");
      }
      owned.push_back({p.triangle, p.index, static_cast<uint32_t>(s), p.level});
    }
  }
  std::sort(owned.begin(), owned.end(), [](const Owned& a, const Owned& b) {  // a total order
    if (a.triangle != b.triangle) return a.triangle < b.triangle;
    if (a.index != b.index) return a.index < b.index;
    return a.level != b.level ? a.level < b.level : a.sphere < b.sphere;
  });
  for (size_t begin = 0; begin < owned.size();) {
    const uint32_t t = owned[begin].triangle, level = owned[begin].level;
    size_t end = begin;
    while (end < owned.size() && owned[end].triangle == t) ++end;
    if (owner[t] != UINT32_MAX) {
      return Invalid("triangle " + std::to_string(t) + " is owned whole by sphere " + std::to_string(owner[t]) +
                     " and in pieces by sphere " + std::to_string(owned[begin].sphere));
    }
    for (size_t k = begin; k < end; ++k) {
      if (owned[k].level != level || owned[k].index != k - begin || end - begin != size_t{level} * level) {
        return Invalid("triangle " + std::to_string(t) + "'s pieces are not each of its " + std::to_string(level) +
                       " x " + std::to_string(level) + " grid's pieces once, at one level");
      }
      if (set.sphere_part[owned[k].sphere] != set.sphere_part[owned[begin].sphere]) {
        return Invalid("triangle " + std::to_string(t) + "'s pieces are owned by spheres " +
                       std::to_string(owned[begin].sphere) + " and " + std::to_string(owned[k].sphere) +
                       " of different parts");
      }
    }
    owner[t] = owned[begin].sphere;
    begin = end;
  }
  return std::nullopt;
}

// The vertices and triangles the spheres name, and each triangle owned once.
std::optional<Error> CheckOwnership(const SphereSet& set) {
  [[maybe_unused]] const size_t n = set.size();
  [[maybe_unused]] const size_t joints = set.joint_count();
  for (uint32_t v : set.vertices) {
    if (v >= set.source_vertex_count + set.piece_points.size())
      return Invalid("a sphere names vertex " + std::to_string(v) + " out of range");
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
  if (!set.fast_only && (set.triangles.size() > set.source_triangle_count ||
                         set.triangles.size() + set.pieces.size() < set.source_triangle_count ||
                         (set.pieces.empty() && set.triangles.size() != set.source_triangle_count))) {
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
  if (auto err = CheckPieces(set, owner)) return err;
  if (set.fast_only) return std::nullopt;
  for (size_t t = 0; t < owner.size(); ++t) {
    if (owner[t] == UINT32_MAX) return Invalid("triangle " + std::to_string(t) + " is owned by no sphere");
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
// refit_job.h) are for a figure computed elsewhere and rounded once more. Until 2026-12-06 this
// allowed 1e-4 of the radius, and a review found a Soldier file shrunk within it that left a
// vertex 1.45e-6 outside its fast sphere at the worst pose; every file in the fuzz corpus, back to
// layout 1, passes the 2 ulps.
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

// The reach groups (all three arrays empty, or: 1 to kMaxReachGroups groups per sphere, each with a
// finite positive radius and a reach per influence entry in [0, 1] summing to at least 1); with a
// mesh, every source vertex dominated by one of its sphere's groups (a group that misses a vertex
// would give fast spheres that miss it).
std::optional<Error> CheckReachGroups(const SphereSet& set) {
  const size_t n = set.size();
  if (set.reach_group_offsets.empty() && set.reach_group_radii.empty() && set.reach_group_weights.empty()) {
    if (!set.reach_group_blend.empty() || !set.reach_group_deviation.empty()) {
      return Invalid("the reach groups' blends are given without the groups");
    }
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
  // The groups' blends: both arrays empty, or each as long as the reaches, within [0, 1], and 0 on
  // an entry that repeats an earlier entry's joint.
  const bool blends = !set.reach_group_blend.empty() || !set.reach_group_deviation.empty();
  if (blends && (set.reach_group_blend.size() != weights || set.reach_group_deviation.size() != weights)) {
    return Invalid("the reach groups have " + std::to_string(set.reach_group_blend.size()) + " blend and " +
                   std::to_string(set.reach_group_deviation.size()) + " deviation entries for " +
                   std::to_string(weights) + " (one each per group and influence, or none)");
  }
  std::vector<uint8_t> repeated;  // per entry of the sphere: its joint appeared at an earlier entry
  if (blends) {
    for (size_t s = 0, base = 0; s < n; ++s) {
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
  }
  if (!set.has_mesh() || set.fast_only) return std::nullopt;
  auto vertices = FastBoundVerticesFromMesh(set);
  if (!vertices.ok()) return vertices.error();
  for (size_t s = 0, base = 0; s < n; ++s) {
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

std::optional<Error> SphereSet::Validate() const {
  for (const auto check :
       {CheckSkeleton, CheckParts, CheckSphereArrays, CheckSpheres, CheckOwnership, CheckInfluences, CheckExclusions,
        CheckMesh, CheckFastRadii, CheckFastReference, CheckReachGroups, CheckContactRules}) {
    if (auto err = check(*this)) return err;
  }
  return std::nullopt;
}

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

std::string PointName(const SphereSet& set, uint32_t k) {
  if (k < set.source_vertex_count) return "source vertex " + std::to_string(k);
  const PiecePoint& g = set.piece_points[k - set.source_vertex_count];
  return "grid point (" + std::to_string(g.i) + ", " + std::to_string(g.j) + ") of level " + std::to_string(g.level) +
         " of triangle " + std::to_string(g.triangle);
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

std::vector<uint32_t> SourceVerticesOfPoints(const SphereSet& set) {
  std::vector<uint32_t> out;
  out.reserve(set.vertices.size());
  for (uint32_t point : set.vertices) {
    if (point < set.source_vertex_count) {
      out.push_back(point);
      continue;
    }
    const uint32_t t = set.piece_points[point - set.source_vertex_count].triangle;
    for (int c = 0; c < 3; ++c) out.push_back(set.triangle_vertices[3 * size_t{t} + c]);
  }
  std::sort(out.begin(), out.end());
  out.erase(std::unique(out.begin(), out.end()), out.end());
  return out;
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
      // Σ_b w_b |p_b - c| (refit_job.h, "Fast mode"), taken over Σ_b w_b (1 up to float rounding of
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
