#include <gtest/gtest.h>

#include <cfloat>
#include <cmath>
#include <limits>
#include <string>

#include "runtime/format/contact_rules_sets.h"
#include "runtime/sample_sphere_set.h"
#include "skinspheres/runtime/format/sphere_set.h"
#include "skinspheres/runtime/refit/mesh_bounds.h"

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

// The influences' reach (sphere_set.h): in [0, 1], one per influence or none, and with a mesh never
// below what the mesh's weights give (by hand for TwoJointsWithMesh: sphere 0 a 1, b 0.5; sphere 1
// a 0.75, b 1); a source vertex weighted on a joint outside its sphere's influences is refused.
TEST(SphereSetTest, InfluenceReachBelowTheMeshOrOutOfRangeIsRefused) {
  auto message = [](const SphereSet& s) { return s.Validate() ? s.Validate()->message : std::string("accepted"); };
  SphereSet s = TwoJointsWithMesh();
  EXPECT_EQ(message(s), "accepted");
  s.influence_reach = {1.0f, 0.5f, 0.75f, 1.0f};
  EXPECT_EQ(message(s), "accepted") << "the mesh's own reach";
  s.influence_reach = {1.0f, 0.6f, 1.0f, 1.0f};
  EXPECT_EQ(message(s), "accepted") << "a larger reach only loosens the bound";
  s.influence_reach = {1.0f, std::nextafter(0.5f, 0.0f), 0.75f, 1.0f};
  EXPECT_EQ(message(s),
            "sphere 0 has influence reach 0.49999997 on joint 1, below the weight 0.5 one of its source "
            "vertices gives that joint");
  s.influence_reach = {1.0f, 0.5f, 0.0f, 1.0f};
  EXPECT_EQ(message(s),
            "sphere 1 has influence reach 0 on joint 0, below the weight 0.75 one of its source vertices "
            "gives that joint");
  s.influence_reach = {1.0f, 0.5f, 0.75f, 1.0f + FLT_EPSILON};
  EXPECT_EQ(message(s), "sphere 1 has influence reach 1.00000012 on joint 1 (must be within [0, 1])");
  s.influence_reach = {1.0f, std::numeric_limits<float>::quiet_NaN(), 0.75f, 1.0f};
  EXPECT_EQ(message(s), "sphere 0 has influence reach nan on joint 1 (must be within [0, 1])");
  s.influence_reach = {-0.0f, 0.5f, 0.75f, 1.0f};
  EXPECT_EQ(message(s),
            "sphere 0 has influence reaches summing to 0.5, below 1 (one source vertex's weights alone sum to 1)");
  s.influence_reach = {0.5f, 0.5f, 0.75f, 1.0f};
  EXPECT_EQ(message(s),
            "sphere 0 has influence reach 0.5 on joint 0, below the weight 1 one of its source vertices "
            "gives that joint")
      << "summing to 1, still below the mesh's";
  s.influence_reach = {1.0f, 0.5f, 0.75f};
  EXPECT_EQ(message(s), "the spheres have 3 influence reach entries for 4 influences (one each, or none)");
  // A mesh vertex whose weights do not sum to 1 (skinning would not be a convex blend, which every
  // fast bound assumes): refused, by the vertex; a few ulps of rounding pass.
  s = TwoJointsWithMesh();
  s.mesh.influence_weights[1] = 0.95f;
  EXPECT_EQ(message(s).rfind("mesh vertex 1 has skin weights summing to 1.2", 0), 0u) << message(s);
  s = TwoJointsWithMesh();
  s.mesh.influence_weights[0] = 0.5f;
  EXPECT_EQ(message(s), "mesh vertex 0 has skin weights summing to 0.5, not 1");
  s = TwoJointsWithMesh();
  s.mesh.influence_weights[1] = std::nextafter(0.75f, 1.0f);
  EXPECT_EQ(message(s), "accepted") << "one ulp over 1";
  s.mesh.influence_weights[1] = 0.75f + 16 * FLT_EPSILON;
  EXPECT_EQ(message(s).rfind("mesh vertex 1 has skin weights summing to 1.0000", 0), 0u)
      << "16 epsilons over 1 is past the tolerance: " << message(s);
  // Without a mesh (version 1, fast-only) the range and the sum are checked: a sphere's reaches
  // sum to at least 1, since any one of its source vertices has weights summing to 1.
  SphereSet no_mesh = TwoSpheres();
  no_mesh.influence_reach = {1.0f, 1.0f};
  EXPECT_EQ(message(no_mesh), "accepted");
  no_mesh.influence_reach = {1.0f, 0.25f};
  EXPECT_EQ(message(no_mesh),
            "sphere 1 has influence reaches summing to 0.25, below 1 (one source vertex's weights alone "
            "sum to 1)");
  no_mesh.influence_reach = {1.0f, 1.0f - 2 * FLT_EPSILON};
  EXPECT_EQ(message(no_mesh), "accepted") << "rounding of a normalised sum";
  no_mesh.influence_reach = {-1.0f, 0.25f};
  EXPECT_EQ(message(no_mesh), "sphere 0 has influence reach -1 on joint 0 (must be within [0, 1])");
  // Sphere 0 without joint b among its influences: vertices 1 and 2 are weighted on it.
  s = TwoJointsWithMesh();
  s.influence_offsets = {0, 1, 3};
  s.influence_joints = {0, 0, 1};
  s.influence_weights = {1.0f, 0.5f, 0.5f};
  EXPECT_EQ(message(s),
            "sphere 0: its source vertex 1 is weighted on joint 1, which is not among the sphere's influences");
  auto reach = InfluenceReachFromMesh(s);
  ASSERT_FALSE(reach.ok());
  EXPECT_EQ(reach.error().message, message(s));
}

