#include "skinspheres/runtime/sphere_set.h"

#include "runtime/sample_sphere_set.h"

#include <gtest/gtest.h>

namespace skinspheres::runtime {
namespace {

TEST(SphereSetTest, ConsistentSetValidates) {
  EXPECT_FALSE(TwoSpheres().Validate().has_value());
  EXPECT_FALSE(TwoSpheresWithMesh().Validate().has_value());
  EXPECT_TRUE(TwoSpheresWithMesh().has_mesh());
  EXPECT_FALSE(TwoSpheres().has_mesh());
}

TEST(SphereSetTest, BrokenMeshesAreRefused) {
  auto s = TwoSpheresWithMesh();
  s.mesh.positions_bind[2].z() = std::numeric_limits<float>::infinity();
  EXPECT_TRUE(s.Validate().has_value());
  s = TwoSpheresWithMesh();
  s.mesh.binds[0].inverse_bind(0, 0) = std::numeric_limits<float>::quiet_NaN();
  EXPECT_TRUE(s.Validate().has_value());
  s = TwoSpheresWithMesh();
  s.triangle_vertices.clear();  // a mesh without triangles is no mesh, but its vertices remain
  ASSERT_TRUE(s.Validate().has_value());
  EXPECT_NE(s.Validate()->message.find("no triangles"), std::string::npos);
  s = TwoSpheresWithMesh();
  s.vertices = {0, 1, 2, 1, 2, 0};  // sphere 1 owns (1 2 3) but lists vertex 0 instead of 3
  ASSERT_TRUE(s.Validate().has_value());
  EXPECT_NE(s.Validate()->message.find("sphere 1 owns triangle 1 but not its vertex 3"), std::string::npos);
}

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
