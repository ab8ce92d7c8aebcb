// SphereSet: the fitted spheres of one character, the contract between the offline fitter
// (skinspheres::lib writes it) and the runtime (reads it, never links Assimp).
//
// Everything is in the rest pose, in the world space of the source file (no rescaling, glTF +Y up).
// Per-sphere data is stored as parallel arrays (structure of arrays) plus CSR lists:
//   sphere s owns source vertices  vertices[vertex_offsets[s] .. vertex_offsets[s+1])
//   and source triangles           triangles[triangle_offsets[s] .. triangle_offsets[s+1])
// Vertex and triangle indices count the source file's own vertices and triangles, mesh by mesh
// and primitive by primitive in file order, so an engine can pass its own skinned buffer.
//
// Fast refit (no vertex skinning) reads, per sphere, the joints that influence its vertices with
// their blend weights, and radius_fast: the radius around center_rest that holds, for every source
// vertex, the weighted mean distance of its copies carried rigidly by each of its joints at rest
// (equal to the plain radius when the file's rest pose is its bind pose; a file may hold the
// farthest copy instead, which is sound too), and per influence its reach: the largest weight any
// of the sphere's source vertices gives that joint, which tightens the fast bound (docs/REFIT.md).
//
// Version 2 adds the skinned mesh itself (`mesh`, `triangle_vertices`): what a triangle-level test
// behind the spheres needs, and what lets fast mode skin only the vertices it tests. A set read
// from a version-1 file has no mesh (has_mesh() false) and works for everything else.
//
// Version 4 states the contact rules on triangles (contact_rules below); a set read from an older
// file keeps the rules it was fitted with, stated on sphere pairs.
//
// On disk: JSON, {"format":"skinspheres.sphere_set","version":4,...} (sphere_set_io.h); files of
// versions 1 to 3 still load (and such a set is written back as the version it came in). Binary
// (sphere_set_binary.h, docs/FORMAT.md): the same set, memory-mappable, loaded ~100x faster; its
// fast-only variant leaves out what only exact mode and triangle tests read (fast_only below).
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "skinspheres/runtime/error.h"
#include "skinspheres/skinning/math_types.h"
#include "skinspheres/skinning/skinned_mesh.h"

