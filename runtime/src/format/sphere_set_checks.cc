// The sphere set's structural checks: skeleton, parts, per-sphere arrays, spheres, pieces, ownership,
// influences, exclusions and mesh (sphere_set_checks.h).
#include "format/sphere_set_checks.h"

#include <algorithm>
#include <cfloat>
#include <cmath>
#include <cstdint>
#include <limits>
#include <optional>
#include <string>
#include <vector>

#include "format/grid_point.h"
#include "skinspheres/runtime/refit/mesh_bounds.h"

namespace skinspheres::runtime::internal {

namespace {

// A grid point's key, ordered by triangle, level, i, j.
uint64_t PointKey(uint32_t triangle, uint16_t level, uint8_t i, uint8_t j) {
  return (uint64_t{triangle} << 32) | (uint64_t{level} << 16) | (uint64_t{i} << 8) | j;
}

// The source vertex at grid point (i, j) when it is one of the triangle's corners, else UINT32_MAX.
uint32_t CornerVertex(const SphereSet& set, uint32_t triangle, uint16_t level, uint8_t i, uint8_t j) {
  const int corner = GridCorner(level, i, j);
  return corner < 0 ? UINT32_MAX : set.triangle_vertices[3 * size_t{triangle} + static_cast<size_t>(corner)];
}

using skinning::kWeightSumTolerance;  // skinned_mesh.h

std::optional<Error> CheckMeshSkin(const SphereSet& set);
std::optional<Error> CheckSpheresHoldTheirCorners(const SphereSet& set);

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
  if (auto err = CheckMeshSkin(set)) return err;
  return CheckSpheresHoldTheirCorners(set);
}

// The mesh's skin: bind entries naming joints in range with finite affine inverse bind matrices,
// well-formed influence lists with finite weights >= 0 summing to 1 per vertex.
std::optional<Error> CheckMeshSkin(const SphereSet& set) {
  const skinning::SkinnedMesh& mesh = set.mesh;
  const size_t vertices = set.source_vertex_count;
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
  return std::nullopt;
}

// Every vertex of a triangle a sphere owns, and every corner of a piece it owns, among that
// sphere's points (what the refit bounds is what a triangle test reads).
std::optional<Error> CheckSpheresHoldTheirCorners(const SphereSet& set) {
  const size_t vertices = set.source_vertex_count;
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

namespace {

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

}  // namespace

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

}  // namespace skinspheres::runtime::internal
