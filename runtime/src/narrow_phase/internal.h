// Private: the narrow phase's internals (narrow_phase.h has the contract, contact_rules.h the rules):
// the state of a NarrowPhaseData and of a NarrowPhaseContext, and the steps of set-up and of a frame,
// each in the file named beside it.
//
// Set-up (setup.cc, NarrowPhaseData::Create), in order:
//   1. CheckInputs: a set with its mesh, a filter built from it, a margin and cluster size in range;
//   2. RestMesh: the mesh skinned with the rest transforms; its height; the margin against its size;
//   3. rule 1: one id per rest position (WeldedVertices, contact_rules.cc);
//   4. TriangleRules: each triangle's joint and part, each cut triangle's pieces' owners;
//   5. SphereVertices: each sphere's triangle vertices;
//   6. BuildClusters: each sphere's triangles cut into clusters (by joint, then median splits);
//   7. SelfSpheres: the spheres tested against themselves (triangles of joints rule 2 leaves);
//   8. BuildVertexGroups: mode (b)'s vertex groups, runs and prepared influences;
//   9. VertexTriangles: per welded vertex, the triangles using it, for the depth estimate;
//  10. Patches: each sphere's clusters of one joint, their rest balls; rule 3's distance.
// A frame (narrow_phase_job.cc, NarrowPhaseJob::RunParallel), in order:
//   1. Involved (frame_prepare.cc): the spheres in this frame's pairs and the self-tested ones;
//   2. mode (b): LazySkinner (lazy_skinning.h) skins those spheres' vertices;
//   3. PrepareClusters (frame_prepare.cc): every cluster box of those spheres, their unions;
//   4. TestPair per sphere pair, TestSelf per self-tested sphere, in fixed chunks (cull.cc): boxes,
//      clusters, the rules, the exact test on whole triangles;
//   5. Merge (merge.cc): hits grouped by part pair, sorted, each with its sphere pair;
//   6. Depths (depth.h): the penetration depth of each part pair.
// The oracle (oracle.cc) finds the same hits without spheres: every triangle pair of the mesh whose
// boxes meet (box_grid.h), the rules, the exact test; then steps 5 and 6.
#pragma once

#include <Eigen/Core>
#include <array>
#include <cstddef>
#include <cstdint>
#include <span>
#include <utility>
#include <vector>

#include "format/affine_inverse.h"
#include "format/grid_point.h"
#include "skinspheres/runtime/format/sphere_set.h"
#include "skinspheres/runtime/narrow_phase/contact_rules.h"
#include "skinspheres/runtime/narrow_phase/narrow_phase.h"
#include "skinspheres/runtime/narrow_phase/triangle_contact.h"
#include "skinspheres/skinning/math_types.h"
#include "skinspheres/skinning/parallel_for.h"
#include "skinspheres/skinning/prepared_influences.h"

namespace skinspheres::runtime::narrow_phase {

struct Box {
  float lo[3], hi[3];
  uint32_t id;  // item (a whole triangle or a piece, NarrowPhaseData::Layout) or cluster
};
// A joint's motion since rest in a frame: H = G_j(t) · G_j(rest)^-1, and the operator norm of the
// inverse of its linear part (rounded up; infinite when H is singular or not finite: no bound).
struct JointMotion {
  internal::Mat4d h = internal::Mat4d::Identity();
  double inv_norm = INFINITY;
};

// A triangle's plane in double: normal n = (v1 - v0) x (v2 - v0), a point p = v0, |n|.
struct Plane {
  double n[3], p[3], norm;
};

struct Hit {
  uint32_t i, j;  // sphere pair owning the contact's point (set by Merge: SphereAt)
  uint32_t t, u;  // source triangles
  TriangleContactKind kind;
  float distance;
  float on_t[3], on_u[3];
};
// One of the fixed chunks of a frame's sphere pairs (the split, and so the output, does not depend
// on the thread count).
struct Chunk {
  std::vector<Box> a, b;                // a cluster's triangles (cluster_triangles each)
  std::vector<Plane> plane_a, plane_b;  // and their whole triangles' planes
  std::vector<uint32_t> ka, kb;         // a sphere's clusters (max_sphere_clusters each)
  std::vector<uint32_t> pa, pb;         // where each patch's clusters begin in ka, kb (max_sphere_patches + 1 each)
  std::vector<uint32_t> xa, xb;         // a patch's clusters meeting the other patch (max_sphere_clusters each)
  std::vector<Hit> hits;
  uint64_t last_tested = UINT64_MAX;  // the whole-triangle pair tested last (pieces meet it repeatedly)
  NarrowPhaseContext::Stats stats;
  bool ok = true;
};

}  // namespace skinspheres::runtime::narrow_phase

