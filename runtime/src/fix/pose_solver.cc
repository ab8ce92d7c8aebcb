// PoseSolver (fix/pose_solver.h).
#include "skinspheres/runtime/fix/pose_solver.h"

#include <Eigen/Dense>
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <string>
#include <tuple>

namespace skinspheres::runtime {
namespace {

constexpr float kStepClampRad = 0.15f;  // largest change of one joint per least-squares step
constexpr int kBackoffs = 3;            // halvings of a step that does not lower the excess depth
constexpr float kStopShare = 0.9f;      // a pose holds when nothing is deeper than this share of the limit
constexpr float kAimShare = 0.5f;       // each pair is asked to end this share of the limit deep

Eigen::Vector3f RotationVector(const Quatf& q) {
  const Eigen::AngleAxisf aa(q.normalized());
  return aa.angle() * aa.axis();
}
Quatf FromRotationVector(const Eigen::Vector3f& v) {
  const float angle = v.norm();
  if (!(angle > 0.0f)) return Quatf(Quatf::Identity());
  return Quatf(Eigen::AngleAxisf(angle, v / angle));
}
Eigen::Vector3f ClampNorm(const Eigen::Vector3f& v, float limit) {
  const float n = v.norm();
  return n > limit ? Eigen::Vector3f(v * (limit / n)) : v;
}
// The rotation of a world matrix, scale removed column by column.
Eigen::Matrix3f RotationOf(const Mat4f& m) {
  Eigen::Matrix3f r = m.topLeftCorner<3, 3>();
  for (int c = 0; c < 3; ++c) {
    const float n = r.col(c).norm();
    if (n > 0.0f) r.col(c) /= n;
  }
  return r;
}
// The most frequent entry (the smallest on ties); -1 when empty.
int32_t MostFrequent(const std::map<int32_t, int>& counts) {
  int32_t best = -1;
  int most = 0;
  for (const auto& [joint, n] : counts) {
    if (n > most) best = joint, most = n;
  }
  return best;
}

// The least-squares system of one step: a world rotation vector per joint on a chain (3 columns
// each), a row per violation (the contact centre's motion along the normal), a target per row.
struct StepSystem {
  std::vector<int32_t> joints;
  Eigen::MatrixXf jacobian;
  Eigen::VectorXf target, inverse_weight;
};

// Each side's chain runs from its contact joint towards the root, up to the first joint that also
// moves the other side's intersecting triangles (an ancestor of, or one of, their joints); turning
// a joint of part_a's chain moves part_a's side (+1), of part_b's, part_b's (-1).
StepSystem BuildSystem(const std::vector<PoseViolation>& violations, std::span<const int32_t> parents,
                       std::span<const Mat4f> world, float max_depth) {
  auto moves = [&](int32_t j, const std::vector<int32_t>& others) {
    for (int32_t o : others) {
      for (int32_t k = o; k >= 0; k = parents[static_cast<size_t>(k)]) {
        if (k == j) return true;
      }
    }
    return false;
  };
  StepSystem s;
  std::map<int32_t, int> column;
  std::vector<std::vector<std::pair<int, float>>> rows(violations.size());  // (joint slot, sign)
  for (size_t r = 0; r < violations.size(); ++r) {
    const PoseViolation& v = violations[r];
    for (const auto& [end, others, sign] :
         {std::tuple{v.joint_a, &v.joints_b, 1.0f}, std::tuple{v.joint_b, &v.joints_a, -1.0f}}) {
      for (int32_t j = end; j >= 0 && !moves(j, *others); j = parents[static_cast<size_t>(j)]) {
        auto [it, added] = column.emplace(j, static_cast<int>(s.joints.size()));
        if (added) s.joints.push_back(j);
        rows[r].emplace_back(it->second, sign);
      }
    }
  }
  const int n = static_cast<int>(s.joints.size()) * 3, m = static_cast<int>(violations.size());
  s.jacobian = Eigen::MatrixXf::Zero(m, n);
  s.target.resize(m);
  s.inverse_weight.resize(n);
  // Weight 2^hops, hops: how many bones the deepest contact joint below it lies further from the
  // root: distal joints are cheaper to turn.
  auto depth = [&](int32_t j) {
    int d = 0;
    for (int32_t k = parents[static_cast<size_t>(j)]; k >= 0; k = parents[static_cast<size_t>(k)]) ++d;
    return d;
  };
  for (size_t k = 0; k < s.joints.size(); ++k) {
    const int own = depth(s.joints[k]);
    int hops = 0;
    for (const PoseViolation& v : violations) {
      for (int32_t end : {v.joint_a, v.joint_b}) {
        if (end >= 0) hops = std::max(hops, depth(end) - own);
      }
    }
    s.inverse_weight.segment<3>(static_cast<int>(k) * 3).setConstant(std::ldexp(1.0f, -std::min(hops, 20)));
  }
  for (int r = 0; r < m; ++r) {
    const PoseViolation& v = violations[static_cast<size_t>(r)];
    s.target[r] = v.depth - kAimShare * max_depth;
    for (const auto& [slot, sign] : rows[static_cast<size_t>(r)]) {
      const Eigen::Vector3f origin = world[static_cast<size_t>(s.joints[static_cast<size_t>(slot)])].block<3, 1>(0, 3);
      s.jacobian.block<1, 3>(r, slot * 3) = sign * (v.center - origin).cross(v.normal).transpose();
    }
  }
  return s;
}

// The damped least-squares step, each joint's turn clamped and taken into its parent's frame,
// composed into `correction` (clamped to max_rotation).
void TakeStep(const StepSystem& s, std::span<const int32_t> parents, std::span<const Mat4f> world, float max_rotation,
              std::vector<Eigen::Vector3f>* correction) {
  const Eigen::MatrixXf jw = s.jacobian * s.inverse_weight.asDiagonal();
  Eigen::MatrixXf normal = jw * s.jacobian.transpose();
  normal.diagonal().array() += 1e-3f * std::max(normal.diagonal().maxCoeff(), 1e-12f);
  const Eigen::VectorXf omega = jw.transpose() * normal.ldlt().solve(s.target);
  for (size_t k = 0; k < s.joints.size(); ++k) {
    const auto j = static_cast<size_t>(s.joints[k]);
    const int32_t parent = parents[j];
    const Eigen::Matrix3f parent_rotation =
        parent < 0 ? Eigen::Matrix3f::Identity() : RotationOf(world[static_cast<size_t>(parent)]);
    const Eigen::Vector3f local =
        parent_rotation.transpose() * ClampNorm(omega.segment<3>(static_cast<int>(k) * 3), kStepClampRad);
    (*correction)[j] =
        ClampNorm(RotationVector(FromRotationVector(local) * FromRotationVector((*correction)[j])), max_rotation);
  }
}

}  // namespace

std::vector<int32_t> TriangleJoints(const skinning::SkinnedMesh& mesh, std::span<const uint32_t> triangle_vertices) {
  std::vector<int32_t> out(triangle_vertices.size() / 3, 0);
  for (size_t t = 0; t < out.size(); ++t) {
    std::map<int32_t, float> weight;
    for (size_t k = 0; k < 3; ++k) {
      const size_t v = triangle_vertices[3 * t + k];
      if (v + 1 >= mesh.influence_offsets.size()) continue;
      for (uint32_t i = mesh.influence_offsets[v]; i < mesh.influence_offsets[v + 1]; ++i) {
        weight[mesh.binds[mesh.influence_binds[i]].joint] += mesh.influence_weights[i];
      }
    }
    float best = -1.0f;
    for (const auto& [joint, w] : weight) {
      if (w > best) best = w, out[t] = joint;
    }
  }
  return out;
}

void ApplyCorrection(std::span<const skinning::Transform> source, std::span<const Eigen::Vector3f> correction,
                     std::vector<skinning::Transform>* pose) {
  pose->assign(source.begin(), source.end());
  for (size_t j = 0; j < pose->size() && j < correction.size(); ++j) {
    if (correction[j].isZero()) continue;
    (*pose)[j].rotation = (FromRotationVector(correction[j]) * source[j].rotation).normalized();
  }
}

std::vector<PoseViolation> PoseSolver::Violations(const FrameContacts& contacts, float limit,
                                                  const std::vector<std::pair<uint16_t, uint16_t>>& allow) const {
  std::vector<PoseViolation> out;
  for (const PartContact& p : contacts.parts) {
    if (p.kind != PartContactKind::kPenetrating || !(p.depth > limit)) continue;
    if (std::find(allow.begin(), allow.end(), std::pair(p.part_a, p.part_b)) != allow.end()) continue;
    PoseViolation v;
    v.part_a = p.part_a;
    v.part_b = p.part_b;
    v.depth = p.depth;
    v.normal = Eigen::Vector3f(p.normal[0], p.normal[1], p.normal[2]);
    v.center = Eigen::Vector3f(p.center[0], p.center[1], p.center[2]);
    std::map<int32_t, int> side_a, side_b;
    for (uint32_t k = p.first_triangle_pair; k < p.first_triangle_pair + p.triangle_pair_count; ++k) {
      const TriangleContact& t = contacts.triangle_pairs[k];
      if (t.kind != TriangleContactKind::kIntersecting) continue;
      if (t.triangle_a < triangle_joint_.size()) ++side_a[triangle_joint_[t.triangle_a]];
      if (t.triangle_b < triangle_joint_.size()) ++side_b[triangle_joint_[t.triangle_b]];
    }
    v.joint_a = MostFrequent(side_a);
    v.joint_b = MostFrequent(side_b);
    for (const auto& [joint, n] : side_a) v.joints_a.push_back(joint);
    for (const auto& [joint, n] : side_b) v.joints_b.push_back(joint);
    out.push_back(std::move(v));
  }
  return out;
}

Result<int> PoseSolver::Solve(std::span<const skinning::Transform> source, const PoseSolveSettings& settings,
                              const PlayPoseFn& play, std::vector<Eigen::Vector3f>* correction) const {
  correction->resize(source.size(), Eigen::Vector3f::Zero());
  const float stop = kStopShare * settings.max_depth;
  std::vector<Eigen::Vector3f> best = *correction;
  float best_excess = std::numeric_limits<float>::infinity();
  int backoffs = 0;
  std::vector<skinning::Transform> pose;
  for (int step = 0;; ++step) {
    ApplyCorrection(source, *correction, &pose);
    auto played = play(pose);
    if (!played.ok()) return played.error();
    const std::vector<PoseViolation> violations = Violations(*played->contacts, stop, settings.allow);
    if (violations.empty()) return step;
    // A step is kept only when it lowers the summed excess depth over every pair (new ones
    // included); otherwise it is halved, so that no step trades one penetration for a deeper one.
    float excess = 0.0f;
    for (const PoseViolation& v : violations) excess += v.depth - stop;
    if (!(excess < best_excess)) {
      if (++backoffs > kBackoffs || step >= settings.iterations) {
        *correction = best;
        return -1;
      }
      for (size_t j = 0; j < correction->size(); ++j) (*correction)[j] = 0.5f * (best[j] + (*correction)[j]);
      continue;
    }
    best = *correction;
    best_excess = excess;
    backoffs = 0;
    if (step >= settings.iterations) return -1;
    const StepSystem system = BuildSystem(violations, parents_, played->joint_world, settings.max_depth);
    if (system.joints.empty()) return -1;
    TakeStep(system, parents_, played->joint_world, settings.max_rotation_rad, correction);
  }
}

}  // namespace skinspheres::runtime
