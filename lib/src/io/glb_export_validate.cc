// The GLB exporter's checks on its input (glb_export_stages.h), run before any aiScene is built.
#include <map>
#include <string>

#include "glb_export_stages.h"

namespace skinspheres::lib::detail {
namespace {

using skinning::Interpolation;

Error Invalid(const std::filesystem::path& path, const std::string& what) {
  return MakeError(ErrorCode::kInvalidArgument, "ExportGlb " + path.string() + ": " + what);
}

// Beyond RawCharacter::Validate, the GLB needs a skin even without vertices (Validate skips an
// empty one): one entry per rest position, arrays that agree, bind entries on joints, one inverse
// bind matrix per joint; and finite rest positions.
std::optional<Error> ValidateSkin(const RawCharacter& c, const std::filesystem::path& path) {
  const auto& sk = c.skeleton;
  const auto& s = c.skin;
  const size_t nv = c.positions_rest.size();
  if (s.positions_bind.size() != nv) return Invalid(path, "skin.positions_bind size differs from positions_rest");
  if (s.influence_offsets.size() != nv + 1 || s.influence_offsets.front() != 0 ||
      s.influence_offsets.back() != s.influence_binds.size() ||
      s.influence_weights.size() != s.influence_binds.size()) {
    return Invalid(path, "skin influence arrays are inconsistent (CSR offsets / binds / weights)");
  }
  for (float w : s.influence_weights) {
    if (w < 0.0f) return Invalid(path, "influence weight is negative");
  }
  std::map<int32_t, Mat4f> ibm;
  for (const auto& b : s.binds) {
    if (b.joint < 0 || static_cast<size_t>(b.joint) >= sk.size()) return Invalid(path, "bind entry joint out of range");
    if (!b.inverse_bind.allFinite()) return Invalid(path, "inverse bind matrix is not finite");
    auto [it, fresh] = ibm.emplace(b.joint, b.inverse_bind);
    if (!fresh && !it->second.isApprox(b.inverse_bind, 1e-5f)) {
      return Invalid(path, "joint '" + sk.joint_names[b.joint] +
                               "' has two bind entries with different inverse bind matrices (one glTF skin "
                               "holds one per joint)");
    }
  }
  for (const auto& p : c.positions_rest) {
    if (!p.allFinite()) return Invalid(path, "a rest position is not finite");
  }
  return std::nullopt;
}

// Every mesh range inside the vertex and triangle arrays, its triangles on its own vertices, a
// rigid one on an existing joint.
std::optional<Error> ValidateMeshes(const RawCharacter& c, const std::filesystem::path& path) {
  const size_t nv = c.positions_rest.size();
  for (const auto& m : c.meshes) {
    if (uint64_t{m.first_vertex} + m.vertex_count > nv ||
        uint64_t{m.first_triangle} + m.triangle_count > c.triangles.size()) {
      return Invalid(path, "mesh range '" + m.name + "' exceeds the vertex or triangle arrays");
    }
    for (uint32_t t = m.first_triangle; t < m.first_triangle + m.triangle_count; ++t) {
      for (int k = 0; k < 3; ++k) {
        const int64_t i = c.triangles[t][k];
        if (i < m.first_vertex || i >= int64_t{m.first_vertex} + m.vertex_count) {
          return Invalid(path,
                         "triangle " + std::to_string(t) + " of mesh '" + m.name + "' uses a vertex outside the mesh");
        }
      }
    }
    if (!m.skinned && m.rigid_joint >= static_cast<int32_t>(c.skeleton.size())) {
      return Invalid(path, "rigid mesh '" + m.name + "' follows a missing joint");
    }
  }
  return std::nullopt;
}

// Every clip track on an existing joint, with increasing times and one value (three for
// CUBICSPLINE) per key.
std::optional<Error> ValidateClips(const RawCharacter& c, const std::filesystem::path& path) {
  const auto& sk = c.skeleton;
  for (const auto& clip : c.clips) {
    for (const auto& tr : clip.tracks) {
      if (tr.joint < 0 || static_cast<size_t>(tr.joint) >= sk.size()) {
        return Invalid(path, "clip '" + clip.name + "' has a track for a missing joint");
      }
      auto bad = [](const auto& track) {
        const size_t per = track.interpolation == Interpolation::kCubicSpline ? 3 : 1;
        if (track.values.size() != per * track.times_s.size()) return true;
        for (size_t k = 1; k < track.times_s.size(); ++k) {
          if (!(track.times_s[k] > track.times_s[k - 1])) return true;
        }
        return false;
      };
      if (bad(tr.translation) || bad(tr.rotation) || bad(tr.scale)) {
        return Invalid(path, "clip '" + clip.name + "' track of joint '" + sk.joint_names[tr.joint] +
                                 "' has unordered times or a wrong value count");
      }
    }
  }
  return std::nullopt;
}

// Spheres with increasing frame times, one finite frame per time each, a usable resolution and a
// clip name.
std::optional<Error> ValidateExtras(const GlbExtras& e, const std::filesystem::path& path) {
  if (e.spheres.empty()) return std::nullopt;
  if (e.frame_times_s.empty()) return Invalid(path, "extras: spheres given without frame times");
  for (size_t k = 1; k < e.frame_times_s.size(); ++k) {
    if (!(e.frame_times_s[k] > e.frame_times_s[k - 1])) return Invalid(path, "extras: frame times not increasing");
  }
  for (size_t i = 0; i < e.spheres.size(); ++i) {
    if (e.spheres[i].per_frame_xyzr.size() != e.frame_times_s.size()) {
      return Invalid(path, "extras: sphere " + std::to_string(i) + " has " +
                               std::to_string(e.spheres[i].per_frame_xyzr.size()) + " frames, expected " +
                               std::to_string(e.frame_times_s.size()));
    }
    for (const auto& f : e.spheres[i].per_frame_xyzr) {
      if (!f.allFinite() || f.w() < 0.0f)
        return Invalid(path, "extras: sphere " + std::to_string(i) + " has a bad frame");
    }
  }
  if (e.sphere_segments < 3 || e.sphere_rings < 2) return Invalid(path, "extras: sphere resolution too low");
  if (e.clip_name.empty()) return Invalid(path, "extras: empty clip name");
  return std::nullopt;
}

}  // namespace

std::optional<Error> ValidateForExport(const RawCharacter& c, const GlbExtras& e, const std::filesystem::path& path) {
  // The rules every stage relies on (skeleton, triangle indices, skin arrays, bind entries).
  if (auto invalid = c.Validate()) return Invalid(path, invalid->message);
  if (auto err = ValidateSkin(c, path)) return err;
  if (auto err = ValidateMeshes(c, path)) return err;
  if (auto err = ValidateClips(c, path)) return err;
  return ValidateExtras(e, path);
}

}  // namespace skinspheres::lib::detail
