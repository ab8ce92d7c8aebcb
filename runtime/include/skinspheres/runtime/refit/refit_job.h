// RefitJob: the per-frame sphere refit. SphereSet (rest pose) + this frame's pose -> one bounding
// sphere per fitted sphere, written as Vec4f (xyz centre, w radius), ready for the broad
// phase (broad_phase.h). Both modes are CONSERVATIVE: every vertex of every triangle a sphere owns
// (sphere_set.h, `triangles`) is inside the refitted sphere, for any pose linear blend skinning
// can produce from the given joint transforms.
//
// Notation: G_j(t) world (model) transform of joint j this frame, G_j(rest) its rest transform
// (SphereSet::joint_rest_world), T_j = G_j(t) · G_j(rest)^-1 the joint's motion since rest (or
// since the bind pose: "Reference frame" below),
// A_j the 3x3 linear part of T_j. c = centers_rest[s]; (j, w_j) the sphere's influences
// (influence_joints / influence_weights, renormalised to sum exactly 1 in RefitRestData).
//
// Centre (both modes, when joint transforms are given):
//     c' = Σ_j w_j · T_j · c
//   The fitted centre carried by the sphere's own blended joint transform, i.e. the same linear
//   blend skinning the vertices get, applied to the centre. Why: it moves with the body exactly
//   as the sphere's patch does, so when the patch moves rigidly (one joint, or all influences
//   moving together) c' stays at the same place relative to its vertices and the radius stays at
//   its fitted, tight value; it costs O(influences), not O(vertices); it is the same centre in
//   both modes, so switching mode never makes a sphere jump; and it is continuous in the pose
//   (no flicker that a per-frame bounding-box or minimum-ball centre would show).
//
// Exact mode (kExact): input `positions`, skinned positions indexed by SOURCE vertex index (only
//   the spheres' source vertices are read). Radius = max_v |p_v - c'| over the sphere's source
//   vertices — the smallest radius around c' that holds every owned triangle's vertices, the
//   guarantee. Without joint transforms (joint_world empty) the centre falls back to the centre of
//   the axis-aligned box of the sphere's skinned source vertices: it needs nothing but the
//   positions, and its radius is at most sqrt(3) times the minimum enclosing ball's (half the
//   box diagonal <= sqrt(3)/2 · the largest extent <= sqrt(3) · R_min); it can jump between frames.
//
// Fast mode (kFast): no vertex is skinned; input is G_j(t) per skeleton joint. With
// d_j = T_j c - c' and W_j the reach of the sphere's influence on joint j (RefitRestData::reach():
// the largest total weight any of the sphere's source vertices gives j, SphereSet::influence_reach),
//     r' = s_max · radius_fast + min(max_j |d_j|, Σ_j W_j |d_j|) + margin
//   Kavan & Žára 2005 ("Fast collision detection for skeletally deformable models", bounding-sphere
//   refit) with its spread term max_j |d_j| capped by the weighted sum.
//   Derivation. A source vertex is skinned as v' = Σ_b w_b M_b(t) p_bind over its bind entries b
//   (weights >= 0, Σ w_b = 1), M_b(t) = G_j(b)(t) · IBM_b. Write p_b = M_b(rest) · p_bind, the
//   rest copy of the vertex carried rigidly by entry b; then M_b(t) = T_j(b) · M_b(rest), so
//     v' = Σ_b w_b T_j(b) p_b
//     v' - c' = Σ_b w_b T_j(b)(p_b - c)  +  (Σ_b w_b T_j(b) c - c')
//   T_j is affine, T_j(p_b) - T_j(c) = A_j (p_b - c), so the first term has norm
//     <= Σ_b w_b |A_j(b)| |p_b - c| <= s_max · Σ_b w_b |p_b - c| <= s_max · radius_fast
//   since radius_fast is at least every source vertex's weighted mean distance of its rest copies,
//   Σ_b w_b |p_b - c| (FastBoundVerticesFromMesh; sphere_set.h), and s_max bounds the largest
//   singular value of every A_j of the sphere's influence joints. The mean is at most the farthest
//   copy's distance, which files written before 2026-12-06 store: they stay sound. Where a vertex's
//   copies spread (rest pose not the bind pose, below) the mean is the much smaller figure: a copy
//   far off through an entry of weight 0.03 counts at 3%. Measured (play --verify --mode fast,
//   every clip): the fast radii over the radius the skinned triangles need go from 1.276 to 1.030
//   on RobotExpressive and from 1.202 to 1.074 on Soldier, and the sphere pairs per frame from 315.7
//   to 35.3 and from 397.8 to 150.5; the other characters' copies coincide (no change). The second
//   term, with w_vj the vertex's total weight on joint j (Σ_j w_vj = 1; the joints of a vertex are
//   among the sphere's influence joints, which SphereSet::Validate checks against the mesh), is
//     Σ_j w_vj (T_j c - c') = Σ_j w_vj d_j,
//   a convex combination of the d_j, so its norm is at most max_j |d_j|; and by the triangle
//   inequality at most Σ_j w_vj |d_j| <= Σ_j W_j |d_j|, since w_vj <= W_j. Both hold for every
//   source vertex, hence their minimum does, and |v' - c'| <= r'. The sum is the smaller one when
//   the sphere's vertices give some of its joints only small weights (a sphere on a joint's border
//   whose vertices lean to one side): a joint that moves far from c' then counts at its weight,
//   not in full. With every W_j = 1 (a set with neither reach nor mesh) the sum is
//   Σ_j |d_j| >= max_j |d_j| and r' is the plain Kavan & Žára bound, bit for bit (a float sum of
//   non-negative terms is never below its largest term). The sums run in influence order, the
//   same operations in the vector code and in the tests' scalar reference.
//   s_max: σ_max(A)^2 = λ_max(AᵀA) <= max_i Σ_k |(AᵀA)_ik| (the spectral
//   radius is below any induced norm, here the infinity norm of the symmetric AᵀA), so
//     s_max = max_j sqrt(max_i Σ_k |(A_jᵀ A_j)_ik|),
//   exact for rotations and uniform scales (AᵀA = s²I), an over-estimate under non-uniform scale.
//   Where the file's rest pose is not its bind pose (Soldier, RobotExpressive: G_j(rest)·IBM_j
//   differs per joint) the copies p_b of one vertex differ, and radius_fast, which covers their
//   weighted mean distance, can exceed radius_rest; where rest = bind it equals radius_rest.
//
// Reference frame. Nothing above needs the rest pose itself. Take any invertible reference
// transform R_j per joint in place of G_j(rest): T_j = G_j(t) · R_j^-1, a vertex's copy through
// entry b p_b = R_j(b) · IBM_b · p_bind (so M_b(t) p_bind = T_j(b) p_b), c any point of the
// reference space. The derivation holds word for word, with radius_fast the radius around c that
// holds every vertex's weighted mean copy distance. A set uses one of two (SphereSet::fast_reference_inverse /
// _spheres):
//   - the rest pose, R_j = G_j(rest): c = centers_rest, radius_fast = SphereSet::radii_fast (every
//     set without a stored reference, every file written before it);
//   - the bind pose, R_j = IBM_first(j)^-1 (the inverse bind matrix of j's first bind entry whose
//     matrix can be inverted; the rest pose's for a joint with none): a
//     vertex's copy through entry b is IBM_first(j)^-1 · IBM_b · p_bind, which is p_bind itself
//     for j's first entry, so a vertex's copies coincide; c = the rest centre carried back by the
//     sphere's blended rest-from-bind transform (Σ_j w_j G_j(rest) · IBM_first(j))^-1 · c_rest,
//     rounded to float; radius_fast = the largest weighted mean distance from c to a vertex's
//     copies, in double, rounded up (FastReferenceRadiiFromMesh, which Validate() holds a stored
//     radius to).
//   The fitter stores the bind pose (ChooseFastReference) when the set has a mesh, its rest pose is
//   not its bind pose (some G_j(rest) · IBM_b differs from I by more than 1e-6), and the bound
//   summed over the spheres at the rest pose plus at the bind pose, in double, is smaller with it
//   by more than 0.1% (less is float rounding, or bind entries no vertex weighs).
//   The choice is stored, never made at load, so a set and its fast-only file refit alike.
//   Measured (play --verify --mode fast, every clip) when radius_fast held the farthest copy (until
//   2026-12-06): Soldier took it, its fast radii over the radius the skinned vertices need going
//   from 1.64 to 1.30 and its sphere pairs per frame from 1518 to 806; RobotExpressive kept the
//   rest pose (its sum 7x larger with the bind pose). With the weighted mean the rest pose's copies
//   cost little, and none of the five characters here takes the bind pose any more (Soldier's sum
//   of fast radii over rest radii is 1.015 at rest); CesiumMan and Xbot gain 2e-6 of the sum
//   (float rounding; CesiumMan's rest pose differs from its bind pose only on bind entries no
//   vertex weighs); the built-in character has rest = bind. The exact refit with joint
//   transforms uses the same centre, so its spheres move with the reference too (their radii stay
//   the exact ones).
//
// Reach groups. The derivation bounds each source vertex v by s_max · Σ_b w_b |p_b - c| over its own
// copies plus min(max_j |d_j|, Σ_j w_vj |d_j|) with its own weights, and the formula above replaces
// both by the sphere's largest (radius_fast, W_j). A sphere whose vertices fall into groups g, each
// with a radius r_g at least the weighted mean copy distance of each of its members and a reach
// W_gj >= w_vj of its members,
// is bounded the same way group by group:
//     r' = max_g (s_max · r_g + min(max_j |d_j|, Σ_j W_gj |d_j|)) + margin
// Every vertex is in some group and |v' - c'| is at most its group's term. Each group's figures are
// at most the one-group ones (r_g <= radius_fast, W_gj <= W_j: the fitter takes them from the same
// per-vertex figures), so r' never exceeds the one-group bound; with one group per sphere it is the
// one-group bound, bit for bit. The fitter groups a sphere's vertices by their weights (k-means, at
// most kMaxReachGroups; SphereSet::reach_group_offsets), which separates the vertices that lean on
// one joint from those that blend: measured (play --verify --mode fast, every clip), the fast radii
// over the radius the skinned triangles need go from 1.239 to 1.172 on CesiumMan and 1.297 to 1.224
// on Soldier (then with the bind reference), and the sphere pairs per frame from 385 to 257 and 806
// to 592. Validate() checks with the mesh that every source vertex is dominated by a group of its
// sphere (FastBoundVerticesFromMesh). The sums run per group in influence order, the same
// operations in the vector code and the tests' scalar reference.
//
// Group blends (SphereSet::reach_group_blend / reach_group_deviation). A vertex's spread term is
// Σ_j w_vj d_j, a vector, which the reach bounds by the sum of lengths. For any weights m_gj,
//     Σ_j w_vj d_j = Σ_j m_gj d_j + Σ_j (w_vj - m_gj) d_j,
// so with |w_vj - m_gj| <= e_gj for every member v of group g,
//     |Σ_j w_vj d_j| <= |Σ_j m_gj d_j| + Σ_j e_gj |d_j|,
// and the group's term becomes min(max_j |d_j|, Σ_j W_gj |d_j|, |Σ_j m_gj d_j| + Σ_j e_gj |d_j| + ρ_g),
// ρ_g = 32·FLT_EPSILON·(Σ_j |d_j| + Σ_j m_gj · max|c'_xyz|) a rounding allowance: the vector sum can
// cancel to nearly 0 while each T_j c is far out (two joints translated far in opposite directions,
// the vertices staying put), and the margin below scales with c' alone, so ρ covers the rounding of
// each T_j c - c' (a few ulps of |d_j| + |c'|), of the sum and its norm, and of the vertices' float
// weight totals (a few ulps each, against e). The first part is a vector sum, evaluated each frame: where the members'
// weights are alike (e small) the bound follows where the blend actually carries them instead of adding the joints'
// motions up. m and e are per (group, influence entry); an entry that repeats an earlier entry's
// joint has m = e = 0, so each joint counts once. The fitter takes m the midpoint of the members'
// weights and e the largest distance from it, rounded up; Validate() checks with the mesh that every
// vertex lies within e of m in a group that also holds it by radius and reach, and without a mesh
// that some weights summing to 1 fit within e of m. Without blends (every file before
// binary layout 5) the kernels skip the term: the same bits as before; with m = 0 and e = W it
// would give the same bits too. Measured (play --verify --mode fast, every clip, default fit): the
// fast radii over the radius the skinned triangles need go from 1.172 to 1.073 on CesiumMan, 1.074
// to 1.052 on Soldier, 1.080 to 1.078 on Xbot (with Soldier's clips; the fitter does not store them
// for Xbot, lib FitSettings::group_blends), 1.030 to 1.028 on RobotExpressive and 1.038 to 1.025 on
// the built-in character, and the sphere pairs per frame from 256.5 to 147.1, 150.5 to 114.3, 30.1
// to 29.3, 35.3 to 33.6 and 11.5 to 11.1; the fast refit costs 50-75% more; 0
// triangle-frames outside, the narrow phase equal to the oracle in every frame. The vector sum
// runs per group in influence order, lane by lane (x, y, z), the same operations in every copy of
// the kernel and the tests' scalar reference. Σ_j m_gj is fixed per set: RefitRestData sums it once
// (group_blend_sum(), in float, k ascending), the order in which the scalar reference sums it.
//
// Triangle pieces (SphereSet::pieces, docs/TRIANGLE_PIECES.md). A sphere that owns pieces of a
// triangle bounds their corners, the grid points in its point list, in place of the triangle's
// vertices. Exact mode computes each grid point from its triangle's skinned vertices (GridPoint,
// sphere_set.h) and bounds it like a vertex; the piece is the convex hull of its corners, so the
// sphere holds it. With rest data it bounds only the grid points at the corners of the hull of what
// the sphere lists on each cut triangle (RefitRestData::exact_points): the others lie inside that
// hull at every pose, so no centre has them farthest. Fast mode bounds a grid point as a vertex with one position per
// bind entry: with barycentric weights β_v over the triangle's vertices v,
//     g' = Σ_v β_v Σ_b w_vb M_b(t) p_v = Σ_b W_b M_b(t) q_b,   W_b = Σ_v β_v w_vb,
//     q_b = Σ_v β_v w_vb p_v / W_b,
// over the union of the three vertices' bind entries: W_b >= 0 and Σ_b W_b = 1, so g' is a convex
// blend of the copies T_j(b) p_b with p_b = R_j(b) · IBM_b · q_b, which is every step of the
// derivation above. Its copies spread where the triangle's vertices weigh the joints differently
// (q_b leans to the vertices that weigh b), but the first term of the derivation is bounded by the
// triangle inequality before taking any maximum:
//     |Σ_b W_b A_j(b) (p_b - c)| <= s_max Σ_b W_b |p_b - c|,
// so the radius a grid point needs is the weighted mean of its copies' distances, as a vertex's is,
// and its per-joint totals Σ_b W_b the reach it needs (FastBoundVerticesFromMesh); Validate() holds
// the stored radii, reaches and groups to them as for a vertex. The piece lies in the sphere
// because its corners do.
//
// margin: both modes add 16·FLT_EPSILON·(max|c'_xyz| + r), a few ulps of the coordinates, so the
// float evaluation (of the centre, the distances, and the caller's own skinning) cannot leave a
// vertex outside by rounding. Exact-mode radii therefore equal the max distance to ~2e-6 relative.
//
// Jobs: spans in, spans out; Validate() is O(1) (sizes and pointers; the
// SphereSet's indices were checked when RefitRestData was built from it); Run()/RunRange() never
// allocate nor throw; RunRange(begin, end) refits spheres [begin, end), each sphere computed by the
// same instructions whatever the split, so RunParallel (any ParallelFor) gives bit-identical
// output for any thread count. Non-finite input (NaN/Inf joint matrices or positions) makes
// Run() return false; the spheres it touched then hold unspecified (possibly NaN) values.
#pragma once

