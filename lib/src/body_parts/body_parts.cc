// Body parts from skeleton topology, skin weights and rest-pose geometry (see body_parts.h).
//
// Steps: (1) dominant joint per vertex and per triangle; (2) the weighted tree (joints whose
// subtree carries weight); (3) every (pelvis P, spine child s, chest C, head h, arms, legs)
// candidate scored by symmetry, coverage and up-direction; (4) left/right from the feet;
// (5) leftover weighted subtrees to the nearest part; (6) overrides. The fitter (paper §3,
// disk of rays) then walks each part's `chain`.
#include "skinspheres/lib/body_parts/body_parts.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cctype>
#include <cmath>
#include <fstream>
#include <limits>
#include <nlohmann/json.hpp>
#include <sstream>
#include <system_error>

namespace skinspheres::lib {

const char* PartKindName(PartKind kind) {
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

using Vec3 = Eigen::Vector3d;

bool IsValidPartName(const std::string& name) {
  static const char* kNames[] = {"torso", "head", "arm_l", "arm_r", "leg_l", "leg_r"};
  for (const char* n : kNames) {
    if (name == n) return true;
  }
  if (name.rfind("chain_", 0) == 0 && name.size() > 6) {
    for (size_t i = 6; i < name.size(); ++i) {
      if (!std::isdigit(static_cast<unsigned char>(name[i]))) return false;
    }
    return true;
  }
  return false;
}

// +1 for a name that says left, -1 for right, 0 otherwise. Tokens split at non-alphanumerics,
// lower->upper case changes and letter/digit changes: "mixamorig:LeftArm" -> mixamorig left arm,
// "UpperLeg.L" -> upper leg l, "leg_joint_R_1" -> leg joint r 1.
int NameSide(const std::string& name) {
  std::vector<std::string> tokens;
  std::string cur;
  auto flush = [&] {
    if (!cur.empty()) tokens.push_back(cur);
    cur.clear();
  };
  for (size_t i = 0; i < name.size(); ++i) {
    const unsigned char c = static_cast<unsigned char>(name[i]);
    if (!std::isalnum(c)) {
      flush();
      continue;
    }
    if (!cur.empty()) {
      const unsigned char p = static_cast<unsigned char>(name[i - 1]);
      const bool case_break = std::islower(p) && std::isupper(c);
      const bool digit_break = (std::isdigit(p) != 0) != (std::isdigit(c) != 0);
      if (case_break || digit_break) flush();
    }
    cur.push_back(static_cast<char>(std::tolower(c)));
  }
  flush();
  int side = 0;
  for (const std::string& t : tokens) {
    if (t == "left" || t == "l" || t == "lft") side += 1;
    if (t == "right" || t == "r" || t == "rt" || t == "rgt") side -= 1;
  }
  return side > 0 ? 1 : (side < 0 ? -1 : 0);
}

struct PointStats {
  Vec3 sum = Vec3::Zero();
  double count = 0.0;
  Vec3 Centroid() const { return count > 0.0 ? Vec3(sum / count) : Vec3::Zero(); }
};

struct Candidate {
  int32_t pelvis = -1, spine_child = -1, chest = -1, head = -1;
  int32_t arm[2] = {-1, -1};
  int32_t leg[2] = {-1, -1};
  double cost = std::numeric_limits<double>::infinity();
};

double PointSegmentDistance(const Vec3& p, const Vec3& a, const Vec3& b) {
  const Vec3 ab = b - a;
  const double len2 = ab.squaredNorm();
  double t = len2 > 0.0 ? (p - a).dot(ab) / len2 : 0.0;
  t = std::clamp(t, 0.0, 1.0);
  return (p - (a + t * ab)).norm();
}

class Splitter {
 public:
  explicit Splitter(const RawCharacter& ch) : ch_(ch) {}

  Result<BodyParts> Run(const PartOverrides* overrides) {
    if (auto err = ValidateInput(); err.code != ErrorCode::kOk) return err;
    BuildTopology();
    DominantJoints();
    BuildWeightedTree();
    out_.joint_part.assign(n_, -1);
    const Candidate best = FindHumanoid();
    if (best.cost < kHumanoidMaxCost) {
      BuildHumanoid(best);
    } else {
      BuildChains();
    }
    if (overrides != nullptr) {
      if (auto err = ApplyOverrides(*overrides); err.code != ErrorCode::kOk) return err;
    }
    AssignTriangles();
    return std::move(out_);
  }

 private:
  static constexpr double kHumanoidMaxCost = 1.5;

  Error Fail(ErrorCode code, const std::string& what) const {
    return MakeError(code, (ch_.source_file.empty() ? std::string("<character>") : ch_.source_file) + ": " + what);
  }

  Error ValidateInput() {
    const auto& sk = ch_.skeleton;
    if (sk.size() == 0) return Fail(ErrorCode::kInvalidData, "skeleton has no joints");
    if (!sk.Validate()) return Fail(ErrorCode::kInvalidData, "skeleton arrays disagree in size or parents are not ordered parents-first");
    n_ = static_cast<int32_t>(sk.size());
    const size_t nv = ch_.positions_rest.size();
    for (size_t t = 0; t < ch_.triangles.size(); ++t) {
      for (int k = 0; k < 3; ++k) {
        const int idx = ch_.triangles[t][k];
        if (idx < 0 || static_cast<size_t>(idx) >= nv) {
          return Fail(ErrorCode::kInvalidData, "triangle " + std::to_string(t) + " uses vertex " + std::to_string(idx) +
                                                   " of " + std::to_string(nv));
        }
      }
    }
    const auto& skin = ch_.skin;
    has_skin_ = skin.vertex_count() > 0;
    if (!has_skin_) return {};
    if (skin.vertex_count() != nv) {
      return Fail(ErrorCode::kInvalidData, "skin has " + std::to_string(skin.vertex_count()) + " vertices, mesh has " +
                                               std::to_string(nv));
    }
    if (skin.influence_offsets.size() != nv + 1 || skin.influence_offsets.front() != 0 ||
        skin.influence_offsets.back() != skin.influence_binds.size() ||
        skin.influence_binds.size() != skin.influence_weights.size()) {
      return Fail(ErrorCode::kInvalidData, "skin influence arrays disagree in size");
    }
    for (size_t v = 0; v < nv; ++v) {
      if (skin.influence_offsets[v] > skin.influence_offsets[v + 1]) {
        return Fail(ErrorCode::kInvalidData, "skin influence offsets decrease at vertex " + std::to_string(v));
      }
    }
    for (size_t b = 0; b < skin.binds.size(); ++b) {
      if (skin.binds[b].joint < 0 || skin.binds[b].joint >= n_) {
        return Fail(ErrorCode::kInvalidData, "bind entry " + std::to_string(b) + " names joint " +
                                                 std::to_string(skin.binds[b].joint) + " of " + std::to_string(n_));
      }
    }
    for (size_t i = 0; i < skin.influence_binds.size(); ++i) {
      if (skin.influence_binds[i] >= skin.binds.size()) {
        return Fail(ErrorCode::kInvalidData, "influence " + std::to_string(i) + " uses bind entry " +
                                                 std::to_string(skin.influence_binds[i]) + " of " +
                                                 std::to_string(skin.binds.size()));
      }
      if (!std::isfinite(skin.influence_weights[i])) {
        return Fail(ErrorCode::kInvalidData, "influence " + std::to_string(i) + " has a non-finite weight");
      }
    }
    for (const MeshRange& m : ch_.meshes) {
      if (m.rigid_joint >= n_) {
        return Fail(ErrorCode::kInvalidData, "mesh '" + m.name + "' follows joint " + std::to_string(m.rigid_joint) +
                                                 " of " + std::to_string(n_));
      }
    }
    return {};
  }

  void BuildTopology() {
    const auto& sk = ch_.skeleton;
    parent_ = sk.parents;
    children_.assign(n_, {});
    for (int32_t j = 0; j < n_; ++j) {
      if (parent_[j] >= 0) children_[parent_[j]].push_back(j);
    }
    std::vector<Mat4f> world(n_);
    sk.RestWorld(world);
    jpos_.resize(n_);
    for (int32_t j = 0; j < n_; ++j) jpos_[j] = world[j].topRightCorner<3, 1>().cast<double>();
  }

  // Vertex: the joint of largest weight; triangle: largest summed weight over its 3 vertices.
  // Ties -> smallest joint index.
  void DominantJoints() {
    const size_t nv = ch_.positions_rest.size();
    const auto& skin = ch_.skin;
    vertex_joint_.assign(nv, -1);
    std::vector<std::pair<int32_t, float>> acc;
    auto add = [&acc](int32_t joint, float w) {
      for (auto& e : acc) {
        if (e.first == joint) {
          e.second += w;
          return;
        }
      }
      acc.emplace_back(joint, w);
    };
    auto best_of = [&acc]() {
      int32_t best = -1;
      float best_w = 0.0f;
      for (const auto& e : acc) {
        if (e.second <= 0.0f) continue;
        if (best < 0 || e.second > best_w || (e.second == best_w && e.first < best)) {
          best = e.first;
          best_w = e.second;
        }
      }
      return best;
    };
    auto add_vertex = [&](size_t v) {
      for (uint32_t i = skin.influence_offsets[v]; i < skin.influence_offsets[v + 1]; ++i) {
        add(skin.binds[skin.influence_binds[i]].joint, skin.influence_weights[i]);
      }
    };
    if (has_skin_) {
      for (size_t v = 0; v < nv; ++v) {
        acc.clear();
        add_vertex(v);
        vertex_joint_[v] = best_of();
      }
    }
    // Fallback joint for weightless triangles: their mesh's rigid joint, else the first root.
    std::vector<int32_t> tri_fallback(ch_.triangles.size(), 0);
    for (const MeshRange& m : ch_.meshes) {
      if (m.rigid_joint < 0) continue;
      const size_t end = std::min<size_t>(ch_.triangles.size(), size_t{m.first_triangle} + m.triangle_count);
      for (size_t t = m.first_triangle; t < end; ++t) tri_fallback[t] = m.rigid_joint;
    }
    out_.triangle_joint.assign(ch_.triangles.size(), 0);
    for (size_t t = 0; t < ch_.triangles.size(); ++t) {
      acc.clear();
      if (has_skin_) {
        for (int k = 0; k < 3; ++k) add_vertex(static_cast<size_t>(ch_.triangles[t][k]));
      }
      const int32_t best = best_of();
      out_.triangle_joint[t] = best >= 0 ? best : tri_fallback[t];
    }
  }

  void BuildWeightedTree() {
    weighted_.assign(n_, false);
    for (int32_t j : vertex_joint_) {
      if (j >= 0) weighted_[j] = true;
    }
    for (int32_t j : out_.triangle_joint) weighted_[j] = true;
    if (std::none_of(weighted_.begin(), weighted_.end(), [](bool b) { return b; })) {
      weighted_.assign(n_, true);  // a bare skeleton: every joint counts
    }
    sub_ = weighted_;
    for (int32_t j = n_ - 1; j >= 0; --j) {
      if (sub_[j] && parent_[j] >= 0) sub_[parent_[j]] = true;
    }
    wchildren_.assign(n_, {});
    for (int32_t j = 0; j < n_; ++j) {
      for (int32_t c : children_[j]) {
        if (sub_[c]) wchildren_[j].push_back(c);
      }
    }
    // Subtree point statistics: vertices by their dominant joint plus joint positions.
    own_.assign(n_, PointStats{});
    for (size_t v = 0; v < vertex_joint_.size(); ++v) {
      const int32_t j = vertex_joint_[v];
      if (j < 0) continue;
      own_[j].sum += ch_.positions_rest[v].cast<double>();
      own_[j].count += 1.0;
    }
    own_vertices_.assign(n_, 0.0);
    for (int32_t j = 0; j < n_; ++j) {
      own_vertices_[j] = own_[j].count;
      own_[j].sum += jpos_[j];
      own_[j].count += 1.0;
    }
    subtree_ = own_;
    subtree_vertices_ = own_vertices_;
    subtree_weighted_.assign(n_, 0);
    for (int32_t j = 0; j < n_; ++j) subtree_weighted_[j] = weighted_[j] ? 1 : 0;
    for (int32_t j = n_ - 1; j >= 0; --j) {
      const int32_t p = parent_[j];
      if (p < 0) continue;
      subtree_[p].sum += subtree_[j].sum;
      subtree_[p].count += subtree_[j].count;
      subtree_vertices_[p] += subtree_vertices_[j];
      subtree_weighted_[p] += subtree_weighted_[j];
    }
    total_vertices_ = 0.0;
    for (int32_t j = 0; j < n_; ++j) total_vertices_ += own_vertices_[j];
    total_weighted_ = 0;
    for (int32_t j = 0; j < n_; ++j) total_weighted_ += weighted_[j] ? 1 : 0;
  }

  bool IsAncestor(int32_t a, int32_t j) const {  // a is j or above j
    for (int32_t x = j; x >= 0; x = parent_[x]) {
      if (x == a) return true;
    }
    return false;
  }

  // Scores every (P, s, C, head, arms, legs) candidate; returns the cheapest (cost = inf if none).
  Candidate FindHumanoid() const {
    Candidate best;
    std::vector<int32_t> branch_nodes;
    for (int32_t j = 0; j < n_; ++j) {
      if (wchildren_[j].size() >= 3) branch_nodes.push_back(j);
    }
    // Only the kMaxCandidates heaviest weighted children of a branch (by skinned vertices below
    // them) can be a leg, the spine, an arm or the head: the search is O(K^5) in the children, and
    // rigs with skirt or hair bones under the pelvis or chest have dozens of light ones.
    constexpr size_t kMaxCandidates = 6;
    std::vector<std::vector<int32_t>> top(n_);
    for (int32_t b : branch_nodes) {
      std::vector<int32_t> kids = wchildren_[b];
      std::stable_sort(kids.begin(), kids.end(),
                       [&](int32_t x, int32_t y) { return subtree_vertices_[x] > subtree_vertices_[y]; });
      if (kids.size() > kMaxCandidates) kids.resize(kMaxCandidates);
      std::sort(kids.begin(), kids.end());  // back to index order: ties still go to the lowest indices
      top[b] = std::move(kids);
    }
    for (int32_t p : branch_nodes) {
      for (int32_t s : top[p]) {
        for (int32_t c : branch_nodes) {
          if (c == p || !IsAncestor(s, c)) continue;
          const auto& pc = top[p];
          const auto& cc = top[c];
          for (int32_t h : cc) {
            for (size_t a0 = 0; a0 < cc.size(); ++a0) {
              for (size_t a1 = a0 + 1; a1 < cc.size(); ++a1) {
                if (cc[a0] == h || cc[a1] == h) continue;
                for (size_t l0 = 0; l0 < pc.size(); ++l0) {
                  for (size_t l1 = l0 + 1; l1 < pc.size(); ++l1) {
                    if (pc[l0] == s || pc[l1] == s) continue;
                    Candidate cand;
                    cand.pelvis = p;
                    cand.spine_child = s;
                    cand.chest = c;
                    cand.head = h;
                    cand.arm[0] = cc[a0];
                    cand.arm[1] = cc[a1];
                    cand.leg[0] = pc[l0];
                    cand.leg[1] = pc[l1];
                    cand.cost = Score(cand);
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

  double Score(const Candidate& c) const {
    const double inf = std::numeric_limits<double>::infinity();
    const Vec3 P = jpos_[c.pelvis], C = jpos_[c.chest];
    const Vec3 L0 = subtree_[c.leg[0]].Centroid(), L1 = subtree_[c.leg[1]].Centroid();
    const Vec3 A0 = subtree_[c.arm[0]].Centroid(), A1 = subtree_[c.arm[1]].Centroid();
    const Vec3 H = subtree_[c.head].Centroid();
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
      const double na = subtree_weighted_[a], nb = subtree_weighted_[b];
      return std::abs(na - nb) / std::max(1.0, std::max(na, nb));
    };
    cost += 0.5 * (mismatch(c.leg[0], c.leg[1]) + mismatch(c.arm[0], c.arm[1]));
    // Coverage: share of the weighted vertices (or joints) that the six parts' cores hold.
    double covered = subtree_vertices_[c.leg[0]] + subtree_vertices_[c.leg[1]] + subtree_vertices_[c.arm[0]] +
                     subtree_vertices_[c.arm[1]] + subtree_vertices_[c.head];
    double covered_joints = subtree_weighted_[c.leg[0]] + subtree_weighted_[c.leg[1]] + subtree_weighted_[c.arm[0]] +
                            subtree_weighted_[c.arm[1]] + subtree_weighted_[c.head];
    for (int32_t x = c.chest; x >= 0; x = parent_[x]) {  // the spine path and everything above P
      covered += own_vertices_[x];
      covered_joints += weighted_[x] ? 1 : 0;
    }
    if (total_vertices_ > 0.0) {
      cost += 1.0 - covered / total_vertices_;
    } else {
      cost += 1.0 - covered_joints / std::max(1, total_weighted_);
    }
    return cost;
  }

  // Points of a part: its joints' positions and the vertices whose dominant joint it holds.
  std::vector<Vec3> PartPoints(int32_t part) const {
    std::vector<Vec3> pts;
    for (int32_t j = 0; j < n_; ++j) {
      if (out_.joint_part[j] == part) pts.push_back(jpos_[j]);
    }
    for (size_t v = 0; v < vertex_joint_.size(); ++v) {
      if (vertex_joint_[v] >= 0 && out_.joint_part[vertex_joint_[v]] == part) {
        pts.push_back(ch_.positions_rest[v].cast<double>());
      }
    }
    return pts;
  }

  // How far the foot reaches along `d` beyond the shin: centroid of the lowest 10% of the leg
  // minus centroid of the 10%..30% band. Returns {offset, leg length}.
  std::pair<double, double> FootReach(int32_t leg_part, const Vec3& u, const Vec3& d) const {
    const std::vector<Vec3> pts = PartPoints(leg_part);
    double hmin = std::numeric_limits<double>::infinity(), hmax = -hmin;
    for (const Vec3& p : pts) {
      hmin = std::min(hmin, p.dot(u));
      hmax = std::max(hmax, p.dot(u));
    }
    const double len = hmax - hmin;
    if (!(len > 0.0)) return {0.0, 0.0};
    PointStats foot, shin;
    for (const Vec3& p : pts) {
      const double h = (p.dot(u) - hmin) / len;
      if (h <= 0.1) {
        foot.sum += p;
        foot.count += 1.0;
      } else if (h <= 0.3) {
        shin.sum += p;
        shin.count += 1.0;
      }
    }
    if (foot.count == 0.0 || shin.count == 0.0) return {0.0, len};
    return {(foot.Centroid() - shin.Centroid()).dot(d), len};
  }

  void MarkSubtree(int32_t root, int32_t part) {
    std::vector<int32_t> stack{root};
    while (!stack.empty()) {
      const int32_t j = stack.back();
      stack.pop_back();
      out_.joint_part[j] = part;
      for (auto it = children_[j].rbegin(); it != children_[j].rend(); ++it) stack.push_back(*it);
    }
  }

  // Main chain from `root`: at a fork, continue to the child (weighted subtrees first) whose
  // subtree holds the joint farthest from `root` in the rest pose (the middle finger, the toe);
  // ties -> smallest index.
  std::vector<int32_t> MainChain(int32_t root) const {
    std::vector<double> far(n_, -1.0);
    for (int32_t j = n_ - 1; j >= root; --j) {
      if (!IsAncestor(root, j)) continue;
      far[j] = std::max(far[j], (jpos_[j] - jpos_[root]).norm());
      if (j != root) far[parent_[j]] = std::max(far[parent_[j]], far[j]);
    }
    std::vector<int32_t> chain{root};
    int32_t cur = root;
    while (!children_[cur].empty()) {
      int32_t next = -1;
      for (int pass = 0; pass < 2 && next < 0; ++pass) {
        for (int32_t c : children_[cur]) {
          if (pass == 0 && !sub_[c]) continue;
          if (next < 0 || far[c] > far[next]) next = c;
        }
      }
      chain.push_back(next);
      cur = next;
    }
    return chain;
  }

  // joints = chain, then the part's other joints depth-first from the chain's side branches.
  void FillJoints(BodyPart& part, int32_t part_index, const std::vector<int32_t>& roots) {
    std::vector<bool> listed(n_, false);
    part.joints.clear();
    for (int32_t j : part.chain) {
      part.joints.push_back(j);
      listed[j] = true;
    }
    std::vector<int32_t> order = part.chain;
    for (int32_t r : roots) {
      if (!listed[r] && std::find(order.begin(), order.end(), r) == order.end()) order.push_back(r);
    }
    for (size_t i = 0; i < order.size(); ++i) {
      std::vector<int32_t> stack{order[i]};
      while (!stack.empty()) {
        const int32_t j = stack.back();
        stack.pop_back();
        if (out_.joint_part[j] != part_index) continue;
        if (!listed[j]) {
          listed[j] = true;
          part.joints.push_back(j);
        }
        for (auto it = children_[j].rbegin(); it != children_[j].rend(); ++it) {
          if (!listed[*it]) stack.push_back(*it);
        }
      }
    }
  }

  // Provisional part indices while building: 0 torso, 1 head, 2/3 arm[0]/arm[1], 4/5 leg[0]/leg[1];
  // the sides are decided once detached subtrees (IK feet) have joined their limbs.
  void BuildHumanoid(const Candidate& c) {
    out_.humanoid = true;
    out_.parts.resize(6);
    const int32_t roots[6] = {-1, c.head, c.arm[0], c.arm[1], c.leg[0], c.leg[1]};
    for (int i = 1; i < 6; ++i) MarkSubtree(roots[i], i);
    // Torso: the spine path P..C and the weighted joints above P.
    std::vector<int32_t> spine;
    for (int32_t x = c.chest; x != c.pelvis; x = parent_[x]) spine.push_back(x);
    spine.push_back(c.pelvis);
    std::reverse(spine.begin(), spine.end());
    for (int32_t x : spine) out_.joint_part[x] = 0;
    for (int32_t x = parent_[c.pelvis]; x >= 0; x = parent_[x]) {
      if (weighted_[x]) out_.joint_part[x] = 0;
    }
    out_.parts[0].chain = spine;
    for (int i = 1; i < 6; ++i) out_.parts[i].chain = MainChain(roots[i]);
    const std::vector<std::vector<int32_t>> extra_roots = AttachLeftovers(c);

    // Sides. up u: legs -> head; l0: between the arms; forward from the feet; left = u x forward.
    const Vec3 L[2] = {subtree_[c.leg[0]].Centroid(), subtree_[c.leg[1]].Centroid()};
    const Vec3 A[2] = {subtree_[c.arm[0]].Centroid(), subtree_[c.arm[1]].Centroid()};
    const Vec3 H = subtree_[c.head].Centroid();
    const Vec3 mid_leg = 0.5 * (L[0] + L[1]);
    const Vec3 u = (H - mid_leg).normalized();
    Vec3 lat = (A[0] - A[1]) - (A[0] - A[1]).dot(u) * u;
    if (lat.norm() < 1e-12) lat = (L[0] - L[1]) - (L[0] - L[1]).dot(u) * u;
    const Vec3 l0 = lat.normalized();
    const Vec3 d = u.cross(l0);
    const auto r0 = FootReach(4, u, d), r1 = FootReach(5, u, d);
    const double reach = r0.first + r1.first, leg_len = 0.5 * (r0.second + r1.second);
    Vec3 left;
    if (leg_len > 0.0 && std::abs(reach) > 0.02 * leg_len) {
      left = u.cross(reach > 0.0 ? d : Vec3(-d));
      out_.facing_from = "feet";
    } else {
      // Names break the tie: each limb votes with its side of the l0 axis.
      int vote = 0;
      auto side_vote = [&](int part, const Vec3& centroid) {
        int name_score = 0;
        for (int32_t j = 0; j < n_; ++j) {
          if (out_.joint_part[j] == part) name_score += NameSide(ch_.skeleton.joint_names[j]);
        }
        const double s = (centroid - mid_leg).dot(l0);
        vote += (s > 0 ? 1 : (s < 0 ? -1 : 0)) * (name_score > 0 ? 1 : (name_score < 0 ? -1 : 0));
      };
      for (int i = 0; i < 2; ++i) {
        side_vote(2 + i, A[i]);
        side_vote(4 + i, L[i]);
      }
      if (vote != 0) {
        left = vote > 0 ? l0 : Vec3(-l0);
        out_.facing_from = "names";
      } else {
        // glTF convention: the character faces +Z.
        Vec3 fwd = Vec3::UnitZ() - Vec3::UnitZ().dot(u) * u;
        if (fwd.norm() < 1e-6) fwd = Vec3::UnitX() - Vec3::UnitX().dot(u) * u;
        left = u.cross(fwd.normalized());
        out_.facing_from = "convention";
      }
    }
    out_.up = u.cast<float>();
    out_.left = left.normalized().cast<float>();
    const bool swap_arms = (A[0] - mid_leg).dot(left) < (A[1] - mid_leg).dot(left);
    const bool swap_legs = (L[0] - mid_leg).dot(left) < (L[1] - mid_leg).dot(left);
    int remap[6] = {0, 1, 2, 3, 4, 5};
    if (swap_arms) std::swap(remap[2], remap[3]);
    if (swap_legs) std::swap(remap[4], remap[5]);
    for (int32_t& p : out_.joint_part) {
      if (p >= 0) p = remap[p];
    }
    std::vector<BodyPart> parts(6);
    std::vector<std::vector<int32_t>> part_roots(6);
    for (int i = 0; i < 6; ++i) {
      parts[remap[i]].chain = std::move(out_.parts[i].chain);
      if (i > 0) part_roots[remap[i]].push_back(roots[i]);
      part_roots[remap[i]].insert(part_roots[remap[i]].end(), extra_roots[i].begin(), extra_roots[i].end());
    }
    const PartKind kinds[6] = {PartKind::kTorso,   PartKind::kHead,    PartKind::kArmLeft,
                               PartKind::kArmRight, PartKind::kLegLeft, PartKind::kLegRight};
    for (int i = 0; i < 6; ++i) {
      parts[i].kind = kinds[i];
      parts[i].name = PartKindName(kinds[i]);
    }
    out_.parts = std::move(parts);
    for (int32_t j = 0; j < n_; ++j) {
      if (out_.joint_part[j] == 0 && (parent_[j] < 0 || out_.joint_part[parent_[j]] != 0)) part_roots[0].push_back(j);
    }
    for (int i = 0; i < 6; ++i) FillJoints(out_.parts[i], i, part_roots[i]);
  }

  // Leftovers in joint order: a weightless joint inherits its parent's part; a weighted subtree
  // hanging elsewhere joins the part with the nearest core bone (point-segment distance in the
  // rest pose), and continues a limb's chain when it is nearest to that chain's tip.
  // Returns the attached subtree roots per (provisional) part.
  std::vector<std::vector<int32_t>> AttachLeftovers(const Candidate& c) {
    std::vector<std::vector<int32_t>> extra_roots(6);
    std::vector<bool> core(n_, false);
    for (int32_t j = 0; j < n_; ++j) core[j] = out_.joint_part[j] >= 0;
    for (int32_t j = 0; j < n_; ++j) {
      if (core[j]) continue;
      const int32_t p = parent_[j];
      if (!sub_[j]) {
        out_.joint_part[j] = p >= 0 ? out_.joint_part[p] : -1;
        continue;
      }
      if (p >= 0 && !core[p] && out_.joint_part[p] >= 0) {  // inside an attached subtree
        out_.joint_part[j] = out_.joint_part[p];
        continue;
      }
      if (IsAncestor(j, c.pelvis)) continue;  // weightless ancestor of the pelvis: above the body
      double best = std::numeric_limits<double>::infinity();
      int best_part = 0;
      bool at_tip = false;
      for (int32_t a = 0; a < n_; ++a) {
        if (!core[a]) continue;
        const int part = out_.joint_part[a];
        const auto& ch = out_.parts[part].chain;
        double dist = (jpos_[j] - jpos_[a]).norm();
        bool tip = part > 0 && a == ch.back();
        for (int32_t b : children_[a]) {
          if (!core[b] || out_.joint_part[b] != part) continue;
          const double seg = PointSegmentDistance(jpos_[j], jpos_[a], jpos_[b]);
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
      out_.joint_part[j] = best_part;
      extra_roots[best_part].push_back(j);
      if (at_tip && best_part > 1) {  // continues a limb's tip: an IK foot under the root
        const std::vector<int32_t> more = MainChain(j);
        auto& ch = out_.parts[best_part].chain;
        ch.insert(ch.end(), more.begin(), more.end());
      }
    }
    return extra_roots;
  }

  void BuildChains() {
    out_.humanoid = false;
    std::vector<int32_t> starts;  // chain start joints, depth-first
    // Above the body: weightless joints with a single weighted child stay -1.
    std::vector<int32_t> stack;
    for (int32_t r = n_ - 1; r >= 0; --r) {
      if (parent_[r] < 0 && sub_[r]) stack.push_back(r);
    }
    std::vector<int32_t> body_roots;
    while (!stack.empty()) {
      const int32_t j = stack.back();
      stack.pop_back();
      if (!weighted_[j]) {
        if (wchildren_[j].size() == 1) {
          stack.push_back(wchildren_[j][0]);
          continue;
        }
        if (wchildren_[j].size() >= 2) {
          for (auto it = wchildren_[j].rbegin(); it != wchildren_[j].rend(); ++it) stack.push_back(*it);
          continue;
        }
      }
      body_roots.push_back(j);
    }
    // Depth-first over chains.
    std::vector<int32_t> todo(body_roots.rbegin(), body_roots.rend());
    while (!todo.empty()) {
      const int32_t s = todo.back();
      todo.pop_back();
      const int32_t index = static_cast<int32_t>(out_.parts.size());
      BodyPart part;
      part.kind = PartKind::kChain;
      part.name = "chain_" + std::to_string(index);
      int32_t cur = s;
      part.chain.push_back(cur);
      while (wchildren_[cur].size() == 1) {
        cur = wchildren_[cur][0];
        part.chain.push_back(cur);
      }
      if (wchildren_[cur].empty()) {  // on to the weightless tip
        const std::vector<int32_t> tail = MainChain(cur);
        part.chain.insert(part.chain.end(), tail.begin() + 1, tail.end());
      }
      for (int32_t j : part.chain) out_.joint_part[j] = index;
      out_.parts.push_back(std::move(part));
      for (auto it = wchildren_[cur].rbegin(); it != wchildren_[cur].rend(); ++it) todo.push_back(*it);
    }
    // Weightless joints inherit their parent's part.
    for (int32_t j = 0; j < n_; ++j) {
      if (out_.joint_part[j] < 0 && !sub_[j] && parent_[j] >= 0) out_.joint_part[j] = out_.joint_part[parent_[j]];
    }
    for (size_t i = 0; i < out_.parts.size(); ++i) FillJoints(out_.parts[i], static_cast<int32_t>(i), {});
  }

  Error ApplyOverrides(const PartOverrides& ov) {
    const std::string src = ov.source_file.empty() ? std::string("<overrides>") : ov.source_file;
    for (const auto& [joint_name, part_name] : ov.joint_to_part) {
      const int32_t j = ch_.skeleton.Find(joint_name);
      if (j < 0) {
        return MakeError(ErrorCode::kNotFound, src + ": joint '" + joint_name + "' is not in " +
                                                   (ch_.source_file.empty() ? std::string("the character") : ch_.source_file));
      }
      const int32_t p = out_.Find(part_name);
      if (p < 0) {
        std::string have;
        for (const BodyPart& bp : out_.parts) have += (have.empty() ? "" : ", ") + bp.name;
        return MakeError(ErrorCode::kInvalidArgument, src + ": joint '" + joint_name + "' -> part '" + part_name +
                                                          "', which this character does not have (" + have + ")");
      }
      const int32_t old = out_.joint_part[j];
      if (old == p) continue;
      if (old >= 0) {
        auto& oj = out_.parts[old].joints;
        oj.erase(std::remove(oj.begin(), oj.end(), j), oj.end());
        auto& oc = out_.parts[old].chain;
        oc.erase(std::remove(oc.begin(), oc.end(), j), oc.end());
      }
      out_.joint_part[j] = p;
      out_.parts[p].joints.push_back(j);
    }
    return {};
  }

  void AssignTriangles() {
    out_.triangle_part.assign(ch_.triangles.size(), -1);
    for (size_t t = 0; t < ch_.triangles.size(); ++t) {
      int32_t p = out_.joint_part[out_.triangle_joint[t]];
      if (p < 0) p = 0;  // cannot happen: a dominant joint is weighted, hence in a part
      out_.triangle_part[t] = p;
      if (!out_.parts.empty()) out_.parts[p].triangles.push_back(static_cast<uint32_t>(t));
    }
  }

  const RawCharacter& ch_;
  int32_t n_ = 0;
  bool has_skin_ = false;
  std::vector<int32_t> parent_;
  std::vector<std::vector<int32_t>> children_, wchildren_;
  std::vector<Vec3> jpos_;
  std::vector<int32_t> vertex_joint_;
  std::vector<bool> weighted_, sub_;
  std::vector<PointStats> own_, subtree_;
  std::vector<double> own_vertices_, subtree_vertices_;
  std::vector<int32_t> subtree_weighted_;
  double total_vertices_ = 0.0;
  int32_t total_weighted_ = 0;
  BodyParts out_;
};

}  // namespace

Result<BodyParts> SplitBodyParts(const RawCharacter& character, const PartOverrides* overrides) {
  Splitter s(character);
  return s.Run(overrides);
}

Result<PartOverrides> LoadPartOverrides(const std::filesystem::path& file, const skinning::Skeleton* skeleton) {
  const std::string name = file.string();
  std::error_code ec;
  if (!std::filesystem::exists(file, ec)) return MakeError(ErrorCode::kFileNotFound, name + ": file not found");
  if (std::filesystem::is_directory(file, ec)) return MakeError(ErrorCode::kFileUnreadable, name + ": is a directory");
  std::ifstream in(file, std::ios::binary);
  if (!in) return MakeError(ErrorCode::kFileUnreadable, name + ": cannot open for reading");
  std::stringstream buf;
  buf << in.rdbuf();
  if (in.bad()) return MakeError(ErrorCode::kFileUnreadable, name + ": read error");
  nlohmann::json j;
  try {
    j = nlohmann::json::parse(buf.str());
  } catch (const nlohmann::json::exception& e) {
    return MakeError(ErrorCode::kFormatRejected, name + ": malformed JSON: " + e.what());
  }
  if (!j.is_object()) {
    return MakeError(ErrorCode::kFormatRejected, name + ": expected a JSON object {\"joint name\": \"part name\", ...}, got " +
                                                     std::string(j.type_name()));
  }
  PartOverrides out;
  out.source_file = name;
  for (auto it = j.begin(); it != j.end(); ++it) {
    if (!it.value().is_string()) {
      return MakeError(ErrorCode::kFormatRejected, name + ": joint '" + it.key() + "' maps to a " +
                                                       std::string(it.value().type_name()) + ", expected a part name string");
    }
    const std::string part = it.value().get<std::string>();
    if (!IsValidPartName(part)) {
      return MakeError(ErrorCode::kInvalidArgument, name + ": joint '" + it.key() + "' -> unknown part '" + part +
                                                        "' (expected torso, head, arm_l, arm_r, leg_l, leg_r or chain_<k>)");
    }
    if (skeleton != nullptr && skeleton->Find(it.key()) < 0) {
      return MakeError(ErrorCode::kNotFound, name + ": unknown joint '" + it.key() + "' (not in the skeleton)");
    }
    out.joint_to_part[it.key()] = part;
  }
  return out;
}

}  // namespace skinspheres::lib
