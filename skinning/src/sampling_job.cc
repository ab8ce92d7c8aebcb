
#include "skinspheres/skinning/sampling_job.h"

#include <algorithm>
#include <cmath>
#include <sstream>

namespace skinspheres::skinning {
namespace {

template <typename V>
size_t ValuesPerKey(const Track<V>& track) {
  return track.interpolation == Interpolation::kCubicSpline ? 3 : 1;
}

template <typename V>
bool TrackSizesOk(const Track<V>& track) {
  return track.values.size() == track.times_s.size() * ValuesPerKey(track);
}

// Value of key k (the middle of the triple for CUBICSPLINE).
template <typename V>
const V& KeyValue(const Track<V>& track, size_t k) {
  return track.values[k * ValuesPerKey(track) + (ValuesPerKey(track) == 3 ? 1 : 0)];
}

inline Eigen::Vector3f Lerp(const Eigen::Vector3f& a, const Eigen::Vector3f& b, float s) { return a + (b - a) * s; }
inline Quatf Lerp(const Quatf& a, const Quatf& b, float s) {
  return a.slerp(s, b).normalized();  // Eigen's slerp takes the shortest arc
}

inline Vec4f Coeffs(const Eigen::Vector3f& v) { return Vec4f(v.x(), v.y(), v.z(), 0.0f); }
inline Vec4f Coeffs(const Quatf& q) { return q.coeffs(); }
inline void FromCoeffs(const Vec4f& c, Eigen::Vector3f* v) { *v = c.head<3>(); }
inline void FromCoeffs(const Vec4f& c, Quatf* q) {
  *q = Quatf(c[3], c[0], c[1], c[2]);
  const float n = q->norm();
  *q = n > 0.0f ? Quatf(q->coeffs() / n) : Quatf(Quatf::Identity());
}

// Samples one track at t (already clamped to the clip). Keys must be non-empty.
template <typename V>
V Sample(const Track<V>& track, float t) {
  const std::vector<float>& times = track.times_s;
  const size_t n = times.size();
  if (n == 1 || !(t > times.front())) return KeyValue(track, 0);
  if (t >= times.back()) return KeyValue(track, n - 1);
  // k: last key with times[k] <= t; t < times[k + 1].
  // min: a NaN last key (a clip that skipped ValidateClip) must not index past the end.
  const size_t k =
      std::min(static_cast<size_t>(std::upper_bound(times.begin(), times.end(), t) - times.begin()) - 1, n - 2);
  const float dt = times[k + 1] - times[k];
  const float s = dt > 0.0f ? std::clamp((t - times[k]) / dt, 0.0f, 1.0f) : 0.0f;
  switch (track.interpolation) {
    case Interpolation::kStep: return KeyValue(track, k);
    case Interpolation::kLinear: return Lerp(track.values[k], track.values[k + 1], s);
    case Interpolation::kCubicSpline: {
      // values: [a_k, v_k, b_k] per key (in-tangent, value, out-tangent).
      const Vec4f v0 = Coeffs(track.values[3 * k + 1]);
      const Vec4f b0 = Coeffs(track.values[3 * k + 2]);
      const Vec4f a1 = Coeffs(track.values[3 * (k + 1)]);
      const Vec4f v1 = Coeffs(track.values[3 * (k + 1) + 1]);
      const float s2 = s * s, s3 = s2 * s;
      const Vec4f p =
          (2 * s3 - 3 * s2 + 1) * v0 + (s3 - 2 * s2 + s) * dt * b0 + (-2 * s3 + 3 * s2) * v1 + (s3 - s2) * dt * a1;
      V out;
      FromCoeffs(p, &out);
      return out;
    }
  }
  return KeyValue(track, k);
}

template <typename V>
bool FiniteValue(const V& v) {
  return Coeffs(v).allFinite();
}

template <typename V>
bool CheckTrack(const Track<V>& track, const char* channel, size_t index, std::string* error) {
  auto fail = [&](const std::string& what) {
    if (error) {
      std::ostringstream os;
      os << "track " << index << " (" << channel << "): " << what;
      *error = os.str();
    }
    return false;
  };
  if (!TrackSizesOk(track)) {
    std::ostringstream os;
    os << track.values.size() << " values for " << track.times_s.size() << " keys (expected "
       << track.times_s.size() * ValuesPerKey(track) << ")";
    return fail(os.str());
  }
  for (size_t k = 0; k < track.times_s.size(); ++k) {
    if (!std::isfinite(track.times_s[k])) return fail("key time " + std::to_string(k) + " is not finite");
    if (k > 0 && !(track.times_s[k] > track.times_s[k - 1]))
      return fail("key times not strictly increasing at key " + std::to_string(k));
  }
  for (size_t i = 0; i < track.values.size(); ++i) {
    if (!FiniteValue(track.values[i])) return fail("value " + std::to_string(i) + " is not finite");
  }
  return true;
}

}  // namespace

bool SamplingJob::Validate() const {
  if (clip == nullptr || skeleton == nullptr) return false;
  if (!std::isfinite(time_s)) return false;
  if (!skeleton->Validate() || out_local.size() < skeleton->size()) return false;
  const int32_t joints = static_cast<int32_t>(skeleton->size());
  for (const JointTrack& track : clip->tracks) {
    if (track.joint < 0 || track.joint >= joints) return false;
    if (!TrackSizesOk(track.translation) || !TrackSizesOk(track.rotation) || !TrackSizesOk(track.scale)) return false;
  }
  return true;
}

bool SamplingJob::Run() const {
  if (!Validate()) return false;
  float t = time_s;
  if (clip->duration_s > 0.0f) t = std::clamp(t, 0.0f, clip->duration_s);
  const size_t n = skeleton->size();
  std::copy(skeleton->rest_local.begin(), skeleton->rest_local.begin() + static_cast<std::ptrdiff_t>(n),
            out_local.begin());
  for (const JointTrack& track : clip->tracks) {
    Transform& out = out_local[static_cast<size_t>(track.joint)];
    if (!track.translation.empty()) out.translation = Sample(track.translation, t);
    if (!track.rotation.empty()) out.rotation = Sample(track.rotation, t);
    if (!track.scale.empty()) out.scale = Sample(track.scale, t);
  }
  return true;
}

float LoopTime(float time_s, float duration_s) {
  if (!(duration_s > 0.0f) || !std::isfinite(time_s) || !std::isfinite(duration_s)) return 0.0f;
  float t = std::fmod(time_s, duration_s);
  if (t < 0.0f) t += duration_s;
  return t >= duration_s ? 0.0f : t;  // fmod of a negative tiny value can round up to duration
}

bool ValidateClip(const AnimationClip& clip, const Skeleton& skeleton, std::string* error) {
  if (!skeleton.Validate()) {
    if (error) *error = "skeleton is inconsistent (array sizes or parent order)";
    return false;
  }
  if (!std::isfinite(clip.duration_s) || clip.duration_s < 0.0f) {
    if (error) *error = "clip '" + clip.name + "': duration is negative or not finite";
    return false;
  }
  for (size_t i = 0; i < clip.tracks.size(); ++i) {
    const JointTrack& track = clip.tracks[i];
    if (track.joint < 0 || static_cast<size_t>(track.joint) >= skeleton.size()) {
      if (error) {
        *error = "clip '" + clip.name + "': track " + std::to_string(i) + " names joint " +
                 std::to_string(track.joint) + ", skeleton has " + std::to_string(skeleton.size());
      }
      return false;
    }
    std::string what;
    if (!CheckTrack(track.translation, "translation", i, &what) || !CheckTrack(track.rotation, "rotation", i, &what) ||
        !CheckTrack(track.scale, "scale", i, &what)) {
      if (error) *error = "clip '" + clip.name + "': " + what;
      return false;
    }
  }
  return true;
}

}  // namespace skinspheres::skinning
