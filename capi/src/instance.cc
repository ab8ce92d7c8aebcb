// The C API's instances (skinspheres/skinspheres.h): per-frame update, sphere pairs and contacts.
#include "capi_internal.h"

using namespace skinspheres::capi;

extern "C" {

skinspheres_status skinspheres_instance_create(const skinspheres_asset* asset, const char* const* joint_names,
                                               size_t joint_count, skinspheres_instance** out_instance) {
  return Guard([&] {
    if (out_instance) *out_instance = nullptr;
    if (asset == nullptr || out_instance == nullptr || (joint_names == nullptr && joint_count != 0)) {
      return FailStatic(SKINSPHERES_INVALID_ARGUMENT, "null asset, joint_names or out_instance");
    }
    skinspheres::Result<rt::CharacterInstance> created = rt::CharacterInstance::Create(asset->asset);
    rt::JointMapping mapping;
    if (joint_names != nullptr) {
      auto mapped = rt::MapJoints(asset->asset->sphere_set(), Names(joint_names, joint_count));
      if (!mapped.ok()) return Fail(mapped.error());
      mapping = std::move(mapped).value();
      created = rt::CharacterInstance::Create(asset->asset, mapping);
    }
    if (!created.ok()) return Fail(created.error());
    // Every member braced, not make_unique's parentheses: clang 14 (scripts/tidy) lacks C++20's
    // parenthesised aggregate initialisation, and GCC warns of a member left out.
    std::unique_ptr<skinspheres_instance> instance(
        new skinspheres_instance{std::move(created).value(), nullptr, {}, {}, {}, {}});
    instance->extra_joints = std::move(mapping.extra_engine_joints);
    instance->unmapped_joints = std::move(mapping.unmapped_set_joints);
    asset->references.fetch_add(1, std::memory_order_relaxed);  // nothing throws after this
    instance->asset = asset;
    *out_instance = instance.release();
    return SKINSPHERES_OK;
  });
}

void skinspheres_instance_destroy(skinspheres_instance* instance) {
  if (instance == nullptr) return;
  skinspheres_asset* asset = const_cast<skinspheres_asset*>(instance->asset);  // immutable: only counted
  delete instance;
  skinspheres_asset_release(asset);
}

skinspheres_asset* skinspheres_instance_asset(const skinspheres_instance* instance) {
  return instance ? const_cast<skinspheres_asset*>(instance->asset) : nullptr;
}

size_t skinspheres_instance_extra_joint_count(const skinspheres_instance* instance) {
  return instance ? instance->extra_joints.size() : 0;
}
const char* skinspheres_instance_extra_joint_name(const skinspheres_instance* instance, size_t k) {
  return NameAt(instance ? &instance->extra_joints : nullptr, k, "extra joint index out of range");
}
size_t skinspheres_instance_unmapped_joint_count(const skinspheres_instance* instance) {
  return instance ? instance->unmapped_joints.size() : 0;
}
const char* skinspheres_instance_unmapped_joint_name(const skinspheres_instance* instance, size_t k) {
  return NameAt(instance ? &instance->unmapped_joints : nullptr, k, "unmapped joint index out of range");
}

size_t skinspheres_instance_joint_count(const skinspheres_instance* instance) {
  return instance ? instance->instance.joint_input_count() : 0;
}

skinspheres_status skinspheres_instance_update_fast(skinspheres_instance* instance, const float* joint_world,
                                                    size_t joint_count) {
  return skinspheres_instance_update_fast_strided(instance, joint_world, joint_count, nullptr);
}

skinspheres_status skinspheres_instance_update_exact(skinspheres_instance* instance, const float* positions,
                                                     size_t vertex_count, const float* joint_world,
                                                     size_t joint_count) {
  return skinspheres_instance_update_exact_strided(instance, positions, vertex_count, kPackedPositionStride,
                                                   joint_world, joint_count, nullptr);
}

skinspheres_status skinspheres_instance_update_fast_strided(skinspheres_instance* instance, const float* joint_world,
                                                            size_t joint_count,
                                                            const skinspheres_matrix_layout* joint_layout) {
  return Guard([&] {
    if (instance == nullptr) return FailStatic(SKINSPHERES_INVALID_ARGUMENT, "null instance");
    if (joint_world == nullptr) return FailStatic(SKINSPHERES_INVALID_ARGUMENT, "fast mode needs joint matrices");
    SizeGather(*instance, joint_layout, nullptr, kPackedPositionStride);
    return FromFrame(instance->instance.UpdateFast(Joints(*instance, joint_world, joint_count, joint_layout)));
  });
}

skinspheres_status skinspheres_instance_update_exact_strided(skinspheres_instance* instance, const float* positions,
                                                             size_t vertex_count, ptrdiff_t position_stride,
                                                             const float* joint_world, size_t joint_count,
                                                             const skinspheres_matrix_layout* joint_layout) {
  return Guard([&] {
    if (instance == nullptr) return FailStatic(SKINSPHERES_INVALID_ARGUMENT, "null instance");
    if (positions == nullptr) return FailStatic(SKINSPHERES_INVALID_ARGUMENT, "exact mode needs vertex positions");
    if (joint_world == nullptr && joint_count != 0) {
      return FailStatic(SKINSPHERES_INVALID_ARGUMENT, "null joint_world with a joint count");
    }
    SizeGather(*instance, joint_layout, positions, position_stride);
    return FromFrame(instance->instance.UpdateExact(Positions(*instance, positions, vertex_count, position_stride),
                                                    Joints(*instance, joint_world, joint_count, joint_layout)));
  });
}

skinspheres_status skinspheres_instance_find_sphere_pairs(skinspheres_instance* instance, size_t* out_count) {
  return Guard([&] {
    if (out_count) *out_count = 0;
    if (instance == nullptr) return FailStatic(SKINSPHERES_INVALID_ARGUMENT, "null instance");
    const size_t n = instance->instance.FindSpherePairs().size();
    if (out_count) *out_count = n;
    return FromFrame(instance->instance.status());
  });
}

skinspheres_status skinspheres_instance_get_sphere_pairs(const skinspheres_instance* instance,
                                                         skinspheres_sphere_pair* out, size_t capacity,
                                                         size_t* out_count) {
  if (out_count) *out_count = 0;
  if (instance == nullptr || (out == nullptr && capacity != 0)) {
    return FailStatic(SKINSPHERES_INVALID_ARGUMENT, "null instance or buffer");
  }
  return CopyOut(instance->instance.sphere_pairs(), out, capacity, out_count,
                 "the sphere-pair buffer holds fewer entries than the count");
}

const skinspheres_sphere_pair* skinspheres_instance_sphere_pairs(const skinspheres_instance* instance,
                                                                 size_t* out_count) {
  if (out_count) *out_count = 0;
  if (instance == nullptr) return nullptr;
  const auto contacts = instance->instance.sphere_pairs();
  if (out_count) *out_count = contacts.size();
  return reinterpret_cast<const skinspheres_sphere_pair*>(contacts.data());
}

const float* skinspheres_instance_spheres(const skinspheres_instance* instance, size_t* out_count) {
  if (out_count) *out_count = 0;
  if (instance == nullptr || !instance->instance.spheres_valid()) return nullptr;
  const auto spheres = instance->instance.spheres();
  if (out_count) *out_count = spheres.size();
  return spheres.empty() ? nullptr : spheres.data()->data();
}

skinspheres_status skinspheres_instance_status(const skinspheres_instance* instance, const char** message) {
  if (instance == nullptr) {
    if (message) *message = "null instance";
    return SKINSPHERES_INVALID_ARGUMENT;
  }
  const rt::FrameStatus st = instance->instance.status();
  if (message) *message = st.message;
  return static_cast<skinspheres_status>(st.code);
}

skinspheres_status skinspheres_instance_reserve_contacts(skinspheres_instance* instance, size_t count) {
  return Guard([&] {
    if (instance == nullptr) return FailStatic(SKINSPHERES_INVALID_ARGUMENT, "null instance");
    instance->instance.ReserveContacts(count);
    return SKINSPHERES_OK;
  });
}

skinspheres_status skinspheres_instance_reserve_sphere_pairs(skinspheres_instance* instance, size_t count) {
  return Guard([&] {
    if (instance == nullptr) return FailStatic(SKINSPHERES_INVALID_ARGUMENT, "null instance");
    instance->instance.ReserveSpherePairs(count);
    return SKINSPHERES_OK;
  });
}

skinspheres_status skinspheres_instance_find_contacts(skinspheres_instance* instance, const float* positions,
                                                      size_t vertex_count, size_t* out_part_pairs,
                                                      size_t* out_triangle_pairs) {
  return skinspheres_instance_find_contacts_strided(instance, positions, vertex_count, kPackedPositionStride,
                                                    out_part_pairs, out_triangle_pairs);
}

skinspheres_status skinspheres_instance_find_contacts_strided(skinspheres_instance* instance, const float* positions,
                                                              size_t vertex_count, ptrdiff_t position_stride,
                                                              size_t* out_part_pairs, size_t* out_triangle_pairs) {
  return Guard([&] {
    if (out_part_pairs) *out_part_pairs = 0;
    if (out_triangle_pairs) *out_triangle_pairs = 0;
    if (instance == nullptr) return FailStatic(SKINSPHERES_INVALID_ARGUMENT, "null instance");
    if (positions == nullptr && vertex_count != 0) {
      return FailStatic(SKINSPHERES_INVALID_ARGUMENT, "null positions with a vertex count");
    }
    SizeGather(*instance, nullptr, positions, position_stride);
    const rt::FrameStatus st =
        instance->instance.FindContacts(Positions(*instance, positions, vertex_count, position_stride));
    const rt::FrameContacts& found = instance->instance.contacts();
    if (out_part_pairs) *out_part_pairs = found.parts.size();
    if (out_triangle_pairs) *out_triangle_pairs = found.triangle_pairs.size();
    return FromFrame(st);
  });
}

skinspheres_status skinspheres_instance_get_part_contacts(const skinspheres_instance* instance,
                                                          skinspheres_part_contact* out, size_t capacity,
                                                          size_t* out_count) {
  if (out_count) *out_count = 0;
  if (instance == nullptr || (out == nullptr && capacity != 0)) {
    return FailStatic(SKINSPHERES_INVALID_ARGUMENT, "null instance or buffer");
  }
  return CopyOut(std::span<const rt::PartContact>(instance->instance.contacts().parts), out, capacity, out_count,
                 "the part-contact buffer holds fewer entries than the count");
}

skinspheres_status skinspheres_instance_get_triangle_contacts(const skinspheres_instance* instance, size_t part_contact,
                                                              skinspheres_triangle_contact* out, size_t capacity,
                                                              size_t* out_count) {
  if (out_count) *out_count = 0;
  if (instance == nullptr || (out == nullptr && capacity != 0)) {
    return FailStatic(SKINSPHERES_INVALID_ARGUMENT, "null instance or buffer");
  }
  const rt::FrameContacts& found = instance->instance.contacts();
  std::span<const rt::TriangleContact> pairs = found.triangle_pairs;
  if (part_contact != static_cast<size_t>(SKINSPHERES_ALL_PART_PAIRS)) {
    if (part_contact >= found.parts.size()) {
      return FailStatic(SKINSPHERES_INVALID_ARGUMENT, "part_contact is not below the part-pair count");
    }
    const rt::PartContact& p = found.parts[part_contact];
    pairs = pairs.subspan(p.first_triangle_pair, p.triangle_pair_count);
  }
  return CopyOut(pairs, out, capacity, out_count, "the triangle-contact buffer holds fewer entries than the count");
}

}  // extern "C"
