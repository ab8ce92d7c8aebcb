// Private: the narrow phase's internals (narrow_phase.h has the contract): the state of a
// NarrowPhaseData and of a NarrowPhaseContext, and the steps of set-up and of a frame, each in the
// file named beside it.
//
// Set-up (setup.cc, NarrowPhaseData::Create), in order:
//   1. CheckInputs: a set with its mesh, a filter built from it, a margin and cluster size in range;
//   2. RestMesh: the mesh skinned with the rest transforms; its height; the margin against its size;
//   3. WeldVertices (rule 2): one id per rest position;
//   4. SphereVertices: each sphere's triangle vertices;
//   5. BuildClusters: each sphere's triangles cut into clusters (median splits);
//   6. BuildVertexGroups: mode (b)'s vertex groups, runs and prepared influences;
//   7. Neighbours: same part and overlapping or sharing a vertex at rest, for the depth estimate;
//   8. RestExclusions (rule 3): the triangle pairs that touch at rest (AllPairs, oracle.cc).
// A frame (narrow_phase_job.cc, NarrowPhaseJob::RunParallel), in order:
//   1. Involved (frame_prepare.cc): the spheres in this frame's pairs;
//   2. mode (b): LazySkinner (lazy_skinning.h) skins those spheres' vertices;
//   3. PrepareClusters (frame_prepare.cc): every cluster box of those spheres, their unions;
//   4. TestPair per sphere pair, in fixed chunks (cull.cc): boxes, clusters, the exact test;
//   5. Merge (merge.cc): hits grouped by part pair, sorted;
//   6. Depths (depth.h): the penetration depth of each part pair.
#pragma once

#include <Eigen/Core>
#include <array>
#include <cstddef>
#include <cstdint>
#include <span>
#include <utility>
#include <vector>

#include "format/grid_point.h"
#include "skinspheres/runtime/format/sphere_set.h"
#include "skinspheres/runtime/narrow_phase/narrow_phase.h"
#include "skinspheres/skinning/math_types.h"
#include "skinspheres/skinning/parallel_for.h"
#include "skinspheres/skinning/prepared_influences.h"

