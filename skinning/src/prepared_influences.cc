
#include "skinspheres/skinning/prepared_influences.h"

#include <Eigen/Core>
#include <algorithm>
#include <limits>

namespace skinspheres::skinning {

bool PreparedInfluences::Build(size_t vertex_count, std::span<const uint32_t> offsets, std::span<const uint16_t> binds,
                               std::span<const float> weights, std::span<const uint32_t> subset, std::string* error) {
  *this = PreparedInfluences();
  auto fail = [&](const std::string& what) {
    if (error) *error = "PreparedInfluences: " + what;
    return false;
  };
  if (vertex_count > std::numeric_limits<uint32_t>::max()) return fail("more than 2^32 vertices");
  if (offsets.size() < vertex_count + 1) {
    return fail(std::to_string(offsets.size()) + " influence offsets for " + std::to_string(vertex_count) +
                " vertices (need vertex_count + 1)");
  }
  const size_t slots = subset.empty() ? vertex_count : subset.size();
  if (slots > std::numeric_limits<uint32_t>::max()) return fail("more than 2^32 subset entries");
  auto vertex_of = [&](size_t i) -> size_t { return subset.empty() ? i : subset[i]; };

  // Check every used vertex and count vertices per influence count.
  std::vector<size_t> per_count;
  size_t total_pairs = 0;
  uint32_t max_bind = 0;
  size_t max_vertex = 0;
  for (size_t i = 0; i < slots; ++i) {
    const size_t v = vertex_of(i);
    if (v >= vertex_count) {
      return fail("subset entry " + std::to_string(i) + " is vertex " + std::to_string(v) + ", mesh has " +
                  std::to_string(vertex_count));
    }
    const uint32_t first = offsets[v], last = offsets[v + 1];
    if (last < first || last > binds.size() || last > weights.size()) {
      return fail("vertex " + std::to_string(v) + ": influence range [" + std::to_string(first) + ", " +
                  std::to_string(last) + ") is decreasing or past the bind/weight arrays (" +
                  std::to_string(binds.size()) + ", " + std::to_string(weights.size()) + ")");
    }
    const size_t n = last - first;
    if (per_count.size() <= n) per_count.resize(n + 1, 0);
    ++per_count[n];
    total_pairs += n;
    for (uint32_t k = first; k < last; ++k) max_bind = std::max<uint32_t>(max_bind, binds[k]);
    max_vertex = std::max(max_vertex, v);
  }
  if (total_pairs > std::numeric_limits<uint32_t>::max() - kWeightPadding) return fail("more than 2^32 influences");

  // Groups by ascending count; stable inside a group.
  std::vector<uint32_t> group_of_count(per_count.size(), 0);
  uint32_t slot = 0, pair = 0;
  for (size_t n = 0; n < per_count.size(); ++n) {
    if (per_count[n] == 0) continue;
    group_of_count[n] = static_cast<uint32_t>(groups_.size());
    groups_.push_back(Group{static_cast<uint32_t>(n), slot, 0, pair});
    slot += static_cast<uint32_t>(per_count[n]);
    pair += static_cast<uint32_t>(per_count[n] * n);
  }
  vertices_.resize(slots);
  matrix_offsets_.resize(total_pairs);
  weights_.resize(total_pairs + kWeightPadding);  // kernels may read 8 weights from any vertex
  for (size_t i = 0; i < slots; ++i) {
    const size_t v = vertex_of(i);
    const uint32_t first = offsets[v];
    const size_t n = offsets[v + 1] - first;
    Group& g = groups_[group_of_count[n]];
    const size_t s = size_t{g.first_slot} + g.slot_count;
    vertices_[s] = static_cast<uint32_t>(v);
    const size_t p = g.first_influence + size_t{g.slot_count} * n;
    for (size_t k = 0; k < n; ++k) {
      matrix_offsets_[p + k] = static_cast<uint32_t>(binds[first + k]) * 16u;  // floats per Matrix4f
      weights_[p + k] = weights[first + k];
    }
    ++g.slot_count;
  }
  required_vertex_count_ = slots > 0 ? max_vertex + 1 : 0;
  required_matrix_count_ = total_pairs > 0 ? size_t{max_bind} + 1 : 0;
  return true;
}

}  // namespace skinspheres::skinning