namespace skinspheres::runtime {

inline constexpr const char* kSphereSetFormat = "skinspheres.sphere_set";
inline constexpr int kSphereSetVersionWithRules = 4;    // written when the contact rules are on triangles
inline constexpr int kSphereSetVersionWithPieces = 3;   // written for sets before them with triangle pieces
inline constexpr int kSphereSetVersion = 2;             // for sets before them with a mesh and no pieces
inline constexpr int kSphereSetVersionWithoutMesh = 1;  // for sets before them without a mesh; all four are read
inline constexpr uint32_t kMaxReachGroups = 4;          // per sphere (SphereSet::reach_group_offsets)

// Why a sphere pair is excluded. Under ContactRules::kTriangles (narrow_phase/contact_rules.h): every
// triangle of both spheres has one joint (kSameJoint), or every joint of one sphere's triangles is
// within contact_hops of every joint of the other's (kAdjacentJoints). Sets written before those rules
// (kSpherePairs) state them on the spheres' own joints, and kBindOverlap: the spheres overlap at rest.
enum class ExclusionReason : uint8_t {
  kSameJoint = 0,
  kAdjacentJoints = 1,
  kBindOverlap = 2,  // only in sets with ContactRules::kSpherePairs
};
const char* ToString(ExclusionReason reason);
std::optional<ExclusionReason> ExclusionReasonFromString(std::string_view text);

// How a set states which triangle pairs are not contacts (narrow_phase/contact_rules.h).
enum class ContactRules : uint8_t {
  kSpherePairs = 0,  // sets written before the rules on triangles: on sphere pairs, as fitted
  kTriangles = 1,    // on triangles: the same contacts whatever the fit
};
const char* ToString(ContactRules rules);  // "sphere_pairs", "triangles"
std::optional<ContactRules> ContactRulesFromString(std::string_view text);

struct ExcludedPair {
  uint32_t i = 0;  // i < j
  uint32_t j = 0;
  ExclusionReason reason = ExclusionReason::kSameJoint;
};

// Triangle pieces (docs/TRIANGLE_PIECES.md). A source triangle is owned whole by one sphere, or cut
// into the level² sub-triangles of its regular level-L grid (2 <= L <= kMaxPieceLevel), each owned
// by one sphere. Grid point (i, j) of triangle t (i + j <= L) is the barycentric combination
//   ((L - i - j) · p0 + i · p1 + j · p2) / L   of its vertices p0, p1, p2 (triangle_vertices[3t..]),
// at every pose: linear blend skinning is linear in the vertices' skinned positions, so a grid
// point of the skinned triangle is the same combination of its skinned vertices.
inline constexpr uint16_t kMaxPieceLevel = 16;

// A grid point that is not one of its triangle's vertices (those are source vertices).
struct PiecePoint {
  uint32_t triangle = 0;
  uint16_t level = 0;
  uint8_t i = 0, j = 0;  // weights i / level on p1, j / level on p2
  friend bool operator==(const PiecePoint&, const PiecePoint&) = default;
};

// Sub-triangle `index` of its triangle's level-L grid, index < L²: the L(L+1)/2 upward ones first,
// (i, j) (i+1, j) (i, j+1) for j = 0.. L-1, i = 0.. L-1-j in that order, then the L(L-1)/2 downward
// ones, (i+1, j) (i+1, j+1) (i, j+1) for j = 0.. L-2, i = 0.. L-2-j: every piece wound as the
// triangle is.
struct TrianglePiece {
  uint32_t triangle = 0;
  uint16_t level = 0;
  uint16_t index = 0;
  friend bool operator==(const TrianglePiece&, const TrianglePiece&) = default;
};

// The grid coordinates (i, j) of the piece's three corners, in the order above; false when the level
// or index is out of range.
bool PieceCorners(uint16_t level, uint16_t index, uint8_t corners[3][2]);

// Which of its triangle's vertices grid point (i, j) of level L is: 0, 1 or 2 at the corners (the
// point is that source vertex), -1 anywhere else.
inline int GridCorner(uint16_t level, uint8_t i, uint8_t j) {
  if (j == 0 && (i == 0 || i == level)) return i == 0 ? 0 : 1;
  return i == 0 && j == level ? 2 : -1;
}

// Grid point (i, j) of level L of the triangle p0 p1 p2 in float, in a fixed order, each coordinate
// clamped to the triangle's own range (float rounding could put a point on an axis-aligned edge an
// ulp outside the triangle's box, so that a piece's box would not lie in its triangle's). The same
// bits on every platform: defined in the library, which builds without FMA contraction.
Eigen::Vector3f GridPoint(const Eigen::Vector3f& p0, const Eigen::Vector3f& p1, const Eigen::Vector3f& p2,
                          uint16_t level, uint8_t i, uint8_t j);

struct SpherePart {
  std::string name;              // "torso", "head", "arm_l", "arm_r", "leg_l", "leg_r", or chain names
  std::vector<uint32_t> joints;  // skeleton joint indices
};

struct SphereSet {
  // Where it came from.
  std::string source_file;
  uint32_t source_vertex_count = 0;
  uint32_t source_triangle_count = 0;
  std::string params_json = "{}";  // the fit parameters, as written by the fitter (JSON object text)

  // The skeleton it was fitted on (for matching an instance's joints, and for fast refit).
  std::vector<std::string> joint_names;
  std::vector<int32_t> joint_parents;   // -1 for roots, parents[i] < i
  std::vector<Mat4f> joint_rest_world;  // G_j at rest

  std::vector<SpherePart> parts;

