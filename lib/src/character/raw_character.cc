// RawCharacter's name and the rules every stage relies on (raw_character.h).
#include "skinspheres/lib/character/raw_character.h"

#include <cmath>
#include <limits>

namespace skinspheres::lib {

std::string RawCharacter::Name() const { return source_file.empty() ? std::string("<character>") : source_file; }

std::optional<Error> RawCharacter::Validate() const {
  auto fail = [&](const std::string& what) { return MakeError(ErrorCode::kInvalidData, Name() + ": " + what); };
  const auto& sk = skeleton;
  if (sk.size() == 0) return fail("skeleton has no joints");
  if (!sk.Validate()) return fail("skeleton arrays disagree in size or parents are not ordered parents-first");
  const int32_t n = static_cast<int32_t>(sk.size());
  const size_t nv = positions_rest.size();
  for (size_t t = 0; t < triangles.size(); ++t) {
    for (int k = 0; k < 3; ++k) {
      const int idx = triangles[t][k];
      if (idx < 0 || static_cast<size_t>(idx) >= nv) {
        return fail("triangle " + std::to_string(t) + " uses vertex " + std::to_string(idx) + " of " +
                    std::to_string(nv));
      }
    }
  }
  // Without a skin nothing below applies; note that the rigid-joint check at the end is skipped too.
  if (skin.vertex_count() == 0) return std::nullopt;
  if (skin.vertex_count() != nv) {
    return fail("skin has " + std::to_string(skin.vertex_count()) + " vertices, mesh has " + std::to_string(nv));
  }
  if (skin.influence_offsets.size() != nv + 1 || skin.influence_offsets.front() != 0 ||
      skin.influence_offsets.back() != skin.influence_binds.size() ||
      skin.influence_binds.size() != skin.influence_weights.size()) {
    return fail("skin influence arrays disagree in size");
  }
  for (size_t v = 0; v < nv; ++v) {
    if (skin.influence_offsets[v] > skin.influence_offsets[v + 1]) {
      return fail("skin influence offsets decrease at vertex " + std::to_string(v));
    }
  }
  for (size_t b = 0; b < skin.binds.size(); ++b) {
    if (skin.binds[b].joint < 0 || skin.binds[b].joint >= n) {
      return fail("bind entry " + std::to_string(b) + " names joint " + std::to_string(skin.binds[b].joint) + " of " +
                  std::to_string(n));
    }
  }
  for (size_t i = 0; i < skin.influence_binds.size(); ++i) {
    if (skin.influence_binds[i] >= skin.binds.size()) {
      return fail("influence " + std::to_string(i) + " uses bind entry " + std::to_string(skin.influence_binds[i]) +
                  " of " + std::to_string(skin.binds.size()));
    }
    if (!std::isfinite(skin.influence_weights[i])) {
      return fail("influence " + std::to_string(i) + " has a non-finite weight");
    }
  }
  // Weights sum to 1 per vertex (the importers normalise them): the fitted set's fast bounds assume
  // it, so a character built in code with other sums is refused here, before the fit, by vertex.
  double sum = 0.0;
  if (const size_t v = skinning::FirstVertexNotSummingToOne(skin.influence_offsets, skin.influence_weights, &sum);
      v != std::numeric_limits<size_t>::max()) {
    return fail("vertex " + std::to_string(v) + " has skin weights summing to " + std::to_string(sum) +
                ", not 1 (normalise them)");
  }
  for (const MeshRange& m : meshes) {
    if (m.rigid_joint >= n) {
      return fail("mesh '" + m.name + "' follows joint " + std::to_string(m.rigid_joint) + " of " + std::to_string(n));
    }
  }
  return std::nullopt;
}

}  // namespace skinspheres::lib
