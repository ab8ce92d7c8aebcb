// SplitBodyParts: the split's stages in order (body_parts.h; each stage in split_stages.h and its
// own file). The paper (§3) divides a human mesh into regions: arms, legs and torso; here the head
// is a sixth, and a character that is not humanoid is split into chains. The fitter then walks each
// part's `chain`.
#include "skinspheres/lib/body_parts/body_parts.h"

#include "split_stages.h"

namespace skinspheres::lib {

const char* ToString(PartKind kind) {
  switch (kind) {
    case PartKind::kTorso: return "torso";
    case PartKind::kHead: return "head";
    case PartKind::kArmLeft: return "arm_l";
    case PartKind::kArmRight: return "arm_r";
    case PartKind::kLegLeft: return "leg_l";
    case PartKind::kLegRight: return "leg_r";
    case PartKind::kChain: return "chain";
  }
  return "chain";
}

int32_t BodyParts::Find(std::string_view name) const {
  for (size_t i = 0; i < parts.size(); ++i) {
    if (parts[i].name == name) return static_cast<int32_t>(i);
  }
  return -1;
}

namespace {

// Each triangle goes to its dominant joint's part.
void AssignTriangles(const RawCharacter& ch, BodyParts* out) {
  out->triangle_part.assign(ch.triangles.size(), -1);
  for (size_t t = 0; t < ch.triangles.size(); ++t) {
    int32_t p = out->joint_part[out->triangle_joint[t]];
    if (p < 0) p = 0;  // cannot happen: a dominant joint is weighted, hence in a part
    out->triangle_part[t] = p;
    if (!out->parts.empty()) out->parts[p].triangles.push_back(static_cast<uint32_t>(t));
  }
}

}  // namespace

Result<BodyParts> SplitBodyParts(const RawCharacter& character, const PartOverrides* overrides) {
  if (auto error = character.Validate()) return *error;
  BodyParts out;
  const WeightedSkeleton ws = BuildWeightedSkeleton(character, &out.triangle_joint);
  out.joint_part.assign(ws.n, -1);
  const HumanoidCandidate best = FindHumanoid(ws);
  if (best.cost < kHumanoidMaxCost) {
    BuildHumanoid(character, ws, best, &out);
  } else {
    BuildChains(ws, &out);
  }
  if (overrides != nullptr) {
    if (auto error = ApplyOverrides(character, *overrides, &out)) return *error;
  }
  AssignTriangles(character, &out);
  return out;
}

}  // namespace skinspheres::lib
