#include <gtest/gtest.h>

#include <cfloat>
#include <cmath>
#include <fstream>
#include <nlohmann/json.hpp>

#include "runtime/format/contact_rules_sets.h"
#include "runtime/sample_sphere_set.h"
#include "skinspheres/runtime/format/sphere_set_io.h"
#include "test_support.h"

namespace skinspheres::runtime {
namespace {

void ExpectSame(const SphereSet& a, const SphereSet& b) {
  EXPECT_EQ(a.source_file, b.source_file);
  EXPECT_EQ(a.source_vertex_count, b.source_vertex_count);
  EXPECT_EQ(a.source_triangle_count, b.source_triangle_count);
  EXPECT_EQ(nlohmann::json::parse(a.params_json), nlohmann::json::parse(b.params_json));
  EXPECT_EQ(a.joint_names, b.joint_names);
  EXPECT_EQ(a.joint_parents, b.joint_parents);
  ASSERT_EQ(a.joint_rest_world.size(), b.joint_rest_world.size());
  for (size_t k = 0; k < a.joint_rest_world.size(); ++k) EXPECT_EQ(a.joint_rest_world[k], b.joint_rest_world[k]);
  ASSERT_EQ(a.parts.size(), b.parts.size());
  for (size_t k = 0; k < a.parts.size(); ++k) {
    EXPECT_EQ(a.parts[k].name, b.parts[k].name);
    EXPECT_EQ(a.parts[k].joints, b.parts[k].joints);
  }
  EXPECT_EQ(a.centers_rest, b.centers_rest);  // bit-exact: floats are written with enough digits
  EXPECT_EQ(a.radii_rest, b.radii_rest);
  EXPECT_EQ(a.radii_fast, b.radii_fast);
  EXPECT_EQ(a.sphere_part, b.sphere_part);
  EXPECT_EQ(a.sphere_joint, b.sphere_joint);
  EXPECT_EQ(a.sphere_level, b.sphere_level);
  EXPECT_EQ(a.vertex_offsets, b.vertex_offsets);
  EXPECT_EQ(a.vertices, b.vertices);
  EXPECT_EQ(a.triangle_offsets, b.triangle_offsets);
  EXPECT_EQ(a.triangles, b.triangles);
  EXPECT_EQ(a.influence_offsets, b.influence_offsets);
  EXPECT_EQ(a.influence_joints, b.influence_joints);
  EXPECT_EQ(a.influence_weights, b.influence_weights);
  EXPECT_EQ(a.influence_reach, b.influence_reach);
  EXPECT_EQ(a.triangle_vertices, b.triangle_vertices);
  EXPECT_EQ(a.mesh.positions_bind, b.mesh.positions_bind);
  ASSERT_EQ(a.mesh.binds.size(), b.mesh.binds.size());
  for (size_t k = 0; k < a.mesh.binds.size(); ++k) {
    EXPECT_EQ(a.mesh.binds[k].joint, b.mesh.binds[k].joint);
    EXPECT_EQ(a.mesh.binds[k].inverse_bind, b.mesh.binds[k].inverse_bind);
  }
  EXPECT_EQ(a.mesh.influence_offsets, b.mesh.influence_offsets);
  EXPECT_EQ(a.mesh.influence_binds, b.mesh.influence_binds);
  EXPECT_EQ(a.mesh.influence_weights, b.mesh.influence_weights);
  ExpectSameRules(a, b);  // rules, hops, rest gap (bits) and excluded pairs with their reasons
}

TEST(SphereSetIoTest, RoundTripIsExact) {
  SphereSet set = TwoSpheres();
  set.source_file = "some/char.glb";
  set.params_json = R"({"rays":80,"overlap":0.3})";
  set.centers_rest[0] = Eigen::Vector3f(0.1f, 1.0f / 3.0f, -2.7182817f);
  set.radii_rest[1] = 0.123456789f;
  set.radii_fast[1] = 1.5f;
  set.joint_rest_world[0](0, 3) = 0.7f;
  auto read = ReadSphereSetJson(WriteSphereSetJson(set), "mem");
  ASSERT_TRUE(read.ok()) << read.error().message;
  ExpectSame(set, *read);
}

// A set with its contact rules on triangles (the default of a set made in memory) is written as
// version 4 with "contact_rules" and its mesh; the same set with its rules on sphere pairs (as read
// from an older file) as version 2, without "contact_rules", as version-2 writers did. Both read back
// exactly.
TEST(SphereSetIoTest, MeshRoundTripIsExactInVersion4AndVersion2) {
  const SphereSet set = TwoSpheresWithMesh();
  ASSERT_EQ(set.contact_rules, ContactRules::kTriangles);
  const std::string text = WriteSphereSetJson(set);
  const nlohmann::json j = nlohmann::json::parse(text);
  EXPECT_EQ(j["version"], kSphereSetVersionWithRules);
  EXPECT_TRUE(j.contains("mesh"));
  EXPECT_EQ(j["contact_rules"], nlohmann::json::parse(R"({"on":"triangles","hops":1,"rest_gap":0.0})"));
  auto read = ReadSphereSetJson(text, "mem");
  ASSERT_TRUE(read.ok()) << read.error().message;
  EXPECT_TRUE(read->has_mesh());
  ExpectSame(set, *read);
  EXPECT_EQ(WriteSphereSetJson(*read), text);

  const SphereSet old = WithRulesOnSpherePairs(TwoSpheresWithMesh());
  const std::string old_text = WriteSphereSetJson(old);
  const nlohmann::json old_j = nlohmann::json::parse(old_text);
  EXPECT_EQ(old_j["version"], kSphereSetVersion);
  EXPECT_FALSE(old_j.contains("contact_rules"));
  auto old_read = ReadSphereSetJson(old_text, "v2.json");
  ASSERT_TRUE(old_read.ok()) << old_read.error().message;
  EXPECT_TRUE(old_read->has_mesh());
  ExpectSame(old, *old_read);
  EXPECT_EQ(WriteSphereSetJson(*old_read), old_text);
}

TEST(SphereSetIoTest, VersionOneFilesLoadWithoutAMesh) {
  // A set without a mesh and its rules on sphere pairs is written as version 1, exactly as version-1
  // writers did, and read back as a set without a mesh; a version-1 file carrying a mesh is not
  // version 1.
  const SphereSet old = WithRulesOnSpherePairs(TwoSpheres());
  const std::string text = WriteSphereSetJson(old);
  nlohmann::json j = nlohmann::json::parse(text);
  EXPECT_EQ(j["version"], 1);
  EXPECT_FALSE(j.contains("mesh"));
  EXPECT_FALSE(j.contains("contact_rules"));
  auto read = ReadSphereSetJson(text, "v1.json");
  ASSERT_TRUE(read.ok()) << read.error().message;
  EXPECT_FALSE(read->has_mesh());
  ExpectSame(old, *read);
  EXPECT_EQ(WriteSphereSetJson(*read), text);
  j["mesh"] = nlohmann::json::parse(WriteSphereSetJson(TwoSpheresWithMesh()))["mesh"];
  auto mixed = ReadSphereSetJson(j.dump(), "v1.json");
  ASSERT_FALSE(mixed.ok());
  EXPECT_NE(mixed.error().message.find("$.mesh is not part of version 1"), std::string::npos) << mixed.error().message;
  // With its rules on triangles the same set is version 4, which may have no mesh either.
  const std::string v4 = WriteSphereSetJson(TwoSpheres());
  const nlohmann::json j4 = nlohmann::json::parse(v4);
  EXPECT_EQ(j4["version"], kSphereSetVersionWithRules);
  EXPECT_FALSE(j4.contains("mesh"));
  auto read4 = ReadSphereSetJson(v4, "v4.json");
  ASSERT_TRUE(read4.ok()) << read4.error().message;
  EXPECT_FALSE(read4->has_mesh());
  ExpectSame(TwoSpheres(), *read4);
  EXPECT_EQ(WriteSphereSetJson(*read4), v4);
}

// "contact_rules" (version 4): the rules, hops and rest gap read back bit for bit, for every hops
// value and gaps that need all of a float's digits (kMaxRestGapShare of the rest height, one ulp
// below it, the smallest denormal, -0); a set whose rules are on sphere pairs (read from a
// version-3 file, pieces and a bind_overlap pair included) reads with hops and gap 0 and writes the
// same version-3 text back. A version-4 file may state its rules on sphere pairs: it reads as such
// a set, which is written as the version its content calls for.
TEST(SphereSetIoTest, ContactRulesRoundTripExactly) {
  const SphereSet base = TwoJointsWithMesh();  // rest height 0.5: gaps up to 0.025
  const float largest = kMaxRestGapShare * 0.5f;
  for (uint32_t hops = 0; hops <= kMaxContactHops; ++hops) {
    for (const float gap : {0.0f, -0.0f, 1e-45f, std::nextafter(largest, 0.0f), largest, 0.0123456789f}) {
      SphereSet set = WithRulesOnTriangles(base, hops, 0.0f);
      set.rest_gap = gap;
      ASSERT_FALSE(set.Validate().has_value()) << set.Validate()->message;
      const std::string text = WriteSphereSetJson(set);
      const nlohmann::json j = nlohmann::json::parse(text);
      EXPECT_EQ(j["version"], kSphereSetVersionWithRules);
      EXPECT_EQ(j["contact_rules"]["on"], "triangles");
      EXPECT_EQ(j["contact_rules"]["hops"], hops);
      auto read = ReadSphereSetJson(text, "rules.json");
      ASSERT_TRUE(read.ok()) << read.error().message;
      ExpectSame(set, *read);
      EXPECT_EQ(WriteSphereSetJson(*read), text) << "hops " << hops << ", gap " << gap;
    }
  }
  // Hops 0 leaves joints a and b apart: rule 2 excludes no pair; at 1 it excludes (0, 1).
  EXPECT_TRUE(WithRulesOnTriangles(base, 0, 0.0f).excluded_pairs.empty());
  ASSERT_EQ(WithRulesOnTriangles(base, 1, 0.0f).excluded_pairs.size(), 1u);

  SphereSet old = WithRulesOnSpherePairs(TwoJointsWithPieces());
  old.excluded_pairs = {{0, 1, ExclusionReason::kBindOverlap}};
  const std::string v3 = WriteSphereSetJson(old);
  EXPECT_EQ(nlohmann::json::parse(v3)["version"], kSphereSetVersionWithPieces);
  EXPECT_FALSE(nlohmann::json::parse(v3).contains("contact_rules"));
  auto read3 = ReadSphereSetJson(v3, "v3.json");
  ASSERT_TRUE(read3.ok()) << read3.error().message;
  EXPECT_EQ(read3->contact_rules, ContactRules::kSpherePairs);
  EXPECT_EQ(read3->contact_hops, 0u);
  EXPECT_EQ(Bits(read3->rest_gap), 0u);
  ExpectSame(old, *read3);
  EXPECT_EQ(WriteSphereSetJson(*read3), v3);

  nlohmann::json stated = nlohmann::json::parse(v3);
  stated["version"] = kSphereSetVersionWithRules;
  stated["contact_rules"] = {{"on", "sphere_pairs"}, {"hops", 0}, {"rest_gap", 0}};
  auto read4 = ReadSphereSetJson(stated.dump(), "v4.json");
  ASSERT_TRUE(read4.ok()) << read4.error().message;
  ExpectSame(old, *read4);
  EXPECT_EQ(WriteSphereSetJson(*read4), v3);
}

// "influence_reach" (sphere_set.h): written per sphere when the set has it, read back bit for bit;
// a file without it (written before it existed) reads as a set without reach, which refits as the
// mesh gives (version 2) or as the bound without reach (version 1: no mesh, reach 1).
TEST(SphereSetIoTest, InfluenceReachIsOptionalAndExact) {
  SphereSet set = TwoJointsWithMesh();
  set.influence_reach = {1.0f, 0.50000006f, 0.75f, 1.0f};
  const std::string text = WriteSphereSetJson(set);
  nlohmann::json j = nlohmann::json::parse(text);
  EXPECT_EQ(j["spheres"][0]["influence_reach"].size(), 2u);
  auto read = ReadSphereSetJson(text, "mem");
  ASSERT_TRUE(read.ok()) << read.error().message;
  ExpectSame(set, *read);
  EXPECT_EQ(WriteSphereSetJson(*read), text);
  for (auto& sphere : j["spheres"]) sphere.erase("influence_reach");
  auto without = ReadSphereSetJson(j.dump(), "old.json");
  ASSERT_TRUE(without.ok()) << without.error().message;
  EXPECT_TRUE(without->influence_reach.empty());
  EXPECT_EQ(WriteSphereSetJson(*without), j.dump()) << "a set without reach is written without it";
  EXPECT_FALSE(nlohmann::json::parse(WriteSphereSetJson(TwoSpheres()))["spheres"][0].contains("influence_reach"));
  // A version-1 file with it (a set without a mesh that has a reach, e.g. from a fast-only one).
  SphereSet v1 = WithRulesOnSpherePairs(TwoSpheres());
  v1.influence_reach = {1.0f, 1.0f - 2 * FLT_EPSILON};  // one joint per sphere: every vertex weighs it fully
  ASSERT_EQ(nlohmann::json::parse(WriteSphereSetJson(v1))["version"], 1);
  auto v1_read = ReadSphereSetJson(WriteSphereSetJson(v1), "v1.json");
  ASSERT_TRUE(v1_read.ok()) << v1_read.error().message;
  EXPECT_EQ(v1_read->influence_reach, v1.influence_reach);
}

TEST(SphereSetIoTest, EveryTruncationOfAMeshSetIsAClearError) {
  const std::string text = WriteSphereSetJson(TwoSpheresWithMesh());
  for (size_t n = 0; n < text.size(); n += 5) {
    auto read = ReadSphereSetJson(text.substr(0, n), "cut.json");
    ASSERT_FALSE(read.ok()) << "prefix of " << n << " bytes was accepted";
    EXPECT_EQ(read.error().message.rfind("cut.json: ", 0), 0u) << read.error().message;
  }
}

TEST(SphereSetIoTest, FileRoundTripAndMissingFile) {
  const auto dir = test::TempDir("sphere_set_io");
  const SphereSet set = TwoSpheres();
  ASSERT_FALSE(SaveSphereSet(set, dir / "s.json").has_value());
  auto read = LoadSphereSet(dir / "s.json");
  ASSERT_TRUE(read.ok()) << read.error().message;
  ExpectSame(set, *read);

  auto missing = LoadSphereSet(dir / "nope.json");
  ASSERT_FALSE(missing.ok());
  EXPECT_EQ(missing.error().code, ErrorCode::kFileNotFound);
  EXPECT_NE(missing.error().message.find("nope.json"), std::string::npos);
}

TEST(SphereSetIoTest, EveryTruncationIsAClearError) {
  const std::string text = WriteSphereSetJson(TwoSpheres());
  // Every proper prefix is refused, and none crashes.
  for (size_t n = 0; n < text.size(); n += 7) {
    auto read = ReadSphereSetJson(text.substr(0, n), "cut.json");
    ASSERT_FALSE(read.ok()) << "prefix of " << n << " bytes was accepted";
    EXPECT_EQ(read.error().message.rfind("cut.json: ", 0), 0u) << read.error().message;
  }
}

TEST(SphereSetIoTest, WrongContentIsRefusedWithItsPlace) {
  using nlohmann::json;
  // A version-1 document (no mesh, no contact rules); the contact rules' refusals are
  // sphere_set_hostile_tests.cc's.
  const json good = json::parse(WriteSphereSetJson(WithRulesOnSpherePairs(TwoSpheres())));
  struct Case {
    const char* what;
    std::function<void(json&)> edit;
    ErrorCode code;
    const char* message_part;
  };
  const std::vector<Case> cases = {
      {"format", [](json& j) { j["format"] = "other"; }, ErrorCode::kInvalidData, "not a sphere set"},
      {"version", [](json& j) { j["version"] = 5; }, ErrorCode::kVersionMismatch,
       "version 5 is not supported (this build reads versions 1 to 4)"},
      {"version 0", [](json& j) { j["version"] = 0; }, ErrorCode::kVersionMismatch, "version 0"},
      {"version 2 without mesh", [](json& j) { j["version"] = 2; }, ErrorCode::kInvalidData, "$.mesh is missing"},
      {"missing spheres", [](json& j) { j.erase("spheres"); }, ErrorCode::kInvalidData, "$.spheres is missing"},
      {"center size",
       [](json& j) {
         j["spheres"][1]["center"] = {1, 2};
       },
       ErrorCode::kInvalidData, "$.spheres[1].center"},
      {"radius type", [](json& j) { j["spheres"][0]["radius"] = "big"; }, ErrorCode::kInvalidData,
       "$.spheres[0].radius"},
      {"vertex range", [](json& j) { j["spheres"][0]["vertices"][0] = 99; }, ErrorCode::kInvalidData, "vertex 99"},
      {"negative index", [](json& j) { j["spheres"][0]["vertices"][0] = -1; }, ErrorCode::kInvalidData, "out of range"},
      {"reason", [](json& j) { j["excluded_pairs"][0][2] = "because"; }, ErrorCode::kInvalidData, "because"},
      // A quoted string of the file with control characters stays on one line, escaped.
      {"reason with a newline", [](json& j) { j["excluded_pairs"][0][2] = std::string("be\ncause\0", 9); },
       ErrorCode::kInvalidData, "unknown reason \"be\\ncause\\x00\""},
      {"pair order",
       [](json& j) {
         j["excluded_pairs"][0] = {1, 0, "same_joint"};
       },
       ErrorCode::kInvalidData, "i < j"},
      {"id", [](json& j) { j["spheres"][1]["id"] = 5; }, ErrorCode::kInvalidData, "id is not its index"},
      {"huge unsigned", [](json& j) { j["skeleton"]["joints"][0]["parent"] = 18446744073709551615ull; },
       ErrorCode::kInvalidData, "parent is out of range"},
  };
  const json good_mesh = json::parse(WriteSphereSetJson(TwoSpheresWithMesh()));
  const std::vector<Case> mesh_cases = {
      {"mesh triangle index", [](json& j) { j["mesh"]["triangles"][4] = 9; }, ErrorCode::kInvalidData,
       "mesh triangle 1 names vertex 9"},
      {"mesh triangle count", [](json& j) { j["mesh"]["triangles"].erase(5); }, ErrorCode::kInvalidData,
       "5 triangle indices, expected 3 x 2"},
      {"mesh positions", [](json& j) { j["mesh"]["positions_bind"].erase(0); }, ErrorCode::kInvalidData, "xyz triples"},
      {"mesh vertex count",
       [](json& j) {
         j["mesh"]["positions_bind"] = {0, 0, 0};
       },
       ErrorCode::kInvalidData, "1 vertices, expected 4"},
      {"bind joint", [](json& j) { j["mesh"]["binds"][0]["joint"] = 3; }, ErrorCode::kInvalidData,
       "bind entry 0 names joint 3"},
      {"bind matrix",
       [](json& j) {
         j["mesh"]["binds"][0]["inverse_bind"] = {1, 0};
       },
       ErrorCode::kInvalidData, "$.mesh.binds[0].inverse_bind has 2 entries"},
      {"influence bind", [](json& j) { j["mesh"]["influence_binds"][2] = 1; }, ErrorCode::kInvalidData,
       "bind entry out of range"},
      {"influence offsets",
       [](json& j) {
         j["mesh"]["influence_offsets"][1] = 3;
         j["mesh"]["influence_offsets"][2] = 2;
       },
       ErrorCode::kInvalidData, "mesh influence lists are malformed"},
      {"influence weight", [](json& j) { j["mesh"]["influence_weights"][0] = -1; }, ErrorCode::kInvalidData,
       "negative or not finite"},
      {"owned vertex", [](json& j) { j["mesh"]["triangles"][0] = 3; }, ErrorCode::kInvalidData,
       "sphere 0 owns triangle 0 but not its vertex 3"},
  };
  SphereSet reach_set = TwoJointsWithMesh();
  reach_set.influence_reach = {1.0f, 0.5f, 0.75f, 1.0f};
  const json good_reach = json::parse(WriteSphereSetJson(reach_set));
  const std::vector<Case> reach_cases = {
      {"reach missing on one sphere", [](json& j) { j["spheres"][1].erase("influence_reach"); },
       ErrorCode::kInvalidData, "$.spheres[1].influence_reach is missing (the first sphere has one)"},
      {"reach only on a later sphere", [](json& j) { j["spheres"][0].erase("influence_reach"); },
       ErrorCode::kInvalidData, "$.spheres[1].influence_reach is given but the first sphere has none"},
      {"reach count", [](json& j) { j["spheres"][0]["influence_reach"] = {1}; }, ErrorCode::kInvalidData,
       "$.spheres[0].influence_reach has 1 entries, expected 2"},
      {"reach type", [](json& j) { j["spheres"][0]["influence_reach"][1] = "all"; }, ErrorCode::kInvalidData,
       "$.spheres[0].influence_reach is not a number"},
      {"reach above 1", [](json& j) { j["spheres"][1]["influence_reach"][0] = 2; }, ErrorCode::kInvalidData,
       "sphere 1 has influence reach 2 on joint 0 (must be within [0, 1])"},
      {"reach below the mesh", [](json& j) { j["spheres"][0]["influence_reach"][1] = 0.25; }, ErrorCode::kInvalidData,
       "sphere 0 has influence reach 0.25 on joint 1, below the weight 0.5"},
  };
  // Each case edits a good document; the reader refuses it with its code, naming the place.
  const auto refuse_all = [](const json& base, const std::vector<Case>& edits) {
    for (const auto& c : edits) {
      json j = base;
      c.edit(j);
      auto read = ReadSphereSetJson(j.dump(), "bad.json");
      ASSERT_FALSE(read.ok()) << c.what;
      EXPECT_EQ(read.error().code, c.code) << c.what << ": " << read.error().message;
      EXPECT_NE(read.error().message.find(c.message_part), std::string::npos) << c.what << ": " << read.error().message;
      EXPECT_EQ(read.error().message.rfind("bad.json: ", 0), 0u) << read.error().message;
      EXPECT_EQ(read.error().message.find_first_of(std::string("\n\0", 2)), std::string::npos) << c.what;
    }
  };
  refuse_all(good_reach, reach_cases);
  refuse_all(good_mesh, mesh_cases);
  refuse_all(good, cases);
}

}  // namespace
}  // namespace skinspheres::runtime
