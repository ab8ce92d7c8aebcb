// The engine-facing API: one CharacterAsset per fitted character (shared, read-only), one
// CharacterInstance per character on screen (its own scratch), and a crowd helper.
//
//   auto set = LoadSphereSet("xbot.ssb");                  // set-up: binary or JSON; check set.ok()
//   auto asset = CharacterAsset::Create(std::move(set).value());
//   auto mapping = MapJoints((*asset)->sphere_set(), my_joint_names);  // joint_mapping.h; errors name
//   auto instance = CharacterInstance::Create(*asset, *mapping);       // missing joints and the file
//   each frame:
//     FrameStatus st = instance->UpdateFast(joint_world);   // my joint order; or UpdateExact(skinned, joint_world)
//     if (st.ok()) for (const SpherePair& c : instance->FindSpherePairs()) ...          // sphere pairs (broad phase)
//     if (instance->FindContacts().ok())                                    // triangles (narrow phase)
//       for (const PartContact& p : instance->contacts().parts) ...
//
// CharacterAsset holds the SphereSet, the refit's rest data (RefitRestData: G_j(rest)^-1 applied to
// the centres), the broad phase's PairFilter and, for a set with a mesh (format version 2), the
// narrow phase's data (narrow_phase.h: the contact rules' tables, clusters and patches built at
// set-up for the margin of its NarrowPhaseSettings); immutable after Create, so any number of instances on any threads
// share it through a shared_ptr.
//
// CharacterInstance: refitted spheres (refit_job.h) + the self-collision broad phase
// (broad_phase.h) + the narrow phase (narrow_phase.h). Allocation, in full in docs/EMBEDDING.md:
// Create allocates; per frame, a list grows the first time a frame needs more room than any before
// (ReserveContacts pins them at set-up), the first FindSpherePairs sizes the single query's cache
// and the first FindContacts the narrow phase's scratch (with a margin, also the margin query's)
// unless ReserveSpherePairs or ReserveContacts did, and the first FindContacts without positions its
// skinned-position buffer; nothing else. Per-frame calls never
// throw; they return a FrameStatus whose message is a static string (no allocation). A failed update (non-finite input,
// short spans) marks the instance's spheres invalid, so FindSpherePairs() then returns no contacts and status() says
// why; other instances are untouched. Not thread-safe per instance; distinct instances may run concurrently.
//
// Many instances at once (a crowd): crowd/crowd.h.
#pragma once

#include <Eigen/Core>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <utility>
#include <vector>

#include "skinspheres/runtime/api/joint_mapping.h"
#include "skinspheres/runtime/broad_phase/broad_phase.h"
#include "skinspheres/runtime/broad_phase/pair_filter.h"
#include "skinspheres/runtime/error.h"
#include "skinspheres/runtime/format/sphere_set.h"
#include "skinspheres/runtime/narrow_phase/narrow_phase.h"
#include "skinspheres/runtime/refit/refit_job.h"
#include "skinspheres/skinning/math_types.h"
#include "skinspheres/skinning/parallel_for.h"

namespace skinspheres::runtime {

// Outcome of one per-frame call. message is a static string (never freed, never allocated).
struct FrameStatus {
  ErrorCode code = ErrorCode::kOk;
  const char* message = "";
  bool ok() const { return code == ErrorCode::kOk; }
};

class CharacterAsset {
 public:
  // Validates the set (SphereSet::Validate), inverts the rest transforms, builds the pair filter
  // and, when the set has a mesh, the narrow phase's data with these settings (a set without a mesh
  // is accepted: narrow_phase() is then null and FindContacts refuses). Errors name the set's
  // source file: kInvalidData (inconsistent set, singular rest transform), kInvalidArgument (a
  // negative or non-finite margin).
  static Result<std::shared_ptr<const CharacterAsset>> Create(SphereSet set, const NarrowPhaseSettings& narrow = {});

  // Whether the set was fitted on this character: the same vertex count (source vertex indices)
  // and every joint the runtime reads present by name, in any order (MapJoints, joint_mapping.h:
  // the engine's own list, e.g. a glTF skin's joints without their `Armature` ancestor, matches).
  // std::nullopt when it matches; otherwise kMismatchedAsset with a message naming the loaded set
  // file, the character it was fitted on, and the difference (vertex counts, missing joint names).
  // A match says nothing of the order: unless the list is the set's own, in order, create the
  // instances with MapJoints' mapping so that they read matrices in the list's order.
  std::optional<Error> Matches(std::span<const std::string> joint_names, size_t vertex_count) const;

