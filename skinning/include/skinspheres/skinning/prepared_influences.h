// PreparedInfluences: influences re-laid out once, at set-up, for the fast SkinningJob path.
//
// Built from CSR influences (skinned_mesh.h) and an optional vertex subset (e.g. the runtime's
// sphere source vertices). Vertices are grouped by influence count n; inside a group each vertex
// owns exactly n (matrix byte offset, weight) pairs, contiguous, in the CSR order, so the kernel
// runs a loop unrolled for n with no per-vertex count and no u16 widening; a matrix is addressed
// by its float offset (bind * 16), which x86 folds into the load's address.
// A slot is one vertex to skin: slots run group after group (ascending n), and inside a group in
// the order of the input (subset order, or vertex order). Skinning results are bit-identical to
// the CSR path of the same SkinningJob (same operations in the same order per vertex).
// Build() allocates and checks everything once; afterwards the object is immutable, which is
// what lets SkinningJob::Validate() check a prepared job in O(1).
#pragma once

#include <cstdint>
#include <span>
#include <string>
#include <vector>

namespace skinspheres::skinning {

class PreparedInfluences {
 public:
  struct Group {
    uint32_t influence_count = 0;  // n, the same for every vertex of the group
    uint32_t first_slot = 0;       // first slot of the group
    uint32_t slot_count = 0;       // vertices in the group
    uint32_t first_influence = 0;  // index of the group's first (offset, weight) pair
  };

  // offsets: vertex_count + 1 CSR offsets; binds / weights: >= offsets[vertex_count] entries.
  // subset: vertex indices to skin (each < vertex_count, duplicates allowed); empty = every vertex.
  // Returns false (and says why in *error) on inconsistent input; the object is then empty.
  bool Build(size_t vertex_count, std::span<const uint32_t> offsets, std::span<const uint16_t> binds,
             std::span<const float> weights, std::span<const uint32_t> subset = {}, std::string* error = nullptr);

  size_t size() const { return vertices_.size(); }  // slots
  bool empty() const { return vertices_.empty(); }
  std::span<const Group> groups() const { return groups_; }
  std::span<const uint32_t> vertices() const { return vertices_; }              // per slot
  std::span<const uint32_t> matrix_offsets() const { return matrix_offsets_; }  // bind * 16 (floats)
  std::span<const float> weights() const { return std::span<const float>(weights_).first(matrix_offsets_.size()); }
  // Buffers a job needs: vertex_count >= required_vertex_count(), joint_matrices > max bind.
  size_t required_vertex_count() const { return required_vertex_count_; }
  size_t required_matrix_count() const { return required_matrix_count_; }

 private:
  static constexpr size_t kWeightPadding = 8;  // zeros after the last weight: kernels load 4-8 at once
  std::vector<Group> groups_;
  std::vector<uint32_t> vertices_;
  std::vector<uint32_t> matrix_offsets_;
  std::vector<float> weights_;
  size_t required_vertex_count_ = 0;
  size_t required_matrix_count_ = 0;
};

}  // namespace skinspheres::skinning
