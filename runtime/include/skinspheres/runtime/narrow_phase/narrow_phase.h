// Narrow phase: the triangle pairs of a character that really touch in a frame, grouped by
// body-part pair. Which pairs count is stated once, on the mesh, in contact_rules.h; the spheres
// (broad_phase.h) only filter the search. A contact is an INTERSECTING pair (exact test, touching
// counts) or, with a margin > 0, a pair WITHIN MARGIN. A set whose rules are on triangles reports
// the same pairs whatever its fit; cut triangles' pieces only lead the search.
// Input: the broad phase's sphere pairs (with a margin: of spheres grown by half of it) and either
// (a) the skinned positions the spheres hold or (b) joint matrices only, from which the job skins
// just the vertices it tests (bit-identical to skinning the whole mesh). Needs a set with a mesh
// (else kVersionMismatch).
// Output: FrameContacts, flat sorted arrays of part pairs, sphere pairs and triangle pairs, with a
// penetration depth, normal and centre per part pair (the same in both modes and for every fit).
// Allocation: NarrowPhaseData (shared, immutable) and NarrowPhaseContext (per instance) allocate at
// set-up; a frame allocates nothing once the outputs and scratch have held its size. Never throws.
// Threads: output identical for any ParallelFor and thread count.
// How it is found, the depth, the layouts and the memory: docs/NARROW_PHASE.md.
#pragma once

#include <Eigen/Core>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <span>
#include <utility>
#include <vector>

#include "skinspheres/runtime/broad_phase/broad_phase.h"
#include "skinspheres/runtime/broad_phase/pair_filter.h"
#include "skinspheres/runtime/error.h"
#include "skinspheres/runtime/format/sphere_set.h"
#include "skinspheres/runtime/narrow_phase/contact_rules.h"
#include "skinspheres/skinning/math_types.h"
#include "skinspheres/skinning/parallel_for.h"
#include "skinspheres/skinning/prepared_influences.h"

namespace skinspheres::runtime {

namespace narrow_phase {
struct Access;  // runtime/src/narrow_phase/internal.h
}  // namespace narrow_phase

// The largest margin NarrowPhaseData::Create accepts, as a share of the character's rest size (the
// largest extent of its mesh at rest): beyond it nearly every triangle pair near a joint is within
// the margin, and set-up memory and per-frame contacts grow with the square of the triangle count.
inline constexpr float kMaxMarginShareOfSize = 0.05f;

// Intersections up to this share of the rest pose's height are touching, deeper ones penetrating:
// 9 mm on a 1.8 m character.
inline constexpr float kDefaultTouchToleranceShare = 0.005f;

struct NarrowPhaseSettings {
  // > 0: also report triangle pairs whose distance is below this (model units); 0: intersections
  // only. Pairs within this distance at rest are excluded, so it is fixed at set-up. At most
  // kMaxMarginShareOfSize times the character's rest size (else kInvalidArgument).
  float margin = 0.0f;
  // Triangles per cluster at most, 1..256 (docs/NARROW_PHASE.md#how-it-is-found).
  uint32_t cluster_triangles = 16;
  // Part pairs intersecting deeper than this share of the rest pose's height (its extent along +Y,
  // glTF's up) are penetrating, the others touching (PartContact::kind). Finite, in [0, 1).
  float touch_tolerance_share = kDefaultTouchToleranceShare;
};

enum class PartContactKind : uint8_t { kTouching = 0, kPenetrating = 1 };
const char* ToString(PartContactKind kind);  // "touching", "penetrating"

enum class TriangleContactKind : uint8_t { kIntersecting = 0, kWithinMargin = 1 };
const char* ToString(TriangleContactKind kind);  // "intersecting", "within_margin"

struct TriangleContact {
  uint32_t triangle_a = 0;  // source triangle of the part pair's part_a
  uint32_t triangle_b = 0;  // source triangle of part_b (same part: triangle_a < triangle_b)
  TriangleContactKind kind = TriangleContactKind::kIntersecting;
  float distance = 0.0f;       // 0 when intersecting, else the closest distance (< margin)
  float point[3] = {0, 0, 0};  // representative point: the midpoint of on_a and on_b
  // Intersecting: the two ends of the intersection segment (a coplanar overlap gives its centre
  // twice). Within margin: the closest points, on triangle_a and on triangle_b.
  float on_a[3] = {0, 0, 0};
  float on_b[3] = {0, 0, 0};
  friend bool operator==(const TriangleContact&, const TriangleContact&) = default;
};

// A sphere pair by its indices alone (broad_phase.h's SpherePair also carries the depth and parts).
struct SpherePairId {
  uint32_t i = 0;  // i <= j, sphere indices (i == j: two triangles of one sphere)
  uint32_t j = 0;
  friend bool operator==(const SpherePairId&, const SpherePairId&) = default;
};

struct PartContact {
  uint16_t part_a = 0;  // part_a <= part_b, SphereSet::parts indices
  uint16_t part_b = 0;
  uint32_t first_sphere_pair = 0;  // FrameContacts::sphere_pairs[first, first + count)
  uint32_t sphere_pair_count = 0;
  uint32_t first_triangle_pair = 0;  // FrameContacts::triangle_pairs[first, first + count)
  uint32_t triangle_pair_count = 0;
  uint32_t intersecting_count = 0;  // how many of those are kIntersecting
  float depth = 0.0f;               // penetration depth estimate (header comment); 0 without intersections
  float min_distance = 0.0f;        // 0 with intersections, else the smallest within-margin distance
  float normal[3] = {0, 0, 0};      // contact normal, from part_b towards part_a (0 without intersections)
  float center[3] = {0, 0, 0};      // contact centre C (with intersections), else the closest pair's point
  // Penetrating: intersecting deeper than NarrowPhaseData::touch_tolerance(); else touching.
  PartContactKind kind = PartContactKind::kTouching;
  friend bool operator==(const PartContact&, const PartContact&) = default;
};

struct FrameContacts {
  std::vector<PartContact> parts;
  std::vector<SpherePairId> sphere_pairs;
  std::vector<TriangleContact> triangle_pairs;

