// FramesAt, SampleFrames, ClipFromFrames, BakeClip (bake_clip.h).
#include "skinspheres/lib/retarget/bake_clip.h"

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "skinspheres/skinning/sampling_job.h"

namespace skinspheres::lib {

double FramesAt(float duration_s, float fps) { return std::floor(double(duration_s) * fps + 1e-3) + 1.0; }

Result<std::vector<std::vector<skinning::Transform>>> SampleFrames(const skinning::AnimationClip& clip,
                                                                   const skinning::Skeleton& skeleton, float fps) {
  if (!(fps > 0.0f) || fps > 10000.0f) {
    return MakeError(ErrorCode::kInvalidArgument,
                     "the frame rate must be in (0, 10000] (got " + std::to_string(fps) + ")");
  }
  std::string why;
  if (!skinning::ValidateClip(clip, skeleton, &why)) {
    return MakeError(ErrorCode::kInvalidArgument, "clip \"" + clip.name + "\": " + why);
  }
  const double frames = FramesAt(clip.duration_s, fps);
  if (!(frames <= kMaxFrames)) {
    return MakeError(ErrorCode::kInvalidArgument,
                     "clip \"" + clip.name + "\" would play " + std::to_string(frames) + " frames (at most 1000000)");
  }
  std::vector<std::vector<skinning::Transform>> out(static_cast<size_t>(std::max(1.0, frames)),
                                                    std::vector<skinning::Transform>(skeleton.size()));
  for (size_t f = 0; f < out.size(); ++f) {
    const float t = static_cast<float>(static_cast<int>(f)) / fps;  // playback: f / fps with int f
    // The clip's time at t as playback takes it (PlaybackTime in the tool): t within the clip,
    // else wrapped (a last frame up to a thousandth of a frame past the end).
    const float clip_time = !(clip.duration_s > 0.0f)             ? 0.0f
                            : (t >= 0.0f && t <= clip.duration_s) ? t
                                                                  : skinning::LoopTime(t, clip.duration_s);
    if (!skinning::SamplingJob{&clip, &skeleton, clip_time, out[f]}.Run()) {
      return MakeError(ErrorCode::kInvalidArgument,
                       "clip \"" + clip.name + "\" cannot be sampled at t=" + std::to_string(clip_time));
    }
  }
  return out;
}

skinning::AnimationClip ClipFromFrames(const std::string& name,
                                       const std::vector<std::vector<skinning::Transform>>& frames, float fps) {
  skinning::AnimationClip out;
  out.name = name;
  const size_t joints = frames.empty() ? 0 : frames.front().size(), n = frames.size();
  out.tracks.resize(joints);
  for (size_t j = 0; j < joints; ++j) {
    skinning::JointTrack& tr = out.tracks[j];
    tr.joint = static_cast<int32_t>(j);
    for (auto* times : {&tr.translation.times_s, &tr.rotation.times_s, &tr.scale.times_s}) times->reserve(n);
    tr.translation.values.reserve(n);
    tr.rotation.values.reserve(n);
    tr.scale.values.reserve(n);
  }
  for (size_t f = 0; f < n; ++f) {
    const float t = static_cast<float>(static_cast<int>(f)) / fps;
    for (size_t j = 0; j < joints; ++j) {
      skinning::JointTrack& tr = out.tracks[j];
      tr.translation.times_s.push_back(t);
      tr.rotation.times_s.push_back(t);
      tr.scale.times_s.push_back(t);
      tr.translation.values.push_back(frames[f][j].translation);
      tr.rotation.values.push_back(frames[f][j].rotation);
      tr.scale.values.push_back(frames[f][j].scale);
    }
  }
  out.duration_s = out.tracks.empty() ? 0.0f : out.tracks.front().translation.times_s.back();
  return out;
}

Result<skinning::AnimationClip> BakeClip(const skinning::AnimationClip& clip, const skinning::Skeleton& skeleton,
                                         float fps) {
  auto frames = SampleFrames(clip, skeleton, fps);
  if (!frames.ok()) return frames.error();
  return ClipFromFrames(clip.name, *frames, fps);
}

}  // namespace skinspheres::lib
