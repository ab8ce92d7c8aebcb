// The C API's crowds (skinspheres/skinspheres.h): many instances updated and queried in one call.
#include "capi_internal.h"

namespace {

using namespace skinspheres::capi;

// A crowd input as the runtime reads it (the strided one copied into the instance's buffers; its
// positions only in exact mode, the only one that reads them).
rt::CharacterFrameInput FrameInput(skinspheres_instance& inst, const skinspheres_frame_input& in, rt::RefitMode) {
  return {Joints(inst, in.joint_world, in.joint_count, nullptr),
          Positions(inst, in.positions, in.vertex_count, kPackedPositionStride)};
}
rt::CharacterFrameInput FrameInput(skinspheres_instance& inst, const skinspheres_frame_input_strided& in,
                                   rt::RefitMode mode) {
  const float* positions = mode == rt::RefitMode::kExact ? in.positions : nullptr;
  return {Joints(inst, in.joint_world, in.joint_count, in.joint_layout),
          Positions(inst, positions, in.vertex_count, in.position_stride)};
}
void SizeGather(skinspheres_instance&, const skinspheres_frame_input&, rt::RefitMode) {}
void SizeGather(skinspheres_instance& inst, const skinspheres_frame_input_strided& in, rt::RefitMode mode) {
  skinspheres::capi::SizeGather(inst, in.joint_layout, mode == rt::RefitMode::kExact ? in.positions : nullptr,
                                in.position_stride);
}

template <typename Input>
struct CrowdWork {
  skinspheres_instance* const* instances;
  const Input* inputs;
  rt::RefitMode mode;
  bool find_contacts;              // then the narrow phase (skinspheres_crowd_update_and_find_contacts)
  size_t count;                    // instances
  size_t block;                    // instances per index of the parallel loop (16 or 1)
  std::atomic<bool> all_ok{true};  // set to false by any thread; read after the loop
};

// The range in blocks of 16 through rt::CrowdRange (consecutive instances of one asset refitted
// together when the CPU has AVX-512F), the C inputs converted on the stack.
template <typename Input>
void RunCrowdRange(CrowdWork<Input>* work, size_t begin, size_t end) {
  constexpr size_t kBlock = 16;
  for (size_t first = begin; first < end; first += kBlock) {
    const size_t count = std::min(kBlock, end - first);
    rt::CharacterInstance* instances[kBlock];
    rt::CharacterFrameInput inputs[kBlock];
    for (size_t k = 0; k < count; ++k) {
      instances[k] = &work->instances[first + k]->instance;
      inputs[k] = FrameInput(*work->instances[first + k], work->inputs[first + k], work->mode);
    }
    if (!rt::CrowdRange(std::span(instances, count), std::span(inputs, count), work->mode, work->find_contacts).ok()) {
      work->all_ok.store(false, std::memory_order_relaxed);
    }
  }
}

// Blocks [begin, end) of the loop: instances [begin * block, min(end * block, count)).
template <typename Input>
void RunCrowdBlocks(void* context, size_t begin, size_t end) {
  auto* work = static_cast<CrowdWork<Input>*>(context);
  RunCrowdRange(work, begin * work->block, std::min(end * work->block, work->count));
}

// Update + FindSpherePairs (+ FindContacts) of every instance through the engine's loop or the default one.
template <typename Input>
skinspheres_status RunCrowd(skinspheres_instance* const* instances, const Input* inputs, size_t count,
                            skinspheres_refit_mode mode, bool find_contacts, skinspheres_parallel_for_fn parallel_for,
                            void* user) {
  return Guard([&] {
    if (count != 0 && (instances == nullptr || inputs == nullptr)) {
      return FailStatic(SKINSPHERES_INVALID_ARGUMENT, "null instances or inputs");
    }
    if (mode != SKINSPHERES_MODE_EXACT && mode != SKINSPHERES_MODE_FAST) {
      return FailStatic(SKINSPHERES_INVALID_ARGUMENT, "unknown refit mode");
    }
    for (size_t i = 0; i < count; ++i) {
      if (instances[i] == nullptr) return FailStatic(SKINSPHERES_INVALID_ARGUMENT, "null instance");
    }
    const rt::RefitMode rt_mode = mode == SKINSPHERES_MODE_FAST ? rt::RefitMode::kFast : rt::RefitMode::kExact;
    // Strided inputs: the instances' gather buffers, sized here (the loop then allocates nothing).
    for (size_t i = 0; i < count; ++i) SizeGather(*instances[i], inputs[i], rt_mode);
    // The loop's indices are blocks of instances, as rt::CrowdUpdateAndFindSpherePairs's (CrowdBlock): no range
    // it hands out cuts a batch of 16 short.
    const size_t block = rt::CrowdBlock(rt_mode, find_contacts);
    CrowdWork<Input> work{instances, inputs, rt_mode, find_contacts, count, block};
    const size_t blocks = (count + block - 1) / block;
    if (parallel_for != nullptr) {
      if (count) parallel_for(user, blocks, 1, &RunCrowdBlocks<Input>, &work);
    } else {
      skinspheres::DefaultParallelFor()(
          blocks, 1, [&work](size_t begin, size_t end) { RunCrowdBlocks<Input>(&work, begin, end); });
    }
    if (!work.all_ok.load()) {
      return FailStatic(SKINSPHERES_INVALID_DATA, "at least one instance failed; see skinspheres_instance_status");
    }
    return SKINSPHERES_OK;
  });
}

}  // namespace

using namespace skinspheres::capi;

extern "C" {

skinspheres_status skinspheres_crowd_update_and_find_sphere_pairs(skinspheres_instance* const* instances,
                                                                  const skinspheres_frame_input* inputs, size_t count,
                                                                  skinspheres_refit_mode mode,
                                                                  skinspheres_parallel_for_fn parallel_for,
                                                                  void* user) {
  return RunCrowd(instances, inputs, count, mode, /*find_contacts=*/false, parallel_for, user);
}

skinspheres_status skinspheres_crowd_update_and_find_contacts(skinspheres_instance* const* instances,
                                                              const skinspheres_frame_input* inputs, size_t count,
                                                              skinspheres_refit_mode mode,
                                                              skinspheres_parallel_for_fn parallel_for, void* user) {
  return RunCrowd(instances, inputs, count, mode, /*find_contacts=*/true, parallel_for, user);
}

skinspheres_status skinspheres_crowd_update_and_find_sphere_pairs_strided(skinspheres_instance* const* instances,
                                                                          const skinspheres_frame_input_strided* inputs,
                                                                          size_t count, skinspheres_refit_mode mode,
                                                                          skinspheres_parallel_for_fn parallel_for,
                                                                          void* user) {
  return RunCrowd(instances, inputs, count, mode, /*find_contacts=*/false, parallel_for, user);
}

skinspheres_status skinspheres_crowd_update_and_find_contacts_strided(skinspheres_instance* const* instances,
                                                                      const skinspheres_frame_input_strided* inputs,
                                                                      size_t count, skinspheres_refit_mode mode,
                                                                      skinspheres_parallel_for_fn parallel_for,
                                                                      void* user) {
  return RunCrowd(instances, inputs, count, mode, /*find_contacts=*/true, parallel_for, user);
}

}  // extern "C"
