// Self-collision broad phase: every pair of one character's spheres (or of several characters
// sharing a space, see PairFilter::Combine) that overlaps or touches, except the pairs its
// PairFilter excludes, with the penetration depth and the body parts.
//
//   contact (i, j), i < j, when |c_i - c_j|^2 <= (r_i + r_j)^2 and !filter.excluded(i, j)
//   depth = (r_i + r_j) - |c_i - c_j|            (>= 0 up to rounding; 0 when touching)
//
// Evaluated in float, in exactly this order ((dx*dx + dy*dy) + dz*dz, dx = c_j.x - c_i.x), by the
// fast path and by the all-pairs oracle alike, so both report the same pairs and the same depths.
//
// Fast path (SelfCollisionJob): a cache of candidate pairs with a skin (a Verlet list). When the
// cache is built, every sphere gets a skin s_k and the candidates are the allowed pairs whose
// spheres, grown by their skins, touch; they are kept sorted by (i, j). Each frame the job checks,
// for every sphere, that it moved less than its skin relative to the set's mean motion (a
// character that walks keeps its cache) and grew by less than what is left; if so, every pair
// that touches now is a candidate (triangle inequality), and the frame costs one pass over the
// spheres plus the exact sphere test on the candidates, whose hits come out already sorted.
// Otherwise the cache is rebuilt: skins from each sphere's own recent speed times a lookahead,
// then all pairs (up to kAllPairsMax spheres, in index order: already sorted) or a sweep in
// blocks along the axis of largest spread, inside strips across the next axis when that saves
// work (touching spheres lie in the same or adjacent strips, so the work grows linearly with the
// count at constant density), listed exclusions left out as it goes, then two counting-sort
// passes. The sweep order is kept between builds (insertion sort per strip and strip of origin,
// then merged). The lookahead adapts per context to the cheapest counted work per
// frame (lifetime of the cache against its size); motion that breaks every cache gets no skin,
// and a small set then skips the cache and writes all pairs straight into the output. Every
// test is SIMD: SSE2, AVX2 or AVX-512, picked at run time (or forced with
// SelfCollisionJob::simd) with bit-identical results.
//
// Output: contacts sorted by (i, j), identical for any thread count, instruction set and
// previous frame history. No allocation and no exception per frame once the context is sized
// (Resize) and the output vector has held the largest contact count seen (reserve it at set-up).
// The candidate cache never grows: when a build does not fit the context's max_candidates, a
// small set is answered without a cache (all pairs straight into the output), a larger one is
// rebuilt without skins and, if even that does not fit, answered by a sweep straight into the
// output, then sorted.
//
// Crowds, each character alone: one SelfCollisionJob per character (each with its own context
// and output), run by RunSelfCollisionJobs through a ParallelFor (TBB by default, or the
// engine's job system), or by RunSelfCollisionJobRange.
//
// Characters that may touch each other: one job over their spheres laid end to end, with the
// filter of PairFilter::Combine (pairs between characters on or off; each character keeps its
// own exclusions). Sphere k of character g is index filter.group_begin(g) + k; a contact (i, j)
// belongs to characters filter.group(i) and filter.group(j). Above kAllPairsMax spheres (and 16
// or more per character on average) the context runs such a space by character (method kGroups):
// each character on a context and cache of its own, exactly as if it were alone, so one walking
// character no longer ends the whole space's cache; the pairs between characters come from a
// sweep of the characters' bounding boxes, then the exact test on the spheres of each that lie
// inside the other's box. Those per-character contexts and filters are made on the first frame
// with the filter (that frame allocates; a context that alternates between two such filters
// makes them again at every switch: give each space its own context). Contacts between
// characters are kept in room for n and, beyond it, written to the output, which is then sorted.
// Characters piled into each other (more than 16 pairs between characters per sphere, tested
// afresh every frame) are run as one set for the next 64 frames.
//
//   std::vector<const PairFilter*> members = {&a->filter(), &b->filter(), ...};   // set-up
//   PairFilter space = PairFilter::Combine(members, {.pairs_between_members = true}).value();
//   BroadPhaseContext context(space.size());
//   each frame: copy each instance's spheres() to all[space.group_begin(g) ...], then
//   SelfCollisionJob{all, &space, &context, &contacts}.Run();
#pragma once

#include <Eigen/Core>
#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

#include "skinspheres/skinning/math_types.h"
#include "skinspheres/skinning/parallel_for.h"
#include "skinspheres/runtime/broad_phase/pair_filter.h"

namespace skinspheres::runtime {

struct Contact {
  uint32_t i = 0;          // sphere index, i < j
  uint32_t j = 0;
  float depth = 0.0f;      // r_i + r_j - |c_i - c_j|, same units as the spheres
  uint16_t part_i = 0;     // filter.part(i)
  uint16_t part_j = 0;     // filter.part(j)

