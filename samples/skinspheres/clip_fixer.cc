// ClipFixer (clip_fixer.h).
#include "clip_fixer.h"

#include <Eigen/Dense>
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <limits>
#include <map>

#include "skinspheres/lib/retarget/bake_clip.h"
#include "skinspheres/skinning/local_to_model_job.h"

namespace skinspheres::tool {

struct ClipFixer::Violation {
  uint16_t part_a = 0, part_b = 0;
  float depth = 0.0f;
  Eigen::Vector3f normal = Eigen::Vector3f::Zero();  // from part_b towards part_a
  Eigen::Vector3f center = Eigen::Vector3f::Zero();
  int32_t joint_a = -1, joint_b = -1;       // each side's most frequent joint among its intersecting triangles
  std::vector<int32_t> joints_a, joints_b;  // every joint of each side's intersecting triangles
};

namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr float kStepClampRad = 0.15f;  // largest change of one joint per least-squares step

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
Eigen::Matrix3f RotationOf(const skinspheres::Mat4f& m) {
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

double Percentile(std::vector<float> v, double q) {
  if (v.empty()) return 0.0;
  const size_t k = std::min(v.size() - 1, static_cast<size_t>(q * double(v.size() - 1) + 0.5));
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(k), v.end());
  return v[k];
}

// Every frame's joint positions in model space.
std::vector<std::vector<Eigen::Vector3f>> JointPositions(const skinning::Skeleton& skeleton, const Poses& poses) {
  std::vector<std::vector<Eigen::Vector3f>> out(poses.size());
  std::vector<skinspheres::Mat4f> world(skeleton.size());
  for (size_t f = 0; f < poses.size(); ++f) {
    skinning::LocalToModelJob l2m;
    l2m.skeleton = &skeleton;
    l2m.input = poses[f];
    l2m.output = world;
    l2m.Run();
    out[f].resize(skeleton.size());
    for (size_t j = 0; j < skeleton.size(); ++j) out[f][j] = world[j].block<3, 1>(0, 3);
  }
  return out;
}

// Spreads each solved frame's change over its neighbours: a Gaussian-weighted mean whose weights
// sum to at least 1, so a run of equal changes keeps its value and eases in and out around it.
void Spread(const std::vector<std::vector<Eigen::Vector3f>>& delta, const std::vector<char>& solved, float sigma,
            std::vector<std::vector<Eigen::Vector3f>>* corrections, std::vector<char>* changed) {
  const int frames = static_cast<int>(delta.size());
  const int reach = std::max(1, static_cast<int>(std::ceil(3.0f * sigma)));
  std::vector<float> kernel(static_cast<size_t>(reach) + 1);
  for (int d = 0; d <= reach; ++d) kernel[static_cast<size_t>(d)] = std::exp(-0.5f * float(d * d) / (sigma * sigma));
  for (int f = 0; f < frames; ++f) {
    float weight = 0.0f;
    for (int g = std::max(0, f - reach); g <= std::min(frames - 1, f + reach); ++g) {
      if (solved[static_cast<size_t>(g)]) weight += kernel[static_cast<size_t>(std::abs(f - g))];
    }
    if (weight == 0.0f) continue;
    const float norm = 1.0f / std::max(1.0f, weight);
    auto& c = (*corrections)[static_cast<size_t>(f)];
    for (int g = std::max(0, f - reach); g <= std::min(frames - 1, f + reach); ++g) {
      if (!solved[static_cast<size_t>(g)]) continue;
      const float w = kernel[static_cast<size_t>(std::abs(f - g))] * norm;
      const auto& d = delta[static_cast<size_t>(g)];
      for (size_t j = 0; j < c.size(); ++j) c[j] += w * d[j];
    }
    (*changed)[static_cast<size_t>(f)] = 1;
  }
}

}  // namespace

