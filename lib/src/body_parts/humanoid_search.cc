// The humanoid search: every (pelvis P, spine s, chest C, head, arms, legs) reading of the weighted
// tree, scored by mirror symmetry, limb similarity, spine-along-up and the share of the weighted
// vertices it explains; the cheapest wins. See split_stages.h and body_parts.h.
#include <algorithm>
#include <cmath>

#include "split_stages.h"

namespace skinspheres::lib {
namespace {

using Vec3 = Eigen::Vector3d;

// The candidate's cost (lower is more humanoid): mirror symmetry of arms and legs, legs on both
// sides, head on the mirror plane, spine along up, similar limbs, and the share of the weighted
// vertices it explains. inf when a hard rule fails: legs below the pelvis, head above the chest,
// arms above the legs, chest not below the pelvis, arms (or legs) apart sideways.
double Score(const WeightedSkeleton& ws, const HumanoidCandidate& c) {
  const double inf = std::numeric_limits<double>::infinity();
  const Vec3 P = ws.jpos[c.pelvis], C = ws.jpos[c.chest];
  const Vec3 L0 = ws.subtree[c.leg[0]].Centroid(), L1 = ws.subtree[c.leg[1]].Centroid();
  const Vec3 A0 = ws.subtree[c.arm[0]].Centroid(), A1 = ws.subtree[c.arm[1]].Centroid();
  const Vec3 H = ws.subtree[c.head].Centroid();
  const Vec3 mid_leg = 0.5 * (L0 + L1);
  const double height = (H - mid_leg).norm();
  if (!(height > 0.0)) return inf;
  const Vec3 u = (H - mid_leg) / height;
  // Legs below the pelvis, head above the chest, arms above the legs.
  if ((L0 - P).dot(u) >= 0.0 || (L1 - P).dot(u) >= 0.0) return inf;
  if ((H - C).dot(u) <= 0.0) return inf;
  if ((A0 - mid_leg).dot(u) <= 0.0 || (A1 - mid_leg).dot(u) <= 0.0) return inf;
  if ((C - P).dot(u) < -0.05 * height) return inf;
  // Mirror plane between the arms (normal l through their midpoint m).
  Vec3 lat = (A0 - A1) - (A0 - A1).dot(u) * u;
  if (lat.norm() < 1e-9 * height) lat = (L0 - L1) - (L0 - L1).dot(u) * u;
  if (lat.norm() < 1e-9 * height) return inf;
  const Vec3 l = lat.normalized();
  const Vec3 m = 0.5 * (A0 + A1);
  auto reflect = [&](const Vec3& x) { return Vec3(x - 2.0 * (x - m).dot(l) * l); };
  double cost = 0.0;
  cost += (reflect(A0) - A1).norm() / height;
  cost += (reflect(L0) - L1).norm() / height;
  // Legs on opposite sides of the mirror plane.
  if ((L0 - m).dot(l) * (L1 - m).dot(l) >= 0.0) cost += 0.5;
  // Head near the mirror plane, spine along up.
  cost += std::abs((H - m).dot(l)) / height;
  const double spine_len = (C - P).norm();
  if (spine_len > 1e-6 * height) cost += 0.5 * (1.0 - std::max(0.0, (C - P).dot(u) / spine_len));
  // Similar limbs (weighted joint counts).
  auto mismatch = [&](int32_t a, int32_t b) {
    const double na = ws.subtree_weighted[a], nb = ws.subtree_weighted[b];
    return std::abs(na - nb) / std::max(1.0, std::max(na, nb));
  };
  cost += 0.5 * (mismatch(c.leg[0], c.leg[1]) + mismatch(c.arm[0], c.arm[1]));
  // Coverage: share of the weighted vertices (or joints) that the six parts' cores hold.
  double covered = ws.subtree_vertices[c.leg[0]] + ws.subtree_vertices[c.leg[1]] + ws.subtree_vertices[c.arm[0]] +
                   ws.subtree_vertices[c.arm[1]] + ws.subtree_vertices[c.head];
  double covered_joints = ws.subtree_weighted[c.leg[0]] + ws.subtree_weighted[c.leg[1]] +
                          ws.subtree_weighted[c.arm[0]] + ws.subtree_weighted[c.arm[1]] + ws.subtree_weighted[c.head];
  for (int32_t x = c.chest; x >= 0; x = ws.parent[x]) {  // the spine path and everything above P
    covered += ws.own_vertices[x];
    covered_joints += ws.weighted[x] ? 1 : 0;
  }
  if (ws.total_vertices > 0.0) {
    cost += 1.0 - covered / ws.total_vertices;
  } else {
    cost += 1.0 - covered_joints / std::max(1, ws.total_weighted);
  }
  return cost;
}

}  // namespace

HumanoidCandidate FindHumanoid(const WeightedSkeleton& ws) {
  HumanoidCandidate best;
  std::vector<int32_t> branch_nodes;
  for (int32_t j = 0; j < ws.n; ++j) {
    if (ws.wchildren[j].size() >= 3) branch_nodes.push_back(j);
  }
  // Only the kMaxCandidates heaviest weighted children of a branch (by skinned vertices below
  // them) can be a leg, the spine, an arm or the head: the search is O(K^5) in the children, and
  // rigs with skirt or hair bones under the pelvis or chest have dozens of light ones.
  constexpr size_t kMaxCandidates = 6;
  std::vector<std::vector<int32_t>> top(ws.n);
  for (int32_t b : branch_nodes) {
    std::vector<int32_t> kids = ws.wchildren[b];
    std::stable_sort(kids.begin(), kids.end(),
                     [&](int32_t x, int32_t y) { return ws.subtree_vertices[x] > ws.subtree_vertices[y]; });
    if (kids.size() > kMaxCandidates) kids.resize(kMaxCandidates);
    std::sort(kids.begin(), kids.end());  // back to index order: ties still go to the lowest indices
    top[b] = std::move(kids);
  }
  for (int32_t p : branch_nodes) {
    for (int32_t s : top[p]) {
      for (int32_t c : branch_nodes) {
        if (c == p || !ws.IsAncestor(s, c)) continue;
        const auto& pc = top[p];
        const auto& cc = top[c];
        for (int32_t h : cc) {
          for (size_t a0 = 0; a0 < cc.size(); ++a0) {
            for (size_t a1 = a0 + 1; a1 < cc.size(); ++a1) {
              if (cc[a0] == h || cc[a1] == h) continue;
              for (size_t l0 = 0; l0 < pc.size(); ++l0) {
                for (size_t l1 = l0 + 1; l1 < pc.size(); ++l1) {
                  if (pc[l0] == s || pc[l1] == s) continue;
                  HumanoidCandidate cand;
                  cand.pelvis = p;
                  cand.spine_child = s;
                  cand.chest = c;
                  cand.head = h;
                  cand.arm[0] = cc[a0];
                  cand.arm[1] = cc[a1];
                  cand.leg[0] = pc[l0];
                  cand.leg[1] = pc[l1];
                  cand.cost = Score(ws, cand);
                  if (cand.cost < best.cost) best = cand;  // strict: first (lowest indices) wins ties
                }
              }
            }
          }
        }
      }
    }
  }
  return best;
}

}  // namespace skinspheres::lib