  // Per sphere (all of size size()).
  std::vector<Eigen::Vector3f> centers_rest;
  std::vector<float> radii_rest;
  std::vector<float> radii_fast;       // >= radii_rest; see the header comment
  std::vector<uint16_t> sphere_part;   // index into parts
  std::vector<uint16_t> sphere_joint;  // dominant joint of the owned triangles
  std::vector<uint16_t> sphere_level;  // disk level within its part (paper §4.3)

  // CSR lists (offsets have size()+1 entries).
  std::vector<uint32_t> vertex_offsets, vertices;
  std::vector<uint32_t> triangle_offsets, triangles;
  std::vector<uint32_t> influence_offsets;
  std::vector<uint16_t> influence_joints;
  std::vector<float> influence_weights;  // sum to 1 per sphere
  // Per influence entry (same CSR) or empty: the entry's reach W in [0, 1] (docs/REFIT.md#fast-mode);
  // empty: computed from the mesh, else 1. Like radius_fast and the blends, it holds for the mesh's
  // skin weights: an engine that re-quantises or prunes them must fit with the weights it skins with.
  std::vector<float> influence_reach;

  // The fast refit's reference frame, or both empty: the rest pose. Per joint R_j^-1 (column-major
  // 4x4, affine); per sphere (c, r) in reference space. With a mesh Validate() checks r; a fast-only
  // file keeps them. Meaning and checks: docs/REFIT.md#the-fast-refits-data-in-a-sphereset.
  std::vector<Mat4f> fast_reference_inverse;
  std::vector<Vec4f> fast_reference_spheres;

  // The fast bound's reach groups, or all three empty: one group per sphere. Sphere s has groups
  // [reach_group_offsets[s], [s+1]) (1 to kMaxReachGroups), each a radius and K_s reaches (K_s the
  // sphere's influence count). Layout and checks: docs/REFIT.md#the-fast-refits-data-in-a-sphereset.
  std::vector<uint32_t> reach_group_offsets;
  std::vector<float> reach_group_radii;
  std::vector<float> reach_group_weights;
  // Each reach group's blend m and deviation e, laid out as reach_group_weights, or both empty: none
  // (the bound without them, bit for bit). Needs the groups. docs/REFIT.md#group-blends.
  std::vector<float> reach_group_blend;
  std::vector<float> reach_group_deviation;

  std::vector<ExcludedPair> excluded_pairs;  // sorted by (i, j), i < j, unique

  // The contact rules (narrow_phase/contact_rules.h). kTriangles: rule 2 at contact_hops (at most
  // kMaxContactHops), rule 3 with rest_gap (model units, >= 0, at most kMaxRestGapShare of the rest
  // height); excluded_pairs then holds only sphere pairs rule 2 excludes whole. kSpherePairs (read
  // from a file written before the rules on triangles): excluded_pairs as fitted, contact_hops and
  // rest_gap 0. WriteContactRules (contact_rules.h) fills all four for a set made by hand.
  ContactRules contact_rules = ContactRules::kTriangles;
  uint32_t contact_hops = 1;
  float rest_gap = 0.0f;

  // Triangle pieces (see TrianglePiece above), or all three empty: every triangle owned whole.
  // Sphere s owns pieces[piece_offsets[s] .. piece_offsets[s+1]). Its point list (`vertices`) then
  // names, besides source vertices v < source_vertex_count, grid points source_vertex_count + k
  // (piece_points[k]): it holds every corner of its pieces (a corner at a triangle vertex is that
  // source vertex) and every vertex of its whole triangles, and the refits bound exactly those
  // points. A triangle is owned whole by one sphere or cut at one level with every piece owned
  // once, all by spheres of one part. Pieces need the mesh (version 2 data); a fast-only set keeps
  // none, and every grid point is listed once.
  std::vector<PiecePoint> piece_points;
  std::vector<uint32_t> piece_offsets;
  std::vector<TrianglePiece> pieces;