void MeasureMotion(const skinning::Skeleton& skeleton, const Poses& source, const FixResult& fixed,
                   const std::vector<std::vector<Eigen::Vector3f>>& corrections, float fps, float height,
                   FixResult* out) {
  const size_t joints = skeleton.size();
  std::vector<float> rotation, bone, moved_bone;
  std::vector<char> joint_changed(joints, 0);
  for (const auto& frame : corrections) {
    for (size_t j = 0; j < frame.size(); ++j) {
      const float angle = frame[j].norm();
      if (!(angle > 1e-5f)) continue;
      rotation.push_back(static_cast<float>(angle * 180.0 / kPi));
      joint_changed[j] = 1;
    }
  }
  out->joints_changed.clear();
  for (size_t j = 0; j < joints; ++j) {
    if (joint_changed[j]) out->joints_changed.push_back(static_cast<int32_t>(j));
  }
  out->rotation_median_deg = static_cast<float>(Percentile(rotation, 0.5));
  out->rotation_max_deg = rotation.empty() ? 0.0f : *std::max_element(rotation.begin(), rotation.end());
  const auto before = JointPositions(skeleton, source), after = JointPositions(skeleton, fixed.poses);
  std::vector<char> moved(joints, 0);
  for (size_t f = 0; f < before.size(); ++f) {
    for (size_t j = 0; j < joints; ++j) {
      if ((after[f][j] - before[f][j]).norm() > 1e-5f * height) moved[j] = 1;
      const int32_t parent = skeleton.parents[j];
      if (parent < 0) continue;
      const Eigen::Vector3f a = before[f][j] - before[f][static_cast<size_t>(parent)];
      const Eigen::Vector3f b = after[f][j] - after[f][static_cast<size_t>(parent)];
      if (!(a.norm() > 1e-6f * height) || !(b.norm() > 1e-6f * height)) continue;
      const double angle = std::atan2(double(a.cross(b).norm()), double(a.dot(b))) * 180.0 / kPi;
      bone.push_back(static_cast<float>(angle));
      if (angle > 0.01) moved_bone.push_back(static_cast<float>(angle));
    }
  }
  out->bone_total = bone.size();
  out->bone_moved = moved_bone.size();
  out->bone_moved_median_deg = static_cast<float>(Percentile(moved_bone, 0.5));
  out->bone_median_deg = static_cast<float>(Percentile(bone, 0.5));
  out->bone_p95_deg = static_cast<float>(Percentile(bone, 0.95));
  out->bone_max_deg = bone.empty() ? 0.0f : *std::max_element(bone.begin(), bone.end());
  // Jerk: the third difference of each moved joint's position, times fps^3.
  double sum_source = 0.0, sum_fixed = 0.0;
  size_t count = 0;
  const double scale = double(fps) * fps * fps;
  for (size_t j = 0; j < joints; ++j) {
    if (!moved[j]) continue;
    for (size_t f = 0; f + 3 < before.size(); ++f) {
      auto jerk = [&](const std::vector<std::vector<Eigen::Vector3f>>& p) {
        return ((p[f + 3][j] - 3.0f * p[f + 2][j] + 3.0f * p[f + 1][j] - p[f][j]).cast<double>() * scale).squaredNorm();
      };
      sum_source += jerk(before);
      sum_fixed += jerk(after);
      ++count;
    }
  }
  out->jerk_source = count ? std::sqrt(sum_source / double(count)) : 0.0;
  out->jerk_fixed = count ? std::sqrt(sum_fixed / double(count)) : 0.0;
}

void ApplyCorrection(std::span<const skinning::Transform> source, std::span<const Eigen::Vector3f> correction,
                     std::vector<skinning::Transform>* pose) {
  pose->assign(source.begin(), source.end());
  for (size_t j = 0; j < pose->size() && j < correction.size(); ++j) {
    if (correction[j].isZero()) continue;
    (*pose)[j].rotation = (FromRotationVector(correction[j]) * source[j].rotation).normalized();
  }
}

