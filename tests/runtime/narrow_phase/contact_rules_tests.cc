// The contact rules (contact_rules.h) piece by piece against answers worked out by hand or by brute
// force: the skin's joint tree and its hops (nodes that are not joints skipped; dense and searched
// tables alike), each triangle's joint (summed weights, ties to the lower joint), rule 3's test at rest
// against the plain triangle test, the sphere pairs rule 2 excludes whole, and what Validate() refuses.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include "skinspheres/runtime/narrow_phase/contact_rules.h"
#include "skinspheres/runtime/narrow_phase/triangle_contact.h"

namespace skinspheres::runtime {
namespace {

using Eigen::Vector3f;

// A skeleton: 0 "Armature" (not a joint), 1 hips, 2 spine, 3 chest, 4 "neck_end" (not a joint),
// 5 head under it, 6 leg under hips; bind entries name 1, 2, 3, 5 and 6. One triangle per joint, far
// apart, each vertex weighted wholly on its joint; one sphere per triangle. A hand-made set.
SphereSet JointTreeSet() {
  SphereSet s;
  s.source_file = "tree";
  s.joint_names = {"Armature", "hips", "spine", "chest", "neck_end", "head", "leg"};
  s.joint_parents = {-1, 0, 1, 2, 3, 4, 1};
  s.joint_rest_world.assign(7, Mat4f::Identity());
  const int joints[] = {1, 2, 3, 5, 6};
  s.parts = {{"body", {1, 2, 3, 5, 6}}};
  for (int b = 0; b < 5; ++b) s.mesh.binds.push_back(skinning::BindEntry{joints[b], Mat4f::Identity()});
  s.mesh.influence_offsets = {0};
  for (uint32_t t = 0; t < 5; ++t) {
    const Vector3f o(3.0f * float(t), 0, 0);
    for (const Vector3f& c : {Vector3f(0, 0, 0), Vector3f(1, 0, 0), Vector3f(0, 1, 0)}) {
      s.mesh.positions_bind.push_back(o + c);
      s.mesh.influence_binds.push_back(uint16_t(t));
      s.mesh.influence_weights.push_back(1.0f);
      s.mesh.influence_offsets.push_back(uint32_t(s.mesh.influence_binds.size()));
    }
    for (uint32_t c = 0; c < 3; ++c) s.triangle_vertices.push_back(3 * t + c);
    s.centers_rest.push_back(o + Vector3f(0.3f, 0.3f, 0));
    s.radii_rest.push_back(1.0f);
    s.sphere_part.push_back(0);
    s.sphere_joint.push_back(uint16_t(joints[t]));
    s.sphere_level.push_back(uint16_t(t));
    s.vertex_offsets.push_back(3 * t);
    for (uint32_t c = 0; c < 3; ++c) s.vertices.push_back(3 * t + c);
    s.triangle_offsets.push_back(t);
    s.triangles.push_back(t);
    s.influence_offsets.push_back(t);
    s.influence_joints.push_back(uint16_t(joints[t]));
    s.influence_weights.push_back(1.0f);
  }
  s.vertex_offsets.push_back(15);
  s.triangle_offsets.push_back(5);
  s.influence_offsets.push_back(5);
  s.radii_fast = s.radii_rest;
  s.source_vertex_count = 15;
  s.source_triangle_count = 5;
  return s;
}

TEST(ContactRules, HopsCountBonesOfTheSkinsJointTree) {
  const SphereSet s = JointTreeSet();
  const NearJoints one(s, 1), two(s, 2), none(s, 0);
  // hips - spine - chest - (neck_end) - head; hips - leg.
  EXPECT_TRUE(one(1, 2));
  EXPECT_TRUE(one(2, 1));
  EXPECT_FALSE(one(1, 3));
  EXPECT_TRUE(two(1, 3));
  EXPECT_TRUE(one(3, 5)) << "neck_end is not a joint: head hangs under chest in the skin's tree";
  EXPECT_FALSE(one(2, 5));
  EXPECT_TRUE(two(2, 5));
  EXPECT_TRUE(two(2, 6)) << "spine and leg are siblings under hips";
  EXPECT_FALSE(one(2, 6));
  EXPECT_TRUE(none(3, 3));
  EXPECT_FALSE(none(3, 5));
  EXPECT_FALSE(one(0, 1)) << "Armature is no joint of the skin";
  EXPECT_FALSE(one(kNoTriangleJoint, kNoTriangleJoint));
  EXPECT_FALSE(one(1, 4000));
}

// A chain longer than NearJoints::kDenseJoints answers by search, as the table would.
TEST(ContactRules, LongChainsAnswerAsShortOnes) {
  SphereSet s;
  const int n = int(NearJoints::kDenseJoints) + 100;
  for (int j = 0; j < n; ++j) {
    s.joint_names.push_back("j" + std::to_string(j));
    s.joint_parents.push_back(j - 1);
  }
  const NearJoints near(s, 2);
  for (int j : {0, 5, 1000, 1100}) {
    EXPECT_TRUE(near(uint16_t(j), uint16_t(j + 2)));
    EXPECT_FALSE(near(uint16_t(j), uint16_t(j + 3)));
  }
}

TEST(ContactRules, ATrianglesJointWeighsMostOverItsVertices) {
  SphereSet s = JointTreeSet();
  // Triangle 0's vertices: 0 wholly on spine (entry 1), 1 half hips half chest, 2 wholly on hips.
  s.mesh.influence_offsets = {0, 1, 3, 4};
  s.mesh.influence_binds = {1, 0, 2, 0};
  s.mesh.influence_weights = {1.0f, 0.5f, 0.5f, 1.0f};
  for (uint32_t v = 3; v < 15; ++v) {
    s.mesh.influence_binds.push_back(uint16_t(v / 3));
    s.mesh.influence_weights.push_back(1.0f);
    s.mesh.influence_offsets.push_back(uint32_t(s.mesh.influence_binds.size()));
  }
  std::vector<uint16_t> joints = TriangleJoints(s);
  EXPECT_EQ(joints[0], 1) << "hips 1.5 against spine 1 and chest 0.5";
  EXPECT_EQ(joints[1], 2);
  // A tie (hips 1 against spine 1 and chest 1) goes to the lower joint.
  s.mesh.influence_weights[1] = 0.0f;
  s.mesh.influence_weights[2] = 1.0f;
  joints = TriangleJoints(s);
  EXPECT_EQ(joints[0], 1);
}

// Rule 3 (NearAtRest) equals the plain triangle test at the same distance on random pairs near one
// another: the boxes it looks at first never decide otherwise.
TEST(ContactRules, NearAtRestIsTheTriangleTestAtTheDistance) {
  std::mt19937 rng(3);
  std::uniform_real_distribution<float> coord(-1.0f, 1.0f), gap(0.0f, 0.5f);
  std::vector<Vector3f> rest(6);
  const uint32_t a[3] = {0, 1, 2}, b[3] = {3, 4, 5};
  int near = 0;
  for (int k = 0; k < 20000; ++k) {
    for (Vector3f& p : rest) p = Vector3f(coord(rng), coord(rng), coord(rng));
    const Vector3f shift(coord(rng) + 1.5f, coord(rng), coord(rng));
    for (int v = 3; v < 6; ++v) rest[v] += shift;
    const float distance = gap(rng);
    TriangleContactGeometry g;
    const bool expected = TriangleContactOf(rest[0], rest[1], rest[2], rest[3], rest[4], rest[5], distance, &g);
    ASSERT_EQ(NearAtRest(rest.data(), a, b, distance), expected) << k;
    near += expected;
  }
  EXPECT_GT(near, 1000);
  EXPECT_LT(near, 19000);
}

TEST(ContactRules, RuleTwoExcludesSpherePairsWhole) {
  SphereSet s = JointTreeSet();
  ASSERT_EQ(WriteContactRules(&s, 1, 0.0f), std::nullopt);
  EXPECT_EQ(s.contact_rules, ContactRules::kTriangles);
  EXPECT_EQ(s.contact_hops, 1u);
  // Spheres 0..4 hold the triangles of hips, spine, chest, head, leg: one bone apart are (0, 1),
  // (1, 2), (2, 3) through the skipped node, and (0, 4).
  std::vector<std::pair<uint32_t, uint32_t>> pairs;
  for (const ExcludedPair& p : s.excluded_pairs) {
    pairs.push_back({p.i, p.j});
    EXPECT_EQ(p.reason, ExclusionReason::kAdjacentJoints);
  }
  EXPECT_EQ(pairs, (std::vector<std::pair<uint32_t, uint32_t>>{{0, 1}, {0, 4}, {1, 2}, {2, 3}}));
  EXPECT_EQ(s.Validate(), std::nullopt);
  // A sphere that also holds the head's triangle can no longer be excluded against the spine's.
  s.triangle_offsets = {0, 1, 2, 4, 4, 5};
  s.triangles = {0, 1, 2, 3, 4};
  s.vertex_offsets = {0, 3, 6, 12, 12, 15};
  ASSERT_EQ(WriteContactRules(&s, 1, 0.0f), std::nullopt);
  pairs.clear();
  for (const ExcludedPair& p : s.excluded_pairs) pairs.push_back({p.i, p.j});
  EXPECT_EQ(pairs, (std::vector<std::pair<uint32_t, uint32_t>>{{0, 1}, {0, 3}, {0, 4}, {1, 3}, {2, 3}, {3, 4}}))
      << "sphere 2 holds chest and head (two bones from the spine); sphere 3 holds nothing: every pair of it goes";
}

TEST(ContactRules, ValidateRefusesRulesThatWouldHideContacts) {
  SphereSet s = JointTreeSet();
  ASSERT_EQ(WriteContactRules(&s, 1, 0.01f), std::nullopt);
  ASSERT_EQ(s.Validate(), std::nullopt);
  auto refused = [](const SphereSet& set, const std::string& what) {
    const auto err = set.Validate();
    ASSERT_TRUE(err.has_value()) << what;
    EXPECT_EQ(err->code, ErrorCode::kInvalidData);
    EXPECT_NE(err->message.find(what), std::string::npos) << err->message;
  };
  SphereSet unjustified = s;
  unjustified.excluded_pairs.insert(unjustified.excluded_pairs.begin() + 1, {0, 2, ExclusionReason::kAdjacentJoints});
  refused(unjustified, "it would hide their contacts");
  SphereSet overlap = s;
  overlap.excluded_pairs[0].reason = ExclusionReason::kBindOverlap;
  refused(overlap, "overlaps at rest");
  SphereSet hops = s;
  hops.contact_hops = 3;
  refused(hops, "contact hops 3");
  SphereSet wide = s;
  const float height = wide.rest_gap / 0.01f;
  wide.rest_gap = 0.06f * height;
  refused(wide, "of the rest height");
  for (float bad : {-1.0f, std::numeric_limits<float>::quiet_NaN(), std::numeric_limits<float>::infinity()}) {
    SphereSet gap = s;
    gap.rest_gap = bad;
    refused(gap, "rest gap");
  }
  SphereSet old = s;
  old.contact_rules = ContactRules::kSpherePairs;
  refused(old, "on sphere pairs has contact hops or a rest gap");
  old.contact_hops = 0;
  old.rest_gap = 0.0f;
  old.excluded_pairs.push_back({3, 4, ExclusionReason::kBindOverlap});
  EXPECT_EQ(old.Validate(), std::nullopt) << "rules on sphere pairs exclude what they were fitted with";
  EXPECT_NE(WriteContactRules(&s, 3, 0.0f), std::nullopt);
  EXPECT_NE(WriteContactRules(&s, 1, 0.06f), std::nullopt);
  EXPECT_STREQ(ToString(ContactRules::kTriangles), "triangles");
  EXPECT_EQ(ContactRulesFromString("sphere_pairs"), ContactRules::kSpherePairs);
  EXPECT_EQ(ContactRulesFromString("spheres"), std::nullopt);
}

}  // namespace
}  // namespace skinspheres::runtime
