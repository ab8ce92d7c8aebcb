// ClipFixer (clip_fixer.h).
#include "clip_fixer.h"

#include <Eigen/Dense>
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>

#include "skinspheres/lib/retarget/bake_clip.h"
#include "skinspheres/skinning/local_to_model_job.h"

namespace skinspheres::tool {

namespace {

constexpr double kPi = 3.14159265358979323846;
double Percentile(std::vector<float> v, double q) {
  if (v.empty()) return 0.0;
  const size_t k = std::min(v.size() - 1, static_cast<size_t>(std::lround(q * double(v.size() - 1))));
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

Result<ClipFixer> ClipFixer::Create(std::shared_ptr<const Playback> playback) {
  PlayOptions options;  // exact mode: the exact contacts decide
  auto player = ClipPlayer::Create(playback, options);
  if (!player.ok()) return player.error();
  const lib::RawCharacter& ch = playback->loaded().character;
  ClipFixer fixer;
  fixer.playback_ = std::move(playback);
  fixer.player_.emplace(std::move(*player));
  std::vector<uint32_t> triangle_vertices;
  triangle_vertices.reserve(3 * ch.triangle_count());
  for (const Eigen::Vector3i& t : ch.triangles) {
    for (int k = 0; k < 3; ++k) triangle_vertices.push_back(static_cast<uint32_t>(t[k]));
  }
  fixer.solver_.emplace(ch.skeleton.parents, runtime::TriangleJoints(ch.skin, triangle_vertices));
  return fixer;
}

Result<Poses> ClipFixer::Sample(const skinning::AnimationClip& clip, float fps) const {
  auto frames = lib::SampleFrames(clip, playback_->loaded().character.skeleton, fps);
  if (!frames.ok()) return MakeError(frames.error().code, playback_->file() + ": " + frames.error().message);
  return std::move(*frames);
}

// The pose's part pairs (not allowed) that penetrate deeper than `limit`.
Result<std::vector<runtime::PoseViolation>> ClipFixer::Evaluate(std::span<const skinning::Transform> pose, int frame,
                                                                float limit, const FixSettings& settings) {
  ++poses_;
  if (auto err = player_->PlayPose(pose, frame)) return *err;
  return solver_->Violations(player_->contacts(), limit, settings.allow);
}

// One frame's solve (runtime::PoseSolver), playing each pose with the exact contacts.
Result<int> ClipFixer::SolveFrame(const std::vector<skinning::Transform>& source, int frame,
                                  const FixSettings& settings, std::vector<Eigen::Vector3f>* correction) {
  runtime::PoseSolveSettings solve;
  solve.max_depth = settings.max_depth;
  solve.iterations = settings.iterations;
  solve.max_rotation_rad = static_cast<float>(settings.max_rotation_deg * kPi / 180.0);
  solve.allow = settings.allow;
  auto play = [&](std::span<const skinning::Transform> pose) -> Result<runtime::PlayedPose> {
    ++poses_;
    if (auto err = player_->PlayPose(pose, frame)) return *err;
    return runtime::PlayedPose{&player_->contacts(), player_->joint_world()};
  };
  return solver_->Solve(source, solve, play, correction);
}

void ClipFixer::Measure(const Poses& poses, const FixSettings& settings, FixMeasures* out) {
  *out = {};
  for (size_t f = 0; f < poses.size(); ++f) {
    auto violations = Evaluate(poses[f], static_cast<int>(f), settings.max_depth, settings);
    if (!violations.ok() || violations->empty()) continue;
    ++out->frames_failing;
    for (const runtime::PoseViolation& v : *violations) {
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
      runtime::ApplyCorrection(source[f], corrections[f], &pose);
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
      for (auto& c : frame) {
        if (c.norm() > max_rotation) c *= max_rotation / c.norm();
      }
    }
  }
  result.poses.resize(frames);
  for (size_t f = 0; f < frames; ++f) runtime::ApplyCorrection(source[f], corrections[f], &result.poses[f]);
  Measure(source, settings, &result.before);
  Measure(result.poses, settings, &result.after);
  result.poses_evaluated = poses_;
  MeasureMotion(skeleton, source, result, corrections, fps, playback_->body_height(), &result);
  return result;
}

}  // namespace skinspheres::tool
