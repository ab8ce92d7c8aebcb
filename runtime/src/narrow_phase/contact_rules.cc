// The contact rules of contact_rules.h: the rest pose, welded vertices, triangle joints, the joint
// tree's neighbourhoods, the sphere pairs rule 2 excludes, rule 3's test at rest, and their checks.
#include "skinspheres/runtime/narrow_phase/contact_rules.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <string>
#include <unordered_map>

#include "skinspheres/runtime/narrow_phase/triangle_contact.h"
#include "skinspheres/skinning/skinning_job.h"
#include "skinspheres/skinning/skinning_matrices_job.h"

namespace skinspheres::runtime {

const char* ToString(ContactRules rules) {
  switch (rules) {
    case ContactRules::kSpherePairs: return "sphere_pairs";
    case ContactRules::kTriangles: return "triangles";
  }
  return "unknown";
}

std::optional<ContactRules> ContactRulesFromString(std::string_view text) {
  if (text == "sphere_pairs") return ContactRules::kSpherePairs;
  if (text == "triangles") return ContactRules::kTriangles;
  return std::nullopt;
}

bool RestPositions(const SphereSet& set, std::vector<Eigen::Vector3f>* out) {
  const skinning::SkinnedMesh& mesh = set.mesh;
  std::vector<Mat4f> matrices(mesh.binds.size());
  if (!skinning::SkinningMatricesJob{mesh.binds, set.joint_rest_world, matrices}.Run()) return false;
  out->assign(mesh.vertex_count(), Eigen::Vector3f::Zero());
  skinning::SkinningJob job;
  job.joint_matrices = matrices;
  job.vertex_count = mesh.vertex_count();
  job.in_positions = {reinterpret_cast<const float*>(mesh.positions_bind.data()), 3 * mesh.vertex_count()};
  job.out_positions = {reinterpret_cast<float*>(out->data()), 3 * out->size()};
  job.influence_offsets = mesh.influence_offsets;
  job.influence_binds = mesh.influence_binds;
  job.influence_weights = mesh.influence_weights;
  return mesh.vertex_count() == 0 || job.Run();
}

float RestHeight(std::span<const Eigen::Vector3f> positions) {
  if (positions.empty()) return 0.0f;
  float low = positions[0].y(), high = low;
  for (const Eigen::Vector3f& p : positions) {
    low = std::min(low, p.y());
    high = std::max(high, p.y());
  }
  return high - low;
}

std::vector<uint32_t> WeldedVertices(std::span<const Eigen::Vector3f> rest_positions) {
  struct KeyHash {
    size_t operator()(const std::array<uint32_t, 3>& k) const {
      return (size_t{k[0]} * 0x9E3779B97F4A7C15ull) ^ (size_t{k[1]} * 0xC2B2AE3D27D4EB4Full) ^
             (size_t{k[2]} * 0x165667B19E3779F9ull);
    }
  };
  std::vector<uint32_t> canonical(rest_positions.size());
  std::unordered_map<std::array<uint32_t, 3>, uint32_t, KeyHash> first;
  first.reserve(rest_positions.size());
  for (uint32_t v = 0; v < rest_positions.size(); ++v) {
    std::array<uint32_t, 3> key;
    for (int k = 0; k < 3; ++k) {
      const float x = rest_positions[v][k] + 0.0f;  // -0 -> +0
      std::memcpy(&key[k], &x, sizeof(float));
    }
    canonical[v] = first.emplace(key, v).first->second;
  }
  return canonical;
}

std::vector<uint16_t> TriangleJoints(const SphereSet& set) {
  const skinning::SkinnedMesh& mesh = set.mesh;
  std::vector<uint16_t> out(set.source_triangle_count, kNoTriangleJoint);
  std::vector<std::pair<uint16_t, double>> sums;  // (joint, summed weight), a few per triangle
  for (uint32_t t = 0; t < set.source_triangle_count; ++t) {
    sums.clear();
    for (int c = 0; c < 3; ++c) {
      const uint32_t v = set.triangle_vertices[3 * size_t{t} + c];
      for (uint32_t k = mesh.influence_offsets[v]; k < mesh.influence_offsets[v + 1]; ++k) {
        const auto joint = static_cast<uint16_t>(mesh.binds[mesh.influence_binds[k]].joint);
        auto it = std::find_if(sums.begin(), sums.end(), [&](const auto& s) { return s.first == joint; });
        if (it == sums.end()) {
          sums.emplace_back(joint, 0.0);
          it = sums.end() - 1;
        }
        it->second += double(mesh.influence_weights[k]);
      }
    }
    double best = 0.0;
    for (const auto& [joint, weight] : sums) {
      if (weight > best || (weight == best && weight > 0.0 && joint < out[t])) {
        best = weight;
        out[t] = joint;
      }
    }
  }
  return out;
}

NearJoints::NearJoints(const SphereSet& set, uint32_t hops) {
  const size_t joints = set.joint_count();
  // The skin's joint tree: the joints bind entries name (every joint without a mesh), each hung under
  // its nearest ancestor among them.
  std::vector<uint8_t> in_tree(joints, set.has_mesh() ? 0 : 1);
  for (const skinning::BindEntry& b : set.mesh.binds) {
    if (b.joint >= 0 && size_t(b.joint) < joints) in_tree[b.joint] = 1;
  }
  std::vector<int32_t> parent(joints, -1);
  std::vector<std::vector<uint16_t>> adjacent(joints);
  for (size_t j = 0; j < joints; ++j) {
    if (!in_tree[j]) continue;
    int32_t p = set.joint_parents[j];
    while (p >= 0 && !in_tree[p]) p = set.joint_parents[p];
    parent[j] = p;
    if (p >= 0) {
      adjacent[j].push_back(uint16_t(p));
      adjacent[p].push_back(uint16_t(j));
    }
  }
  // Breadth-first from each joint, `hops` deep.
  offsets_.assign(1, 0);
  std::vector<uint16_t> frontier, next, found;
  for (size_t j = 0; j < joints; ++j) {
    found.assign(1, uint16_t(j));
    frontier.assign(1, uint16_t(j));
    for (uint32_t h = 0; h < hops && !frontier.empty(); ++h) {
      next.clear();
      for (uint16_t a : frontier) {
        for (uint16_t b : adjacent[a]) {
          if (std::find(found.begin(), found.end(), b) == found.end()) {
            found.push_back(b);
            next.push_back(b);
          }
        }
      }
      frontier.swap(next);
    }
    std::sort(found.begin(), found.end());
    joints_.insert(joints_.end(), found.begin(), found.end());
    offsets_.push_back(uint32_t(joints_.size()));
  }
  count_ = std::min<size_t>(joints, kNoTriangleJoint);
  if (count_ <= kDenseJoints) {
    words_ = (count_ + 63) / 64;
    dense_.assign(count_ * words_, 0);
    for (size_t a = 0; a < count_; ++a) {
      for (uint16_t b : of(uint16_t(a))) dense_[a * words_ + (b >> 6)] |= uint64_t{1} << (b & 63);
    }
  }
}

bool NearJoints::Search(uint16_t a, uint16_t b) const {
  const auto list = of(a);
  return std::binary_search(list.begin(), list.end(), b);
}

namespace {

// Per sphere, the joints of its triangles and pieces' triangles, sorted and unique.
std::vector<std::vector<uint16_t>> SphereJoints(const SphereSet& set, std::span<const uint16_t> triangle_joints) {
  std::vector<std::vector<uint16_t>> out(set.size());
  for (size_t s = 0; s < set.size(); ++s) {
    auto& list = out[s];
    if (!set.has_mesh()) {  // no triangles to read: the sphere's own joint
      list.push_back(set.sphere_joint[s]);
      continue;
    }
    for (uint32_t k = set.triangle_offsets[s]; k < set.triangle_offsets[s + 1]; ++k) {
      list.push_back(triangle_joints[set.triangles[k]]);
    }
    for (const TrianglePiece& p : set.PiecesOf(s)) list.push_back(triangle_joints[p.triangle]);
    std::sort(list.begin(), list.end());
    list.erase(std::unique(list.begin(), list.end()), list.end());
  }
  return out;
}

// Whether every joint of a is near every joint of b.
bool AllNear(const std::vector<uint16_t>& a, const std::vector<uint16_t>& b, const NearJoints& near) {
  for (uint16_t x : a) {
    for (uint16_t y : b) {
      if (!near(x, y)) return false;
    }
  }
  return true;
}

Error Invalid(const std::string& what) { return MakeError(ErrorCode::kInvalidData, what); }

}  // namespace

std::vector<ExcludedPair> ExcludedSpherePairs(const SphereSet& set, std::span<const uint16_t> triangle_joints,
                                              const NearJoints& near) {
  const auto joints = SphereJoints(set, triangle_joints);
  std::vector<ExcludedPair> out;
  for (uint32_t i = 0; i < set.size(); ++i) {
    for (uint32_t j = i + 1; j < set.size(); ++j) {
      if (!AllNear(joints[i], joints[j], near)) continue;
      const bool one_joint = joints[i].size() <= 1 && joints[j].size() <= 1 &&
                             (joints[i].empty() || joints[j].empty() || joints[i][0] == joints[j][0]);
      out.push_back({i, j, one_joint ? ExclusionReason::kSameJoint : ExclusionReason::kAdjacentJoints});
    }
  }
  return out;
}

bool NearAtRest(const Eigen::Vector3f* rest, const uint32_t a[3], const uint32_t b[3], float distance) {
  for (int k = 0; k < 3; ++k) {
    const float lo_a = std::min({rest[a[0]][k], rest[a[1]][k], rest[a[2]][k]});
    const float hi_a = std::max({rest[a[0]][k], rest[a[1]][k], rest[a[2]][k]});
    const float lo_b = std::min({rest[b[0]][k], rest[b[1]][k], rest[b[2]][k]});
    const float hi_b = std::max({rest[b[0]][k], rest[b[1]][k], rest[b[2]][k]});
    // Apart on this axis by more than the distance (a hair more, for the subtraction's rounding).
    if (double(lo_b) - double(hi_a) > double(distance) * (1.0 + 1e-6) ||
        double(lo_a) - double(hi_b) > double(distance) * (1.0 + 1e-6)) {
      return false;
    }
  }
  TriangleContactGeometry g;
  return TriangleContactOf(rest[a[0]], rest[a[1]], rest[a[2]], rest[b[0]], rest[b[1]], rest[b[2]], distance, &g);
}

std::optional<Error> WriteContactRules(SphereSet* set, uint32_t hops, float rest_gap_share) {
  if (hops > kMaxContactHops) {
    return MakeError(ErrorCode::kInvalidArgument, "contact hops must be at most " + std::to_string(kMaxContactHops) +
                                                      " (got " + std::to_string(hops) + ")");
  }
  if (!(rest_gap_share >= 0.0f && rest_gap_share <= kMaxRestGapShare)) {
    return MakeError(ErrorCode::kInvalidArgument, "the rest gap must be a share of the rest height in [0, " +
                                                      std::to_string(kMaxRestGapShare) + "]");
  }
  set->contact_rules = ContactRules::kTriangles;
  set->contact_hops = hops;
  set->rest_gap = 0.0f;
  const NearJoints near(*set, hops);
  if (!set->has_mesh()) {
    set->excluded_pairs = ExcludedSpherePairs(*set, {}, near);
    return std::nullopt;
  }
  std::vector<Eigen::Vector3f> rest;
  if (!RestPositions(*set, &rest)) {
    return MakeError(ErrorCode::kInvalidData, set->source_file + ": the mesh cannot be skinned at rest");
  }
  set->excluded_pairs = ExcludedSpherePairs(*set, TriangleJoints(*set), near);
  set->rest_gap = rest_gap_share * RestHeight(rest);
  return std::nullopt;
}

std::optional<Error> CheckContactRules(const SphereSet& set) {
  if (set.contact_rules == ContactRules::kSpherePairs) {
    if (set.contact_hops != 0 || set.rest_gap != 0.0f || std::signbit(set.rest_gap)) {
      return Invalid("a set with its contact rules on sphere pairs has contact hops or a rest gap");
    }
    return std::nullopt;
  }
  if (set.contact_rules != ContactRules::kTriangles) return Invalid("unknown contact rules");
  if (set.contact_hops > kMaxContactHops) {
    return Invalid("contact hops " + std::to_string(set.contact_hops) + " above " + std::to_string(kMaxContactHops));
  }
  if (!(set.rest_gap >= 0.0f) || !std::isfinite(set.rest_gap)) return Invalid("the rest gap is not finite and >= 0");
  for (const ExcludedPair& p : set.excluded_pairs) {
    if (p.reason == ExclusionReason::kBindOverlap) {
      return Invalid("excluded pair (" + std::to_string(p.i) + ", " + std::to_string(p.j) +
                     ") overlaps at rest: a reason only sets with their contact rules on sphere pairs give");
    }
  }
  if (!set.has_mesh()) return std::nullopt;
  std::vector<Eigen::Vector3f> rest;
  if (!RestPositions(set, &rest)) return Invalid("the mesh cannot be skinned at rest");
  if (set.rest_gap > kMaxRestGapShare * RestHeight(rest) * (1.0f + 1e-6f)) {
    return Invalid("the rest gap " + std::to_string(set.rest_gap) + " is more than " +
                   std::to_string(kMaxRestGapShare) + " of the rest height");
  }
  // Rule 2 must exclude every listed sphere pair whole.
  const NearJoints near(set, set.contact_hops);
  const auto joints = SphereJoints(set, TriangleJoints(set));
  for (const ExcludedPair& p : set.excluded_pairs) {
    if (!AllNear(joints[p.i], joints[p.j], near)) {
      return Invalid("excluded pair (" + std::to_string(p.i) + ", " + std::to_string(p.j) +
                     ") holds triangles whose joints are more than " + std::to_string(set.contact_hops) +
                     " bones apart: it would hide their contacts");
    }
  }
  return std::nullopt;
}

}  // namespace skinspheres::runtime
