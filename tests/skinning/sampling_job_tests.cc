// SamplingJob against analytic values: STEP, LINEAR (lerp, slerp), glTF CUBICSPLINE Hermite
// (reproduces a cubic exactly from its values and derivatives), before the first and after the
// last key, a single key, rest values for untouched joints/channels, clamping, looping, refusals.
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "skinspheres/skinning/sampling_job.h"

namespace skinspheres::skinning {
namespace {

Skeleton ThreeJoints() {
  Skeleton s;
  s.joint_names = {"root", "spine", "head"};
  s.parents = {-1, 0, 1};
  s.rest_local.resize(3);
  for (int i = 0; i < 3; ++i) {
    s.rest_local[i].translation = Eigen::Vector3f(1.0f * i, 2.0f, 3.0f);
    s.rest_local[i].rotation = skinspheres::Quatf(Eigen::AngleAxisf(0.1f * (i + 1), Eigen::Vector3f::UnitX()));
    s.rest_local[i].scale = Eigen::Vector3f(1.0f, 1.0f + i, 1.0f);
  }
  return s;
}

struct Sampler {
  Skeleton skeleton = ThreeJoints();
  AnimationClip clip;
  std::vector<Transform> out = std::vector<Transform>(3);
  const Transform& At(float t, int joint = 1) {
    SamplingJob job{&clip, &skeleton, t, out};
    EXPECT_TRUE(job.Run());
    return out[joint];
  }
};

float AngleBetween(const skinspheres::Quatf& a, const skinspheres::Quatf& b) { return a.angularDistance(b); }

TEST(SamplingJob, StepHoldsKeys) {
  Sampler s;
  s.clip.duration_s = 2.0f;
  JointTrack t;
  t.joint = 1;
  t.translation.interpolation = Interpolation::kStep;
  t.translation.times_s = {0.0f, 1.0f, 2.0f};
  t.translation.values = {{1, 0, 0}, {2, 0, 0}, {3, 0, 0}};
  s.clip.tracks.push_back(t);
  EXPECT_EQ(s.At(0.0f).translation.x(), 1.0f);
  EXPECT_EQ(s.At(0.999f).translation.x(), 1.0f);
  EXPECT_EQ(s.At(1.0f).translation.x(), 2.0f);
  EXPECT_EQ(s.At(1.5f).translation.x(), 2.0f);
  EXPECT_EQ(s.At(2.0f).translation.x(), 3.0f);
  EXPECT_EQ(s.At(7.0f).translation.x(), 3.0f);  // clamped to the clip
  EXPECT_EQ(s.At(-1.0f).translation.x(), 1.0f);
}

TEST(SamplingJob, LinearLerpsAndHoldsOutsideKeys) {
  Sampler s;
  s.clip.duration_s = 4.0f;
  JointTrack t;
  t.joint = 2;
  t.translation.times_s = {1.0f, 3.0f};
  t.translation.values = {{0, 0, 0}, {4, -2, 8}};
  t.scale.times_s = {1.0f, 3.0f};
  t.scale.values = {{1, 1, 1}, {3, 1, 1}};
  s.clip.tracks.push_back(t);
  const Transform& a = s.At(1.5f, 2);
  EXPECT_TRUE(a.translation.isApprox(Eigen::Vector3f(1, -0.5f, 2), 1e-6f));
  EXPECT_NEAR(a.scale.x(), 1.5f, 1e-6f);
  EXPECT_TRUE(s.At(0.5f, 2).translation.isApprox(Eigen::Vector3f(0, 0, 0)));        // before the first key
  EXPECT_TRUE(s.At(3.5f, 2).translation.isApprox(Eigen::Vector3f(4, -2, 8)));       // after the last key
  EXPECT_TRUE(s.At(3.5f, 2).rotation.isApprox(s.skeleton.rest_local[2].rotation));  // no rotation track
}

TEST(SamplingJob, LinearRotationSlerpsShortestArc) {
  Sampler s;
  s.clip.duration_s = 1.0f;
  JointTrack t;
  t.joint = 0;
  t.rotation.times_s = {0.0f, 1.0f};
  const skinspheres::Quatf q0 = skinspheres::Quatf::Identity();
  const skinspheres::Quatf q1(Eigen::AngleAxisf(1.2f, Eigen::Vector3f(1, 2, 3).normalized()));
  t.rotation.values = {q0, skinspheres::Quatf(-q1.coeffs())};  // same rotation, opposite sign
  s.clip.tracks.push_back(t);
  for (float u : {0.0f, 0.25f, 0.5f, 0.9f, 1.0f}) {
    const skinspheres::Quatf expected(Eigen::AngleAxisf(1.2f * u, Eigen::Vector3f(1, 2, 3).normalized()));
    const skinspheres::Quatf got = s.At(u, 0).rotation;
    EXPECT_NEAR(got.norm(), 1.0f, 1e-6f);
    EXPECT_LT(AngleBetween(got, expected), 1e-5f) << "u = " << u;
  }
}

TEST(SamplingJob, CubicSplineReproducesACubic) {
  // f(t) = c3 t³ + c2 t² + c1 t + c0 per component; keys hold f and f' (tangents are derivatives,
  // glTF scales them by the key interval), so the Hermite spline is exact.
  const Eigen::Vector3f c3(1, -0.5f, 0.25f), c2(-2, 1, 0), c1(0.5f, 3, -1), c0(0.5f, -1, 2);
  auto f = [&](float t) -> Eigen::Vector3f { return ((c3 * t + c2) * t + c1) * t + c0; };
  auto df = [&](float t) -> Eigen::Vector3f { return (3 * c3 * t + 2 * c2) * t + c1; };
  Sampler s;
  s.clip.duration_s = 5.0f;
  JointTrack t;
  t.joint = 1;
  t.translation.interpolation = Interpolation::kCubicSpline;
  t.translation.times_s = {1.0f, 1.5f, 3.5f};
  for (float k : t.translation.times_s) {
    t.translation.values.push_back(df(k));  // in-tangent a_k
    t.translation.values.push_back(f(k));   // value v_k
    t.translation.values.push_back(df(k));  // out-tangent b_k
  }
  s.clip.tracks.push_back(t);
  for (float time : {1.0f, 1.2f, 1.5f, 2.0f, 2.75f, 3.4f, 3.5f}) {
    EXPECT_LT((s.At(time).translation - f(time)).norm(), 2e-5f) << "t = " << time;
  }
  EXPECT_LT((s.At(0.2f).translation - f(1.0f)).norm(), 1e-6f);  // before the first key: v_0
  EXPECT_LT((s.At(4.9f).translation - f(3.5f)).norm(), 1e-6f);  // after the last key: v_last
}

TEST(SamplingJob, CubicSplineUsesInAndOutTangentsSeparately) {
  // One segment [0, 2], v0 = 0, v1 = 0, out-tangent b0 = 1, in-tangent a1 = 3 (x only).
  // p(s) = (s³ - 2s² + s) Δt b0 + (s³ - s²) Δt a1 with Δt = 2; at s = 0.5: 0.125·2·1 - 0.125·2·3 = -0.5.
  Sampler s;
  s.clip.duration_s = 2.0f;
  JointTrack t;
  t.joint = 1;
  t.translation.interpolation = Interpolation::kCubicSpline;
  t.translation.times_s = {0.0f, 2.0f};
  t.translation.values = {{100, 0, 0}, {0, 0, 0}, {1, 0, 0}, {3, 0, 0}, {0, 0, 0}, {-100, 0, 0}};
  s.clip.tracks.push_back(t);
  EXPECT_NEAR(s.At(1.0f).translation.x(), -0.5f, 1e-6f);
}

TEST(SamplingJob, CubicSplineRotationIsNormalised) {
  Sampler s;
  s.clip.duration_s = 1.0f;
  JointTrack t;
  t.joint = 1;
  t.rotation.interpolation = Interpolation::kCubicSpline;
  t.rotation.times_s = {0.0f, 1.0f};
  const skinspheres::Quatf zero(0, 0, 0, 0);
  const skinspheres::Quatf q1(Eigen::AngleAxisf(1.5f, Eigen::Vector3f::UnitZ()));
  t.rotation.values = {zero, skinspheres::Quatf::Identity(), zero, zero, q1, zero};
  s.clip.tracks.push_back(t);
  const skinspheres::Quatf mid = s.At(0.5f).rotation;
  EXPECT_NEAR(mid.norm(), 1.0f, 1e-6f);
  // Zero tangents: equal blend of two unit quaternions, renormalised = the half-angle rotation.
  EXPECT_LT(AngleBetween(mid, skinspheres::Quatf(Eigen::AngleAxisf(0.75f, Eigen::Vector3f::UnitZ()))), 1e-5f);
}

TEST(SamplingJob, SingleKeyIsConstantAndUntouchedJointsKeepRest) {
  Sampler s;
  s.clip.duration_s = 3.0f;
  for (Interpolation mode : {Interpolation::kStep, Interpolation::kLinear, Interpolation::kCubicSpline}) {
    s.clip.tracks.clear();
    JointTrack t;
    t.joint = 1;
    t.scale.interpolation = mode;
    t.scale.times_s = {1.0f};
    if (mode == Interpolation::kCubicSpline) {
      t.scale.values = {{9, 9, 9}, {2, 3, 4}, {9, 9, 9}};
    } else {
      t.scale.values = {{2, 3, 4}};
    }
    s.clip.tracks.push_back(t);
    for (float time : {0.0f, 1.0f, 2.5f}) {
      EXPECT_TRUE(s.At(time).scale.isApprox(Eigen::Vector3f(2, 3, 4))) << "mode " << int(mode);
      EXPECT_TRUE(s.out[1].translation.isApprox(s.skeleton.rest_local[1].translation));
      for (int j : {0, 2}) {
        EXPECT_TRUE(s.out[j].translation.isApprox(s.skeleton.rest_local[j].translation));
        EXPECT_TRUE(s.out[j].rotation.isApprox(s.skeleton.rest_local[j].rotation));
        EXPECT_TRUE(s.out[j].scale.isApprox(s.skeleton.rest_local[j].scale));
      }
    }
  }
}

TEST(SamplingJob, LoopTimeWraps) {
  EXPECT_FLOAT_EQ(LoopTime(2.5f, 1.0f), 0.5f);
  EXPECT_FLOAT_EQ(LoopTime(-0.25f, 1.0f), 0.75f);
  EXPECT_FLOAT_EQ(LoopTime(0.3f, 2.0f), 0.3f);
  EXPECT_EQ(LoopTime(1.0f, 0.0f), 0.0f);
  EXPECT_EQ(LoopTime(NAN, 1.0f), 0.0f);
  for (float t : {-1e-9f, 3.0f, 1e6f}) {
    const float l = LoopTime(t, 1.5f);
    EXPECT_GE(l, 0.0f);
    EXPECT_LT(l, 1.5f);
  }
}

TEST(SamplingJob, ValidateRefusesBadJobs) {
  EXPECT_FALSE(SamplingJob().Validate());
  EXPECT_FALSE(SamplingJob().Run());
  Sampler s;
  JointTrack t;
  t.joint = 1;
  t.translation.times_s = {0.0f, 1.0f};
  t.translation.values = {{0, 0, 0}, {1, 1, 1}};
  s.clip.tracks.push_back(t);
  SamplingJob good{&s.clip, &s.skeleton, 0.5f, s.out};
  EXPECT_TRUE(good.Validate());
  SamplingJob j = good;
  j.skeleton = nullptr;
  EXPECT_FALSE(j.Validate());
  j = good;
  j.clip = nullptr;
  EXPECT_FALSE(j.Validate());
  j = good;
  j.out_local = std::span<Transform>(s.out).first(2);
  EXPECT_FALSE(j.Run());
  j = good;
  j.time_s = NAN;
  EXPECT_FALSE(j.Run());
  AnimationClip bad = s.clip;
  bad.tracks[0].joint = 3;
  j = good;
  j.clip = &bad;
  EXPECT_FALSE(j.Run());
  bad = s.clip;
  bad.tracks[0].translation.values.pop_back();
  EXPECT_FALSE(j.Run());
  bad = s.clip;
  bad.tracks[0].translation.interpolation = Interpolation::kCubicSpline;  // needs 3 values per key
  EXPECT_FALSE(j.Run());
}

TEST(SamplingJob, ValidateClipExplainsProblems) {
  Skeleton skeleton = ThreeJoints();
  AnimationClip clip;
  clip.name = "walk";
  clip.duration_s = 1.0f;
  JointTrack t;
  t.joint = 0;
  t.rotation.times_s = {0.0f, 0.5f, 0.5f};
  t.rotation.values.assign(3, skinspheres::Quatf::Identity());
  clip.tracks.push_back(t);
  std::string error;
  EXPECT_FALSE(ValidateClip(clip, skeleton, &error));
  EXPECT_NE(error.find("walk"), std::string::npos) << error;
  EXPECT_NE(error.find("not strictly increasing"), std::string::npos) << error;
  clip.tracks[0].rotation.times_s = {0.0f, 0.5f, 1.0f};
  EXPECT_TRUE(ValidateClip(clip, skeleton, &error)) << error;
  clip.tracks[0].joint = 9;
  EXPECT_FALSE(ValidateClip(clip, skeleton, &error));
  EXPECT_NE(error.find("joint 9"), std::string::npos) << error;
}

}  // namespace
}  // namespace skinspheres::skinning