namespace skinspheres::runtime {

// What NarrowPhaseData derives from a set (its accessors read these).
struct NarrowPhaseData::Layout {
  NarrowPhaseSettings settings;
  size_t max_sphere_triangles = 0;
  size_t max_sphere_clusters = 0;
  size_t max_sphere_patches = 0;
  // Items: what clusters list and the exact test takes. Item id < triangle_count is that whole
  // triangle; id >= triangle_count is piece_items[id - triangle_count], a piece of a cut triangle
  // (sphere_set.h, TrianglePiece; docs/TRIANGLE_PIECES.md): pieces are tested, triangles reported.
  struct PieceItem {
    uint32_t triangle;
    uint16_t level;
    uint8_t corners[3][2];  // grid coordinates (i, j) of its corners (PieceCorners)
  };
  uint32_t triangle_count = 0;
  std::vector<PieceItem> piece_items;
  // The rules (contact_rules.h).
  ContactRules rules = ContactRules::kTriangles;
  NearJoints near;                       // rule 2 (kTriangles)
  std::vector<uint16_t> triangle_joint;  // per triangle, rule 2's joint (kTriangles; empty otherwise)
  std::vector<uint16_t> triangle_part;   // per triangle, the part of the sphere(s) owning it
  // Per triangle: the sphere owning it whole, or kCut | k: cut at level piece_level[k], piece p owned
  // by sphere piece_owner[piece_owner_offsets[k] + p] (SphereAt).
  static constexpr uint32_t kCut = uint32_t{1} << 31;
  std::vector<uint32_t> triangle_owner;
  std::vector<uint16_t> piece_level;
  std::vector<uint32_t> piece_owner_offsets, piece_owner;
  std::vector<uint32_t> self_spheres;  // spheres tested against themselves (kTriangles), ascending
  float rest_size = 0.0f;              // the rest mesh's largest extent: the scale of grid points' rounding
  // Rule 3's distance: the larger of the rest gap and the margin (kTriangles), the margin otherwise.
  float rest_distance = 0.0f;
  // Patches: sphere s's clusters of one rule-2 joint (kTriangles; one patch per sphere otherwise),
  // patches [patch_offsets[s], patch_offsets[s + 1]); patch p has clusters
  // [patch_cluster_offsets[p], patch_cluster_offsets[p + 1]). To bound how far its points moved from
  // their rest positions carried by its joint's motion (Deviation, Still): the ball holding their rest
  // positions (xyz, radius, rounded up); per joint their skin names (copies [patch_copy_offsets[p],
  // patch_copy_offsets[p + 1])), the ball of their rest copies through that joint and the largest
  // weight a point gives it; and whether it may be skipped on that bound at all (kTriangles, none of
  // its triangles degenerate at rest, as rule 3 says nothing of how near such a triangle lay, and
  // every joint's rest transform invertible).
  std::vector<uint32_t> patch_offsets, patch_cluster_offsets, patch_copy_offsets;
  std::vector<uint16_t> patch_joint, patch_copy_joint;
  std::vector<uint8_t> patch_still_ok;
  std::vector<std::array<double, 4>> patch_rest_ball, patch_copy_ball;
  std::vector<double> patch_copy_reach;
  // Per cluster, besides cluster_vertices, the other vertices of its pieces' triangles (the motion
  // bound covers the whole triangles the exact test reads), CSR.
  std::vector<uint32_t> cluster_far_offsets, cluster_far_vertices;
  // The joints patches name (kTriangles), and per skeleton joint G_j(rest)^-1 (those joints only).
  std::vector<uint16_t> motion_joints;
  std::vector<internal::Mat4d> rest_inverse;
  std::vector<uint32_t> sphere_item_offsets, sphere_items;  // per sphere: its whole triangles, then pieces
  // Clusters: sphere s has clusters [cluster_offsets[s], cluster_offsets[s + 1]); cluster c has
  // items cluster_triangles[cluster_triangle_offsets[c] ..), and their corners likewise: the source
  // vertices among them (a whole triangle's three, a piece's corners at its triangle's vertices) in
  // cluster_vertices, a piece's other corners (grid points, each once) in cluster_grid. A frame's
  // cluster box is the box of those points (PositionBox): the box of its items' boxes, not of the
  // large triangles its pieces were cut from.
  std::vector<uint32_t> cluster_offsets;
  std::vector<uint16_t> cluster_joint;  // per cluster, its triangles' one joint (kTriangles)
  std::vector<uint32_t> cluster_ids;    // 0, 1, ..., cluster count - 1: a patch's clusters as a span
  std::vector<uint32_t> cluster_triangle_offsets, cluster_triangles;
  std::vector<uint32_t> cluster_vertex_offsets, cluster_vertices;
  std::vector<uint32_t> cluster_grid_offsets;
  std::vector<PiecePoint> cluster_grid;
  // Per piece item (id - triangle_count), each corner: its source vertex, or kGridRef | its index in
  // cluster_grid (within its cluster's range), where a frame's PositionBox left the point.
  static constexpr uint32_t kGridRef = uint32_t{1} << 31;
  std::vector<std::array<uint32_t, 3>> piece_corner_refs;
  // Mode (b)'s vertex groups, runs and run bitsets: docs/NARROW_PHASE.md#mode-bs-layout-in-narrowphasedata.
  skinning::PreparedInfluences lazy_influences;
  std::vector<uint32_t> run_begin, group_run_offsets, group_runs, group_sizes;
  std::vector<uint32_t> sphere_group_offsets, sphere_groups;
  std::vector<uint32_t> sphere_run_offsets, sphere_run_words;
  std::vector<uint64_t> sphere_run_bits;
  std::vector<uint32_t> welded;
  std::vector<uint32_t> sphere_vertex_offsets, sphere_vertices;
  // Per welded vertex id (the first vertex of each rest position), the triangles using it, CSR: the
  // depth estimate's flood over the mesh.
  std::vector<uint32_t> vertex_triangle_offsets, vertex_triangles;
  std::vector<Eigen::Vector3f> rest_positions;
  float rest_height = 0.0f;  // rest_positions' extent along +Y

