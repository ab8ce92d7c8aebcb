// Test-only oracle: a slow, obvious clip sampler + forward kinematics + linear blend skinning,
// written independently of skinning/ so tests can check clips and skinned shapes against it. It
// takes any character type with a skinning::Skeleton `skeleton` and a skinning::SkinnedMesh `skin`
// (lib::RawCharacter in the offline tests, test::Character from the fixtures elsewhere).
#pragma once

#include <Eigen/Geometry>
#include <algorithm>
#include <vector>

#include "skinspheres/skinning/animation_clip.h"
#include "skinspheres/skinning/math_types.h"
#include "skinspheres/skinning/skeleton.h"
#include "skinspheres/skinning/skinned_mesh.h"

namespace skinspheres::test {

// Finds the key interval of t: i with times[i] <= t < times[i+1] (clamped), and the fraction u.
inline void FindKey(const std::vector<float>& times, float t, size_t& i, float& u) {
  if (times.size() == 1 || t <= times.front()) {
    i = 0;
    u = 0.0f;
    return;
  }
  if (t >= times.back()) {
    i = times.size() - 1;
    u = 0.0f;
    return;
  }
  i = static_cast<size_t>(std::upper_bound(times.begin(), times.end(), t) - times.begin()) - 1;
  u = (t - times[i]) / (times[i + 1] - times[i]);
}

template <typename V>
V Hermite(const skinning::Track<V>& tr, size_t i, float u) {
  const float dt = tr.times_s[i + 1] - tr.times_s[i];
  const V& p0 = tr.values[3 * i + 1];
  const V& m0 = tr.values[3 * i + 2];
  const V& p1 = tr.values[3 * (i + 1) + 1];
  const V& m1 = tr.values[3 * (i + 1) + 0];
  const float u2 = u * u, u3 = u2 * u;
  return (2 * u3 - 3 * u2 + 1) * p0 + (u3 - 2 * u2 + u) * dt * m0 + (-2 * u3 + 3 * u2) * p1 + (u3 - u2) * dt * m1;
}

inline Eigen::Vector3f SampleVec(const skinning::Track<Eigen::Vector3f>& tr, float t) {
  size_t i;
  float u;
  FindKey(tr.times_s, t, i, u);
  const bool cubic = tr.interpolation == skinning::Interpolation::kCubicSpline;
  auto value = [&](size_t k) { return cubic ? tr.values[3 * k + 1] : tr.values[k]; };
  if (i + 1 >= tr.times_s.size() || u == 0.0f) return value(i);
  if (tr.interpolation == skinning::Interpolation::kStep) return value(i);
  if (cubic) return Hermite(tr, i, u);
  return (1 - u) * value(i) + u * value(i + 1);
}

inline skinspheres::Quatf SampleQuat(const skinning::Track<skinspheres::Quatf>& tr, float t) {
  size_t i;
  float u;
  FindKey(tr.times_s, t, i, u);
  const bool cubic = tr.interpolation == skinning::Interpolation::kCubicSpline;
  auto value = [&](size_t k) { return cubic ? tr.values[3 * k + 1] : tr.values[k]; };
  if (i + 1 >= tr.times_s.size() || u == 0.0f) return value(i).normalized();
  if (tr.interpolation == skinning::Interpolation::kStep) return value(i).normalized();
  if (cubic) {
    const float dt = tr.times_s[i + 1] - tr.times_s[i];
    const float u2 = u * u, u3 = u2 * u;
    const skinspheres::Vec4f p0 = tr.values[3 * i + 1].coeffs(), m0 = tr.values[3 * i + 2].coeffs();
    const skinspheres::Vec4f p1 = tr.values[3 * (i + 1) + 1].coeffs(), m1 = tr.values[3 * (i + 1)].coeffs();
    const skinspheres::Vec4f c =
        (2 * u3 - 3 * u2 + 1) * p0 + (u3 - 2 * u2 + u) * dt * m0 + (-2 * u3 + 3 * u2) * p1 + (u3 - u2) * dt * m1;
    return skinspheres::Quatf(c.normalized());
  }
  return value(i).normalized().slerp(u, value(i + 1).normalized());
}

// Local transforms of every joint at time t (rest where a channel has no track).
template <class Character>
std::vector<skinning::Transform> SampleLocal(const Character& c, const skinning::AnimationClip& clip, float t) {
  std::vector<skinning::Transform> local = c.skeleton.rest_local;
  for (const auto& tr : clip.tracks) {
    if (!tr.translation.empty()) local[tr.joint].translation = SampleVec(tr.translation, t);
    if (!tr.rotation.empty()) local[tr.joint].rotation = SampleQuat(tr.rotation, t);
    if (!tr.scale.empty()) local[tr.joint].scale = SampleVec(tr.scale, t);
  }
  return local;
}

template <class Character>
std::vector<skinspheres::Mat4f> WorldOf(const Character& c, const std::vector<skinning::Transform>& local) {
  std::vector<skinspheres::Mat4f> w(local.size());
  for (size_t j = 0; j < local.size(); ++j) {
    const skinspheres::Mat4f m = local[j].ToMatrix();
    w[j] = c.skeleton.parents[j] < 0 ? m : skinspheres::Mat4f(w[c.skeleton.parents[j]] * m);
  }
  return w;
}

// p' = Σ w_k · G_joint(b_k) · IBM_k · p_bind for every vertex.
template <class Character>
std::vector<Eigen::Vector3f> Skin(const Character& c, const std::vector<skinspheres::Mat4f>& world) {
  const auto& s = c.skin;
  std::vector<Eigen::Vector3f> out(s.vertex_count());
  for (size_t v = 0; v < s.vertex_count(); ++v) {
    skinspheres::Vec4f acc = skinspheres::Vec4f::Zero();
    for (uint32_t k = s.influence_offsets[v]; k < s.influence_offsets[v + 1]; ++k) {
      const auto& b = s.binds[s.influence_binds[k]];
      acc += s.influence_weights[k] * (world[b.joint] * b.inverse_bind * s.positions_bind[v].homogeneous());
    }
    out[v] = acc.head<3>();
  }
  return out;
}

template <class Character>
std::vector<Eigen::Vector3f> PoseAt(const Character& c, const skinning::AnimationClip& clip, float t) {
  return Skin(c, WorldOf(c, SampleLocal(c, clip, t)));
}

}  // namespace skinspheres::test
