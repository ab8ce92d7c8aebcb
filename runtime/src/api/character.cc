// CharacterAsset / CharacterInstance / UpdateAndQueryCrowd (character.h): set-up allocates and
// reports Errors; per frame only jobs run (RefitJob, SelfCollisionJob, NarrowPhaseJob) and
// FrameStatus comes back.
#include "skinspheres/runtime/api/character.h"


#include <algorithm>
#include <atomic>
#include <bit>
#include <cmath>
#include <cstdint>
#include <utility>
#include <vector>

#include "broad_phase/sphere_test.h"
#include "crowd/crowd_query.h"
#include "refit/refit_internal.h"

namespace skinspheres::runtime {
namespace {

// Sets of up to this many spheres are queried 16 instances at a time in the crowd calls (all the
// allowed pairs of 16 instances in one vector test each); larger sets query one by one, where the
// candidate cache tests far fewer pairs than all of them.
constexpr size_t kCrowdQueryMaxSpheres = 256;

std::atomic<bool> crowd_query_batched{true};
thread_local uint64_t batched_queries = 0;  // batches queried at once on this thread (tests)

std::vector<uint32_t> CrowdPairs(const PairFilter& filter) {
  std::vector<uint32_t> pairs;
  const size_t n = filter.size();
  if (n < 2 || n > kCrowdQueryMaxSpheres) return pairs;
  for (uint32_t i = 0; i < n; ++i) {
    for (uint32_t j = i + 1; j < n; ++j) {
      if (!filter.excluded(i, j)) pairs.push_back(i << 16 | j);
    }
  }
  return pairs;
}

}  // namespace

namespace internal {
void SetCrowdQueryBatched(bool batched) { crowd_query_batched.store(batched, std::memory_order_relaxed); }
bool CrowdQueryBatched() { return crowd_query_batched.load(std::memory_order_relaxed); }
uint64_t CrowdQueryBatches() { return batched_queries; }
}  // namespace internal

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
    return MakeError(ErrorCode::kInvalidArgument, "sphere set '" + set.source_file + "': the narrow-phase margin must be finite and >= 0");
  }
  asset->set_ = std::move(set);
  asset->rest_ = std::move(rest).value();
  asset->filter_ = std::move(filter).value();
  asset->crowd_pairs_ = CrowdPairs(asset->filter_);
  return std::shared_ptr<const CharacterAsset>(std::move(asset));
}

std::optional<Error> CharacterAsset::Matches(std::span<const std::string> joint_names, size_t vertex_count) const {
  if (vertex_count != set_.source_vertex_count) {
    return MakeError(ErrorCode::kMismatchedAsset, DescribeSphereSet(set_) + " was fitted on " +
                                                      std::to_string(set_.source_vertex_count) + " vertices, the character has " +
                                                      std::to_string(vertex_count));
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
  inst.context_.Resize(n);
  inst.contacts_.reserve(std::max<size_t>(64, 4 * n));
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
    return MakeError(ErrorCode::kInvalidArgument, DescribeSphereSet(set) + ": the joint mapping was made for a set of " +
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
                                                        set.joint_names[j] + "' unmapped, and the spheres move with it");
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
  frame_contacts_.clear();
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
  job->spheres = &set;
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
    if (joint_world.data() != joint_world_.data()) std::copy_n(joint_world.begin(), joint_world_.size(), joint_world_.begin());
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

std::span<const Contact> CharacterInstance::Query() {
  contacts_.clear();
  queried_ = true;
  query_ok_ = false;
  if (!valid_) {
    if (status_.ok()) status_ = {ErrorCode::kInvalidArgument, "no valid spheres to query"};
    return {};
  }
  SelfCollisionJob job;
  job.spheres = spheres_;
  job.filter = &asset_->filter();
  job.context = &context_;
  job.out = &contacts_;
  if (!job.Run()) {
    contacts_.clear();
    status_ = {ErrorCode::kInvalidData, "broad phase refused the spheres"};
    return {};
  }
  query_ok_ = true;
  status_ = {};
  return contacts_;
}

FrameStatus CharacterInstance::FindContacts(std::span<const Eigen::Vector3f> skinned_positions,
                                            const ParallelFor& parallel_for) {
  frame_contacts_.clear();
  const NarrowPhaseData* data = asset_->narrow_phase();
  if (data == nullptr) {
    status_ = {ErrorCode::kVersionMismatch, "the sphere set has no mesh (format version 1, or a fast-only file): no narrow phase"};
    return status_;
  }
  if (!queried_) Query();
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
               "UpdateAndQueryCrowd)"};
    return status_;
  }
  if (!skinned_positions.empty() && skinned_positions.size() < asset_->source_vertex_count()) {
    status_ = {ErrorCode::kInvalidArgument, "fewer skinned positions than the asset's source vertices"};
    return status_;
  }
  if (!narrow_context_.sized_for(*data)) {  // first call: warm-up allocation (Create says why)
    narrow_context_.Resize(*data, /*lazy_skinning=*/skinned_positions.empty());
    frame_contacts_.Reserve(std::max<size_t>(64, 4 * asset_->size()));
  }
  NarrowPhaseJob job;
  job.set = &asset_->sphere_set();
  job.data = data;
  job.spheres = spheres_;
  job.pairs = contacts_;
  job.positions = skinned_positions;
  job.joint_world = skinned_positions.empty() ? std::span<const Mat4f>(joint_world_) : std::span<const Mat4f>();
  job.context = &narrow_context_;
  job.out = &frame_contacts_;
  if (!job.RunParallel(parallel_for)) {
    frame_contacts_.clear();
    status_ = {ErrorCode::kInvalidData, "narrow phase refused the frame (non-finite positions or joint matrices)"};
    return status_;
  }
  status_ = {};
  return status_;
}

