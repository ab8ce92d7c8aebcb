// Drives the engine API on a sphere set a reader accepted (shared by the sphere-set fuzz targets):
// an asset, an instance, a fast update, a query and (sets with a mesh) the narrow phase from the
// joints at the rest pose, and an exact update and query when the set has its vertex lists, then
// the narrow phase from the rest positions. A set the asset refuses (e.g. a singular rest transform) is
// fine; a crash, or an instance refused for an accepted asset, is not.
#pragma once

#include <span>
#include <utility>
#include <vector>

#include "fuzz_check.h"
#include "skinspheres/runtime/api/character.h"
#include "skinspheres/runtime/format/sphere_set.h"

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
  instance->FindSpherePairs();
  // The narrow phase (sets with a mesh): mode (b) skins what the pairs need from the joints.
  const runtime::NarrowPhaseData* narrow = (*asset)->narrow_phase();
  if (narrow != nullptr) instance->FindContacts();
  if (exact && vertices <= (1u << 16)) {
    const std::vector<Eigen::Vector3f> positions(vertices, Eigen::Vector3f::Zero());
    instance->UpdateExact(positions, rest);
    instance->FindSpherePairs();
    // Mode (a) on the rest pose's own positions: the exact refit's input and the narrow phase's.
    if (narrow != nullptr && narrow->rest_positions().size() == vertices) {
      const std::span<const Eigen::Vector3f> at_rest = narrow->rest_positions();
      instance->UpdateExact(at_rest, rest);
      instance->FindSpherePairs();
      instance->FindContacts(at_rest);
    }
  }
}

}  // namespace skinspheres::fuzz