Result<ClipFixer> ClipFixer::Create(std::shared_ptr<const Playback> playback) {
  PlayOptions options;  // exact mode: the exact contacts decide
  auto player = ClipPlayer::Create(playback, options);
  if (!player.ok()) return player.error();
  const lib::RawCharacter& ch = playback->loaded().character;
  ClipFixer fixer;
  fixer.playback_ = std::move(playback);
  fixer.player_.emplace(std::move(*player));
  // Each vertex's joints by weight, then each triangle's joint: the largest summed weight.
  const auto& skin = ch.skin;
  fixer.triangle_joint_.assign(ch.triangle_count(), 0);
  for (size_t t = 0; t < ch.triangle_count(); ++t) {
    std::map<int32_t, float> weight;
    for (int k = 0; k < 3; ++k) {
      const auto v = static_cast<size_t>(ch.triangles[t][k]);
      if (v + 1 >= skin.influence_offsets.size()) continue;
      for (uint32_t i = skin.influence_offsets[v]; i < skin.influence_offsets[v + 1]; ++i) {
        weight[skin.binds[skin.influence_binds[i]].joint] += skin.influence_weights[i];
      }
    }
    float best = -1.0f;
    for (const auto& [joint, w] : weight) {
      if (w > best) best = w, fixer.triangle_joint_[t] = joint;
    }
  }
  fixer.depth_.assign(ch.skeleton.size(), 0);
  for (size_t j = 0; j < ch.skeleton.size(); ++j) {
    const int32_t parent = ch.skeleton.parents[j];
    fixer.depth_[j] = parent < 0 ? 0 : fixer.depth_[static_cast<size_t>(parent)] + 1;
  }
  return fixer;
}

Result<Poses> ClipFixer::Sample(const skinning::AnimationClip& clip, float fps) const {
  auto frames = lib::SampleFrames(clip, playback_->loaded().character.skeleton, fps);
  if (!frames.ok()) return MakeError(frames.error().code, playback_->file() + ": " + frames.error().message);
  return std::move(*frames);
}

// The pose's part pairs (not allowed) that penetrate deeper than `limit`.
Result<std::vector<ClipFixer::Violation>> ClipFixer::Evaluate(std::span<const skinning::Transform> pose, int frame,
                                                              float limit, const FixSettings& settings) {
  ++poses_;
  if (auto err = player_->PlayPose(pose, frame)) return *err;
  const runtime::FrameContacts& contacts = player_->contacts();
  std::vector<Violation> out;
  for (const runtime::PartContact& p : contacts.parts) {
    if (p.kind != runtime::PartContactKind::kPenetrating || !(p.depth > limit)) continue;
    if (std::find(settings.allow.begin(), settings.allow.end(), std::pair(p.part_a, p.part_b)) != settings.allow.end())
      continue;
    Violation v;
    v.part_a = p.part_a;
    v.part_b = p.part_b;
    v.depth = p.depth;
    v.normal = Eigen::Vector3f(p.normal[0], p.normal[1], p.normal[2]);
    v.center = Eigen::Vector3f(p.center[0], p.center[1], p.center[2]);
    std::map<int32_t, int> side_a, side_b;
    for (uint32_t k = p.first_triangle_pair; k < p.first_triangle_pair + p.triangle_pair_count; ++k) {
      const runtime::TriangleContact& t = contacts.triangle_pairs[k];
      if (t.kind != runtime::TriangleContactKind::kIntersecting) continue;
      ++side_a[triangle_joint_[t.triangle_a]];
      ++side_b[triangle_joint_[t.triangle_b]];
    }
    v.joint_a = MostFrequent(side_a);
    v.joint_b = MostFrequent(side_b);
    for (const auto& [joint, n] : side_a) v.joints_a.push_back(joint);
    for (const auto& [joint, n] : side_b) v.joints_b.push_back(joint);
    out.push_back(v);
  }
  return out;
}

