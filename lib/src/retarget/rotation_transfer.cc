// The world-space, rest-relative transfer (retarget.h, step 5; retarget_stages.h, TransferClip):
// the source sampled at every bake time, each mapped joint's world rotation
// A · Q_source(t) · Q_source_rest⁻¹ · A⁻¹ · Q_target_rest made local under its animated parent,
// the root-motion joint placed at p_target_rest + k · A · (p_source(t) − p_source_rest).
#include <algorithm>
#include <cmath>
#include <utility>

#include "retarget_stages.h"
#include "skinspheres/skinning/sampling_job.h"

namespace skinspheres::lib::retarget {
namespace {

template <typename V>
void AddTrackTimes(const skinning::Track<V>& track, std::vector<float>* times) {
  const auto& t = track.times_s;
  for (size_t k = 0; k < t.size(); ++k) {
    times->push_back(t[k]);
    if (k == 0) continue;
    if (track.interpolation == skinning::Interpolation::kStep) {
      times->push_back(std::max(t[k - 1], t[k] - kRetargetStepEpsilon_s));
    } else if (track.interpolation == skinning::Interpolation::kCubicSpline) {
      for (int s = 1; s < kRetargetCubicSubdivisions; ++s)
        times->push_back(t[k - 1] + (t[k] - t[k - 1]) * static_cast<float>(s) / kRetargetCubicSubdivisions);
    }
  }
}

// Keys whose rotations take the short way from one to the next (q and -q are the same rotation).
void MakeContinuous(std::vector<Quatf>* keys) {
  for (size_t k = 1; k < keys->size(); ++k) {
    if ((*keys)[k].coeffs().dot((*keys)[k - 1].coeffs()) < 0.0f) (*keys)[k].coeffs() *= -1.0f;
  }
}

}  // namespace

std::vector<float> BakeTimes(const skinning::AnimationClip& clip) {
  std::vector<float> times = {0.0f};
  const float duration = std::max(0.0f, clip.duration_s);
  times.push_back(duration);
  for (const auto& tr : clip.tracks) {
    AddTrackTimes(tr.translation, &times);
    AddTrackTimes(tr.rotation, &times);
    AddTrackTimes(tr.scale, &times);
  }
  for (float& t : times) t = std::isfinite(t) ? std::clamp(t, 0.0f, duration) : 0.0f;
  std::sort(times.begin(), times.end());
  times.erase(std::unique(times.begin(), times.end()), times.end());
  return times;
}

Result<skinning::AnimationClip> TransferClip(const SourceRig& source, size_t clip_index, const RawCharacter& target,
                                             const Correspondence& c, const WorldPose& source_rest,
                                             const WorldPose& target_rest, const Alignment& alignment,
                                             int32_t root_joint) {
  const skinning::AnimationClip& in = source.clips.at(clip_index);
  std::string why;
  if (!skinning::ValidateClip(in, source.nodes, &why)) {
    return MakeError(ErrorCode::kInvalidData, source.source_file + ": clip \"" + in.name + "\": " + why);
  }
  const skinning::Skeleton& t = target.skeleton;
  const std::vector<float> times = BakeTimes(in);
  // Per mapped joint: A⁻¹ · S_j · Q_target_rest and Q_source_rest⁻¹, the constant factors of its rotation.
  const Quatf a = alignment.rotation;
  std::vector<Quatf> after(t.size()), before(t.size());
  std::vector<int32_t> mapped;
  for (size_t j = 0; j < t.size(); ++j) {
    const int32_t n = c.node_of[j];
    if (n < 0) continue;
    mapped.push_back(static_cast<int32_t>(j));
    after[j] = (a.inverse() * alignment.swing[j] * target_rest.rotation[j]).normalized();
    before[j] = source_rest.rotation[static_cast<size_t>(n)].inverse();
  }
  const int32_t root_node = root_joint >= 0 ? c.node_of[static_cast<size_t>(root_joint)] : -1;
  if (uint64_t{times.size()} * (mapped.size() + 1) > kMaxRetargetKeys) {
    return MakeError(ErrorCode::kInvalidData, source.source_file + ": clip \"" + in.name + "\" would be baked at " +
                                                  std::to_string(times.size()) + " times for " +
                                                  std::to_string(mapped.size()) + " joints, more than " +
                                                  std::to_string(kMaxRetargetKeys) + " keys");
  }

  skinning::AnimationClip out;
  out.name = in.name;
  out.duration_s = in.duration_s;
  std::vector<std::vector<Quatf>> rotations(t.size());
  std::vector<Eigen::Vector3f> root_translations;
  std::vector<skinning::Transform> source_locals(source.nodes.size());
  std::vector<Mat4f> scratch, target_world(t.size());
  std::vector<Quatf> target_rotation(t.size());
  WorldPose now;
  for (float time : times) {
    if (!skinning::SamplingJob{&in, &source.nodes, time, source_locals}.Run()) {
      return MakeError(ErrorCode::kInvalidData, source.source_file + ": clip \"" + in.name +
                                                    "\" cannot be sampled at t=" + std::to_string(time));
    }
    PoseOf(source.nodes, source_locals, &now, &scratch);
    for (size_t j = 0; j < t.size(); ++j) {
      const int32_t p = t.parents[j];
      const Quatf parent_rotation = p < 0 ? Quatf(Quatf::Identity()) : target_rotation[static_cast<size_t>(p)];
      const Mat4f parent_world = p < 0 ? Mat4f::Identity() : target_world[static_cast<size_t>(p)];
      skinning::Transform local = t.rest_local[j];
      const int32_t n = c.node_of[j];
      if (n >= 0) {
        const Quatf world = (a * now.rotation[static_cast<size_t>(n)] * before[j] * after[j]).normalized();
        local.rotation = (parent_rotation.inverse() * world).normalized();
        rotations[j].push_back(local.rotation);
      }
      if (static_cast<int32_t>(j) == root_joint && root_node >= 0) {
        const Eigen::Vector3f moved =
            now.position[static_cast<size_t>(root_node)] - source_rest.position[static_cast<size_t>(root_node)];
        const Eigen::Vector3f world = target_rest.position[j] + alignment.hip_scale * (a * moved);
        local.translation = (parent_world.inverse() * world.homogeneous()).head<3>();
        root_translations.push_back(local.translation);
      }
      target_rotation[j] = (parent_rotation * local.rotation).normalized();
      target_world[j] = parent_world * local.ToMatrix();
    }
  }
  for (int32_t j : mapped) {
    skinning::JointTrack track;
    track.joint = j;
    track.rotation.times_s = times;
    track.rotation.values = std::move(rotations[static_cast<size_t>(j)]);
    MakeContinuous(&track.rotation.values);
    if (j == root_joint && root_node >= 0) {
      track.translation.times_s = times;
      track.translation.values = std::exchange(root_translations, {});
    }
    out.tracks.push_back(std::move(track));
  }
  return out;
}

}  // namespace skinspheres::lib::retarget
