// SamplingJob: evaluates an AnimationClip at one time into per-joint local transforms.
//
// Contract:
//  - time_s is clamped to [0, clip->duration_s] (when duration_s > 0); inside each track the value
//    is held before its first key and after its last key (glTF 2.0). LoopTime() wraps a running
//    time into the clip for looping playback.
//  - STEP holds key i on [t_i, t_i+1); LINEAR lerps translations/scales and slerps rotations
//    (shortest arc); CUBICSPLINE is glTF's Hermite spline: values hold (in-tangent a_k, value v_k,
//    out-tangent b_k) per key and, with s = (t - t_k) / Δt, Δt = t_k+1 - t_k,
//      p(s) = (2s³-3s²+1) v_k + (s³-2s²+s) Δt b_k + (-2s³+3s²) v_k+1 + (s³-s²) Δt a_k+1.
//    Rotations are renormalised after LINEAR and CUBICSPLINE.
//  - out_local must hold >= skeleton->size() entries; a joint (or channel) without a track gets
//    the skeleton's rest_local value. Entries past skeleton->size() are not touched.
//  - Validate() is O(tracks) (sizes, joint indices, finite time); it does not re-check that key
//    times increase: ValidateClip() does that once, offline. Run() validates, never allocates,
//    never throws. Nothing else in skinning needs a clip.
#pragma once

#include <span>
#include <string>

#include "skinspheres/skinning/animation_clip.h"
#include "skinspheres/skinning/skeleton.h"

namespace skinspheres::skinning {

struct SamplingJob {
  const AnimationClip* clip = nullptr;
  const Skeleton* skeleton = nullptr;
  float time_s = 0.0f;             // seconds from the clip's start
  std::span<Transform> out_local;  // >= skeleton->size()

  bool Validate() const;
  bool Run() const;
};

// Wraps a running time into [0, duration_s) for looping playback (0 when duration_s <= 0 or
// time_s is not finite). Negative times wrap backwards.
float LoopTime(float time_s, float duration_s);

// Full offline check of a clip against a skeleton: joint indices in range, key times finite and
// strictly increasing, value counts matching the interpolation (1 or 3 per key), finite values.
// On failure returns false and, when error is given, says which track and what is wrong.
bool ValidateClip(const AnimationClip& clip, const Skeleton& skeleton, std::string* error = nullptr);

}  // namespace skinspheres::skinning