// Damped least-squares steps on one frame until no pair is deeper than 0.9 of the limit: returns
// the steps taken, or -1 when the frame still fails after settings.iterations.
Result<int> ClipFixer::SolveFrame(const std::vector<skinning::Transform>& source, int frame,
                                  const FixSettings& settings, std::vector<Eigen::Vector3f>* correction) {
  const skinning::Skeleton& skeleton = playback_->loaded().character.skeleton;
  const float max_rotation = static_cast<float>(settings.max_rotation_deg * kPi / 180.0);
  std::vector<skinning::Transform> pose;
  // A step is kept only when it lowers the summed excess depth over every pair (new ones included):
  // otherwise it is halved, at most kBackoffs times, so that no step trades one penetration for a
  // deeper one.
  constexpr int kBackoffs = 3;
  std::vector<Eigen::Vector3f> best = *correction;
  float best_excess = std::numeric_limits<float>::infinity();
  int backoffs = 0;
  for (int step = 0;; ++step) {
    ApplyCorrection(source, *correction, &pose);
    auto violations = Evaluate(pose, frame, 0.9f * settings.max_depth, settings);
    if (!violations.ok()) return violations.error();
    if (violations->empty()) return step;
    float excess = 0.0f;
    for (const Violation& v : *violations) excess += v.depth - 0.9f * settings.max_depth;
    if (!(excess < best_excess)) {
      if (++backoffs > kBackoffs || step == settings.iterations) {
        *correction = best;
        return -1;
      }
      for (size_t j = 0; j < correction->size(); ++j) (*correction)[j] = 0.5f * (best[j] + (*correction)[j]);
      continue;
    }
    best = *correction;
    best_excess = excess;
    backoffs = 0;
    if (step == settings.iterations) return -1;
    const auto world = player_->joint_world();
    // Unknowns: a world rotation vector per joint on a chain; sign +1 moves part_a's side.
    std::map<int32_t, int> column;
    std::vector<int32_t> joints;
    std::vector<std::vector<std::pair<int, float>>> rows(violations->size());  // (joint slot, sign)
    for (size_t r = 0; r < violations->size(); ++r) {
      const Violation& v = (*violations)[r];
      // Each side's chain: from its contact joint towards the root, up to the first joint that also
      // moves the other side's intersecting triangles (an ancestor of, or one of, their joints).
      auto moves = [&](int32_t j, const std::vector<int32_t>& others) {
        for (int32_t o : others) {
          for (int32_t k = o; k >= 0; k = skeleton.parents[static_cast<size_t>(k)]) {
            if (k == j) return true;
          }
        }
        return false;
      };
      for (const auto& [end, others, sign] :
           {std::tuple{v.joint_a, &v.joints_b, 1.0f}, std::tuple{v.joint_b, &v.joints_a, -1.0f}}) {
        for (int32_t j = end; j >= 0 && !moves(j, *others); j = skeleton.parents[static_cast<size_t>(j)]) {
          auto [it, added] = column.emplace(j, static_cast<int>(joints.size()));
          if (added) joints.push_back(j);
          rows[r].emplace_back(it->second, sign);
        }
      }
    }
    if (joints.empty()) return -1;
    const int n = static_cast<int>(joints.size()) * 3, m = static_cast<int>(violations->size());
    Eigen::MatrixXf jacobian = Eigen::MatrixXf::Zero(m, n);
    Eigen::VectorXf target(m), inverse_weight(n);
    for (size_t k = 0; k < joints.size(); ++k) {
      // 2^hops from the chain's contact end: distal joints are cheaper to turn.
      const int32_t j = joints[k];
      int hops = 0;
      for (const Violation& v : *violations) {
        for (int32_t end : {v.joint_a, v.joint_b}) {
          if (end >= 0 && depth_[static_cast<size_t>(end)] >= depth_[static_cast<size_t>(j)])
            hops = std::max(hops, depth_[static_cast<size_t>(end)] - depth_[static_cast<size_t>(j)]);
        }
      }
      inverse_weight.segment<3>(static_cast<int>(k) * 3).setConstant(std::ldexp(1.0f, -std::min(hops, 20)));
    }
    for (int r = 0; r < m; ++r) {
      const Violation& v = (*violations)[static_cast<size_t>(r)];
      target[r] = v.depth - 0.5f * settings.max_depth;
      for (const auto& [slot, sign] : rows[static_cast<size_t>(r)]) {
        const Eigen::Vector3f origin = world[static_cast<size_t>(joints[static_cast<size_t>(slot)])].block<3, 1>(0, 3);
        jacobian.block<1, 3>(r, slot * 3) = sign * (v.center - origin).cross(v.normal).transpose();
      }
    }
    const Eigen::MatrixXf jw = jacobian * inverse_weight.asDiagonal();
    Eigen::MatrixXf normal = jw * jacobian.transpose();
    normal.diagonal().array() += 1e-3f * std::max(normal.diagonal().maxCoeff(), 1e-12f);
    const Eigen::VectorXf omega = jw.transpose() * normal.ldlt().solve(target);
    for (size_t k = 0; k < joints.size(); ++k) {
      const auto j = static_cast<size_t>(joints[k]);
      const int32_t parent = skeleton.parents[j];
      const Eigen::Matrix3f parent_rotation =
          parent < 0 ? Eigen::Matrix3f::Identity() : RotationOf(world[static_cast<size_t>(parent)]);
      const Eigen::Vector3f local =
          parent_rotation.transpose() * ClampNorm(omega.segment<3>(static_cast<int>(k) * 3), kStepClampRad);
      (*correction)[j] =
          ClampNorm(RotationVector(FromRotationVector(local) * FromRotationVector((*correction)[j])), max_rotation);
    }
  }
}

