// The six parts of a humanoid: torso = pelvis .. chest plus the weighted joints above the pelvis,
// head, arms and legs = the subtrees of the candidate's roots; weighted subtrees hanging elsewhere
// join the nearest part; the sides decide which arm and leg is left. See split_stages.h.
#include <algorithm>
#include <limits>

#include "split_stages.h"

namespace skinspheres::lib {
namespace {

using Vec3 = Eigen::Vector3d;

double PointSegmentDistance(const Vec3& p, const Vec3& a, const Vec3& b) {
  const Vec3 ab = b - a;
  const double len2 = ab.squaredNorm();
  double t = len2 > 0.0 ? (p - a).dot(ab) / len2 : 0.0;
  t = std::clamp(t, 0.0, 1.0);
  return (p - (a + t * ab)).norm();
}

// Leftovers in joint order: a weightless joint inherits its parent's part; a weighted subtree
// hanging elsewhere joins the part with the nearest core bone (point-segment distance in the
// rest pose), and continues a limb's chain when it is nearest to that chain's tip.
// Returns the attached subtree roots per (provisional) part.
std::vector<std::vector<int32_t>> AttachLeftovers(const WeightedSkeleton& ws, const HumanoidCandidate& c,
                                                  BodyParts* out) {
  std::vector<std::vector<int32_t>> extra_roots(6);
  std::vector<int32_t>& joint_part = out->joint_part;
  std::vector<bool> core(ws.n, false);
  for (int32_t j = 0; j < ws.n; ++j) core[j] = joint_part[j] >= 0;
  for (int32_t j = 0; j < ws.n; ++j) {
    if (core[j]) continue;
    const int32_t p = ws.parent[j];
    if (!ws.sub[j]) {
      joint_part[j] = p >= 0 ? joint_part[p] : -1;
      continue;
    }
    if (p >= 0 && !core[p] && joint_part[p] >= 0) {  // inside an attached subtree
      joint_part[j] = joint_part[p];
      continue;
    }
    if (ws.IsAncestor(j, c.pelvis)) continue;  // weightless ancestor of the pelvis: above the body
    double best = std::numeric_limits<double>::infinity();
    int best_part = 0;
    bool at_tip = false;
    for (int32_t a = 0; a < ws.n; ++a) {
      if (!core[a]) continue;
      const int part = joint_part[a];
      const auto& ch = out->parts[part].chain;
      double dist = (ws.jpos[j] - ws.jpos[a]).norm();
      bool tip = part > 0 && a == ch.back();
      for (int32_t b : ws.children[a]) {
        if (!core[b] || joint_part[b] != part) continue;
        const double seg = PointSegmentDistance(ws.jpos[j], ws.jpos[a], ws.jpos[b]);
        if (seg < dist) {
          dist = seg;
          tip = part > 0 && ch.size() >= 2 && a == ch[ch.size() - 2] && b == ch.back();
        }
      }
      if (dist < best || (dist == best && part < best_part)) {
        best = dist;
        best_part = part;
        at_tip = tip;
      }
    }
    joint_part[j] = best_part;
    extra_roots[best_part].push_back(j);
    if (at_tip && best_part > 1) {  // continues a limb's tip: an IK foot under the root
      const std::vector<int32_t> more = ws.MainChain(j);
      auto& ch = out->parts[best_part].chain;
      ch.insert(ch.end(), more.begin(), more.end());
    }
  }
  return extra_roots;
}

}  // namespace

// Provisional part indices while building: 0 torso, 1 head, 2/3 arm[0]/arm[1], 4/5 leg[0]/leg[1];
// the sides are decided once detached subtrees (IK feet) have joined their limbs.
void BuildHumanoid(const RawCharacter& ch, const WeightedSkeleton& ws, const HumanoidCandidate& c, BodyParts* out) {
  out->humanoid = true;
  out->parts.resize(6);
  const int32_t roots[6] = {-1, c.head, c.arm[0], c.arm[1], c.leg[0], c.leg[1]};
  for (int i = 1; i < 6; ++i) MarkSubtree(ws, roots[i], i, &out->joint_part);
  // Torso: the spine path P..C and the weighted joints above P.
  std::vector<int32_t> spine;
  for (int32_t x = c.chest; x != c.pelvis; x = ws.parent[x]) spine.push_back(x);
  spine.push_back(c.pelvis);
  std::reverse(spine.begin(), spine.end());
  for (int32_t x : spine) out->joint_part[x] = 0;
  for (int32_t x = ws.parent[c.pelvis]; x >= 0; x = ws.parent[x]) {
    if (ws.weighted[x]) out->joint_part[x] = 0;
  }
  out->parts[0].chain = spine;
  for (int i = 1; i < 6; ++i) out->parts[i].chain = ws.MainChain(roots[i]);
  const std::vector<std::vector<int32_t>> extra_roots = AttachLeftovers(ws, c, out);

  // Sides, then the provisional parts in their final order.
  const Sides sides = FindSides(ch, ws, c, out->joint_part);
  out->facing_from = sides.from;
  out->up = sides.up.cast<float>();
  out->left = sides.left.normalized().cast<float>();
  int remap[6] = {0, 1, 2, 3, 4, 5};
  if (sides.swap_arms) std::swap(remap[2], remap[3]);
  if (sides.swap_legs) std::swap(remap[4], remap[5]);
  for (int32_t& p : out->joint_part) {
    if (p >= 0) p = remap[p];
  }
  std::vector<BodyPart> parts(6);
  std::vector<std::vector<int32_t>> part_roots(6);
  for (int i = 0; i < 6; ++i) {
    parts[remap[i]].chain = std::move(out->parts[i].chain);
    if (i > 0) part_roots[remap[i]].push_back(roots[i]);
    part_roots[remap[i]].insert(part_roots[remap[i]].end(), extra_roots[i].begin(), extra_roots[i].end());
  }
  const PartKind kinds[6] = {PartKind::kTorso,    PartKind::kHead,    PartKind::kArmLeft,
                             PartKind::kArmRight, PartKind::kLegLeft, PartKind::kLegRight};
  for (int i = 0; i < 6; ++i) {
    parts[i].kind = kinds[i];
    parts[i].name = ToString(kinds[i]);
  }
  out->parts = std::move(parts);
  for (int32_t j = 0; j < ws.n; ++j) {
    if (out->joint_part[j] == 0 && (ws.parent[j] < 0 || out->joint_part[ws.parent[j]] != 0)) part_roots[0].push_back(j);
  }
  for (int i = 0; i < 6; ++i) FillJoints(ws, out->joint_part, i, part_roots[i], &out->parts[i]);
}

}  // namespace skinspheres::lib