#include <Eigen/Core>
#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

#include "skinspheres/runtime/error.h"
#include "skinspheres/runtime/format/sphere_set.h"
#include "skinspheres/skinning/math_types.h"
#include "skinspheres/skinning/parallel_for.h"

namespace skinspheres::runtime {

enum class RefitMode : uint8_t {
  kExact,  // skinned source vertices -> tight radius (see above)
  kFast,   // joint transforms only -> conservative radius (see above)
};
const char* ToString(RefitMode mode);  // "exact", "fast"

// The fitter's choice of the fast refit's reference frame (the header comment, "Reference frame"):
// stores the bind pose in set->fast_reference_inverse / fast_reference_spheres and returns true when
// the set has a mesh, its rest pose is not its bind pose and the bind pose bounds tighter by more
// than 0.1%; clears them and returns false otherwise. Clears the set's reach groups either way (they
// are measured in the reference frame; the fitter writes them after). The set must pass Validate()
// without a reference; an error only when it does not.
Result<bool> ChooseFastReference(SphereSet* set);

// Rest-pose data the refit reads every frame, derived once from a SphereSet (allocates; then
// immutable and shareable between threads and instances).
class RefitRestData {
 public:
  RefitRestData() = default;  // empty: fits only an empty set

  // Validates the set (SphereSet::Validate()) and refuses rest transforms that cannot be inverted
  // (kInvalidData, naming the set's source file and the joint).
  static Result<RefitRestData> Create(const SphereSet& set);