void ClipFixer::Measure(const Poses& poses, const FixSettings& settings, FixMeasures* out) {
  *out = {};
  for (size_t f = 0; f < poses.size(); ++f) {
    auto violations = Evaluate(poses[f], static_cast<int>(f), settings.max_depth, settings);
    if (!violations.ok() || violations->empty()) continue;
    ++out->frames_failing;
    for (const Violation& v : *violations) {
      if (v.depth > out->worst_depth) out->worst_depth = v.depth, out->worst_frame = static_cast<int>(f);
      const std::pair pair(v.part_a, v.part_b);
      if (std::find(out->failing_pairs.begin(), out->failing_pairs.end(), pair) == out->failing_pairs.end())
        out->failing_pairs.push_back(pair);
    }
  }
  std::sort(out->failing_pairs.begin(), out->failing_pairs.end());
}

Result<FixResult> ClipFixer::Fix(const Poses& source, float fps, const FixSettings& settings) {
  const skinning::Skeleton& skeleton = playback_->loaded().character.skeleton;
  const size_t frames = source.size(), joints = skeleton.size();
  poses_ = 0;
  FixResult result;
  std::vector<std::vector<Eigen::Vector3f>> corrections(frames,
                                                        std::vector<Eigen::Vector3f>(joints, Eigen::Vector3f::Zero()));
  std::vector<char> failing(frames, 0), changed(frames, 1);
  std::vector<skinning::Transform> pose;
  const float max_rotation = static_cast<float>(settings.max_rotation_deg * kPi / 180.0);
  for (int round = 0;; ++round) {
    // Re-judge the frames whose correction changed.
    bool any = false;
    for (size_t f = 0; f < frames; ++f) {
      if (!changed[f]) {
        any = any || failing[f];
        continue;
      }
      ApplyCorrection(source[f], corrections[f], &pose);
      auto violations = Evaluate(pose, static_cast<int>(f), settings.max_depth, settings);
      if (!violations.ok()) return violations.error();
      failing[f] = !violations->empty();
      any = any || failing[f];
    }
    if (!any || round == settings.rounds) break;
    result.rounds = round + 1;
    std::vector<std::vector<Eigen::Vector3f>> delta(frames);
    for (size_t f = 0; f < frames; ++f) {
      if (!failing[f]) continue;
      std::vector<Eigen::Vector3f> solved = corrections[f];
      auto steps = SolveFrame(source[f], static_cast<int>(f), settings, &solved);
      if (!steps.ok()) return steps.error();
      ++result.solves;
      delta[f].resize(joints);
      for (size_t j = 0; j < joints; ++j) delta[f][j] = solved[j] - corrections[f][j];
    }
    std::fill(changed.begin(), changed.end(), 0);
    Spread(delta, failing, std::max(0.5f, settings.ease_s * fps), &corrections, &changed);
    for (auto& frame : corrections) {
      for (auto& c : frame) c = ClampNorm(c, max_rotation);
    }
  }
  result.poses.resize(frames);
  for (size_t f = 0; f < frames; ++f) ApplyCorrection(source[f], corrections[f], &result.poses[f]);
  Measure(source, settings, &result.before);
  Measure(result.poses, settings, &result.after);
  result.poses_evaluated = poses_;
  MeasureMotion(skeleton, source, result, corrections, fps, playback_->body_height(), &result);
  return result;
}

}  // namespace skinspheres::tool
