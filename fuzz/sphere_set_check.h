// What the sphere-set fuzz targets (JSON and binary) assert of a set a reader accepted, beyond its
// own round trip: it passes SphereSet::Validate, and an asset and instance made from it update
// (fast and, when the set allows it, exact, at the rest pose) and query without crashing.
#pragma once

#include <utility>
#include <vector>

#include "fuzz_check.h"
#include "skinspheres/runtime/character.h"
#include "skinspheres/runtime/sphere_set.h"

namespace skinspheres::fuzz {

inline void CheckEngineApi(runtime::SphereSet set) {
  SKINSPHERES_FUZZ_CHECK(!set.Validate().has_value(), set.Validate()->message);
  const std::vector<Mat4f> rest = set.joint_rest_world;
  const size_t vertices = set.source_vertex_count;
  const bool exact = !set.fast_only;
  auto asset = runtime::CharacterAsset::Create(std::move(set));
  if (!asset.ok()) return;  // e.g. a singular rest transform: refused, not a crash
  auto instance = runtime::CharacterInstance::Create(*asset);
  SKINSPHERES_FUZZ_CHECK(instance.ok(), instance.ok() ? "" : instance.error().message);
  instance->UpdateFast(rest);
  instance->Query();
  if (exact && vertices <= (1u << 16)) {
    const std::vector<Eigen::Vector3f> positions(vertices, Eigen::Vector3f::Zero());
    instance->UpdateExact(positions, rest);
    instance->Query();
  }
}

}  // namespace skinspheres::fuzz
