// PairFilter construction (set-up time: allocates, reports bad indices as Error).
#include <string>

#include "skinspheres/runtime/pair_filter.h"

namespace skinspheres::runtime {

Result<PairFilter> PairFilter::Create(size_t sphere_count, std::span<const uint16_t> sphere_part,
                                      std::span<const ExcludedPair> excluded) {
  if (sphere_count > kMaxSpheres) {
    return MakeError(ErrorCode::kInvalidArgument,
                     "PairFilter: " + std::to_string(sphere_count) + " spheres, more than the " +
                         std::to_string(kMaxSpheres) + " supported");
  }
  if (!sphere_part.empty() && sphere_part.size() != sphere_count) {
    return MakeError(ErrorCode::kInvalidArgument,
                     "PairFilter: " + std::to_string(sphere_part.size()) + " part indices for " +
                         std::to_string(sphere_count) + " spheres");
  }
  PairFilter filter;
  filter.sphere_count_ = sphere_count;
  filter.words_per_row_ = (sphere_count + 63) / 64;
  filter.bits_.assign(sphere_count * filter.words_per_row_, 0);
  if (sphere_part.empty()) {
    filter.parts_.assign(sphere_count, 0);
  } else {
    filter.parts_.assign(sphere_part.begin(), sphere_part.end());
  }
  auto set_bit = [&filter](uint32_t a, uint32_t b) {
    uint64_t& word = filter.bits_[static_cast<size_t>(a) * filter.words_per_row_ + (b >> 6)];
    const uint64_t mask = uint64_t{1} << (b & 63u);
    const bool was_set = (word & mask) != 0;
    word |= mask;
    return !was_set;
  };
  for (uint32_t s = 0; s < sphere_count; ++s) set_bit(s, s);
  for (size_t k = 0; k < excluded.size(); ++k) {
    const ExcludedPair& p = excluded[k];
    if (p.i >= sphere_count || p.j >= sphere_count || p.i == p.j) {
      return MakeError(ErrorCode::kInvalidArgument,
                       "PairFilter: excluded pair #" + std::to_string(k) + " (" + std::to_string(p.i) +
                           ", " + std::to_string(p.j) + ") is invalid for " +
                           std::to_string(sphere_count) + " spheres");
    }
    if (set_bit(p.i, p.j)) ++filter.excluded_pair_count_;
    set_bit(p.j, p.i);
  }
  return filter;
}

Result<PairFilter> PairFilter::FromSphereSet(const SphereSet& set) {
  if (set.sphere_part.size() != set.size()) {
    return MakeError(ErrorCode::kInvalidData,
                     "PairFilter: sphere set '" + set.source_file + "' has " +
                         std::to_string(set.sphere_part.size()) + " part indices for " +
                         std::to_string(set.size()) + " spheres");
  }
  auto filter = Create(set.size(), set.sphere_part, set.excluded_pairs);
  if (!filter.ok()) {
    return MakeError(filter.error().code,
                     filter.error().message + " (sphere set '" + set.source_file + "')");
  }
  return filter;
}

}  // namespace skinspheres::runtime
