// Tests of naive_joint_spheres.h: boxes and radii by hand, and refusals. (The baseline measured on a
// capsule and on the shared characters: fit_metrics_tests.cc.)
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "skinspheres/lib/metrics/naive_joint_spheres.h"

namespace skinspheres::lib {
namespace {

TEST(NaiveJointSpheres, BoundingBoxCentresAndFarthestVertexRadii) {
  const std::vector<Eigen::Vector3f> p{{0, 0, 0}, {2, 0, 0}, {0, 1, 0}, {10, 10, 10}, {10, 12, 10}};
  const std::vector<uint32_t> joint{3, 3, 3, 0, 0};
  const auto res = NaiveJointSpheres(p, joint);
  ASSERT_TRUE(res.ok());
  ASSERT_EQ(res->centers.size(), 2u);
  EXPECT_EQ(res->joints, (std::vector<uint32_t>{0, 3}));
  EXPECT_TRUE(res->centers[0].isApprox(Eigen::Vector3f(10, 11, 10)));
  EXPECT_NEAR(res->radii[0], 1.f, 1e-6);
  EXPECT_TRUE(res->centers[1].isApprox(Eigen::Vector3f(1, 0.5f, 0)));
  EXPECT_NEAR(res->radii[1], std::sqrt(1.25f), 1e-6);
  EXPECT_FALSE(NaiveJointSpheres(p, std::span<const uint32_t>(joint).first(3)).ok());
}

TEST(NaiveJointSpheres, CharacterWithoutInfluencesPutsEveryVertexOnJointZero) {
  RawCharacter c;
  c.source_file = "bare";
  c.positions_rest = {{0, 0, 0}, {2, 0, 0}, {1, 3, 0}};
  const auto res = NaiveJointSpheres(c);
  ASSERT_TRUE(res.ok()) << res.error().message;
  EXPECT_EQ(res->joints, (std::vector<uint32_t>{0}));
  EXPECT_TRUE(res->centers[0].isApprox(Eigen::Vector3f(1, 1.5f, 0)));
  c.skin.influence_offsets = {0, 0};  // neither empty nor one per vertex + 1
  const auto bad = NaiveJointSpheres(c);
  ASSERT_FALSE(bad.ok());
  EXPECT_NE(bad.error().message.find("bare"), std::string::npos) << bad.error().message;
}

}  // namespace
}  // namespace skinspheres::lib
