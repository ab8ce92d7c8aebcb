// PairFilter: which sphere pairs of one character the self-collision broad phase must never
// report, and which body part each sphere belongs to. Built once at set-up (allocates), read
// every frame by SelfCollisionJob (broad_phase.h) from inside the query: an excluded pair is
// skipped where it is found, never produced and filtered afterwards.
//
// Storage: a symmetric n x n bit matrix, row i = ceil(n / 64) 64-bit words, bit (i, j) set when
// the pair {i, j} is excluded (diagonal set too: a sphere never collides with itself), plus one
// uint16_t part index per sphere. 300 spheres take 5 words (40 bytes) a row, 12 KB in all.
//
// Sources: a SphereSet (its excluded_pairs and sphere_part), or explicit lists so tests and
// engines with their own rules can build one. Creation validates indices and reports problems as
// an Error; the result is immutable and shareable between threads and characters.
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

#include "skinspheres/runtime/error.h"
#include "skinspheres/runtime/sphere_set.h"

namespace skinspheres::runtime {

class PairFilter {
 public:
  // More spheres than this are refused (the matrix grows as n^2: 8192 spheres = 8 MiB).
  static constexpr size_t kMaxSpheres = 8192;

  PairFilter() = default;  // an empty filter for 0 spheres

  // From a fitted set: set.excluded_pairs (reasons ignored) and set.sphere_part.
  static Result<PairFilter> FromSphereSet(const SphereSet& set);

  // sphere_part: empty (every sphere in part 0) or exactly sphere_count entries.
  // excluded: pairs in any order, i != j, both < sphere_count; duplicates are allowed.
  static Result<PairFilter> Create(size_t sphere_count, std::span<const uint16_t> sphere_part,
                                   std::span<const ExcludedPair> excluded);

  size_t size() const { return sphere_count_; }
  // Number of distinct excluded pairs {i, j}, i != j.
  size_t excluded_pair_count() const { return excluded_pair_count_; }

  // True when {i, j} must not be reported (always true for i == j). i, j < size(); unchecked.
  bool excluded(uint32_t i, uint32_t j) const {
    return (bits_[static_cast<size_t>(i) * words_per_row_ + (j >> 6)] >> (j & 63u)) & 1u;
  }
  uint16_t part(uint32_t i) const { return parts_[i]; }
  std::span<const uint16_t> parts() const { return parts_; }

  // Raw access for the query kernels: row i starts at bits() + i * words_per_row().
  const uint64_t* bits() const { return bits_.data(); }
  size_t words_per_row() const { return words_per_row_; }

 private:
  size_t sphere_count_ = 0;
  size_t words_per_row_ = 0;
  size_t excluded_pair_count_ = 0;
  std::vector<uint64_t> bits_;    // sphere_count_ * words_per_row_
  std::vector<uint16_t> parts_;   // sphere_count_
};

}  // namespace skinspheres::runtime
