// RefitJob: the per-frame sphere refit. SphereSet (rest pose) + this frame's pose -> one bounding
// sphere per fitted sphere, written as Vec4f (xyz centre, w radius), for the broad phase
// (broad_phase.h). Both modes are CONSERVATIVE: every vertex of every triangle a sphere owns, and
// every corner of every piece it owns, is inside the refitted sphere, for any pose linear blend
// skinning can produce from the given joint transforms.
// Centre (both modes, with joint transforms): the sphere's own blended joint transform applied to
//   its rest centre, c' = Σ_j w_j · T_j · c; continuous in the pose, the same in both modes.
// Exact (kExact): reads skinned `positions`; radius = the largest distance from c' to the sphere's
//   points. Without joint_world: the points' box centre (radius <= sqrt(3) x the minimum ball's).
// Fast (kFast): reads joint_world only; radius = the Kavan & Žára bound, per reach group, with the
//   groups' blends where the set stores them. Both add a rounding margin of a few ulps.
// Derivation, reference frame, groups, blends, pieces, margin: docs/REFIT.md.
// Threads and errors: Validate() is O(1); Run() / RunRange() never allocate nor throw; every sphere
// is computed by the same instructions whatever the split, so RunParallel (any ParallelFor) gives
// bit-identical output for any thread count. Non-finite input (NaN/Inf joint matrices or positions)
// makes Run() return false; the spheres it touched then hold unspecified (possibly NaN) values.
#pragma once

#include <Eigen/Core>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <span>
#include <vector>

#include "skinspheres/runtime/error.h"
#include "skinspheres/runtime/format/sphere_set.h"
#include "skinspheres/skinning/math_types.h"
#include "skinspheres/skinning/parallel_for.h"

namespace skinspheres::runtime {

namespace internal {
struct RestDataAccess;  // runtime/src/refit/rest_data.h
}  // namespace internal

enum class RefitMode : uint8_t {
  kExact,  // skinned source vertices -> tight radius (see above)
  kFast,   // joint transforms only -> conservative radius (see above)
};
const char* ToString(RefitMode mode);  // "exact", "fast"

// The fitter's choice of the fast refit's reference frame (docs/REFIT.md#reference-frame):
// stores the bind pose in set->fast_reference_inverse / fast_reference_spheres and returns true when
// the set has a mesh, its rest pose is not its bind pose and the bind pose bounds tighter by more
// than 0.1%; clears them and returns false otherwise. Clears the set's reach groups either way (they
// are measured in the reference frame; the fitter writes them after). The set must pass Validate()
// without a reference; an error only when it does not.
Result<bool> ChooseFastReference(SphereSet* set);

// Rest-pose data the refit reads every frame, derived once from a SphereSet (allocates; then
// immutable and shareable between threads and instances).
class RefitRestData {
 public:
  RefitRestData();  // empty: fits only an empty set
  ~RefitRestData();
  RefitRestData(const RefitRestData& other);
  RefitRestData& operator=(const RefitRestData& other);
  RefitRestData(RefitRestData&&) noexcept;
  RefitRestData& operator=(RefitRestData&&) noexcept;

  // Validates the set (SphereSet::Validate()) and refuses rest transforms that cannot be inverted
  // (kInvalidData, naming the set's source file and the joint).
  static Result<RefitRestData> Create(const SphereSet& set);

  size_t sphere_count() const;
  size_t joint_count() const;
  size_t influence_count() const;
  size_t source_vertex_count() const;

  // Per influence entry k (SphereSet CSR order): R_j^-1 · c_s, and w_k renormalised to sum 1.
  std::span<const Eigen::Vector3f> center_in_joint() const;
  std::span<const float> weights() const;
  // Per influence entry: the reach W_k (the set's, else from its mesh, else 1).
  std::span<const float> reach() const;
  // Per sphere: radius_fast in the reference frame.
  std::span<const float> radii_fast() const;
  // true: the set stores a reference frame (the bind pose; docs/REFIT.md#reference-frame).
  bool bind_reference() const;
  // Reach groups, their blends, the inverse reference matrices: docs/REFIT.md#refitrestdata-layout.
  std::span<const uint32_t> group_offsets() const;
  std::span<const float> group_radii() const;
  std::span<const float> group_reach() const;
  std::span<const uint32_t> group_reach_offsets() const;
  std::span<const float> group_blend() const;
  std::span<const float> group_deviation() const;
  std::span<const float> group_blend_sum() const;
  std::span<const Eigen::Matrix3f> rest_linear_inverse() const;
  std::span<const float> rest_inverse_rows() const;
  // Exact mode's points per sphere (CSR; docs/REFIT.md#refitrestdata-layout); empty without pieces.
  std::span<const uint32_t> exact_point_offsets() const;
  std::span<const uint32_t> exact_points() const;
  // Points the set names (source vertices and grid points); a set of another size is refused.
  size_t point_count() const;

  // Opaque: defined in runtime/src/refit/rest_data.h, read there by the friend.
  struct Data;

 private:
  friend struct internal::RestDataAccess;
  std::unique_ptr<Data> data_;
};

struct RefitJob {
  RefitMode mode = RefitMode::kFast;
  const SphereSet* set = nullptr;       // the fitted set; must pass SphereSet::Validate()
                                        // (RefitRestData::Create and CharacterAsset check it)
  const RefitRestData* rest = nullptr;  // built from *set; required unless exact mode
                                        // without joint_world
  // G_j(t) per skeleton joint, >= set->joint_count(). Required in fast mode; optional in exact
  // mode (empty: box-centre fallback). Affine; the last row is ignored.
  std::span<const Mat4f> joint_world;
  // Exact mode: skinned positions indexed by source vertex, >= set->source_vertex_count.
  // Only the spheres' source vertices are read. Ignored (may be empty) in fast mode.
  std::span<const Eigen::Vector3f> positions;
  std::span<Vec4f> out;  // >= set->size(): xyz centre, w radius

  // Every reason the job is refused: null pointers, short spans, rest data from another set,
  // exact mode on a fast-only set (SphereSet::fast_only: no vertex lists).
  bool Validate() const;
  // Validates, refits every sphere. False on a refused job or non-finite input / output.
  bool Run() const;
  // Validates, refits spheres [begin, end) (end <= set->size(), begin <= end).
  bool RunRange(size_t begin, size_t end) const;
  // Validates once, then refits [0, size) through parallel_for (parallel_for.h; TBB by default) in
  // chunks of >= grain spheres. Output bit-identical to Run().
  bool RunParallel(const ParallelFor& parallel_for = DefaultParallelFor(), size_t grain = 32) const;
};

}  // namespace skinspheres::runtime
