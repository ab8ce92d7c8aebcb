// PairFilter construction (set-up time: allocates, reports bad indices as Error).
#include "skinspheres/runtime/broad_phase/pair_filter.h"

#include <algorithm>
#include <atomic>
#include <limits>
#include <string>
#include <utility>

namespace skinspheres::runtime {
namespace {

uint64_t NextFilterId() {
  static std::atomic<uint64_t> next{1};
  return next.fetch_add(1, std::memory_order_relaxed);
}

}  // namespace

PairFilter& PairFilter::operator=(PairFilter&& other) noexcept {
  if (this != &other) {
    sphere_count_ = std::exchange(other.sphere_count_, 0);
    excluded_pair_count_ = std::exchange(other.excluded_pair_count_, 0);
    id_ = std::exchange(other.id_, 0);
    within_ = std::exchange(other.within_, true);
    between_ = std::exchange(other.between_, true);
    row_begin_ = std::move(other.row_begin_);
    partners_ = std::move(other.partners_);
    parts_ = std::move(other.parts_);
    group_ = std::move(other.group_);
    group_begin_ = std::move(other.group_begin_);
    other.row_begin_.clear();
    other.partners_.clear();
    other.parts_.clear();
    other.group_.clear();
    other.group_begin_.clear();
  }
  return *this;
}

Result<PairFilter> PairFilter::Create(size_t sphere_count, std::span<const uint16_t> sphere_part,
                                      std::span<const ExcludedPair> excluded) {
  if (sphere_count > kMaxSpheres) {
    return MakeError(ErrorCode::kInvalidArgument, "PairFilter: " + std::to_string(sphere_count) +
                                                      " spheres, more than the " + std::to_string(kMaxSpheres) +
                                                      " supported");
  }
  if (!sphere_part.empty() && sphere_part.size() != sphere_count) {
    return MakeError(ErrorCode::kInvalidArgument, "PairFilter: " + std::to_string(sphere_part.size()) +
                                                      " part indices for " + std::to_string(sphere_count) + " spheres");
  }
  // Both directions of every pair: at most 2^32 - 1 entries in all (offsets are uint32_t).
  if (excluded.size() > (std::numeric_limits<uint32_t>::max() - 1) / 2) {
    return MakeError(ErrorCode::kInvalidArgument,
                     "PairFilter: " + std::to_string(excluded.size()) + " excluded pairs, more than supported");
  }
  for (size_t k = 0; k < excluded.size(); ++k) {
    const ExcludedPair& p = excluded[k];
    if (p.i >= sphere_count || p.j >= sphere_count || p.i == p.j) {
      return MakeError(ErrorCode::kInvalidArgument,
                       "PairFilter: excluded pair #" + std::to_string(k) + " (" + std::to_string(p.i) + ", " +
                           std::to_string(p.j) + ") is invalid for " + std::to_string(sphere_count) + " spheres");
    }
  }
  PairFilter filter;
  filter.sphere_count_ = sphere_count;
  filter.id_ = NextFilterId();
  if (sphere_part.empty()) {
    filter.parts_.assign(sphere_count, 0);
  } else {
    filter.parts_.assign(sphere_part.begin(), sphere_part.end());
  }
  if (sphere_count > 0) filter.group_begin_ = {0, static_cast<uint32_t>(sphere_count)};

  // Compressed rows: count, place, then sort and deduplicate each row.
  std::vector<uint32_t> count(sphere_count + 1, 0);
  for (const ExcludedPair& p : excluded) {
    ++count[p.i];
    ++count[p.j];
  }
  std::vector<uint32_t> begin(sphere_count + 1, 0);
  for (size_t s = 0; s < sphere_count; ++s) begin[s + 1] = begin[s] + count[s];
  std::vector<uint32_t> partners(begin[sphere_count]);
  std::vector<uint32_t> fill(begin.begin(), begin.end() - 1);
  for (const ExcludedPair& p : excluded) {
    partners[fill[p.i]++] = p.j;
    partners[fill[p.j]++] = p.i;
  }
  filter.row_begin_.assign(sphere_count + 1, 0);
  filter.partners_.reserve(partners.size());
  for (size_t s = 0; s < sphere_count; ++s) {
    const auto first = partners.begin() + begin[s], last = partners.begin() + begin[s + 1];
    std::sort(first, last);
    const auto unique_end = std::unique(first, last);
    filter.partners_.insert(filter.partners_.end(), first, unique_end);
    filter.row_begin_[s + 1] = static_cast<uint32_t>(filter.partners_.size());
  }
  filter.excluded_pair_count_ = filter.partners_.size() / 2;
  filter.partners_.shrink_to_fit();
  return filter;
}

Result<PairFilter> PairFilter::FromSphereSet(const SphereSet& set) {
  if (set.sphere_part.size() != set.size()) {
    return MakeError(ErrorCode::kInvalidData, "PairFilter: sphere set '" + set.source_file + "' has " +
                                                  std::to_string(set.sphere_part.size()) + " part indices for " +
                                                  std::to_string(set.size()) + " spheres");
  }
  auto filter = Create(set.size(), set.sphere_part, set.excluded_pairs);
  if (!filter.ok()) {
    return MakeError(filter.error().code, filter.error().message + " (sphere set '" + set.source_file + "')");
  }
  return filter;
}

Result<PairFilter> PairFilter::Combine(std::span<const PairFilter* const> members, CombineOptions options) {
  size_t total = 0, entries = 0;
  for (size_t g = 0; g < members.size(); ++g) {
    const PairFilter* m = members[g];
    if (m == nullptr) {
      return MakeError(ErrorCode::kInvalidArgument, "PairFilter::Combine: member " + std::to_string(g) + " is null");
    }
    if (m->group_count() > 1) {
      return MakeError(ErrorCode::kInvalidArgument,
                       "PairFilter::Combine: member " + std::to_string(g) + " is itself a combined filter");
    }
    total += m->size();
    entries += m->partners_.size();
    if (total > kMaxSpheres) {
      return MakeError(ErrorCode::kInvalidArgument,
                       "PairFilter::Combine: more than " + std::to_string(kMaxSpheres) + " spheres in all");
    }
    if (entries > std::numeric_limits<uint32_t>::max() - 1) {
      return MakeError(ErrorCode::kInvalidArgument, "PairFilter::Combine: too many excluded pairs in all");
    }
  }
  PairFilter filter;
  filter.sphere_count_ = total;
  filter.id_ = NextFilterId();
  filter.within_ = options.pairs_within_members;
  filter.between_ = options.pairs_between_members;
  filter.parts_.reserve(total);
  filter.group_.reserve(total);
  filter.row_begin_.assign(total + 1, 0);
  if (filter.within_) filter.partners_.reserve(entries);
  filter.group_begin_.assign(members.size() + 1, 0);
  size_t base = 0;
  for (size_t g = 0; g < members.size(); ++g) {
    const PairFilter& m = *members[g];
    filter.group_begin_[g] = static_cast<uint32_t>(base);
    filter.parts_.insert(filter.parts_.end(), m.parts_.begin(), m.parts_.end());
    filter.group_.insert(filter.group_.end(), m.size(), static_cast<uint32_t>(g));
    for (size_t s = 0; s < m.size(); ++s) {
      if (filter.within_) {
        for (const uint32_t p : m.excluded_partners(static_cast<uint32_t>(s))) {
          filter.partners_.push_back(static_cast<uint32_t>(base + p));
        }
      }
      filter.row_begin_[base + s + 1] = static_cast<uint32_t>(filter.partners_.size());
    }
    filter.excluded_pair_count_ += filter.within_ ? m.excluded_pair_count_ : 0;
    base += m.size();
  }
  filter.group_begin_[members.size()] = static_cast<uint32_t>(base);
  if (members.empty()) filter.group_begin_.clear();
  return filter;
}

}  // namespace skinspheres::runtime