namespace skinspheres::runtime::narrow_phase {

struct Box {
  float lo[3], hi[3];
  uint32_t id;  // item (a whole triangle or a piece, NarrowPhaseData::Layout) or cluster
};
struct Hit {
  uint32_t i, j;  // sphere pair
  uint32_t t, u;  // t owned by i, u by j
  uint32_t a, b;  // the items (triangles or pieces) that met: a of t, b of u
  TriangleContactKind kind;
  float distance;
  float on_t[3], on_u[3];
};
// One of the fixed chunks of a frame's sphere pairs (the split, and so the output, does not depend
// on the thread count).
struct Chunk {
  std::vector<Box> a, b;         // a cluster's triangles (cluster_triangles each)
  std::vector<uint32_t> ka, kb;  // a sphere's clusters (max_sphere_clusters each)
  std::vector<Hit> hits;
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
  std::vector<uint32_t> sphere_item_offsets, sphere_items;  // per sphere: its whole triangles, then pieces
  // Clusters: sphere s has clusters [cluster_offsets[s], cluster_offsets[s + 1]); cluster c has
  // items cluster_triangles[cluster_triangle_offsets[c] ..), and their corners likewise: the source
  // vertices among them (a whole triangle's three, a piece's corners at its triangle's vertices) in
  // cluster_vertices, a piece's other corners (grid points, each once) in cluster_grid. A frame's
  // cluster box is the box of those points (PositionBox): the box of its items' boxes, not of the
  // large triangles its pieces were cut from.
  std::vector<uint32_t> cluster_offsets;
  std::vector<uint32_t> cluster_triangle_offsets, cluster_triangles;
  std::vector<uint32_t> cluster_vertex_offsets, cluster_vertices;
  std::vector<uint32_t> cluster_grid_offsets;
  std::vector<PiecePoint> cluster_grid;
  // Per piece item (id - triangle_count), each corner: its source vertex, or kGridRef | its index in
  // cluster_grid (within its cluster's range), where a frame's PositionBox left the point.
  static constexpr uint32_t kGridRef = uint32_t{1} << 31;
  std::vector<std::array<uint32_t, 3>> piece_corner_refs;
  // Mode (b): see the accessors.
  skinning::PreparedInfluences lazy_influences;
  std::vector<uint32_t> run_begin, group_run_offsets, group_runs, group_sizes;
  std::vector<uint32_t> sphere_group_offsets, sphere_groups;
  std::vector<uint32_t> sphere_run_offsets, sphere_run_words;
  std::vector<uint64_t> sphere_run_bits;
  std::vector<uint32_t> welded;
  std::vector<uint64_t> rest_excluded;
  std::vector<uint32_t> sphere_vertex_offsets, sphere_vertices;
  std::vector<uint32_t> neighbour_offsets, neighbours;
  std::vector<Eigen::Vector3f> rest_positions;
  float rest_height = 0.0f;  // rest_positions' extent along +Y
};

// A NarrowPhaseContext's scratch, sized by Resize.
struct NarrowPhaseContext::State {
  const NarrowPhaseData* sized_for = nullptr;
  narrow_phase::Chunk chunks[kChunks];
  std::vector<narrow_phase::Hit> merged;
  std::vector<uint64_t> keys;         // scratch for sorting sphere pairs
  std::vector<uint32_t> sphere_mark;  // per sphere: the depth estimate's visits
  std::vector<uint32_t> queue;        // per sphere
  uint32_t sphere_stamp = 0;
  std::vector<uint32_t> sphere_seen;           // per sphere: frame stamp when listed in involved or skinned on demand
  std::vector<uint32_t> involved;              // the spheres in this frame's pairs
  std::vector<narrow_phase::Box> cluster_box;  // per cluster: this frame's box
  std::vector<narrow_phase::Box> sphere_box;   // per sphere: the union of its clusters' boxes
  std::vector<Eigen::Vector3f> grid_pos;       // per cluster_grid entry: this frame's point (Frame::grid_pos)
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
  bool rest_rule;                    // apply rule 3 (false while rule 3 itself is being computed)
  const Box* cluster_box = nullptr;  // this frame's cluster boxes (set for the spheres in pairs)
  const Box* sphere_box = nullptr;   // and the unions of each sphere's cluster boxes
  // This frame's grid points by cluster_grid index, computed with the cluster boxes (the spheres
  // in pairs); null: a piece's corners are computed where they are read.
  const Eigen::Vector3f* grid_pos = nullptr;
};

inline float Slack(float margin) { return margin * (1.0f + 1e-5f); }

inline const Eigen::Vector3f& Vertex(const Frame& f, uint32_t t, int k) {
  return f.pos[f.set.triangle_vertices[3 * size_t{t} + k]];
}

inline uint16_t Part(const SphereSet& set, uint32_t sphere) { return set.sphere_part[sphere]; }

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

// ---- cull.cc: per sphere pair, boxes and clusters, then the exact test

// Box of item `id` (a triangle or a piece); false when a coordinate is not finite.
bool TriangleBox(const Frame& f, uint32_t id, Box* box);

// Does the box come within radius of the sphere's centre? (double: the sphere holds its
// triangles exactly, so a tiny relative slack covers the arithmetic here)
bool BoxReachesSphere(const Box& box, const Vec4f& s, float margin);

// Do balls a and b come within margin of each other? (double, tiny slack)
bool SpheresMeet(const Vec4f& a, const Vec4f& b, float margin);

// Boxes within `slack` of each other on every axis (float subtraction: exact in sign, so slack 0
// is the exact closed test).
bool BoxesMeet(const Box& a, const Box& b, float slack);

// Items a (of sphere i) and b (of sphere j) whose boxes meet: the rules on their triangles, the
// exact test on the items; a hit names the triangles, with the whole triangles' geometry when an
// item is a piece (so the report does not depend on which piece pair found it).
void Test(const Frame& f, uint32_t i, uint32_t j, const Box& a, const Box& b, Chunk& chunk);

// The box of the cluster's skinned corners: its source vertices and its pieces' grid points. False
// when one is not finite.
// The grid points are also written to grid_out[k] for the cluster's range of cluster_grid.
bool PositionBox(const SphereSet& set, const NarrowPhaseData& d, const Eigen::Vector3f* pos, uint32_t c, Box* box,
                 Eigen::Vector3f* grid_out);

// The clusters of sphere s whose box reaches into sphere `other` (grown by the margin).
size_t Reaching(const Frame& f, uint32_t s, const Vec4f& other, uint32_t* out);

// Triangles of cluster a against those of cluster b (each reduced to those reaching the other
// cluster's box). False on a non-finite position.
bool TestClusters(const Frame& f, uint32_t i, uint32_t j, uint32_t ca, uint32_t cb, Chunk& chunk);

// One sphere pair: clusters reaching into the other sphere, cluster pairs whose boxes meet, their
// triangles. False on non-finite input.
bool TestPair(const Frame& f, uint32_t i, uint32_t j, const Vec4f& si, const Vec4f& sj, Chunk& chunk);

// ---- merge.cc: the hits grouped by part pair

// Puts t on part_a's side (the lower part; t < u within one part).
void Normalise(const SphereSet& set, Hit& h);

// hits -> out (parts, sphere pairs, triangle pairs; depth left at 0); hits is left with one hit per
// triangle pair, in the order of out->triangle_pairs (what Depths reads). keys: scratch.
void Merge(const SphereSet& set, std::vector<Hit>& hits, std::vector<uint64_t>& keys, FrameContacts* out);

// ---- depth.h, depth.cc: the penetration depth

Eigen::Vector3d Normal(const Frame& f, uint32_t t);

// ---- oracle.cc: every pair (the brute-force oracle, and rule 3 at set-up)

// Every pair i < j the filter allows whose item boxes (grown by the margin) meet, every item
// against every item. hits appended.
bool AllPairs(const Frame& f, const PairFilter& filter, std::vector<Hit>* hits);

// ---- setup.cc: NarrowPhaseData::Create's stages

// Rest positions: the mesh skinned with the rest transforms.
bool RestPositions(const SphereSet& set, std::vector<Eigen::Vector3f>* out);

// Each sphere's items (Layout::sphere_items): its whole triangles, then its pieces.
void SphereItems(const SphereSet& set, NarrowPhaseData::Layout& d);

// Cuts each sphere's items into clusters of at most settings.cluster_triangles by median
// splits of their rest centroids along the longest axis; each cluster lists its vertices.
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

// The spheres in this frame's pairs, once each (Of(ctx).involved).
void Involved(std::span<const SpherePair> pairs, NarrowPhaseContext& ctx);

// The boxes of the clusters of every involved sphere, and the spheres' unions of them. False on a
// non-finite position.
bool PrepareClusters(const Frame& f, NarrowPhaseContext& ctx, const ParallelFor& parallel_for);

// A sphere's box: the union of its clusters' boxes.
void UniteClusters(const NarrowPhaseData& d, uint32_t s, NarrowPhaseContext& ctx);

}  // namespace skinspheres::runtime::narrow_phase
