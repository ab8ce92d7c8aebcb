// Self-collision broad phase: every pair of one character's spheres that overlaps or touches,
// except the pairs its PairFilter excludes, with the penetration depth and the body parts.
//
//   contact (i, j), i < j, when |c_i - c_j|^2 <= (r_i + r_j)^2 and !filter.excluded(i, j)
//   depth = (r_i + r_j) - |c_i - c_j|            (>= 0 up to rounding; 0 when touching)
//
// Evaluated in float, in exactly this order ((dx*dx + dy*dy) + dz*dz, dx = c_j.x - c_i.x), by the
// fast path and by the all-pairs oracle alike, so both report the same pairs and the same depths.
//
// Fast path (SelfCollisionJob): sort and sweep. Each frame the spheres' intervals on one axis
// [c - r - pad, c + r + pad] are sorted by their start (an insertion sort on the previous frame's
// order, near-linear for coherent motion; a full sort when the order is new or too scrambled),
// then each sphere is tested against the following ones while their intervals overlap, 4 (SSE2)
// or 8 (AVX2) candidates at a time. pad is a tiny relative margin so that float rounding in the
// interval test can never lose a pair the sphere test would accept. The axis is the one of largest
// centre variance, chosen on the context's first frame and re-chosen every kAxisRefreshFrames
// frames (switching only when clearly better, since a switch costs a full sort).
//
// Output: contacts sorted by (i, j), identical for any thread count and for any previous frame
// history. No allocation and no exception per frame once the context is sized and the output
// vector has held the largest contact count seen (reserve it at set-up to be sure).
//
// Crowds: one SelfCollisionJob per character (each with its own context and output), run by
// RunSelfCollisionJobs through a ParallelFor (TBB by default, or the engine's job system), or by
// RunSelfCollisionJobRange.
#pragma once

#include <Eigen/Core>
#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

#include "skinspheres/skinning/math_types.h"
#include "skinspheres/skinning/parallel_for.h"
#include "skinspheres/runtime/pair_filter.h"

namespace skinspheres::runtime {

struct Contact {
  uint32_t i = 0;          // sphere index, i < j
  uint32_t j = 0;
  float depth = 0.0f;      // r_i + r_j - |c_i - c_j|, same units as the spheres
  uint16_t part_i = 0;     // filter.part(i)
  uint16_t part_j = 0;     // filter.part(j)

  friend bool operator==(const Contact&, const Contact&) = default;
};

// Per-character scratch and frame-to-frame memory (sort order, sweep axis). Sized at set-up;
// one per character that runs concurrently (never share one between jobs running at once).
class BroadPhaseContext {
 public:
  static constexpr uint32_t kAxisRefreshFrames = 64;

  BroadPhaseContext() = default;
  explicit BroadPhaseContext(size_t max_spheres) { Resize(max_spheres); }

  // Set-up only (allocates). Forgets the previous frame.
  void Resize(size_t max_spheres);
  size_t max_spheres() const { return max_spheres_; }

  // Forget the previous frame's order and axis (after a teleport or a switch of character). Not
  // needed for correctness: a job also does this itself when the filter or sphere count changes.
  void Invalidate() { previous_count_ = 0; previous_filter_ = nullptr; frame_ = 0; }

  // Diagnostics of the last Run(): sweep axis (0 x, 1 y, 2 z; -1 before any run), how many
  // candidate pairs passed the interval test, and whether the sort fell back to a full sort.
  int sweep_axis() const { return axis_; }
  size_t last_candidate_count() const { return last_candidates_; }
  bool last_full_sort() const { return last_full_sort_; }

 private:
  friend struct SelfCollisionJob;

  struct SortItem {
    float key;         // interval start on the sweep axis
    uint32_t sphere;   // index into the job's spheres
  };

  size_t max_spheres_ = 0;
  size_t previous_count_ = 0;                // 0: no usable previous order
  const PairFilter* previous_filter_ = nullptr;
  uint32_t frame_ = 0;                       // frames since the axis was chosen
  int axis_ = -1;
  size_t last_candidates_ = 0;
  bool last_full_sort_ = false;

  std::vector<SortItem> order_;              // max_spheres
  // Structure of arrays in sweep order, padded by kPad entries (start = +inf) for the SIMD reads.
  static constexpr size_t kPad = 8;
  std::vector<float> x_, y_, z_, r_, start_, end_;  // max_spheres + kPad each
  std::vector<uint32_t> sphere_;                     // max_spheres + kPad
};

struct SelfCollisionJob {
  std::span<const Vec4f> spheres;  // xyz centre, w radius (>= 0); size == filter->size()
  const PairFilter* filter = nullptr;
  BroadPhaseContext* context = nullptr;      // max_spheres() >= spheres.size()
  std::vector<Contact>* out = nullptr;       // cleared, then filled, sorted by (i, j)

  // Every reason the job is refused: null pointers, sizes. Does not read the sphere values.
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