  friend bool operator==(const Contact&, const Contact&) = default;
};

// Instruction set of the broad-phase kernels. kAuto: the widest the CPU has (x86-64: AVX-512, AVX2,
// SSE2; elsewhere kPortable). kPortable: plain C++ over arrays of 4 floats, on every platform.
// Every level, on every platform, gives the same contacts, bit for bit.
enum class BroadPhaseSimd : uint8_t { kAuto, kSse2, kAvx2, kAvx512, kPortable };
bool BroadPhaseSimdSupported(BroadPhaseSimd level);
BroadPhaseSimd ResolveBroadPhaseSimd(BroadPhaseSimd level);  // kAuto -> the level it runs
const char* ToString(BroadPhaseSimd level);

// How the last Run() answered (BroadPhaseContext::last_method()).
enum class BroadPhaseMethod : uint8_t {
  kNone,             // no run yet, a refused run, or fewer than 2 spheres
  kCached,           // the candidate cache held: exact test on its candidates only
  kAllPairsBuild,    // cache rebuilt by all pairs in index order, then tested
  kSweepBuild,       // cache rebuilt by sort and sweep in grid columns, then tested
  kAllPairsDirect,   // no cache fits: all pairs straight into the output
  kSweepDirect,      // no cache fits: sweep straight into the output, then sorted
  kGroups,           // a space of several characters: each character's own cache, then the
                     // pairs between characters whose bounding boxes overlap
};
const char* ToString(BroadPhaseMethod method);

// Per-character scratch and frame-to-frame memory (candidate cache, sweep order and axis, skins).
// Sized at set-up; one per character or space that runs concurrently (never share one between
// jobs running at once). Memory: about 100 bytes per sphere, 16-72 more for the listed pairs as bit
// rows, plus 8 bytes per candidate (above kAllPairsMax: about 170 bytes per sphere, with the listed
// exclusions as 64 bytes of sweep bits, 16 bytes per candidate). A space run by character (kGroups) adds, from its
// first frame, each character's own context and filter (with the default candidate room, about
// 250 bytes per sphere for a character of up to kAllPairsMax spheres) and 16 bytes per sphere for
// the contacts between characters.
class BroadPhaseContext {
 public:
  // Sets of up to this many spheres build their cache by all pairs, larger ones by the sweep.
  static constexpr size_t kAllPairsMax = 512;

  BroadPhaseContext() = default;
  explicit BroadPhaseContext(size_t max_spheres, size_t max_candidates = 0) { Resize(max_spheres, max_candidates); }

  // Set-up only (allocates). Forgets the previous frame. max_candidates: room of the candidate
  // cache; 0 picks min(n(n-1)/2, 16n + 256) for n = max_spheres.
  void Resize(size_t max_spheres, size_t max_candidates = 0);
  size_t max_spheres() const { return max_spheres_; }
  size_t max_candidates() const { return max_candidates_; }

  // Forget the cache, the sweep order and axis (after a teleport or a switch of character). Not
  // needed for correctness: a job checks the cache itself, and forgets it when the filter or the
  // sphere count changes.
  void Invalidate();

  // Diagnostics of the last Run().
  BroadPhaseMethod last_method() const { return method_; }
  // Candidate pairs that got the exact sphere test (after a build: the new cache's).
  size_t last_candidate_count() const { return last_candidates_; }
  // Pairs the build tested with the grown spheres (0 when the cache held).
  size_t last_build_tests() const { return last_build_tests_; }
  // Sweep axis (0 x, 1 y, 2 z) of the latest sweep build; -1 before any.
  int sweep_axis() const { return axis_; }
  // Whether the latest sweep build sorted from scratch (no usable previous order).
  bool last_full_sort() const { return last_full_sort_; }
  // Builds since Resize (a frame that rebuilds counts once, even when it retries without skins).
  uint64_t build_count() const { return build_count_; }
  // Lookahead of the latest build: each sphere's skin is this many frames of its recent motion.
  float last_lookahead() const { return last_lookahead_; }

 private:
  friend struct SelfCollisionJob;
  struct Impl;

  struct SortItem {
    uint64_t key;      // column << 32 | interval start (order-preserving bits)
    uint32_t sphere;   // index into the job's spheres
    uint32_t from;     // while sorting: the column at the previous build
  };
  struct ColumnRun {
    uint32_t column, begin, end;
  };

  size_t max_spheres_ = 0;
  size_t max_candidates_ = 0;

  // The candidate cache.
  bool cache_valid_ = false;
  size_t cache_count_ = 0;           // sphere count it was built for
  uint64_t cache_filter_ = 0;        // PairFilter::id() it was built with
  uint32_t age_ = 0;                 // frames since the build
  float ref_sum_[3] = {0, 0, 0};     // sum of the centres at the build
  int rung_ = 2;                     // lookahead: skin = lookahead x speed (broad_phase/self_collision_job.cc)
  double rung_cost_[8] = {};         // per rung, the recent work per frame of its caches
  double build_cost_ = 0.0;          // work of the cache's build (counted)
  size_t candidate_count_ = 0;
  std::vector<uint32_t> ci_, cj_;    // max_candidates + pad: candidate pairs, sorted by (i, j)
  std::vector<float> ref_;           // 4 x (max_spheres + pad): x, y, z, r at the build
  std::vector<float> allow_;         // max_spheres + pad: skin (1 - 2^-16)
  std::vector<float> motion_;        // max_spheres + pad: motion since the build
  std::vector<float> speed_;         // max_spheres: motion per frame, as used by the last build