void CharacterInstance::ReserveContacts(size_t count) {
  contacts_.reserve(count);
  frame_contacts_.Reserve(count);
  if (const NarrowPhaseData* data = asset_->narrow_phase(); data != nullptr && !narrow_context_.sized_for(*data)) {
    narrow_context_.Resize(*data, /*lazy_skinning=*/false);
  }
}

void CharacterInstance::ReserveSphereContacts(size_t count) { contacts_.reserve(count); }

// The crowd calls' fast refit of up to kRefitBatchLanes instances of one asset at once (one per
// AVX-512 lane, the same bits as each alone: refit_internal.h), then their broad phase at once too
// when the asset is small enough (crowd/crowd_query.h: the same contacts as each alone), else each
// instance's query; then each one's narrow phase if asked.
struct CrowdBatch {
  static constexpr size_t kLanes = internal::kRefitBatchLanes;

  static FrameStatus AfterUpdate(CharacterInstance& inst, RefitMode mode, const CharacterFrameInput& input,
                                 bool find_contacts) {
    inst.Query();
    return AfterQuery(inst, mode, input, find_contacts);
  }

  static FrameStatus AfterQuery(CharacterInstance& inst, RefitMode mode, const CharacterFrameInput& input,
                                bool find_contacts) {
    if (inst.status().ok() && find_contacts) {
      inst.FindContacts(mode == RefitMode::kExact ? input.skinned_positions : std::span<const Eigen::Vector3f>());
    }
    return inst.status();
  }

  // The batch's spheres lanes side by side (RefitFastBatch's soa), per thread: room for the largest
  // set batched, 64-byte aligned (each lane vector one cache line), made by the thread's first batch
  // and kept for its life (not on the stack: engines run jobs on small stacks).
  static float* SoaScratch() {
    constexpr size_t kAlign = 64 / sizeof(float);
    thread_local std::vector<float> soa(kCrowdQueryMaxSpheres * internal::kBatchSphereFloats + kAlign);
    const uintptr_t address = reinterpret_cast<uintptr_t>(soa.data());
    return soa.data() + ((64 - address % 64) % 64) / sizeof(float);
  }

