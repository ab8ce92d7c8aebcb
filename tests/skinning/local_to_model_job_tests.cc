// LocalToModelJob against a naive recursive product G_i = G_parent(i) · L_i on random skeletons,
// the rest pose against Skeleton::RestWorld, a root transform, and refusals.
#include <gtest/gtest.h>

#include <random>
#include <vector>

#include "skinspheres/skinning/local_to_model_job.h"

namespace skinspheres::skinning {
namespace {

Skeleton RandomSkeleton(size_t n, uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  Skeleton s;
  for (size_t i = 0; i < n; ++i) {
    std::string name = std::to_string(i);  // ("j" + to_string trips GCC 12's -Wrestrict false positive)
    name.insert(name.begin(), 'j');
    s.joint_names.push_back(name);
    s.parents.push_back(i == 0 || rng() % 9 == 0 ? -1 : static_cast<int32_t>(rng() % i));
    Transform t;
    t.translation = Eigen::Vector3f(u(rng), u(rng), u(rng));
    t.rotation = skinspheres::Quatf(Eigen::AngleAxisf(3 * u(rng), Eigen::Vector3f(u(rng), u(rng), 2).normalized()));
    t.scale = Eigen::Vector3f(1 + 0.2f * u(rng), 1 + 0.2f * u(rng), 1 + 0.2f * u(rng));
    s.rest_local.push_back(t);
  }
  return s;
}

skinspheres::Mat4f NaiveWorld(const Skeleton& s, std::span<const Transform> locals, const skinspheres::Mat4f& root,
                              int i) {
  const skinspheres::Mat4f l = locals[i].ToMatrix();
  return s.parents[i] < 0 ? skinspheres::Mat4f(root * l)
                          : skinspheres::Mat4f(NaiveWorld(s, locals, root, s.parents[i]) * l);
}

TEST(LocalToModelJob, MatchesNaiveRecursiveProduct) {
  const Skeleton s = RandomSkeleton(40, 3);
  std::mt19937 rng(8);
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  std::vector<Transform> pose = s.rest_local;
  for (Transform& t : pose)
    t.rotation = skinspheres::Quatf(Eigen::AngleAxisf(u(rng), Eigen::Vector3f::UnitY())) * t.rotation;
  skinspheres::Mat4f root = skinspheres::Mat4f::Identity();
  root.topRightCorner<3, 1>() = Eigen::Vector3f(10, 0, -5);
  std::vector<skinspheres::Mat4f> out(s.size());
  LocalToModelJob job;
  job.skeleton = &s;
  job.root = root;
  job.input = pose;
  job.output = out;
  ASSERT_TRUE(job.Run());
  for (size_t i = 0; i < s.size(); ++i) {
    const skinspheres::Mat4f expected = NaiveWorld(s, pose, root, static_cast<int>(i));
    EXPECT_LT((out[i] - expected).cwiseAbs().maxCoeff(), 1e-4f) << "joint " << i;
  }
}

TEST(LocalToModelJob, RestPoseMatchesRestWorld) {
  const Skeleton s = RandomSkeleton(25, 5);
  std::vector<skinspheres::Mat4f> rest(s.size()), out(s.size());
  s.RestWorld(rest);
  LocalToModelJob job;
  job.skeleton = &s;
  job.input = s.rest_local;
  job.output = out;
  ASSERT_TRUE(job.Run());
  for (size_t i = 0; i < s.size(); ++i) EXPECT_TRUE(out[i].isApprox(rest[i], 1e-5f)) << i;
}

TEST(LocalToModelJob, RefusesBadJobs) {
  EXPECT_FALSE(LocalToModelJob().Validate());
  Skeleton s = RandomSkeleton(5, 1);
  std::vector<skinspheres::Mat4f> out(5);
  LocalToModelJob job;
  job.skeleton = &s;
  job.input = s.rest_local;
  job.output = out;
  EXPECT_TRUE(job.Validate());
  LocalToModelJob j = job;
  j.output = std::span<skinspheres::Mat4f>(out).first(4);
  EXPECT_FALSE(j.Run());
  j = job;
  j.input = std::span<const Transform>(s.rest_local).first(4);
  EXPECT_FALSE(j.Run());
  Skeleton bad = s;
  bad.parents[2] = 3;  // child before parent
  j = job;
  j.skeleton = &bad;
  EXPECT_FALSE(j.Run());
}

}  // namespace
}  // namespace skinspheres::skinning