  void clear() {
    parts.clear();
    sphere_pairs.clear();
    triangle_pairs.clear();
  }
  bool empty() const { return parts.empty(); }
  // Set-up: room for this many triangle pairs (and as many part and sphere pairs) without allocating.
  void Reserve(size_t triangle_pairs_capacity);
  friend bool operator==(const FrameContacts&, const FrameContacts&) = default;
};

// What the narrow phase derives once from a sphere set (allocates; immutable afterwards, shared by
// every instance and thread): welded vertex ids, each triangle's joint, part and owner, each sphere's
// clusters, patches and triangle vertices, each vertex's triangles for the depth estimate.
class NarrowPhaseData {
 public:
  NarrowPhaseData();  // empty: usable with no set
  ~NarrowPhaseData();
  NarrowPhaseData(const NarrowPhaseData& other);
  NarrowPhaseData& operator=(const NarrowPhaseData& other);
  NarrowPhaseData(NarrowPhaseData&&) noexcept;
  NarrowPhaseData& operator=(NarrowPhaseData&&) noexcept;

  // Needs set.has_mesh() (else kVersionMismatch naming the set's file) and a filter built from the
  // set (same sphere count, else kInvalidArgument). The set must pass SphereSet::Validate().
  static Result<NarrowPhaseData> Create(const SphereSet& set, const PairFilter& filter,
                                        const NarrowPhaseSettings& settings = {});

  const NarrowPhaseSettings& settings() const;
  float margin() const;
  // The rest pose's height (the mesh skinned at rest: its extent along +Y), and the depth above
  // which a part pair penetrates (settings().touch_tolerance_share of it), in model units.
  float rest_height() const;
  float touch_tolerance() const;
  size_t sphere_count() const;
  size_t triangle_count() const;
  size_t vertex_count() const;

  // The set's rules (contact_rules.h).
  ContactRules rules() const;
  // Rule 1: whether triangles t and u share a vertex by rest position.
  bool ShareVertex(uint32_t t, uint32_t u) const;
  // Rule 3 (contact_rules.h, NearAtRest): the distance at rest within which a pair is excluded (the
  // larger of the set's rest gap and the margin; the margin for rules on sphere pairs), and the test.
  float rest_distance() const;
  bool RestExcluded(uint32_t t, uint32_t u) const;
  // The rest-pose positions (mesh skinned with the rest transforms), per source vertex.
  std::span<const Eigen::Vector3f> rest_positions() const;

  // Opaque: defined in runtime/src/narrow_phase/internal.h, where the friend narrow_phase::Access
  // gives tests and benchmarks its layout (clusters, vertex groups, runs).
  struct Layout;

 private:
  friend struct narrow_phase::Access;
  std::unique_ptr<Layout> layout_;
};

// Per-character scratch (one per instance running concurrently; never share between jobs running at
// once). Resize at set-up; diagnostics of the last run.
class NarrowPhaseContext {
 public:
  // Work is cut into at most this many chunks of sphere pairs (a fixed number, so the split, and
  // the output, do not depend on the thread count).
  static constexpr size_t kChunks = 16;