  // Build scratch.
  std::vector<float> soa_;           // 8 x (max_spheres + pad), see broad_phase/self_collision_job.cc
  std::vector<uint32_t> sphere_;     // max_spheres + pad: sphere at each sweep position
  std::vector<SortItem> order_;      // max_spheres: sweep order (kept between builds)
  std::vector<SortItem> order_by_strip_;  // max_spheres: counting sort scratch
  std::vector<ColumnRun> runs_;            // max_spheres: columns in sweep order
  std::vector<uint32_t> pi_, pj_;    // max_candidates + pad (above kAllPairsMax): unsorted pairs
  std::vector<uint32_t> row_;        // max_spheres + 1: counting sort
  std::vector<uint64_t> near_;       // listed pairs as bits: the sweep's, or the all-pairs rows (broad_phase/self_collision_job.cc)
  std::vector<uint8_t> far_;         // max_spheres (above kAllPairsMax): has listed partners past the bits
  uint64_t near_filter_ = 0;         // PairFilter::id() the bits in near_ (and far_) were made from
  size_t near_count_ = 0;            // and its size (0: not made)
  std::vector<Contact> stage_;       // kStage + pad: contacts before they go to the output
  size_t order_count_ = 0;           // sphere count the order is for (0: none)
  bool order_columns_ = false;       // whether the order has grid columns
  int axis_ = -1;
  double cell_ = 0.0;                // grid column size of the last sweep build

  // Diagnostics.
  BroadPhaseMethod method_ = BroadPhaseMethod::kNone;
  size_t last_candidates_ = 0;
  size_t last_build_tests_ = 0;
  bool last_full_sort_ = false;
  uint64_t build_count_ = 0;
  float last_lookahead_ = 0.0f;

  // A space of several characters (a filter from PairFilter::Combine, more than kAllPairsMax
  // spheres): one context and one filter per character, made on the first frame with that filter.
  std::vector<BroadPhaseContext> group_contexts_;
  std::vector<PairFilter> group_filters_;
  uint64_t groups_filter_ = 0;                // PairFilter::id() they were made from (0: none)
  uint32_t groups_pause_ = 0;                 // frames left to run the space as one set
  std::vector<Contact> group_out_;            // one character's contacts (room: its cache's)
  std::vector<Contact> cross_;                // room for n: contacts between characters, sorted by (i, j)
  std::vector<float> group_box_;              // 8 per character: low x, y, z, -, high x, y, z, -
  std::vector<uint32_t> group_order_;         // characters by low x (kept between frames)
  std::vector<uint32_t> cross_a_, cross_b_;   // spheres of g (of h) inside the other's box
};

struct SelfCollisionJob {
  std::span<const Vec4f> spheres;  // xyz centre, w radius (>= 0); size == filter->size()
  const PairFilter* filter = nullptr;
  BroadPhaseContext* context = nullptr;      // max_spheres() >= spheres.size()
  std::vector<Contact>* out = nullptr;       // cleared, then filled, sorted by (i, j)
  BroadPhaseSimd simd = BroadPhaseSimd::kAuto;  // refused (Validate) when the CPU lacks it

  // Every reason the job is refused: null pointers, sizes, an instruction set the CPU lacks.
  // Does not read the sphere values.
  bool Validate() const;
  // Validates, then runs. Returns false (out cleared) on a refused job or when a centre or radius
  // is not finite or a radius is negative. Never throws (but out may grow past its capacity).
  bool Run() const;
};

// Runs jobs[begin, end) one after the other on the calling thread; false if any failed (the
// others still run). For engines that schedule work themselves.
bool RunSelfCollisionJobRange(std::span<const SelfCollisionJob> jobs, size_t begin, size_t end);

// Runs every job through parallel_for (parallel_for.h; TBB in the current task arena by default).
// Every job must have its own context and output. Output is identical to running them one by one.
bool RunSelfCollisionJobs(std::span<const SelfCollisionJob> jobs,
                          const ParallelFor& parallel_for = DefaultParallelFor());

// The obvious O(n^2) loop over i < j: the test oracle and the benchmark baseline. Same rules and
// arithmetic as the fast path; out cleared then filled in (i, j) order. False (out cleared) when
// spheres.size() != filter.size() or a value is not finite or a radius negative.
bool SelfCollisionAllPairs(std::span<const Vec4f> spheres, const PairFilter& filter,
                           std::vector<Contact>* out);

}  // namespace skinspheres::runtime
