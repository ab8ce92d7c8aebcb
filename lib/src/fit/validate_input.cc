// Stage 0 of the fitter: validate the input before anything is computed (the settings, the
// character, the parts, then the rest pose the stages fit and the runtime refits). See fit_stages.h.
#include <Eigen/LU>
#include <cmath>
#include <limits>
#include <string>

#include "fit_stages.h"

namespace skinspheres::lib {

std::optional<Error> ValidateFitInput(const RawCharacter& ch, const BodyParts& parts, const FitSettings& settings) {
  const std::string name = ch.Name();
  if (auto refused = settings.Validate()) return MakeError(refused->code, "fit settings: " + refused->message);
  if (auto invalid = ch.Validate()) return invalid;
  const size_t joints = ch.skeleton.size();
  if (parts.triangle_part.size() != ch.triangle_count() || parts.triangle_joint.size() != ch.triangle_count()) {
    return MakeError(ErrorCode::kInvalidData, name + ": body parts were made for another mesh");
  }
  // The sphere-set format refuses coordinates beyond 1e18 (runtime/sphere_set.h); say so up front
  // rather than after fitting (squared distances of such spreads overflow float).
  for (size_t v = 0; v < ch.vertex_count(); ++v) {
    const Eigen::Vector3f& p = ch.positions_rest[v];
    if (!p.allFinite() || p.cwiseAbs().maxCoeff() > 1e18f) {
      return MakeError(ErrorCode::kInvalidData, name + ": vertex " + std::to_string(v) +
                                                    " is not finite or lies beyond 1e18 units; nothing can be fitted");
    }
  }
  // The parts must partition the triangles and name joints that exist (parts run in parallel:
  // a triangle in two parts would make the result depend on the threads).
  for (size_t t = 0; t < ch.triangle_count(); ++t) {
    if (parts.triangle_joint[t] < 0 || parts.triangle_joint[t] >= static_cast<int32_t>(joints)) {
      return MakeError(ErrorCode::kInvalidData,
                       name + ": body parts give triangle " + std::to_string(t) + " no valid joint");
    }
  }
  for (size_t k = 0; k < parts.parts.size(); ++k) {
    for (uint32_t t : parts.parts[k].triangles) {
      if (t >= ch.triangle_count() || parts.triangle_part[t] != static_cast<int32_t>(k)) {
        return MakeError(ErrorCode::kInvalidData, name + ": body part " + parts.parts[k].name + " lists triangle " +
                                                      std::to_string(t) + " that is not its own");
      }
    }
    for (int32_t j : parts.parts[k].chain) {
      if (j < 0 || j >= static_cast<int32_t>(joints)) {
        return MakeError(ErrorCode::kInvalidData,
                         name + ": body part " + parts.parts[k].name + " names joint " + std::to_string(j));
      }
    }
  }
  return std::nullopt;
}

namespace {

// Invertible as the runtime requires of every joint's rest transform (RefitRestData): the 3x3
// part's determinant above 1e-12 of its largest entry cubed, in double.
bool InvertibleLinear(const Eigen::Matrix4d& m) {
  const double det = m.topLeftCorner<3, 3>().determinant();
  const double scale = m.topLeftCorner<3, 3>().cwiseAbs().maxCoeff();
  return std::isfinite(det) && std::abs(det) > 1e-12 * scale * scale * scale;
}

// A joint whose rest transform is singular (a zero scale on it or above it: the runtime inverts
// every joint's), or nullopt.
std::optional<std::string> SingularJoint(const skinning::Skeleton& sk, std::span<const Mat4f> rest_world) {
  for (size_t j = 0; j < sk.size(); ++j) {
    if (InvertibleLinear(rest_world[j].cast<double>())) continue;
    const std::string joint = "joint " + std::to_string(j) + " '" + sk.joint_names[j] + "'";
    if (!InvertibleLinear(sk.rest_local[j].ToMatrix().cast<double>())) {
      return joint + " has a singular rest transform (a zero scale); the runtime could not refit the set";
    }
    return joint +
           " has a singular rest world transform (its transforms multiply to one); the runtime could not refit the set";
  }
  return std::nullopt;
}

// A skinned vertex whose skinning matrix G_joint · IBM is singular at rest (a zero or singular
// inverse bind matrix collapses its vertices), or nullopt. Each bind entry is checked once.
std::optional<std::string> SingularSkinningMatrix(const RawCharacter& ch, std::span<const Mat4f> rest_world) {
  const auto& skin = ch.skin;
  if (skin.influence_offsets.size() != ch.vertex_count() + 1) return std::nullopt;
  std::vector<int8_t> bind_ok(skin.binds.size(), -1);  // -1: not checked yet
  for (size_t v = 0; v < ch.vertex_count(); ++v) {
    for (uint32_t k = skin.influence_offsets[v]; k < skin.influence_offsets[v + 1]; ++k) {
      const uint16_t b = skin.influence_binds[k];
      if (b >= skin.binds.size() || !(skin.influence_weights[k] > 0.0f)) continue;
      if (bind_ok[b] < 0) {
        const int32_t j = skin.binds[b].joint;
        bind_ok[b] = j >= 0 && static_cast<size_t>(j) < ch.skeleton.size() &&
                     InvertibleLinear(rest_world[j].cast<double>() * skin.binds[b].inverse_bind.cast<double>());
      }
      if (!bind_ok[b]) {
        return "vertex " + std::to_string(v) + " is skinned by bind entry " + std::to_string(b) +
               " whose inverse bind matrix makes a singular skinning matrix at rest (a zero or singular inverse bind "
               "matrix collapses its vertices)";
      }
    }
  }
  return std::nullopt;
}

// A mesh with no extent or no height (nothing to fit), or nullopt.
std::optional<std::string> FlatMesh(std::span<const Eigen::Vector3f> positions) {
  Eigen::Vector3f lo = Eigen::Vector3f::Constant(std::numeric_limits<float>::infinity()), hi = -lo;
  for (const auto& p : positions) {
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  const Eigen::Vector3d extent = (hi - lo).cast<double>();
  if (!(extent.norm() > 0.0)) return "every vertex of the rest pose is at one point; nothing can be fitted";
  if (!(extent.y() > 1e-6 * extent.norm())) {
    return "the rest pose has zero height (no extent along +Y); nothing can be fitted";
  }
  return std::nullopt;
}

}  // namespace

std::optional<Error> ValidateRestPose(const RawCharacter& ch, std::span<const Mat4f> rest_world) {
  std::optional<std::string> why = SingularJoint(ch.skeleton, rest_world);
  if (!why) why = SingularSkinningMatrix(ch, rest_world);
  if (!why) why = FlatMesh(ch.positions_rest);
  if (!why) return std::nullopt;
  return MakeError(ErrorCode::kInvalidData, ch.Name() + ": degenerate rest pose: " + *why);
}

}  // namespace skinspheres::lib