  NarrowPhaseContext();
  ~NarrowPhaseContext();
  NarrowPhaseContext(const NarrowPhaseContext& other);  // a copy of its scratch
  NarrowPhaseContext& operator=(const NarrowPhaseContext& other);
  NarrowPhaseContext(NarrowPhaseContext&&) noexcept;
  NarrowPhaseContext& operator=(NarrowPhaseContext&&) noexcept;
  // Set-up only (allocates). lazy_skinning: also the mode-(b) buffers (skinned positions, marks).
  void Resize(const NarrowPhaseData& data, bool lazy_skinning);
  // Set-up only (allocates): room for frames of this many sphere pairs without growing a list (mode
  // (b) lists the pairs it tests; Resize makes room for 4 per sphere).
  void Reserve(size_t sphere_pairs);
  bool sized_for(const NarrowPhaseData& data) const;
  bool has_lazy_skinning() const;

  struct Stats {
    size_t sphere_pairs = 0;       // pairs examined
    size_t clusters_bounded = 0;   // clusters of the spheres in pairs (and self-tested), boxed this frame
    size_t patch_pairs = 0;        // pairs of patches (a sphere's clusters of one joint) rule 2 leaves
    size_t still_patch_pairs = 0;  // of those whose boxes met, the ones their motion since rest skipped
    size_t cluster_pairs = 0;      // cluster pairs compared (clusters that reached into the other sphere)
    size_t culled_triangles = 0;   // triangles that reached the other cluster's box (both sides)
    size_t box_tests = 0;          // triangle box pairs compared
    size_t triangle_tests = 0;     // exact triangle-triangle tests run
    size_t skinned_vertices = 0;   // mode (b): vertices skinned this frame
    size_t depth_vertices = 0;     // vertices examined by the depth estimate
  };
  const Stats& last_stats() const;
  // Mode (b), diagnostics: the positions the last run skinned, by source vertex (empty before the
  // first mode-(b) run). Current only for the vertices of the spheres it skinned: those in its pairs
  // and those the depth estimate visited; the others hold earlier frames' values.
  std::span<const Eigen::Vector3f> lazy_positions() const;
  // Diagnostics: the spheres the last run tested (boxed and, in mode (b), skinned): those of the pairs
  // it did not skip whole (as still as at rest, see the top of this file) and the self-tested ones.
  std::span<const uint32_t> tested_spheres() const;

  // Opaque: defined in runtime/src/narrow_phase/internal.h.
  struct State;

 private:
  friend struct narrow_phase::Access;
  std::unique_ptr<State> state_;
};

struct NarrowPhaseJob {
  const SphereSet* set = nullptr;         // has_mesh()
  const NarrowPhaseData* data = nullptr;  // built from *set
  std::span<const Vec4f> spheres;         // the refitted spheres the pairs came from, set->size()
  std::span<const SpherePair> pairs;      // the broad phase's pairs (i < j < set->size()); with a
                                          // margin, of the spheres grown by half of it (above)
  // (a) skinned positions by source vertex (>= set->source_vertex_count), or, when empty,
  // (b) G_j(t) per skeleton joint (>= set->joint_count()): the job skins what it tests.
  // In mode (a) joint_world is optional: given (the matrices the positions were skinned with),
  // patches as still as at rest are skipped whole; empty, every patch is tested. Same output.
  std::span<const Eigen::Vector3f> positions;
  std::span<const Mat4f> joint_world;
  NarrowPhaseContext* context = nullptr;  // Resize(*data, ...) done
  FrameContacts* out = nullptr;           // cleared, then filled

  // Every reason the job is refused: null pointers, sizes, a context sized for other data, no
  // positions and no joint matrices. O(1).
  bool Validate() const;
  // Validates and runs on the calling thread. False (out cleared) on a refused job, a pair index
  // out of range, or non-finite positions. Never throws.
  bool Run() const;
  // The same through parallel_for (parallel_for.h; TBB by default): identical output.
  bool RunParallel(const ParallelFor& parallel_for = DefaultParallelFor()) const;
};

// The oracle, for tests, `play --verify` and benchmarks: no sphere (rules on triangles: every pair
// of triangles whose boxes meet; rules on sphere pairs: every allowed sphere pair, all triangles),
// positions of every source vertex, the same output. docs/NARROW_PHASE.md#the-oracle.
bool FindContactsBruteForce(const SphereSet& set, const NarrowPhaseData& data, const PairFilter& filter,
                            std::span<const Eigen::Vector3f> positions, FrameContacts* out);

}  // namespace skinspheres::runtime
