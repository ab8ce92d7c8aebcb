// Drives the engine API on a sphere set a reader accepted (shared by the sphere-set fuzz targets):
// an asset, an instance, a fast update and a query at the rest pose, and an exact update and query
// when the set has its vertex lists. A set the asset refuses (e.g. a singular rest transform) is
// fine; a crash, or an instance refused for an accepted asset, is not.
#pragma once

#include <utility>
#include <vector>

#include "fuzz_check.h"
#include "skinspheres/runtime/character.h"
#include "skinspheres/runtime/sphere_set.h"

namespace skinspheres::fuzz {

inline void DriveEngine(runtime::SphereSet set) {
  const std::vector<Mat4f> rest = set.joint_rest_world;
  const size_t vertices = set.source_vertex_count;
  const bool exact = !set.fast_only;
  auto asset = runtime::CharacterAsset::Create(std::move(set));
  if (!asset.ok()) return;
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