  // The counts the CSR arrays above imply.
  size_t cluster_count() const { return cluster_vertex_offsets.empty() ? 0 : cluster_vertex_offsets.size() - 1; }
  size_t group_count() const { return group_run_offsets.empty() ? 0 : group_run_offsets.size() - 1; }
  size_t run_count() const { return run_begin.empty() ? 0 : run_begin.size() - 1; }
};

// A NarrowPhaseContext's scratch, sized by Resize.
struct NarrowPhaseContext::State {
  const NarrowPhaseData* sized_for = nullptr;
  narrow_phase::Chunk chunks[kChunks];
  std::vector<narrow_phase::Hit> merged;
  std::vector<uint64_t> keys;           // scratch for sorting sphere pairs
  std::vector<uint32_t> sphere_mark;    // per sphere: SelectWork's visits
  std::vector<uint32_t> triangle_mark;  // per triangle: the depth estimate's visits
  std::vector<uint32_t> queue;          // per triangle
  uint32_t sphere_stamp = 0;
  uint32_t triangle_stamp = 0;
  std::vector<uint32_t> sphere_seen;           // per sphere: frame stamp when listed in involved or skinned on demand
  std::vector<uint32_t> involved;              // the spheres in this frame's pairs
  std::vector<narrow_phase::Box> cluster_box;  // per cluster: this frame's box
  std::vector<narrow_phase::Box> sphere_box;   // per sphere: the union of its clusters' boxes
  std::vector<narrow_phase::Box> patch_box;    // per patch: the union of its clusters' boxes
  // The motion bound (narrow_phase::Still), when the frame has joint matrices: per motion joint its
  // motion since rest; per cluster and per patch how far their points lie from their rest positions
  // carried by that motion of their joint (Deviation); the bound's rounding allowance.
  bool has_motion = false;
  double motion_slack = 0.0;
  std::vector<narrow_phase::JointMotion> joint_motion;  // per skeleton joint
  std::vector<double> cluster_deviation, patch_deviation;
  // The work of the frame: every one of the job's pairs (all_pairs) or the indices of those to test,
  // and the self-tested spheres to test (mode (b) leaves out those whose every patch pair is Still
  // before skinning anything). active_pairs holds at most the job's pairs (NarrowPhaseContext::Reserve).
  bool all_pairs = true;
  std::vector<uint32_t> active_pairs, active_self;
  std::vector<uint32_t> patch_mark, marked_patches;  // MeasureDeviations' scratch
  uint32_t patch_stamp = 0;
  std::vector<Eigen::Vector3f> grid_pos;  // per cluster_grid entry: this frame's point (Frame::grid_pos)
  uint32_t frame_stamp = 0;
  // Mode (b).
  std::vector<Eigen::Vector3f> skinned;              // per vertex
  std::vector<uint64_t> run_bits;                    // per run, one bit: marked, not yet skinned
  std::vector<uint64_t> run_done;                    // per run, one bit: skinned this frame
  size_t marked_begin = 0, marked_end = 0;           // words of run_bits that may be non-zero (begin >= end: none)
  std::vector<std::pair<uint32_t, uint32_t>> spans;  // slot spans to skin (<= runs + slots / block + 1)
  std::vector<Mat4f> bind_matrices;                  // per bind entry
  NarrowPhaseContext::Stats stats;
};

}  // namespace skinspheres::runtime

