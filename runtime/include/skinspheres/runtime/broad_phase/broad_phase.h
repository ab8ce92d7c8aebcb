// Self-collision broad phase: every pair of one character's spheres (or of several characters
// sharing a space, see PairFilter::Combine) that overlaps or touches, except the pairs its
// PairFilter excludes, with the penetration depth and the body parts.
//
//   sphere pair (i, j), i < j, when |c_i - c_j|^2 <= (r_i + r_j)^2 and !filter.excluded(i, j)
//   depth = (r_i + r_j) - |c_i - c_j|            (>= 0 up to rounding; 0 when touching)
//
// Evaluated in float, in exactly this order ((dx*dx + dy*dy) + dz*dz, dx = c_j.x - c_i.x), by the
// fast path and by the all-pairs oracle alike, so both report the same pairs and the same depths.
//
// Fast path (BroadPhaseJob): a cache of candidate pairs with a skin (a Verlet list). When the
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
// BroadPhaseJob::simd) with bit-identical results.
//
// Output: sphere pairs sorted by (i, j), identical for any thread count, instruction set and
// previous frame history. No allocation and no exception per frame once the context is sized
// (Resize) and the output vector has held the largest sphere pair count seen (reserve it at set-up).
// The candidate cache never grows: when a build does not fit the context's max_candidates, a
// small set is answered without a cache (all pairs straight into the output), a larger one is
// rebuilt without skins and, if even that does not fit, answered by a sweep straight into the
// output, then sorted.
//
// Crowds, each character alone: one BroadPhaseJob per character (each with its own context
// and output), run by RunParallel through a ParallelFor (TBB by default, or the
// engine's job system), or by RunRange.
//
// Characters that may touch each other: one job over their spheres laid end to end, with the
// filter of PairFilter::Combine (pairs between characters on or off; each character keeps its
// own exclusions). Sphere k of character g is index filter.group_begin(g) + k; a sphere pair (i, j)
// belongs to characters filter.group(i) and filter.group(j). Above kAllPairsMax spheres (and 16
// or more per character on average) the context runs such a space by character (method kGroups):
// each character on a context and cache of its own, exactly as if it were alone, so one walking
// character does not end the whole space's cache; the pairs between characters come from a
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
//   BroadPhaseJob{all, &space, &context, &sphere pairs}.Run();
#pragma once

#include <Eigen/Core>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <span>
#include <vector>

#include "skinspheres/runtime/broad_phase/pair_filter.h"
#include "skinspheres/runtime/simd_level.h"
#include "skinspheres/skinning/math_types.h"
#include "skinspheres/skinning/parallel_for.h"

namespace skinspheres::runtime {

namespace broad_phase {
class Frame;  // runtime/src/broad_phase/frame.h
}  // namespace broad_phase

struct SpherePair {
  uint32_t sphere_i = 0;  // sphere index, sphere_i < sphere_j
  uint32_t sphere_j = 0;
  float depth = 0.0f;   // r_i + r_j - |c_i - c_j|, same units as the spheres
  uint16_t part_i = 0;  // filter.part(sphere_i)
  uint16_t part_j = 0;  // filter.part(sphere_j)

  friend bool operator==(const SpherePair&, const SpherePair&) = default;
};

// Instruction set of the broad-phase kernels (simd_level.h; SimdLevelSupported says which this CPU
// runs): every level, on every platform, gives the same sphere pairs, bit for bit.
SimdLevel ResolveBroadPhaseSimd(SimdLevel level);  // kAuto -> the level it runs

// How the last Run() answered (BroadPhaseContext::last_method()).
enum class BroadPhaseMethod : uint8_t {
  kNone,            // no run yet, a refused run, or fewer than 2 spheres
  kCached,          // the candidate cache held: exact test on its candidates only
  kAllPairsBuild,   // cache rebuilt by all pairs in index order, then tested
  kSweepBuild,      // cache rebuilt by sort and sweep in grid columns, then tested
  kAllPairsDirect,  // no cache fits: all pairs straight into the output
  kSweepDirect,     // no cache fits: sweep straight into the output, then sorted
  kGroups,          // a space of several characters: each character's own cache, then the
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
// the sphere pairs between characters.
class BroadPhaseContext {
 public:
  // Sets of up to this many spheres build their cache by all pairs, larger ones by the sweep.
  static constexpr size_t kAllPairsMax = 512;