  size_t sphere_count() const { return sphere_count_; }
  size_t joint_count() const { return rest_linear_inverse_.size(); }
  size_t influence_count() const { return center_in_joint_.size(); }
  size_t source_vertex_count() const { return source_vertex_count_; }

  // Per influence entry k of sphere s (SphereSet CSR order): R_j^-1 · c_s, the centre in the
  // joint's reference frame (G_j(rest)^-1 · c_rest with the rest pose as the reference), so
  // T_j c = G_j(t) · center_in_joint[k]; and w_k renormalised to sum 1.
  std::span<const Eigen::Vector3f> center_in_joint() const { return center_in_joint_; }
  std::span<const float> weights() const { return weights_; }
  // Per influence entry: the reach W_k the fast bound uses, SphereSet::influence_reach when the set
  // has one, else computed from its mesh (InfluenceReachFromMesh), else 1 (the bound without it).
  std::span<const float> reach() const { return reach_; }
  // Per sphere: the radius_fast the bound uses, in the reference frame (SphereSet::radii_fast when
  // it is the rest pose).
  std::span<const float> radii_fast() const { return radii_fast_; }
  // true: the set stores a reference frame (the bind pose; the header comment, "Reference frame").
  bool bind_reference() const { return bind_reference_; }
  // The reach groups the bound takes the largest of (the header comment, "Reach groups"): sphere s
  // has groups [group_offsets()[s], group_offsets()[s+1]); group g has radius group_radii()[g] and
  // its sphere's K_s reaches at group_reach()[group_reach_offsets()[s] + (g - group_offsets()[s]) *
  // K_s]. The set's own (SphereSet::reach_group_offsets), else one group per sphere: radii_fast()
  // and reach().
  std::span<const uint32_t> group_offsets() const { return group_offsets_; }
  std::span<const float> group_radii() const { return group_radii_; }
  std::span<const float> group_reach() const { return group_reach_; }
  std::span<const uint32_t> group_reach_offsets() const { return group_reach_offsets_; }
  // The groups' blends and deviations (the header comment, "Group blends"), laid out as
  // group_reach(); both empty when the set has none (the bound without them, bit for bit).
  std::span<const float> group_blend() const { return group_blend_; }
  std::span<const float> group_deviation() const { return group_deviation_; }
  // Per group, laid out as group_radii(): Σ_k m_gk, its blends summed in float with k ascending (the
  // rounding allowance's factor, fixed per set); empty when group_blend() is.
  std::span<const float> group_blend_sum() const { return group_blend_sum_; }
  // Per joint: the 3x3 linear part of the inverse of its reference transform, G_j(rest)^-1 or the
  // inverse bind matrix (A_j = linear(G_j(t)) · this).
  std::span<const Eigen::Matrix3f> rest_linear_inverse() const { return rest_linear_inverse_; }
  // The same matrices by rows for the vector code: 12 floats per joint, rows 0..2 of
  // rest_linear_inverse()[j] at 12 j, 12 j + 4, 12 j + 8, each padded with a 0.
  std::span<const float> rest_inverse_rows() const { return rest_inverse_rows_; }
  // Exact mode's points, per sphere s [exact_point_offsets()[s], [s + 1]) of exact_points(): the
  // set's point list (SphereSet::vertices, same numbering) without the grid points that cannot be
  // farthest from any centre. Of the points a sphere lists on one cut triangle (its grid points and
  // the triangle's vertices it lists), only the corners of their convex hull in grid coordinates
  // are kept: skinning moves a triangle's grid points by one affine map, so at every pose the hull
  // holds the dropped points and its farthest point from any centre is a corner (the refit's
  // margin covers float rounding). Both empty when the set has no pieces (exact mode then reads
  // SphereSet::vertices).
  std::span<const uint32_t> exact_point_offsets() const { return exact_point_offsets_; }
  std::span<const uint32_t> exact_points() const { return exact_points_; }
  // Points the set names (source vertices and grid points); a set of another size is refused.
  size_t point_count() const { return point_count_; }

