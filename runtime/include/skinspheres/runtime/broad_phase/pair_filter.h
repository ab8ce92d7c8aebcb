// PairFilter: which sphere pairs the self-collision broad phase must never report, and which body
// part (and, in a shared space, which character) each sphere belongs to. Built once at set-up
// (allocates), read by BroadPhaseJob (broad_phase.h) while it builds its candidate pairs: an
// excluded pair is dropped where it is found, never reported and filtered afterwards.
//
// Storage grows with the number of exclusions, not with n^2: per sphere, the sorted list of the
// spheres it must not be paired with (both directions, compressed rows: 4 bytes per listed
// partner and 4 bytes per sphere), plus one uint16_t part index per sphere. 50,000 spheres with
// 250,000 excluded pairs take about 2.4 MB.
//
// Groups (characters sharing one space): Combine() concatenates the filters of several
// characters into one, sphere k of member g getting the index group_begin(g) + k. Pairs inside a
// member follow that member's own exclusions; pairs between two members are all allowed or all
// excluded (CombineOptions). A filter made by Create has one group, so group(i) == 0.
//
// excluded(i, j) is true when i == j, when {i, j} is listed, when i and j lie in one group and
// pairs within groups are off, or in two groups and pairs between groups are off.
//
// Sources: a SphereSet (its excluded_pairs and sphere_part), explicit lists (tests, engines with
// their own rules), or Combine. Creation validates indices and reports problems as an Error; the
// result is immutable and shareable between threads and characters. id() identifies the content:
// copies share it, every Create/Combine makes a new one, and a moved-from filter is left empty.
#pragma once

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

#include "skinspheres/runtime/error.h"
#include "skinspheres/runtime/format/sphere_set.h"

namespace skinspheres::runtime {

class PairFilter {
 public:
  // More spheres than this are refused (indices are uint32_t; this bounds set-up memory).
  static constexpr size_t kMaxSpheres = size_t{1} << 26;

  struct CombineOptions {
    bool pairs_within_members = true;   // each member's own pairs (by its own exclusions)
    bool pairs_between_members = true;  // pairs of spheres of two different members
  };

  PairFilter() = default;  // an empty filter for 0 spheres
  PairFilter(const PairFilter&) = default;
  PairFilter& operator=(const PairFilter&) = default;
  PairFilter(PairFilter&& other) noexcept { *this = std::move(other); }
  PairFilter& operator=(PairFilter&& other) noexcept;

  // From a fitted set: set.excluded_pairs (reasons ignored) and set.sphere_part.
  static Result<PairFilter> FromSphereSet(const SphereSet& set);

  // sphere_part: empty (every sphere in part 0) or exactly sphere_count entries.
  // excluded: pairs in any order, i != j, both < sphere_count; duplicates are allowed.
  static Result<PairFilter> Create(size_t sphere_count, std::span<const uint16_t> sphere_part,
                                   std::span<const ExcludedPair> excluded);

  // One filter over the members' spheres laid end to end (member g from group_begin(g)). Null
  // members and members that are themselves combined are refused.
  static Result<PairFilter> Combine(std::span<const PairFilter* const> members, CombineOptions options);

  size_t size() const { return sphere_count_; }
  // Number of distinct listed excluded pairs {i, j}, i != j (the group rules are not counted).
  size_t excluded_pair_count() const { return excluded_pair_count_; }
  uint64_t id() const { return id_; }

  // True when {i, j} must not be reported. i, j < size(); unchecked.
  bool excluded(uint32_t i, uint32_t j) const;
  uint16_t part(uint32_t i) const { return parts_[i]; }
  std::span<const uint16_t> parts() const { return parts_; }

  // The listed partners of sphere i, sorted ascending, without i itself. i < size(); unchecked.
  std::span<const uint32_t> excluded_partners(uint32_t i) const {
    return {partners_.data() + row_begin_[i], partners_.data() + row_begin_[i + 1]};
  }

  // Groups: 1 for a filter made by Create (0 when empty), the member count for Combine.
  size_t group_count() const { return group_begin_.empty() ? 0 : group_begin_.size() - 1; }
  uint32_t group(uint32_t i) const { return group_.empty() ? 0u : group_[i]; }
  // First sphere of group g; group_begin(group_count()) == size().
  uint32_t group_begin(uint32_t g) const { return group_begin_[g]; }
  bool pairs_within_groups() const { return within_; }
  bool pairs_between_groups() const { return between_; }

  // Raw arrays for the query kernels (null when size() == 0). row_begin: size() + 1 offsets into
  // partners; groups: one per sphere, or nullptr when there is a single group.
  const uint32_t* row_begin() const { return row_begin_.data(); }
  const uint32_t* partners() const { return partners_.data(); }
  const uint32_t* groups() const { return group_.empty() ? nullptr : group_.data(); }

 private:
  size_t sphere_count_ = 0;
  size_t excluded_pair_count_ = 0;
  uint64_t id_ = 0;
  bool within_ = true;
  bool between_ = true;
  std::vector<uint32_t> row_begin_;    // sphere_count_ + 1, or empty for no sphere
  std::vector<uint32_t> partners_;     // row_begin_.back(), sorted per row
  std::vector<uint16_t> parts_;        // sphere_count_
  std::vector<uint32_t> group_;        // sphere_count_, or empty for one group
  std::vector<uint32_t> group_begin_;  // group_count() + 1, or empty for no sphere
};

inline bool PairFilter::excluded(uint32_t i, uint32_t j) const {
  if (i == j) return true;
  if (!group_.empty() && group_[i] != group_[j]) return !between_;
  if (!within_) return true;
  const uint32_t* row = partners_.data();
  return std::binary_search(row + row_begin_[i], row + row_begin_[i + 1], j);
}

}  // namespace skinspheres::runtime