TEST(SphereSetTest, ReasonNamesRoundTrip) {
  for (auto r : {ExclusionReason::kSameJoint, ExclusionReason::kAdjacentJoints, ExclusionReason::kBindOverlap}) {
    EXPECT_EQ(ExclusionReasonFromString(ToString(r)), r);
  }
  EXPECT_FALSE(ExclusionReasonFromString("nope").has_value());
}

TEST(SphereSetTest, ContactRuleNamesRoundTrip) {
  EXPECT_STREQ(ToString(ContactRules::kSpherePairs), "sphere_pairs");
  EXPECT_STREQ(ToString(ContactRules::kTriangles), "triangles");
  for (auto r : {ContactRules::kSpherePairs, ContactRules::kTriangles}) {
    EXPECT_EQ(ContactRulesFromString(ToString(r)), r);
  }
  for (const char* other : {"", "Triangles", "spheres", "sphere_pairs "}) {
    EXPECT_FALSE(ContactRulesFromString(other).has_value()) << other;
  }
}

// A set made in memory states its rules on triangles (rule 2 at the default hops, no rest gap); a
// set whose rules are on sphere pairs (as files before them read) may give bind_overlap as a pair's
// reason, which rules on triangles refuse. The messages are sphere_set_hostile_tests.cc's.
TEST(SphereSetTest, ContactRulesDefaultToTrianglesAndOnlySpherePairsGiveBindOverlap) {
  const SphereSet made;
  EXPECT_EQ(made.contact_rules, ContactRules::kTriangles);
  EXPECT_EQ(made.contact_hops, kDefaultContactHops);
  EXPECT_EQ(Bits(made.rest_gap), 0u);
  for (SphereSet s : {TwoSpheres(), TwoSpheresWithMesh()}) {
    EXPECT_FALSE(s.Validate().has_value()) << s.Validate()->message;
    EXPECT_FALSE(WithRulesOnSpherePairs(s).Validate().has_value());
    s.excluded_pairs[0].reason = ExclusionReason::kBindOverlap;
    EXPECT_TRUE(s.Validate().has_value()) << "bind_overlap under rules on triangles";
    EXPECT_FALSE(WithRulesOnSpherePairs(s).Validate().has_value());
  }
}

}  // namespace
}  // namespace skinspheres::runtime