  BroadPhaseContext();  // empty: max_spheres() 0
  explicit BroadPhaseContext(size_t max_spheres, size_t max_candidates = 0);
  ~BroadPhaseContext();
  BroadPhaseContext(const BroadPhaseContext& other);  // a copy of its state, cache included
  BroadPhaseContext& operator=(const BroadPhaseContext& other);
  BroadPhaseContext(BroadPhaseContext&&) noexcept;
  BroadPhaseContext& operator=(BroadPhaseContext&&) noexcept;

  // Set-up only (allocates). Forgets the previous frame. max_candidates: room of the candidate
  // cache; 0 picks min(n(n-1)/2, 16n + 256) for n = max_spheres.
  void Resize(size_t max_spheres, size_t max_candidates = 0);
  size_t max_spheres() const;
  size_t max_candidates() const;

  // Forget the cache, the sweep order and axis (after a teleport or a switch of character). Not
  // needed for correctness: a job checks the cache itself, and forgets it when the filter or the
  // sphere count changes.
  void Invalidate();

  // Diagnostics of the last Run().
  BroadPhaseMethod last_method() const;
  // Candidate pairs that got the exact sphere test (after a build: the new cache's).
  size_t last_candidate_count() const;
  // Pairs the build tested with the grown spheres (0 when the cache held).
  size_t last_build_tests() const;
  // Sweep axis (0 x, 1 y, 2 z) of the latest sweep build; -1 before any.
  int sweep_axis() const;
  // Whether the latest sweep build sorted from scratch (no usable previous order).
  bool last_full_sort() const;
  // Builds since Resize (a frame that rebuilds counts once, even when it retries without skins).
  uint64_t build_count() const;
  // Lookahead of the latest build: each sphere's skin is this many frames of its recent motion.
  float last_lookahead() const;

 private:
  friend struct BroadPhaseJob;
  friend class broad_phase::Frame;
  struct State;  // broad_phase/context_state.h (runtime/src)
  std::unique_ptr<State> state_;
};

struct BroadPhaseJob {
  std::span<const Vec4f> spheres;  // xyz centre, w radius (>= 0); size == filter->size()
  const PairFilter* filter = nullptr;
  BroadPhaseContext* context = nullptr;    // max_spheres() >= spheres.size()
  std::vector<SpherePair>* out = nullptr;  // cleared, then filled, sorted by (i, j)
  SimdLevel simd = SimdLevel::kAuto;       // refused (Validate) when the CPU lacks it

  // Every reason the job is refused: null pointers, sizes, an instruction set the CPU lacks.
  // Does not read the sphere values.
  bool Validate() const;
  // Validates, then runs. Returns false (out cleared) on a refused job or when a centre or radius
  // is not finite or a radius is negative. Never throws (but out may grow past its capacity).
  bool Run() const;
};

// Runs jobs[begin, end) one after the other on the calling thread; false if any failed (the
// others still run). For engines that schedule work themselves.
bool RunRange(std::span<const BroadPhaseJob> jobs, size_t begin, size_t end);

// Runs every job through parallel_for (parallel_for.h; TBB in the current task arena by default).
// Every job must have its own context and output. Output is identical to running them one by one.
bool RunParallel(std::span<const BroadPhaseJob> jobs, const ParallelFor& parallel_for = DefaultParallelFor());

// The obvious O(n^2) loop over i < j: the test oracle and the benchmark baseline. Same rules and
// arithmetic as the fast path; out cleared then filled in (i, j) order. False (out cleared) when
// spheres.size() != filter.size() or a value is not finite or a radius negative.
bool FindSpherePairsBruteForce(std::span<const Vec4f> spheres, const PairFilter& filter, std::vector<SpherePair>* out);

}  // namespace skinspheres::runtime
