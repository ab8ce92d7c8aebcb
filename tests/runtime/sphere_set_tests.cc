#include "skinspheres/runtime/sphere_set.h"

#include <gtest/gtest.h>

namespace skinspheres::runtime {
namespace {

SphereSet TwoSpheres() {
  SphereSet set;
  set.source_vertex_count = 4;
  set.source_triangle_count = 2;
  set.joint_names = {"root"};
  set.joint_parents = {-1};
  set.joint_rest_world = {Eigen::Matrix4f::Identity()};
  set.parts = {{"torso", {0}}};
  set.centers_rest = {Eigen::Vector3f(0, 0, 0), Eigen::Vector3f(1, 0, 0)};
  set.radii_rest = {1.0f, 1.0f};
  set.radii_fast = {1.0f, 1.0f};
  set.sphere_part = {0, 0};
  set.sphere_joint = {0, 0};
  set.sphere_level = {0, 1};
  set.vertex_offsets = {0, 3, 6};
  set.vertices = {0, 1, 2, 1, 2, 3};
  set.triangle_offsets = {0, 1, 2};
  set.triangles = {0, 1};
  set.influence_offsets = {0, 1, 2};
  set.influence_joints = {0, 0};
  set.influence_weights = {1.0f, 1.0f};
  set.excluded_pairs = {{0, 1, ExclusionReason::kSameJoint}};
  return set;
}

TEST(SphereSetTest, ConsistentSetValidates) { EXPECT_FALSE(TwoSpheres().Validate().has_value()); }

TEST(SphereSetTest, EveryBrokenRuleIsRefused) {
  auto s = TwoSpheres();
  s.vertices[0] = 4;
  EXPECT_TRUE(s.Validate().has_value());
  s = TwoSpheres();
  s.radii_fast[1] = 0.5f;
  EXPECT_TRUE(s.Validate().has_value());
  s = TwoSpheres();
  s.excluded_pairs[0] = {1, 0, ExclusionReason::kSameJoint};
  EXPECT_TRUE(s.Validate().has_value());
  s = TwoSpheres();
  s.centers_rest[0].x() = std::numeric_limits<float>::quiet_NaN();
  EXPECT_TRUE(s.Validate().has_value());
  s = TwoSpheres();
  s.vertex_offsets = {0, 3};
  EXPECT_TRUE(s.Validate().has_value());
  s = TwoSpheres();
  s.joint_parents = {0};
  EXPECT_TRUE(s.Validate().has_value());
}

TEST(SphereSetTest, ReasonNamesRoundTrip) {
  for (auto r : {ExclusionReason::kSameJoint, ExclusionReason::kAdjacentJoints, ExclusionReason::kBindOverlap}) {
    EXPECT_EQ(ExclusionReasonFromString(ToString(r)), r);
  }
  EXPECT_FALSE(ExclusionReasonFromString("nope").has_value());
}

}  // namespace
}  // namespace skinspheres::runtime