  // Query of the instances in `lanes` at once: what Query() gives each, from soa. Lanes whose
  // spheres the broad phase would refuse (beyond kMaxMagnitude) are left out of the returned mask,
  // for their own Query() to report.
  static uint32_t QueryBatch(const CharacterAsset& asset, const float* soa, uint32_t lanes,
                             CharacterInstance* const inst[kLanes]) {
#if !defined(SKINSPHERES_X86_64)
    (void)asset, (void)soa, (void)lanes, (void)inst;
    return 0;  // never called: the batch runs only on AVX-512F (RefitBatchUsable)
#else
    lanes &= internal::avx512::BatchValuesOk(soa, asset.size(), internal::kMaxMagnitude);
    if (lanes == 0) return 0;
    for (uint32_t m = lanes; m != 0; m &= m - 1) inst[std::countr_zero(m)]->contacts_.clear();
    constexpr size_t kHits = 16;
    alignas(64) float depth[kLanes * kHits];
    uint32_t pair[kHits];
    uint16_t mask[kHits];
    internal::BatchHits hits{pair, mask, depth, kHits, 0};
    const uint32_t* pairs = asset.crowd_pairs_.data();
    const size_t count = asset.crowd_pairs_.size();
    const PairFilter& filter = asset.filter();
    for (size_t pos = 0; pos < count;) {
      hits.count = 0;
      pos = internal::avx512::BatchTestPairs(soa, pairs, pos, count, lanes, &hits);
      for (size_t h = 0; h < hits.count; ++h) {
        const uint32_t i = pair[h] >> 16, j = pair[h] & 0xFFFFu;
        const uint16_t part_i = filter.part(i), part_j = filter.part(j);
        for (uint32_t m = mask[h]; m != 0; m &= m - 1) {
          const int b = std::countr_zero(m);
          inst[b]->contacts_.push_back(Contact{i, j, depth[kLanes * h + b], part_i, part_j});
        }
      }
    }
    for (uint32_t m = lanes; m != 0; m &= m - 1) {
      CharacterInstance& one = *inst[std::countr_zero(m)];
      one.queried_ = true;
      one.query_ok_ = true;
      one.status_ = {};
      // The cache stays exact without this (its check is against its own build), but its motion
      // statistics (frames since the build) would be wrong: a query alone then starts afresh.
      one.context_.Invalidate();
    }
    ++batched_queries;
    return lanes;
#endif
  }

  // Instances [begin, end) with their inputs; true when all succeeded. In fast mode, with AVX-512F,
  // consecutive instances of one asset are refitted together; the others one by one (CrowdStep).
  static bool Run(std::span<CharacterInstance* const> instances, std::span<const CharacterFrameInput> inputs,
                  RefitMode mode, bool find_contacts, size_t begin, size_t end) {
    bool all_ok = true;
    for (size_t i = begin; i < end;) {
      const CharacterAsset* asset = instances[i]->asset_.get();
      size_t last = i + 1;  // the run of instances of this asset, at most kLanes, none listed twice
      while (last < end && last - i < kLanes && instances[last]->asset_.get() == asset &&
             std::find(instances.begin() + i, instances.begin() + last, instances[last]) == instances.begin() + last) {
        ++last;
      }
      if (mode != RefitMode::kFast || last - i < 2 || !internal::RefitBatchUsable()) {
        for (; i < last; ++i) all_ok &= CrowdStep(*instances[i], mode, inputs[i], find_contacts).ok();
        continue;
      }
      // Check each instance's inputs as Update does; the ones refused drop out of the batch.
      RefitJob jobs[kLanes];
      bool prepared[kLanes] = {};
      size_t lane_of[kLanes];
      const float* world[kLanes];
      float* out[kLanes];
      CharacterInstance* lane_inst[kLanes];
      size_t lanes = 0;
      for (size_t k = i; k < last; ++k) {
        CharacterInstance& inst = *instances[k];
        RefitJob& job = jobs[k - i];
        if (!inst.PrepareUpdate(mode, inputs[k].joint_world, inputs[k].skinned_positions, &job)) {
          all_ok = false;
          continue;
        }
        prepared[k - i] = true;
        lane_of[k - i] = lanes;
        world[lanes] = reinterpret_cast<const float*>(job.joint_world.data());
        out[lanes] = reinterpret_cast<float*>(job.out.data());
        lane_inst[lanes] = &inst;
        ++lanes;
      }
      uint32_t finite = 0;
      float* soa = nullptr;
      if (lanes > 0) {
        for (size_t b = lanes; b < kLanes; ++b) {  // idle lanes repeat the first (same bits, written twice)
          world[b] = world[0];
          out[b] = out[0];
        }
        if (!asset->crowd_pairs_.empty() && internal::CrowdQueryBatched()) soa = SoaScratch();
        finite = internal::RefitFastBatch(asset->sphere_set(), asset->rest(), world, out, soa);
      }
      uint32_t updated = 0;  // lanes refitted and recorded
      for (size_t k = i; k < last; ++k) {
        if (!prepared[k - i]) continue;  // refused: status_ says why
        const bool ok = (finite >> lane_of[k - i]) & 1u;
        if (!instances[k]->FinishUpdate(ok, jobs[k - i].joint_world, /*keep_joints=*/find_contacts).ok()) {
          all_ok = false;
          continue;
        }
        updated |= 1u << lane_of[k - i];
      }
      const uint32_t queried = soa != nullptr && updated != 0 ? QueryBatch(*asset, soa, updated, lane_inst) : 0;
      for (size_t k = i; k < last; ++k) {
        if (!prepared[k - i] || !((updated >> lane_of[k - i]) & 1u)) continue;
        CharacterInstance& inst = *instances[k];
        const bool done = (queried >> lane_of[k - i]) & 1u;
        all_ok &= (done ? AfterQuery(inst, mode, inputs[k], find_contacts)
                        : AfterUpdate(inst, mode, inputs[k], find_contacts))
                      .ok();
      }
      i = last;
    }
    return all_ok;
  }
};