 private:
  size_t sphere_count_ = 0;
  size_t source_vertex_count_ = 0;
  std::vector<Eigen::Vector3f> center_in_joint_;
  std::vector<float> weights_;
  std::vector<float> reach_;
  std::vector<float> radii_fast_;
  bool bind_reference_ = false;
  std::vector<uint32_t> group_offsets_, group_reach_offsets_;
  std::vector<float> group_radii_, group_reach_, group_blend_, group_deviation_, group_blend_sum_;
  std::vector<Eigen::Matrix3f> rest_linear_inverse_;
  std::vector<float> rest_inverse_rows_;
  std::vector<uint32_t> exact_point_offsets_, exact_points_;
  size_t point_count_ = 0;
};

struct RefitJob {
  RefitMode mode = RefitMode::kFast;
  const SphereSet* set = nullptr;       // the fitted set; must pass SphereSet::Validate()
                                        // (RefitRestData::Create and CharacterAsset check it)
  const RefitRestData* rest = nullptr;  // built from *set; required unless exact mode
                                        // without joint_world
  // G_j(t) per skeleton joint, >= set->joint_count(). Required in fast mode; optional in exact
  // mode (empty: box-centre fallback). Affine; the last row is ignored.
  std::span<const Mat4f> joint_world;
  // Exact mode: skinned positions indexed by source vertex, >= set->source_vertex_count.
  // Only the spheres' source vertices are read. Ignored (may be empty) in fast mode.
  std::span<const Eigen::Vector3f> positions;
  std::span<Vec4f> out;  // >= set->size(): xyz centre, w radius

  // Every reason the job is refused: null pointers, short spans, rest data from another set,
  // exact mode on a fast-only set (SphereSet::fast_only: no vertex lists).
  bool Validate() const;
  // Validates, refits every sphere. False on a refused job or non-finite input / output.
  bool Run() const;
  // Validates, refits spheres [begin, end) (end <= set->size(), begin <= end).
  bool RunRange(size_t begin, size_t end) const;
  // Validates once, then refits [0, size) through parallel_for (parallel_for.h; TBB by default) in
  // chunks of >= grain spheres. Output bit-identical to Run().
  bool RunParallel(const ParallelFor& parallel_for = DefaultParallelFor(), size_t grain = 32) const;
};

}  // namespace skinspheres::runtime
