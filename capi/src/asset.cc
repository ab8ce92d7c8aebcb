// The C API's assets (skinspheres/skinspheres.h): loading a sphere set, and what it holds.
#include "capi_internal.h"

using namespace skinspheres::capi;

extern "C" {

skinspheres_status skinspheres_asset_load_file(const char* path, skinspheres_asset** out_asset) {
  return skinspheres_asset_load_file_with(path, nullptr, out_asset);
}

skinspheres_status skinspheres_asset_load_file_with(const char* path, const skinspheres_asset_options* options,
                                                    skinspheres_asset** out_asset) {
  return Guard([&] {
    if (out_asset) *out_asset = nullptr;
    if (path == nullptr || out_asset == nullptr)
      return FailStatic(SKINSPHERES_INVALID_ARGUMENT, "null path or out_asset");
    // UTF-8 on every platform (on Windows a char path would otherwise be read in the code page).
    const std::u8string utf8(reinterpret_cast<const char8_t*>(path));
    return MakeAsset(rt::LoadSphereSet(std::filesystem::path(utf8)), options, out_asset);
  });
}

skinspheres_status skinspheres_asset_load_memory(const void* data, size_t size, const char* name,
                                                 skinspheres_asset** out_asset) {
  return skinspheres_asset_load_memory_with(data, size, name, nullptr, out_asset);
}

skinspheres_status skinspheres_asset_load_memory_with(const void* data, size_t size, const char* name,
                                                      const skinspheres_asset_options* options,
                                                      skinspheres_asset** out_asset) {
  return Guard([&] {
    if (out_asset) *out_asset = nullptr;
    if ((data == nullptr && size != 0) || out_asset == nullptr) {
      return FailStatic(SKINSPHERES_INVALID_ARGUMENT, "null data or out_asset");
    }
    const std::span<const std::byte> bytes(static_cast<const std::byte*>(data), size);
    return MakeAsset(rt::ReadSphereSet(bytes, name ? name : "<memory>"), options, out_asset);
  });
}

float skinspheres_asset_narrow_margin(const skinspheres_asset* asset) {
  const rt::NarrowPhaseData* narrow = asset ? asset->asset->narrow_phase() : nullptr;
  return narrow ? narrow->margin() : 0.0f;
}

int skinspheres_asset_contact_rules(const skinspheres_asset* asset) {
  return asset ? static_cast<int>(asset->asset->sphere_set().contact_rules) : SKINSPHERES_RULES_SPHERE_PAIRS;
}

uint32_t skinspheres_asset_contact_hops(const skinspheres_asset* asset) {
  return asset ? asset->asset->sphere_set().contact_hops : 0u;
}

float skinspheres_asset_rest_gap(const skinspheres_asset* asset) {
  return asset ? asset->asset->sphere_set().rest_gap : 0.0f;
}

float skinspheres_asset_touch_tolerance(const skinspheres_asset* asset) {
  const rt::NarrowPhaseData* narrow = asset ? asset->asset->narrow_phase() : nullptr;
  return narrow ? narrow->touch_tolerance() : 0.0f;
}

void skinspheres_asset_release(skinspheres_asset* asset) {
  if (asset != nullptr && asset->references.fetch_sub(1, std::memory_order_acq_rel) == 1) delete asset;
}

skinspheres_asset* skinspheres_asset_retain(skinspheres_asset* asset) {
  if (asset != nullptr) asset->references.fetch_add(1, std::memory_order_relaxed);
  return asset;
}

size_t skinspheres_asset_sphere_count(const skinspheres_asset* asset) { return asset ? asset->asset->size() : 0; }
size_t skinspheres_asset_joint_count(const skinspheres_asset* asset) { return asset ? asset->asset->joint_count() : 0; }
const char* skinspheres_asset_joint_name(const skinspheres_asset* asset, size_t joint) {
  return NameAt(asset ? &asset->asset->sphere_set().joint_names : nullptr, joint, "joint index out of range");
}
const float* skinspheres_asset_joint_rest_world(const skinspheres_asset* asset, size_t joint) {
  if (!InRange(asset, joint, asset ? asset->asset->joint_count() : 0, "joint index out of range")) return nullptr;
  return asset->asset->sphere_set().joint_rest_world[joint].data();
}
int skinspheres_asset_joint_is_read(const skinspheres_asset* asset, size_t joint) {
  return asset && joint < asset->joint_read.size() && asset->joint_read[joint] ? 1 : 0;
}
size_t skinspheres_asset_part_count(const skinspheres_asset* asset) {
  return asset ? asset->asset->sphere_set().parts.size() : 0;
}
const char* skinspheres_asset_part_name(const skinspheres_asset* asset, size_t part) {
  if (!InRange(asset, part, asset ? asset->asset->sphere_set().parts.size() : 0, "part index out of range"))
    return nullptr;
  return asset->asset->sphere_set().parts[part].name.c_str();
}

skinspheres_status skinspheres_asset_sphere_part(const skinspheres_asset* asset, size_t sphere, size_t* out_part) {
  if (out_part == nullptr) return FailStatic(SKINSPHERES_INVALID_ARGUMENT, "null out_part");
  if (!InRange(asset, sphere, asset ? asset->asset->size() : 0, "sphere index out of range"))
    return SKINSPHERES_INVALID_ARGUMENT;
  *out_part = asset->asset->sphere_set().sphere_part[sphere];
  return SKINSPHERES_OK;
}

skinspheres_status skinspheres_asset_sphere_joints(const skinspheres_asset* asset, size_t sphere, uint32_t* out_joints,
                                                   float* out_weights, size_t capacity, size_t* out_count) {
  if (out_count == nullptr) return FailStatic(SKINSPHERES_INVALID_ARGUMENT, "null out_count");
  *out_count = 0;
  if (!InRange(asset, sphere, asset ? asset->asset->size() : 0, "sphere index out of range"))
    return SKINSPHERES_INVALID_ARGUMENT;
  const Influences in = SphereInfluences(*asset, sphere);
  for (size_t k = 0; k < std::min(capacity, in.joints.size()); ++k) {
    if (out_joints) out_joints[k] = in.joints[k];
    if (out_weights) out_weights[k] = in.weights[k];
  }
  *out_count = in.joints.size();
  if (capacity < in.joints.size()) {
    return FailStatic(SKINSPHERES_BUFFER_TOO_SMALL, "the joint buffer holds fewer entries than the sphere's joints");
  }
  return SKINSPHERES_OK;
}

skinspheres_status skinspheres_asset_sphere_joint(const skinspheres_asset* asset, size_t sphere, size_t* out_joint) {
  if (out_joint == nullptr) return FailStatic(SKINSPHERES_INVALID_ARGUMENT, "null out_joint");
  if (!InRange(asset, sphere, asset ? asset->asset->size() : 0, "sphere index out of range"))
    return SKINSPHERES_INVALID_ARGUMENT;
  const Influences in = SphereInfluences(*asset, sphere);
  if (in.joints.empty()) return FailStatic(SKINSPHERES_INVALID_DATA, "the sphere has no joints");
  size_t best = 0;
  for (size_t k = 1; k < in.joints.size(); ++k) {
    if (in.weights[k] > in.weights[best] || (in.weights[k] == in.weights[best] && in.joints[k] < in.joints[best])) {
      best = k;
    }
  }
  *out_joint = in.joints[best];
  return SKINSPHERES_OK;
}
size_t skinspheres_asset_vertex_count(const skinspheres_asset* asset) {
  return asset ? asset->asset->source_vertex_count() : 0;
}
int skinspheres_asset_is_fast_only(const skinspheres_asset* asset) {
  return asset && asset->asset->sphere_set().fast_only ? 1 : 0;
}

skinspheres_status skinspheres_asset_check(const skinspheres_asset* asset, const char* const* joint_names,
                                           size_t joint_count, size_t vertex_count) {
  return Guard([&] {
    if (asset == nullptr || (joint_names == nullptr && joint_count != 0)) {
      return FailStatic(SKINSPHERES_INVALID_ARGUMENT, "null asset or joint_names");
    }
    const std::vector<std::string> names = Names(joint_names, joint_count);
    if (auto err = asset->asset->Matches(names, vertex_count)) return Fail(*err);
    return SKINSPHERES_OK;
  });
}

int skinspheres_asset_has_triangle_contacts(const skinspheres_asset* asset) {
  return asset && asset->asset->narrow_phase() != nullptr ? 1 : 0;
}

}  // extern "C"
