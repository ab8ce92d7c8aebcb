// Crowds: Update + FindSpherePairs (+ FindContacts) for many CharacterInstances (api/character.h) at once,
// through a ParallelFor (parallel_for.h: TBB by default, or the engine's job system), or in an
// engine's own loop (CrowdRange). Takes the instances and one CharacterFrameInput each; gives each
// instance updated and queried (its status() set) and a FrameStatus for the whole call. Every
// instance's spheres and sphere pairs are identical to running it alone, serially.
//
// Fast mode: consecutive instances of one asset are refitted, and (an asset of up to 1024 spheres)
// queried, several at a time, one per vector lane (runtime/src/crowd/): 16 on a CPU with AVX-512F,
// 8 with AVX2, 4 otherwise (SSE2, and every other platform), with the bits each gets alone.
#pragma once

#include <Eigen/Core>
#include <cstddef>
#include <span>

#include "skinspheres/runtime/api/character.h"
#include "skinspheres/skinning/math_types.h"
#include "skinspheres/skinning/parallel_for.h"

namespace skinspheres::runtime {

// One frame's input for one instance (see CharacterInstance::Update).
struct CharacterFrameInput {
  std::span<const Mat4f> joint_world;
  std::span<const Eigen::Vector3f> skinned_positions;  // exact mode only
};

// One instance's step of the crowd calls below, for an engine that writes its own crowd loop:
// Update(mode, input), then FindSpherePairs(), then, when find_contacts, FindContacts (mode (a) with the
// input's positions in exact mode, mode (b) in fast mode). Without find_contacts the joint
// matrices are not kept for a later FindContacts without positions (see below). The instance's
// status() after the step, kOk or why it failed.
FrameStatus CrowdStep(CharacterInstance& instance, RefitMode mode, const CharacterFrameInput& input,
                      bool find_contacts);

// CrowdStep for instances[i] with inputs[i], one after the other on the calling thread, except
// that consecutive instances of one asset are refitted, and (an asset of up to 1024 spheres)
// queried, together in fast mode: 16, 8 or 4 at a time, one per vector lane, by the widest the CPU
// has (AVX-512F, AVX2, else SSE2 or any other platform; each gets the spheres and sphere pairs it
// gets alone, bit for bit; faster per instance than one at a time). The batched query tests the
// asset's allowed pairs between spheres and body parts whose boxes meet in some instance of the
// batch; it resets each instance's candidate cache (BroadPhaseContext::Invalidate), whose motion
// statistics it does not keep, so a later query alone rebuilds it (and gives exact sphere pairs
// either way). The batch's spheres and its parts' boxes go to per-thread buffers (64-byte aligned;
// 16 lanes: 256 bytes a sphere, 384 bytes a part), grown by the first batch that needs more and
// kept for the thread's life.
// What the crowd calls below run on each range their parallel_for hands out; for an engine that runs its own loop, give
// it ranges of instances ordered by asset, in multiples of 16. An instance listed twice in one range is updated twice,
// in order, as CrowdStep would. Returns kInvalidArgument (and runs nothing) when the spans differ in size or a pointer
// is null; kInvalidData when at least one instance failed (its status() says why); kOk.
FrameStatus CrowdRange(std::span<CharacterInstance* const> instances, std::span<const CharacterFrameInput> inputs,
                       RefitMode mode, bool find_contacts);

// How many consecutive instances the crowd calls below give each index of their parallel_for: the
// batch's width (16, 8 or 4, as above) for a broad-phase-only crowd in fast mode, so that no range
// cuts a batch short; 1 otherwise (the narrow phase's work per instance outweighs the batch's gain).
size_t CrowdBlock(RefitMode mode, bool find_contacts);

// Update(mode, input) then FindSpherePairs() for instances[i] with inputs[i], in parallel (parallel_for over
// blocks of CrowdBlock instances; each range it hands out runs as CrowdRange, so instances ordered
// by asset batch). It
// does not keep the joint matrices for FindContacts mode (b) (a copy of every joint's matrix per
// instance and frame, a tenth of a 10,000-character crowd's frame): a FindContacts without
// positions after it is refused until the next Update, UpdateFast or CrowdUpdateAndFindContacts.
// Returns kInvalidArgument (and runs nothing) when the spans differ in size or an instance pointer
// is null (listing the same instance twice is a data race the caller
// must avoid); kInvalidData when at least one instance failed (each instance's
// status() says why; the others are fully updated); kOk otherwise.
FrameStatus CrowdUpdateAndFindSpherePairs(std::span<CharacterInstance* const> instances,
                                          std::span<const CharacterFrameInput> inputs, RefitMode mode,
                                          const ParallelFor& parallel_for = DefaultParallelFor());

// The same, then FindContacts for every instance: mode (a) with the input's skinned positions in
// exact mode, mode (b) (lazy skinning from the joint matrices) in fast mode. Each instance's
// narrow phase runs on the thread that updates it. kInvalidData also when an instance's asset has
// no mesh (its status() says so).
FrameStatus CrowdUpdateAndFindContacts(std::span<CharacterInstance* const> instances,
                                       std::span<const CharacterFrameInput> inputs, RefitMode mode,
                                       const ParallelFor& parallel_for = DefaultParallelFor());

}  // namespace skinspheres::runtime
