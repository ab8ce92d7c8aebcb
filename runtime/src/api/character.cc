// CharacterAsset / CharacterInstance (api/character.h): set-up allocates and reports Errors; per
// frame only jobs run (RefitJob, BroadPhaseJob, NarrowPhaseJob) and FrameStatus comes back.
#include "skinspheres/runtime/api/character.h"

#include <algorithm>
#include <atomic>
#include <bit>
#include <cmath>
#include <cstdint>
#include <utility>
#include <vector>

#include "crowd/crowd_batch.h"

namespace skinspheres::runtime {

Result<std::shared_ptr<const CharacterAsset>> CharacterAsset::Create(SphereSet set, const NarrowPhaseSettings& narrow) {
  auto rest = RefitRestData::Create(set);
  if (!rest.ok()) return rest.error();
  auto filter = PairFilter::FromSphereSet(set);
  if (!filter.ok()) return filter.error();
  std::shared_ptr<CharacterAsset> asset(new CharacterAsset());
  if (set.has_mesh()) {
    auto data = NarrowPhaseData::Create(set, *filter, narrow);
    if (!data.ok()) return data.error();
    asset->narrow_ = std::move(data).value();
  } else if (!(narrow.margin >= 0.0f) || !std::isfinite(narrow.margin)) {
    return MakeError(ErrorCode::kInvalidArgument,
                     "sphere set '" + set.source_file + "': the narrow-phase margin must be finite and >= 0");
  }
  asset->set_ = std::move(set);
  asset->rest_ = std::move(rest).value();
  asset->filter_ = std::move(filter).value();
  CrowdBatch::ListPairs(asset.get());
  return std::shared_ptr<const CharacterAsset>(std::move(asset));
}

std::optional<Error> CharacterAsset::Matches(std::span<const std::string> joint_names, size_t vertex_count) const {
  if (vertex_count != set_.source_vertex_count) {
    return MakeError(ErrorCode::kMismatchedAsset, DescribeSphereSet(set_) + " was fitted on " +
                                                      std::to_string(set_.source_vertex_count) +
                                                      " vertices, the character has " + std::to_string(vertex_count));
  }
  auto mapping = MapJoints(set_, joint_names);
  if (!mapping.ok()) return mapping.error();
  return std::nullopt;
}

Result<CharacterInstance> CharacterInstance::Create(std::shared_ptr<const CharacterAsset> asset) {
  if (!asset) return MakeError(ErrorCode::kInvalidArgument, "CharacterInstance: null asset");
  CharacterInstance inst;
  const size_t n = asset->size();
  inst.spheres_.assign(n, Vec4f::Zero());
  // The single query's candidate cache (BroadPhaseContext: about 16 KB for Xbot's 77 spheres) is
  // sized by the first FindSpherePairs, or by ReserveSpherePairs / ReserveContacts: an instance the
  // crowd calls only ever query in a batch never holds it.
  inst.sphere_pairs_.reserve(std::max<size_t>(64, 4 * n));
  inst.joint_world_.assign(asset->joint_count(), Mat4f::Identity());
  inst.joint_input_count_ = asset->joint_count();
  // The narrow phase's buffers (a few hundred KB for a large mesh) are sized by the first
  // FindContacts: an instance that only runs the broad phase (a crowd, most of a frame's
  // characters) never holds them.
  inst.asset_ = std::move(asset);
  return inst;
}

Result<CharacterInstance> CharacterInstance::Create(std::shared_ptr<const CharacterAsset> asset,
                                                    const JointMapping& mapping) {
  auto created = Create(std::move(asset));
  if (!created.ok()) return created;
  CharacterInstance& inst = *created;
  const SphereSet& set = inst.asset_->sphere_set();
  const std::vector<bool> read = JointsReadPerFrame(set);
  if (mapping.engine_index.size() != set.joint_count()) {
    return MakeError(ErrorCode::kInvalidArgument, DescribeSphereSet(set) +
                                                      ": the joint mapping was made for a set of " +
                                                      std::to_string(mapping.engine_index.size()) + " joints, not " +
                                                      std::to_string(set.joint_count()));
  }
  for (size_t j = 0; j < read.size(); ++j) {
    const int32_t e = mapping.engine_index[j];
    if (e != JointMapping::kUnmapped && (e < 0 || static_cast<size_t>(e) >= mapping.engine_joint_count)) {
      return MakeError(ErrorCode::kInvalidArgument, DescribeSphereSet(set) + ": the joint mapping sends joint '" +
                                                        set.joint_names[j] + "' past the engine's joints");
    }
    if (!read[j]) continue;
    if (e == JointMapping::kUnmapped) {
      return MakeError(ErrorCode::kInvalidArgument, DescribeSphereSet(set) + ": the joint mapping leaves joint '" +
                                                        set.joint_names[j] +
                                                        "' unmapped, and the spheres move with it");
    }
    inst.gather_.emplace_back(static_cast<uint32_t>(j), static_cast<uint32_t>(e));
  }
  inst.joint_world_.assign(set.joint_count(), Mat4f::Identity());  // joints never read stay identity
  inst.joint_input_count_ = mapping.engine_joint_count;
  inst.mapped_ = true;
  return created;
}

FrameStatus CharacterInstance::Update(RefitMode mode, std::span<const Mat4f> joint_world,
                                      std::span<const Eigen::Vector3f> skinned_positions) {
  return Update(mode, joint_world, skinned_positions, /*keep_joints=*/true);
}

FrameStatus CharacterInstance::Update(RefitMode mode, std::span<const Mat4f> joint_world,
                                      std::span<const Eigen::Vector3f> skinned_positions, bool keep_joints) {
  RefitJob job;
  if (!PrepareUpdate(mode, joint_world, skinned_positions, &job)) return status_;
  return FinishUpdate(job.Run(), job.joint_world, keep_joints);
}

bool CharacterInstance::PrepareUpdate(RefitMode mode, std::span<const Mat4f> joint_world,
                                      std::span<const Eigen::Vector3f> skinned_positions, RefitJob* job) {
  valid_ = false;
  queried_ = false;
  has_joints_ = false;
  contacts_.clear();
  const SphereSet& set = asset_->sphere_set();
  if (mode != RefitMode::kExact && mode != RefitMode::kFast) {
    status_ = {ErrorCode::kInvalidArgument, "unknown refit mode"};
    return false;
  }
  if (mode == RefitMode::kExact && set.fast_only) {
    status_ = {ErrorCode::kInvalidArgument, "exact mode needs the full sphere set; this one was loaded fast-only"};
    return false;
  }
  if (mapped_ && !joint_world.empty()) {  // engine joint order: gather the joints the refit reads
    if (joint_world.size() < joint_input_count_) {
      status_ = {ErrorCode::kInvalidArgument, "fewer joint matrices than the engine joints the mapping was made for"};
      return false;
    }
    for (const auto& [set_joint, engine_joint] : gather_) joint_world_[set_joint] = joint_world[engine_joint];
    joint_world = joint_world_;
  }
  if (mode == RefitMode::kFast || !joint_world.empty()) {
    if (joint_world.size() < set.joint_count()) {
      status_ = {ErrorCode::kInvalidArgument, "fewer joint matrices than the asset's joints"};
      return false;
    }
  }
  if (mode == RefitMode::kExact && skinned_positions.size() < set.source_vertex_count) {
    status_ = {ErrorCode::kInvalidArgument, "fewer skinned positions than the asset's source vertices"};
    return false;
  }
  job->mode = mode;
  job->set = &set;
  job->rest = &asset_->rest();
  job->joint_world = joint_world;
  job->positions = mode == RefitMode::kExact ? skinned_positions : std::span<const Eigen::Vector3f>();
  job->out = spheres_;
  if (!job->Validate()) {
    status_ = {ErrorCode::kInvalidArgument, "refit job refused (inconsistent asset or inputs)"};
    return false;
  }
  return true;
}

FrameStatus CharacterInstance::FinishUpdate(bool refit_ok, std::span<const Mat4f> joint_world, bool keep_joints) {
  if (!refit_ok) {
    status_ = {ErrorCode::kInvalidData, "non-finite joint matrix or skinned position: spheres not updated"};
    return status_;
  }
  valid_ = true;
  if (keep_joints && !joint_world.empty()) {  // kept (set order) for FindContacts mode (b); already there when gathered
    if (joint_world.data() != joint_world_.data())
      std::copy_n(joint_world.begin(), joint_world_.size(), joint_world_.begin());
    has_joints_ = true;
  }
  status_ = {};
  return status_;
}

FrameStatus CharacterInstance::UpdateFast(std::span<const Mat4f> joint_world) {
  return Update(RefitMode::kFast, joint_world, {});
}

FrameStatus CharacterInstance::UpdateExact(std::span<const Eigen::Vector3f> skinned_positions,
                                           std::span<const Mat4f> joint_world) {
  return Update(RefitMode::kExact, joint_world, skinned_positions);
}

std::span<const SpherePair> CharacterInstance::FindSpherePairs() {
  sphere_pairs_.clear();
  queried_ = true;
  query_ok_ = false;
  if (!valid_) {
    if (status_.ok()) status_ = {ErrorCode::kInvalidArgument, "no valid spheres to query"};
    return {};
  }
  SizeQueryContext();  // first call: warm-up allocation (Create says why)
  BroadPhaseJob job;
  job.spheres = spheres_;
  job.filter = &asset_->filter();
  job.context = &context_;
  job.out = &sphere_pairs_;
  if (!job.Run()) {
    sphere_pairs_.clear();
    status_ = {ErrorCode::kInvalidData, "broad phase refused the spheres"};
    return {};
  }
  query_ok_ = true;
  status_ = {};
  return sphere_pairs_;
}

FrameStatus CharacterInstance::FindContacts(std::span<const Eigen::Vector3f> skinned_positions,
                                            const ParallelFor& parallel_for) {
  contacts_.clear();
  const NarrowPhaseData* data = asset_->narrow_phase();
  if (data == nullptr) {
    status_ = {ErrorCode::kVersionMismatch,
               "the sphere set has no mesh (format version 1, or a fast-only file): no narrow phase"};
    return status_;
  }
  if (!queried_) FindSpherePairs();
  if (!valid_) {
    status_ = {ErrorCode::kInvalidArgument, "no valid spheres to find contacts for"};
    return status_;
  }
  if (!query_ok_) {
    status_ = {ErrorCode::kInvalidData, "broad phase refused the spheres"};
    return status_;
  }
  if (skinned_positions.empty() && !has_joints_) {
    status_ = {ErrorCode::kInvalidArgument,
               "no skinned positions, and the last update kept no joint matrices (it had none, or was an "
               "CrowdUpdateAndFindSpherePairs)"};
    return status_;
  }
  if (!skinned_positions.empty() && skinned_positions.size() < asset_->source_vertex_count()) {
    status_ = {ErrorCode::kInvalidArgument, "fewer skinned positions than the asset's source vertices"};
    return status_;
  }
  if (!narrow_context_.sized_for(*data)) {  // first call: warm-up allocation (Create says why)
    narrow_context_.Resize(*data, /*lazy_skinning=*/skinned_positions.empty());
    contacts_.Reserve(std::max<size_t>(64, 4 * asset_->size()));
  }
  std::span<const SpherePair> pairs = sphere_pairs_;
  if (data->margin() > 0.0f) {
    if (!FindMarginPairs(data->margin())) {
      contacts_.clear();
      status_ = {ErrorCode::kInvalidData, "broad phase refused the spheres grown by the margin"};
      return status_;
    }
    pairs = margin_pairs_;
  }
  NarrowPhaseJob job;
  job.set = &asset_->sphere_set();
  job.data = data;
  job.spheres = spheres_;
  job.pairs = pairs;
  job.positions = skinned_positions;
  // Mode (b) skins from them; mode (a) bounds the motion since rest with them (narrow_phase.h).
  job.joint_world = has_joints_ ? std::span<const Mat4f>(joint_world_) : std::span<const Mat4f>();
  job.context = &narrow_context_;
  job.out = &contacts_;
  if (!job.RunParallel(parallel_for)) {
    contacts_.clear();
    status_ = {ErrorCode::kInvalidData, "narrow phase refused the frame (non-finite positions or joint matrices)"};
    return status_;
  }
  status_ = {};
  return status_;
}

bool CharacterInstance::FindMarginPairs(float margin) {
  SizeMarginQuery(std::max(sphere_pairs_.capacity(), 4 * asset_->size()));  // first call: warm-up allocation
  for (size_t s = 0; s < spheres_.size(); ++s) {
    grown_[s] = spheres_[s];
    grown_[s].w() = std::nextafter((spheres_[s].w() + 0.5f * margin) * (1.0f + 1e-6f), INFINITY);
  }
  margin_pairs_.clear();
  BroadPhaseJob job;
  job.spheres = std::span<const Vec4f>(grown_.data(), spheres_.size());
  job.filter = &asset_->filter();
  job.context = &margin_context_;
  job.out = &margin_pairs_;
  return job.Run();
}

void CharacterInstance::SizeMarginQuery(size_t pairs) {
  if (margin_context_.max_spheres() < asset_->size()) {
    margin_context_.Resize(asset_->size());
    grown_.resize(asset_->size());
  }
  if (margin_pairs_.capacity() < pairs) margin_pairs_.reserve(pairs);
}

void CharacterInstance::SizeQueryContext() {
  if (context_.max_candidates() == 0 || context_.max_spheres() < asset_->size()) context_.Resize(asset_->size());
}

void CharacterInstance::ReserveContacts(size_t count) {
  SizeQueryContext();
  sphere_pairs_.reserve(count);
  contacts_.Reserve(count);
  if (const NarrowPhaseData* data = asset_->narrow_phase(); data != nullptr && !narrow_context_.sized_for(*data)) {
    narrow_context_.Resize(*data, /*lazy_skinning=*/false);
  }
  narrow_context_.Reserve(count);
  if (const NarrowPhaseData* data = asset_->narrow_phase(); data != nullptr && data->margin() > 0.0f) {
    SizeMarginQuery(count);
  }
}

void CharacterInstance::ReserveSpherePairs(size_t count) {
  SizeQueryContext();
  sphere_pairs_.reserve(count);
}

}  // namespace skinspheres::runtime
