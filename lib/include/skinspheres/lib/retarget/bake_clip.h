// BakeClip: a clip as one LINEAR key per frame for every joint of a skeleton, the form a clip takes
// when written for other tools (`skinspheres retarget`): what they play at that frame rate is what
// `play` and `check` sampled.
#pragma once

#include <string>
#include <vector>

#include "skinspheres/runtime/error.h"
#include "skinspheres/skinning/animation_clip.h"
#include "skinspheres/skinning/skeleton.h"

namespace skinspheres::lib {

// How many frames a clip plays at fps: floor(duration · fps + 1e-3) + 1 (the last at t = duration,
// a thousandth of a frame of slack for rounding), in double so that no duration overflows; callers
// cap it (kMaxFrames).
double FramesAt(float duration_s, float fps);
inline constexpr double kMaxFrames = 1e6;

// A clip's frames as poses: per frame f (0 .. FramesAt - 1, at time f / fps in float, as the tool's
// playback computes them), every joint's local transform (SamplingJob: a joint without a track keeps
// its rest value). Errors (kInvalidArgument): fps not in (0, 10000], a clip that does not validate
// against the skeleton, more than kMaxFrames frames.
Result<std::vector<std::vector<skinning::Transform>>> SampleFrames(const skinning::AnimationClip& clip,
                                                                   const skinning::Skeleton& skeleton, float fps);

// Poses back to a clip: for every joint, a LINEAR key per frame at f / fps (translation, rotation,
// scale), so that sampling the result at a frame time gives that frame's pose bit for bit. The
// duration is the last frame's time.
skinning::AnimationClip ClipFromFrames(const std::string& name,
                                       const std::vector<std::vector<skinning::Transform>>& frames, float fps);

// SampleFrames then ClipFromFrames, the name kept.
Result<skinning::AnimationClip> BakeClip(const skinning::AnimationClip& clip, const skinning::Skeleton& skeleton,
                                         float fps);

}  // namespace skinspheres::lib