  const SphereSet& sphere_set() const { return set_; }
  const RefitRestData& rest() const { return rest_; }
  const PairFilter& filter() const { return filter_; }
  // The narrow phase's data; nullptr when the set has no mesh (format version 1).
  const NarrowPhaseData* narrow_phase() const { return narrow_ ? &*narrow_ : nullptr; }
  size_t size() const { return set_.size(); }
  size_t joint_count() const { return set_.joint_count(); }
  size_t source_vertex_count() const { return set_.source_vertex_count; }

 private:
  friend struct CrowdBatch;  // crowd/crowd_batch.cc: the crowd calls' query of several instances at once
  CharacterAsset() = default;
  SphereSet set_;
  RefitRestData rest_;
  PairFilter filter_;
  std::optional<NarrowPhaseData> narrow_;
  // The crowd calls' batched query (runtime/src/crowd/crowd_query.h), for sets of 2 to 1024 spheres
  // (empty otherwise: their instances query one by one): the pairs the filter allows, (i << 16) | j,
  // in groups of one row and one part (crowd_groups_: begin, end, part; crowd_part_count_ parts;
  // crowd_pairs_sorted_ when that order is (i, j)'s), and, for sets of up to 160 spheres, the same
  // pairs sorted (crowd_sorted_pairs_).
  std::vector<uint32_t> crowd_pairs_;
  std::vector<uint32_t> crowd_groups_;
  std::vector<uint32_t> crowd_sorted_pairs_;
  size_t crowd_part_count_ = 0;
  bool crowd_pairs_sorted_ = true;
};

struct CharacterFrameInput;  // crowd/crowd.h

class CharacterInstance {
 public:
  // Sizes the spheres, the sphere-pair list and the joint matrices for the asset (kInvalidArgument
  // for a null asset). Joint matrices are then in the set's joint order (SphereSet::joint_names).
  // Two buffers wait for their first use, so that an instance that never needs them never holds
  // them: the single query's candidate cache (the first FindSpherePairs; a crowd call that queries
  // the instance in a batch does not use it) and the narrow phase's scratch (the first
  // FindContacts). ReserveSpherePairs and ReserveContacts size them up front.
  static Result<CharacterInstance> Create(std::shared_ptr<const CharacterAsset> asset);
  // The same, with joint matrices in the engine's own order (mapping: MapJoints on this asset's
  // set; kInvalidArgument when it was built for another set).
  static Result<CharacterInstance> Create(std::shared_ptr<const CharacterAsset> asset, const JointMapping& mapping);

  // How many joint matrices an update reads: the engine's joint count with a mapping, the set's
  // joint count without.
  size_t joint_input_count() const { return joint_input_count_; }

  // Fast refit from G_j(t), one world matrix per joint (>= joint_input_count()).
  FrameStatus UpdateFast(std::span<const Mat4f> joint_world);
  // Exact refit from skinned positions indexed by source vertex (>= source_vertex_count()), with
  // G_j(t) for the centres (may be empty: box-centre fallback, see refit_job.h).
  FrameStatus UpdateExact(std::span<const Eigen::Vector3f> skinned_positions, std::span<const Mat4f> joint_world);
  // Either of the above by mode (positions ignored in fast mode).
  FrameStatus Update(RefitMode mode, std::span<const Mat4f> joint_world,
                     std::span<const Eigen::Vector3f> skinned_positions);

  // The sphere pairs of the current spheres that overlap (broad_phase.h: i < j sorted, depth,
  // parts). Empty, with status() set, when the last update failed or none ran. The span stays
  // valid until the next FindSpherePairs().
  std::span<const SpherePair> FindSpherePairs();
  std::span<const SpherePair> sphere_pairs() const { return sphere_pairs_; }

  // The narrow phase (narrow_phase.h) behind this frame's sphere pairs (FindSpherePairs() runs first if it
  // has not since the last update). Positions:
  //  - skinned_positions given: mode (a), the positions the spheres were refitted from (UpdateExact's
  //    buffer), or the LBS of the same joint matrices after UpdateFast, with the asset's own skin
  //    weights: the fast spheres bound exactly those (refit_job.h; their radius, reach and group
  //    blends all come from the file's weights), so positions skinned with weights an engine pruned
  //    or re-normalised may lie outside them and their contacts be missed;
  //  - empty: mode (b), the instance skins only the vertices of the spheres it tests, from the
  //    joint matrices of the last update (kInvalidArgument when that update had none).
  // Refused (kVersionMismatch) when the asset has no mesh. parallel_for spreads the sphere pairs
  // over threads (same output); the default runs on the calling thread. Results: contacts(),
  // empty after a failure.
  // With a margin (NarrowPhaseSettings::margin > 0), spheres that do not overlap can hold
  // triangles nearer than it: the narrow phase then tests the pairs of the spheres grown by half
  // the margin (a second broad-phase query, with its own cache), not sphere_pairs().
  FrameStatus FindContacts(std::span<const Eigen::Vector3f> skinned_positions = {},
                           const ParallelFor& parallel_for = SerialFor());
  const FrameContacts& contacts() const { return contacts_; }
  // Counters of the last FindContacts (pairs, culled triangles, tests, skinned vertices).
  const NarrowPhaseContext::Stats& narrow_phase_stats() const { return narrow_context_.last_stats(); }

