#include "skinspheres/runtime/sphere_set.h"

#include "runtime/sample_sphere_set.h"

#include <gtest/gtest.h>

namespace skinspheres::runtime {
namespace {

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
