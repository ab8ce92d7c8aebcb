// Drives the engine API on a sphere set a reader accepted (shared by the sphere-set fuzz targets):
// an asset, an instance, a fast update, a query and (sets with a mesh) the narrow phase from the
// joints at the rest pose, and an exact update and query when the set has its vertex lists, then
// the narrow phase from the rest positions. A set the asset refuses (e.g. a singular rest transform) is
// fine; a crash, or an instance refused for an accepted asset, is not.
#pragma once

#include <Eigen/Geometry>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <random>
#include <span>
#include <string>
#include <utility>
#include <vector>

#include "fuzz_check.h"
#include "skinspheres/runtime/api/character.h"
#include "skinspheres/runtime/format/sphere_set.h"
#include "skinspheres/runtime/refit/refit_job.h"

namespace skinspheres::fuzz {

// A seed for the random pose, from the input's bytes (FNV-1a): the same input, the same pose.
inline uint64_t PoseSeed(const uint8_t* data, size_t size) {
  uint64_t h = 1469598103934665603ull;
  for (size_t k = 0; k < size; ++k) h = (h ^ data[k]) * 1099511628211ull;
  return h;
}

// The fast refit of an accepted set (RefitRestData::Create, then RefitJob in fast mode) at its rest
// pose and at a random pose near it (each joint's rest transform, its last row taken as 0 0 0 1 as
// the runtime takes it, moved by a rigid motion: a rotation of up to 3.1 rad and a translation of
// up to 3 units): every radius finite and >= 0, and (sets with
// a mesh and vertex lists) every source vertex, skinned in double, inside its sphere. Rest data the
// set is refused for (a rest transform that cannot be inverted) is fine if the message is one line.
inline void CheckFastRefit(const runtime::SphereSet& set, uint64_t seed) {
  auto rest = runtime::RefitRestData::Create(set);
  if (!rest.ok()) {
    SKINSPHERES_FUZZ_CHECK(rest.error().code != ErrorCode::kCheckFailed, rest.error().message);
    return;
  }
  std::vector<Mat4f> world = set.joint_rest_world;
  std::vector<Vec4f> out(set.size());
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<float> angle(-3.1f, 3.1f), move(-3.0f, 3.0f);
  for (int pose = 0; pose < 2; ++pose) {
    if (pose == 1) {
      for (size_t j = 0; j < world.size(); ++j) {
        Eigen::Vector3f axis(move(rng), move(rng), move(rng));
        axis = axis.norm() > 1e-3f ? axis.normalized() : Eigen::Vector3f::UnitX();
        const Eigen::Affine3f m =
            Eigen::Translation3f(move(rng), move(rng), move(rng)) * Eigen::AngleAxisf(angle(rng), axis);
        Mat4f affine = set.joint_rest_world[j];  // the runtime ignores the last row
        affine.row(3) << 0.0f, 0.0f, 0.0f, 1.0f;
        world[j] = m.matrix() * affine;
      }
    }
    const char* what = pose == 0 ? "at the rest pose" : "at a random pose";
    const bool ran = runtime::RefitJob{runtime::RefitMode::kFast, &set, &*rest, world, {}, out}.Run();
    for (size_t s = 0; s < set.size(); ++s) {
      SKINSPHERES_FUZZ_CHECK(out[s].allFinite() && out[s].w() >= 0.0f,
                             std::string("fast refit ") + what + ": sphere " + std::to_string(s) + " is (" +
                                 std::to_string(out[s].x()) + ", " + std::to_string(out[s].y()) + ", " +
                                 std::to_string(out[s].z()) + ", r " + std::to_string(out[s].w()) + ")");
    }
    SKINSPHERES_FUZZ_CHECK(ran, std::string("fast refit ") + what + " refused an accepted set");
    if (!set.has_mesh() || set.fast_only) continue;
    for (size_t s = 0; s < set.size(); ++s) {
      const Eigen::Vector3d c = out[s].head<3>().cast<double>();
      // A source vertex skinned in double.
      auto skinned = [&](uint32_t v) {
        Eigen::Vector3d p = Eigen::Vector3d::Zero();
        for (uint32_t q = set.mesh.influence_offsets[v]; q < set.mesh.influence_offsets[v + 1]; ++q) {
          const skinning::BindEntry& b = set.mesh.binds[set.mesh.influence_binds[q]];
          const Eigen::Matrix4d m = world[static_cast<size_t>(b.joint)].cast<double>() * b.inverse_bind.cast<double>();
          p += double{set.mesh.influence_weights[q]} *
               (m * set.mesh.positions_bind[v].cast<double>().homogeneous()).head<3>();
        }
        return p;
      };
      for (uint32_t i = set.vertex_offsets[s]; i < set.vertex_offsets[s + 1]; ++i) {
        const uint32_t v = set.vertices[i];
        Eigen::Vector3d p;
        if (v < set.source_vertex_count) {
          p = skinned(v);
        } else {  // a grid point of a cut triangle: the same combination of its skinned vertices
          const runtime::PiecePoint& g = set.piece_points[v - set.source_vertex_count];
          const uint32_t* t = set.triangle_vertices.data() + 3 * size_t{g.triangle};
          const double l = g.level;
          p = (double(g.level - g.i - g.j) / l) * skinned(t[0]) + (double(g.i) / l) * skinned(t[1]) +
              (double(g.j) / l) * skinned(t[2]);
        }
        // Slack: the weights sum to 1 within kWeightSumTolerance, and float rounding of the inputs;
        // with neither a stored reference nor reach groups, radius_fast may fall 1e-4 short of the
        // rest copies by design (CheckFastRadii: files written before HoldMeshCopies).
        const bool old_radii = set.fast_reference_spheres.empty() && set.reach_group_offsets.empty();
        const double slack = 1e-5 * (p.cwiseAbs().maxCoeff() + c.cwiseAbs().maxCoeff() + out[s].w()) +
                             (old_radii ? 2e-4 * out[s].w() : 0.0);
        const double d = (p - c).norm();
        SKINSPHERES_FUZZ_CHECK(!(d > double{out[s].w()} + slack),
                               std::string("fast refit ") + what + ": sphere " + std::to_string(s) +
                                   " misses its point " + std::to_string(v) + " by " + std::to_string(d - out[s].w()) +
                                   " (radius " + std::to_string(out[s].w()) + ")");
      }
    }
  }
}

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
