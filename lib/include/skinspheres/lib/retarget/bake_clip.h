// BakeClip: a clip as one LINEAR key per frame for every joint of a skeleton, the form a clip takes
// when written for other tools (`skinspheres retarget`): what they play at that frame rate is what
// `play` and `check` sampled.
#pragma once

#include "skinspheres/runtime/error.h"
#include "skinspheres/skinning/animation_clip.h"
#include "skinspheres/skinning/skeleton.h"

namespace skinspheres::lib {

// Frames f = 0 .. floor(duration · fps + 1e-3) at times f / fps (in float, as the tool's playback
// computes them), each joint's local translation, rotation and scale sampled there (SamplingJob:
// a joint without a track keeps its rest value) and stored as a LINEAR key, so that sampling the
// result at a frame time gives the source's sample there bit for bit. The name is kept; the
// duration becomes the last frame's time. Errors (kInvalidArgument): fps not in (0, 10000], a clip
// that does not validate against the skeleton, or more than 1,000,000 frames.
Result<skinning::AnimationClip> BakeClip(const skinning::AnimationClip& clip, const skinning::Skeleton& skeleton,
                                         float fps);

}  // namespace skinspheres::lib