  // The refitted spheres (xyz centre, w radius), one per asset sphere; meaningful when
  // spheres_valid().
  std::span<const Vec4f> spheres() const { return spheres_; }
  bool spheres_valid() const { return valid_; }
  // Outcome of the last Update*/FindSpherePairs call.
  FrameStatus status() const { return status_; }

  // Room for this many sphere pairs and as many triangle pairs, the single query's cache and (an
  // asset with a mesh) the narrow phase's scratch, so later frames do not allocate (but for the
  // skinned-position buffer of the first FindContacts without positions).
  void ReserveContacts(size_t count);
  // Room for this many sphere pairs (FindSpherePairs' list) and the single query's cache, for an
  // instance that runs only the broad phase: no triangle-pair room and no narrow-phase scratch
  // (about 570 KB for Xbot, which ReserveContacts would size); a later FindContacts still sizes
  // those itself.
  void ReserveSpherePairs(size_t count);
  const CharacterAsset& asset() const { return *asset_; }
  const std::shared_ptr<const CharacterAsset>& shared_asset() const { return asset_; }

 private:
  friend FrameStatus CrowdStep(CharacterInstance&, RefitMode, const CharacterFrameInput&, bool);
  friend struct CrowdBatch;  // crowd/crowd_batch.cc: the crowd calls' refit and query of several instances at once
  CharacterInstance() = default;
  // Update; keep_joints: also keep the joint matrices for FindContacts mode (b) (a copy of one
  // matrix per set joint; the broad-phase-only crowd call skips it).
  FrameStatus Update(RefitMode mode, std::span<const Mat4f> joint_world,
                     std::span<const Eigen::Vector3f> skinned_positions, bool keep_joints);
  // Update in three steps: Prepare checks the inputs and gathers mapped joints (false: status_
  // says why; *job then refits the spheres), the refit runs, Finish records its outcome.
  bool PrepareUpdate(RefitMode mode, std::span<const Mat4f> joint_world,
                     std::span<const Eigen::Vector3f> skinned_positions, RefitJob* job);
  FrameStatus FinishUpdate(bool refit_ok, std::span<const Mat4f> joint_world, bool keep_joints);
  // Sizes context_ for the asset unless it is already.
  void SizeQueryContext();
  // FindContacts with a margin: margin_pairs_, the pairs of the spheres grown by half of it (and a
  // relative 1e-6 more, for the broad phase's float arithmetic). False when the query refuses.
  bool FindMarginPairs(float margin);
  // Sizes the margin query (its cache, grown_, room for `pairs` pairs) unless it is already.
  void SizeMarginQuery(size_t pairs);
  std::shared_ptr<const CharacterAsset> asset_;
  std::vector<Vec4f> spheres_;
  BroadPhaseContext context_;
  std::vector<SpherePair> sphere_pairs_;
  std::vector<Vec4f> grown_;  // FindMarginPairs
  BroadPhaseContext margin_context_;
  std::vector<SpherePair> margin_pairs_;
  // Engine joint order (a JointMapping): per set joint read per frame, the engine joint; the
  // matrices are gathered into joint_world_ (set order, sized at Create) before the refit. It also
  // keeps the last update's G_j(t) in set order for FindContacts mode (b).
  std::vector<std::pair<uint32_t, uint32_t>> gather_;  // (set joint, engine joint)
  std::vector<Mat4f> joint_world_;
  bool mapped_ = false;
  size_t joint_input_count_ = 0;
  bool has_joints_ = false;  // joint_world_ holds the last update's matrices
  bool queried_ = false;     // FindSpherePairs() ran since the last update
  bool query_ok_ = false;    // and succeeded
  NarrowPhaseContext narrow_context_;
  FrameContacts contacts_;
  bool valid_ = false;
  FrameStatus status_{ErrorCode::kInvalidArgument, "no update has run yet"};
};

}  // namespace skinspheres::runtime