  // The skinned mesh the set was fitted on (version 2; both empty in a version-1 set), indexed by
  // source vertex and source triangle like the lists above:
  //   triangle t has source vertices triangle_vertices[3t], [3t+1], [3t+2];
  //   mesh.positions_bind, mesh.binds (joint, inverse bind matrix) and the per-vertex influences
  //   (CSR over bind entries, weights normalised to sum 1) are the file's skin, so
  //   p_v(t) = Σ_k w_k · G_joint(b_k)(t) · IBM_b_k · p_bind,v  gives every vertex at any pose, and at
  //   rest (G = joint_rest_world) the positions the spheres were fitted on. Rigid meshes hanging
  //   under a joint appear as one bind entry with weight 1 (see skinning/skinned_mesh.h).
  // Every vertex of a triangle a sphere owns is among that sphere's source vertices.
  skinning::SkinnedMesh mesh;               // vertex_count() == source_vertex_count when present
  std::vector<uint32_t> triangle_vertices;  // 3 * source_triangle_count when present

  // True for a set read from a fast-only binary file (sphere_set_binary.h): the per-sphere vertex
  // and triangle lists are empty (offsets all 0) and there is no mesh. Fast refit works; exact
  // refit (RefitJob, CharacterInstance::UpdateExact) and anything reading triangles refuse it.
  bool fast_only = false;

  // Where the set was read from (the path or the name given to a reader; empty when built in
  // memory). Not written to files: errors such as CharacterAsset::Matches name it.
  std::string loaded_from;

  size_t size() const { return centers_rest.size(); }
  bool has_mesh() const { return !triangle_vertices.empty(); }
  // Drops the reach groups and their blends (all five arrays): one group per sphere again.
  void ClearReachGroups() {
    reach_group_offsets.clear();
    reach_group_radii.clear();
    reach_group_weights.clear();
    reach_group_blend.clear();
    reach_group_deviation.clear();
  }
  bool has_pieces() const { return !pieces.empty() || !piece_points.empty() || !piece_offsets.empty(); }
  // The pieces sphere s owns: pieces[piece_offsets[s], piece_offsets[s + 1]), none when the set has no
  // piece offsets (a set without pieces). Needs s < size() and offsets that Validate() accepted.
  std::span<const TrianglePiece> PiecesOf(size_t s) const {
    if (piece_offsets.empty()) return {};
    return {pieces.data() + piece_offsets[s], pieces.data() + piece_offsets[s + 1]};
  }
  // Point k of the point lists (`vertices`) at the given skinned source-vertex positions: a source
  // vertex, or a grid point computed from its triangle's vertices (GridPoint). Needs a valid set with
  // a mesh when k names a grid point.
  Eigen::Vector3f PointAt(uint32_t k, const Eigen::Vector3f* positions) const {
    if (k < source_vertex_count) return positions[k];
    const PiecePoint& g = piece_points[k - source_vertex_count];
    const uint32_t* v = triangle_vertices.data() + 3 * size_t{g.triangle};
    return GridPoint(positions[v[0]], positions[v[1]], positions[v[2]], g.level, g.i, g.j);
  }
  size_t joint_count() const { return joint_names.size(); }
  // Every reason the set is inconsistent (no spheres, a radius <= 0, a triangle owned by no sphere
  // or by two, sizes, offsets, index ranges, NaNs, pair order, an influence reach outside [0, 1];
  // with a mesh: its sizes, indices, finite values, each sphere's vertices covering its triangles',
  // a source vertex weighted on a joint that is not among its sphere's influences, and an influence
  // reach below the one the mesh gives, which would make the fast bound too small);
  // std::nullopt when it is sound.
  std::optional<Error> Validate() const;
};

// The source vertices the set's point lists need skinned, ascending, each once: the source vertices
// among them and the three vertices of each grid point's triangle (what exact refit reads through
// SphereSet::PointAt). Needs a valid set.
std::vector<uint32_t> SourceVerticesOfPoints(const SphereSet& set);

// What the refit bounds need from the mesh (influence reach, fast bound vertices and radii):
// refit/mesh_bounds.h.

}  // namespace skinspheres::runtime
