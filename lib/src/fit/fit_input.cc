// Stage 0 of the fitter: validate the input before anything is computed. See fit_stages.h.
#include <string>

#include "fit_stages.h"

namespace skinspheres::lib {

std::optional<Error> ValidateFitInput(const RawCharacter& ch, const BodyParts& parts, const FitSettings& settings) {
  const std::string name = CharacterName(ch);
  if (auto refused = settings.Validate()) return MakeError(refused->code, "fit settings: " + refused->message);
  const size_t joints = ch.skeleton.size();
  if (!ch.skeleton.Validate() || joints == 0) return MakeError(ErrorCode::kInvalidData, name + ": invalid skeleton");
  if (parts.triangle_part.size() != ch.triangle_count() || parts.triangle_joint.size() != ch.triangle_count()) {
    return MakeError(ErrorCode::kInvalidData, name + ": body parts were made for another mesh");
  }
  for (const auto& tri : ch.triangles) {
    if ((tri.array() < 0).any() || (tri.array() >= static_cast<int>(ch.vertex_count())).any()) {
      return MakeError(ErrorCode::kInvalidData, name + ": a triangle index is out of range");
    }
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
      return MakeError(ErrorCode::kInvalidData, name + ": body parts give triangle " + std::to_string(t) + " no valid joint");
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
        return MakeError(ErrorCode::kInvalidData, name + ": body part " + parts.parts[k].name + " names joint " + std::to_string(j));
      }
    }
  }
  return std::nullopt;
}

}  // namespace skinspheres::lib