namespace skinspheres::runtime::narrow_phase {

// The state behind the two public classes.
struct Access {
  static NarrowPhaseData::Layout& Of(NarrowPhaseData& d) { return *d.layout_; }
  static const NarrowPhaseData::Layout& Of(const NarrowPhaseData& d) { return *d.layout_; }
  static NarrowPhaseContext::State& Of(NarrowPhaseContext& c) { return *c.state_; }
  static const NarrowPhaseContext::State& Of(const NarrowPhaseContext& c) { return *c.state_; }
};
inline NarrowPhaseData::Layout& Of(NarrowPhaseData& d) { return Access::Of(d); }
inline const NarrowPhaseData::Layout& Of(const NarrowPhaseData& d) { return Access::Of(d); }
inline NarrowPhaseContext::State& Of(NarrowPhaseContext& c) { return Access::Of(c); }
inline const NarrowPhaseContext::State& Of(const NarrowPhaseContext& c) { return Access::Of(c); }

// A contour is planar when its smallest spread is at most this share of the middle one.
inline constexpr double kPlanarContour = 0.1;

struct Frame {
  const SphereSet& set;
  const NarrowPhaseData& data;
  const Eigen::Vector3f* pos;
  float margin;
  const Box* cluster_box = nullptr;  // this frame's cluster boxes (set for the spheres in pairs)
  const Box* sphere_box = nullptr;   // and the unions of each sphere's cluster boxes
  const Box* patch_box = nullptr;    // and of each patch's
  // The motion bound's inputs (NarrowPhaseContext::State), or null: no joint matrices this frame.
  const JointMotion* joint_motion = nullptr;
  const double* patch_deviation = nullptr;
  double motion_slack = 0.0;
  // This frame's grid points by cluster_grid index, computed with the cluster boxes (the spheres
  // in pairs); null: a piece's corners are computed where they are read.
  const Eigen::Vector3f* grid_pos = nullptr;
};

inline float Slack(float margin) { return margin * (1.0f + 1e-5f); }

inline const Eigen::Vector3f& Vertex(const Frame& f, uint32_t t, int k) {
  return f.pos[f.set.triangle_vertices[3 * size_t{t} + k]];
}

// How far a piece's float corners may lie from the exact grid points (GridPointInline rounds a few
// ulps of its triangle's coordinates): piece and cluster boxes holding grid points, and the spheres
// they are tested against, are grown by this share of the coordinates' magnitude plus the rest size,
// so that every point of a whole triangle lies in a grown box of one of its pieces.
inline constexpr float kGridRounding = 1.0f / 262144.0f;  // 2^-18, against under 2^-21

// The triangle of item `id` (NarrowPhaseData::Layout): itself, or the piece's.
inline uint32_t ItemTriangle(const NarrowPhaseData::Layout& d, uint32_t id) {
  return id < d.triangle_count ? id : d.piece_items[id - d.triangle_count].triangle;
}

// The corners of item `id` at positions `pos` (by source vertex): a triangle's vertices, or a
// piece's grid points computed from them (GridPointInline: the refits' arithmetic, bit for bit),
// read from `grid_pos` (Frame::grid_pos) when given.
inline void ItemCorners(const SphereSet& set, const NarrowPhaseData::Layout& d, const Eigen::Vector3f* pos,
                        const Eigen::Vector3f* grid_pos, uint32_t id, Eigen::Vector3f out[3]) {
  const uint32_t* v = set.triangle_vertices.data() + 3 * size_t{ItemTriangle(d, id)};
  if (id < d.triangle_count) {
    for (int k = 0; k < 3; ++k) out[k] = pos[v[k]];
    return;
  }
  if (grid_pos != nullptr) {
    const auto& refs = d.piece_corner_refs[id - d.triangle_count];
    constexpr uint32_t kGrid = NarrowPhaseData::Layout::kGridRef;
    for (int k = 0; k < 3; ++k) out[k] = (refs[k] & kGrid) != 0 ? grid_pos[refs[k] & ~kGrid] : pos[refs[k]];
    return;
  }
  const NarrowPhaseData::Layout::PieceItem& p = d.piece_items[id - d.triangle_count];
  for (int k = 0; k < 3; ++k) {
    out[k] =
        runtime::internal::GridPointInline(pos[v[0]], pos[v[1]], pos[v[2]], p.level, p.corners[k][0], p.corners[k][1]);
  }
}

// A sphere whose point list holds triangle t's three vertices: its owner, or a piece's.
inline uint32_t OwnerSphere(const NarrowPhaseData::Layout& d, uint32_t t) {
  const uint32_t owner = d.triangle_owner[t];
  if ((owner & NarrowPhaseData::Layout::kCut) == 0) return owner;
  return d.piece_owner[d.piece_owner_offsets[owner & ~NarrowPhaseData::Layout::kCut]];
}

// The sphere owning the point p (on the frame's triangle t): t's owner, or, for a cut triangle, the
// owner of the piece whose grid cell holds p's barycentric coordinates (in double; a fixed rule on
// cell borders).
uint32_t SphereAt(const Frame& f, uint32_t t, const float p[3]);

// The hit of triangles t and u that met as g says (its sphere pair set later, by Merge).
inline Hit HitOf(uint32_t t, uint32_t u, const TriangleContactGeometry& g) {
  Hit h{};
  h.t = t;
  h.u = u;
  h.kind = g.intersecting ? TriangleContactKind::kIntersecting : TriangleContactKind::kWithinMargin;
  h.distance = g.distance;
  for (int k = 0; k < 3; ++k) {
    h.on_t[k] = g.on_a[k];
    h.on_u[k] = g.on_b[k];
  }
  return h;
}

// ---- cull.cc: per sphere pair, boxes and clusters, then the exact test

// Box of item `id` (a triangle or a piece, the latter grown by GrowForGridRounding); false when a
// coordinate is not finite.
bool TriangleBox(const Frame& f, uint32_t id, Box* box);

// Grows a box holding grid points by kGridRounding of `scale` (the larger of the rest size and the
// largest coordinate of the triangles the points were computed from). The exact refit's rounding
// margin (refit_job.h, 16 epsilons of the coordinates) already holds the exact pieces in their spheres.
void GrowForGridRounding(Box* box, float scale);

// Rule 3 for the frame's set (Layout::rest_distance, at the rest positions).
bool RestNear(const Frame& f, uint32_t t, uint32_t u);

// The motion bound. A patch p of joint A deviates by e_p = max over its points of |x(t) - H_A x_rest|:
// how far its points lie from their rest positions carried rigidly by A's motion. Two ways:
//  - measured (mode a, the caller's positions): MeasuredDeviation of each cluster, while it is boxed;
//  - from the joint matrices alone (mode b, whose positions are the linear blend of the same matrices
//    with the set's skin): a point is sum_k w_k H_j(k) c_k over its rest copies c_k, so
//    x(t) - H_A x_rest = sum_k w_k (H_j(k) - H_A) c_k, at most the larger over the patch's joints j of
//    |(H_j - H_A) m_j| + |L_j - L_A| r_j ((m_j, r_j) the ball of its copies through j), and at most
//    their sum weighted by each joint's largest weight (WeightDeviations).
// Still(a, b): in the frame of a's joint (H_A^-1 applied to everything), a's points lie within
// |H_A^-1| e_a of their rest positions and b's within |H_A^-1| (e_b + |(H_B - H_A) m_b| + |L_B - L_A| r_b)
// ((m_b, r_b) the ball of b's rest positions), so every pair of their triangles that rule 3 leaves,
// at least the rest distance D apart at rest, is at least D less both apart there: no intersection
// while that is above 0, and, with a margin, none nearer than it while it is above the margin times
// |H_A^-1| (the frame's distances shrink by at most that). "Pairs of triangles that move rigidly
// together keep their distance."
double MeasuredDeviation(const Frame& f, uint32_t c, const JointMotion& motion);
void WeightDeviations(const Frame& f, uint32_t s, double* patch_deviation);
bool Still(const Frame& f, uint32_t a, uint32_t b);
// Whether Still could hold with no deviation at all: when not, the joints' motions alone move the
// patches apart by more than rule 3's distance, and nothing need be measured for them.
bool CouldBeStill(const Frame& f, uint32_t a, uint32_t b);

// Does the box come within radius of the sphere's centre? (double: the sphere holds its
// triangles exactly, so a tiny relative slack covers the arithmetic here)
bool BoxReachesSphere(const Box& box, const Vec4f& s, float margin);

// Do balls a and b come within margin of each other? (double, tiny slack)
bool SpheresMeet(const Vec4f& a, const Vec4f& b, float margin);

// Boxes within `slack` of each other on every axis (float subtraction: exact in sign, so slack 0
// is the exact closed test). Branch-free: which boxes meet follows no pattern a predictor learns.
inline bool BoxesMeet(const Box& a, const Box& b, float slack) {
  return (a.lo[0] - b.hi[0] <= slack) & (b.lo[0] - a.hi[0] <= slack) & (a.lo[1] - b.hi[1] <= slack) &
         (b.lo[1] - a.hi[1] <= slack) & (a.lo[2] - b.hi[2] <= slack) & (b.lo[2] - a.hi[2] <= slack);
}

// Items a and b whose boxes meet and whose triangles are not Beyond each other's planes: rules 1 and 3
// on their triangles (rule 2 is the patch pair's), the exact test on the whole triangles (a piece's
// report does not depend on which piece found it).
void Test(const Frame& f, const Box& a, const Box& b, Chunk& chunk);

// The plane of the frame's triangle t; whether every vertex of triangle u lies, with certainty, on one
// side of it beyond the margin (then the two share no point and come no nearer than the margin; a
// degenerate t rejects nothing it need not).
void PlaneOf(const Frame& f, uint32_t t, Plane* out);
bool Beyond(const Frame& f, const Plane& plane, uint32_t u);

// The whole triangles t and u: rules 1 and 3, the exact test; a hit appended. The oracle's step.
void TestTriangles(const Frame& f, uint32_t t, uint32_t u, Chunk& chunk);

// The box of the cluster's skinned corners: its source vertices and its pieces' grid points. False
// when one is not finite.
// The grid points are also written to grid_out[k] for the cluster's range of cluster_grid.
bool PositionBox(const SphereSet& set, const NarrowPhaseData& d, const Eigen::Vector3f* pos, uint32_t c, Box* box,
                 Eigen::Vector3f* grid_out);

// Triangles of cluster a against those of cluster b (each reduced to those reaching the other
// cluster's box). False on a non-finite position.
bool TestClusters(const Frame& f, uint32_t ca, uint32_t cb, Chunk& chunk);

// One sphere pair: per pair of patches rule 2 leaves, their boxes meeting and not Still, the pairs
// of their clusters that reach into the other sphere and whose boxes meet, their triangles. False on
// non-finite input.
bool TestPair(const Frame& f, uint32_t i, uint32_t j, const Vec4f& si, const Vec4f& sj, Chunk& chunk);

// One sphere against itself: its patch pairs as above, then all their cluster pairs whose boxes meet.
bool TestSelf(const Frame& f, uint32_t s, Chunk& chunk);

// ---- merge.cc: the hits grouped by part pair

// Puts t on part_a's side (the lower part; t < u within one part).
void Normalise(const NarrowPhaseData& data, Hit& h);

// hits -> out (parts, sphere pairs, triangle pairs; depth left at 0); hits is left with one hit per
// triangle pair, in the order of out->triangle_pairs (what Depths reads), each with its sphere pair
// (SphereAt of its point). keys: scratch.
void Merge(const Frame& f, std::vector<Hit>& hits, std::vector<uint64_t>& keys, FrameContacts* out);

// ---- depth.h, depth.cc: the penetration depth

Eigen::Vector3d Normal(const Frame& f, uint32_t t);

// ---- oracle.cc: the brute-force oracle

// kTriangles: every triangle pair of the mesh whose boxes (grown by the margin) meet, rules 1-3 with
// rule 3 measured at rest here (not read from the set). kSpherePairs: every sphere pair i < j the
// filter allows, every item against every item. hits appended; false on a non-finite position.
bool AllPairs(const Frame& f, const PairFilter& filter, std::vector<Hit>* hits);

// ---- setup.cc: NarrowPhaseData::Create's stages

// Each sphere's items (Layout::sphere_items): its whole triangles, then its pieces.
void SphereItems(const SphereSet& set, NarrowPhaseData::Layout& d);

// Cuts each sphere's items into clusters of at most settings.cluster_triangles, those of one rule-2
// joint apart (kTriangles), then by median splits of their rest centroids along the longest axis;
// each cluster lists its vertices.
void BuildClusters(const SphereSet& set, NarrowPhaseData* d);

// Mode (b) skins the vertices of the spheres in pairs, each vertex once: the vertices are grouped
// by the set of spheres whose triangles use them (a sphere's inside, the border it shares with a
// neighbour, ...), and each sphere lists its groups. All grouped vertices go into one set of
// prepared influences (the SIMD skinning layout), input group by group: the layout keeps the
// input order inside each influence count, so a group is one run of slots per influence count it
// has, and groups that follow each other in the input sit next to each other in every count.
// False when the influences are inconsistent.
bool BuildVertexGroups(const SphereSet& set, NarrowPhaseData* d);

// ---- frame_prepare.cc: a frame's spheres and cluster boxes

// fn(k) for the index k of every pair of this frame's work.
template <class Fn>
void ForEachActivePair(std::span<const SpherePair> pairs, const NarrowPhaseContext& ctx, Fn&& fn) {
  if (Of(ctx).all_pairs) {
    for (uint32_t k = 0; k < pairs.size(); ++k) fn(k);
  } else {
    for (uint32_t k : Of(ctx).active_pairs) fn(k);
  }
}

// The spheres of this frame's work (SelectWork), once each (Of(ctx).involved).
void Involved(std::span<const SpherePair> pairs, NarrowPhaseContext& ctx);

// The joints' motions since rest (State::joint_motion, has_motion, motion_slack) from G_j(t); none
// when joint_world is empty or the rules are on sphere pairs.
void PrepareMotion(const NarrowPhaseData& data, std::span<const Mat4f> joint_world, NarrowPhaseContext& ctx);

// The frame's work (State::active_pairs, active_self): every pair and self-tested sphere, or, with
// deviations from the joint matrices (lazy: mode b), those with a patch pair rule 2 leaves that is not
// Still (their spheres' patch deviations computed first).
void SelectWork(const Frame& f, std::span<const SpherePair> pairs, bool lazy, NarrowPhaseContext& ctx);

// The boxes of the clusters of every involved sphere, and their unions per patch and per sphere.
// False on a non-finite position.
bool PrepareClusters(const Frame& f, NarrowPhaseContext& ctx, const ParallelFor& parallel_for);

// Mode (a) with joint matrices: the MeasuredDeviation of every patch Still will be asked of (in a
// pair of the work rule 2 leaves, their boxes meeting), after PrepareClusters.
void MeasureDeviations(const Frame& f, std::span<const SpherePair> pairs, NarrowPhaseContext& ctx,
                       const ParallelFor& parallel_for);

// A sphere's patches' and its own box: the unions of its clusters' boxes.
void UniteClusters(const NarrowPhaseData& d, uint32_t s, NarrowPhaseContext& ctx);

}  // namespace skinspheres::runtime::narrow_phase