FrameStatus CrowdStep(CharacterInstance& inst, RefitMode mode, const CharacterFrameInput& input, bool find_contacts) {
  const FrameStatus st = inst.Update(mode, input.joint_world, input.skinned_positions, /*keep_joints=*/find_contacts);
  if (!st.ok()) return st;
  return CrowdBatch::AfterUpdate(inst, mode, input, find_contacts);
}

namespace {

// The caller errors of the crowd calls: spans of different sizes, a null instance.
FrameStatus CheckCrowd(std::span<CharacterInstance* const> instances, std::span<const CharacterFrameInput> inputs) {
  if (instances.size() != inputs.size()) {
    return {ErrorCode::kInvalidArgument, "instances and inputs differ in count"};
  }
  for (CharacterInstance* inst : instances) {
    if (inst == nullptr) return {ErrorCode::kInvalidArgument, "null instance"};
  }
  return {};
}

constexpr FrameStatus kSomeFailed{ErrorCode::kInvalidData, "at least one instance failed; see its status()"};

// Update + Query (+ FindContacts) of every instance through parallel_for, each range as CrowdRange.
FrameStatus RunCrowd(std::span<CharacterInstance* const> instances, std::span<const CharacterFrameInput> inputs,
                     RefitMode mode, bool find_contacts, const ParallelFor& parallel_for) {
  if (const FrameStatus st = CheckCrowd(instances, inputs); !st.ok()) return st;
  std::atomic<bool> all_ok{true};
  // Blocks of CrowdBlock instances: no range the loop hands out cuts a batch short (a range of 8
  // instances would fill half the lanes).
  const size_t block = CrowdBlock(mode, find_contacts);
  const size_t count = instances.size();
  parallel_for((count + block - 1) / block, 1, [&](size_t begin, size_t end) {
    if (!CrowdBatch::Run(instances, inputs, mode, find_contacts, begin * block, std::min(end * block, count))) {
      all_ok.store(false, std::memory_order_relaxed);
    }
  });
  if (!all_ok.load()) return kSomeFailed;
  return {};
}

}  // namespace

size_t CrowdBlock(RefitMode mode, bool find_contacts) {
  return mode == RefitMode::kFast && !find_contacts && internal::RefitBatchUsable() ? CrowdBatch::kLanes : 1;
}

FrameStatus CrowdRange(std::span<CharacterInstance* const> instances, std::span<const CharacterFrameInput> inputs,
                       RefitMode mode, bool find_contacts) {
  if (const FrameStatus st = CheckCrowd(instances, inputs); !st.ok()) return st;
  if (!CrowdBatch::Run(instances, inputs, mode, find_contacts, 0, instances.size())) return kSomeFailed;
  return {};
}

FrameStatus UpdateAndQueryCrowd(std::span<CharacterInstance* const> instances,
                                std::span<const CharacterFrameInput> inputs, RefitMode mode,
                                const ParallelFor& parallel_for) {
  return RunCrowd(instances, inputs, mode, /*find_contacts=*/false, parallel_for);
}

FrameStatus UpdateAndFindContactsCrowd(std::span<CharacterInstance* const> instances,
                                       std::span<const CharacterFrameInput> inputs, RefitMode mode,
                                       const ParallelFor& parallel_for) {
  return RunCrowd(instances, inputs, mode, /*find_contacts=*/true, parallel_for);
}

}  // namespace skinspheres::runtime
