// AnimationClip: keyframed joint tracks, times in seconds from the clip's start.
//
// Interpolation follows glTF 2.0: STEP, LINEAR (slerp for rotations) and CUBICSPLINE (Hermite;
// values hold three entries per key: in-tangent, value, out-tangent, tangents scaled by the key
// interval when evaluated). A joint without a track for a channel keeps its rest value.
#pragma once

#include <Eigen/Geometry>
#include <cstdint>
#include <string>
#include <vector>

#include "skinspheres/skinning/math_types.h"

namespace skinspheres::skinning {

enum class Interpolation : uint8_t { kStep, kLinear, kCubicSpline };

template <typename Value>
struct Track {
  Interpolation interpolation = Interpolation::kLinear;
  std::vector<float> times_s;  // strictly increasing
  std::vector<Value> values;   // times_s.size() values, or 3x that for kCubicSpline
  bool empty() const { return times_s.empty(); }
};

struct JointTrack {
  int32_t joint = -1;  // index into the Skeleton
  Track<Eigen::Vector3f> translation;
  Track<Quatf> rotation;
  Track<Eigen::Vector3f> scale;
};

struct AnimationClip {
  std::string name;
  float duration_s = 0.0f;
  std::vector<JointTrack> tracks;
};

}  // namespace skinspheres::skinning
