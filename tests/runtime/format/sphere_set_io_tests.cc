#include <gtest/gtest.h>

#include <cfloat>
#include <fstream>
#include <nlohmann/json.hpp>

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
  ASSERT_EQ(a.excluded_pairs.size(), b.excluded_pairs.size());
  for (size_t k = 0; k < a.excluded_pairs.size(); ++k) {
    EXPECT_EQ(a.excluded_pairs[k].i, b.excluded_pairs[k].i);
    EXPECT_EQ(a.excluded_pairs[k].j, b.excluded_pairs[k].j);
    EXPECT_EQ(a.excluded_pairs[k].reason, b.excluded_pairs[k].reason);
  }
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

TEST(SphereSetIoTest, MeshRoundTripIsExactAndWrittenAsVersion2) {
  const SphereSet set = TwoSpheresWithMesh();
  const std::string text = WriteSphereSetJson(set);
  EXPECT_EQ(nlohmann::json::parse(text)["version"], 2);
  auto read = ReadSphereSetJson(text, "mem");
  ASSERT_TRUE(read.ok()) << read.error().message;
  EXPECT_TRUE(read->has_mesh());
  ExpectSame(set, *read);
}

TEST(SphereSetIoTest, VersionOneFilesLoadWithoutAMesh) {
  // A set without a mesh is written as version 1, exactly as version-1 writers did, and read back
  // as a set without a mesh; a version-1 file carrying a mesh is not version 1.
  const std::string text = WriteSphereSetJson(TwoSpheres());
  nlohmann::json j = nlohmann::json::parse(text);
  EXPECT_EQ(j["version"], 1);
  EXPECT_FALSE(j.contains("mesh"));
  auto read = ReadSphereSetJson(text, "v1.json");
  ASSERT_TRUE(read.ok()) << read.error().message;
  EXPECT_FALSE(read->has_mesh());
  ExpectSame(TwoSpheres(), *read);
  j["mesh"] = nlohmann::json::parse(WriteSphereSetJson(TwoSpheresWithMesh()))["mesh"];
  auto mixed = ReadSphereSetJson(j.dump(), "v1.json");
  ASSERT_FALSE(mixed.ok());
  EXPECT_NE(mixed.error().message.find("$.mesh is not part of version 1"), std::string::npos) << mixed.error().message;
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
  SphereSet v1 = TwoSpheres();
  v1.influence_reach = {1.0f, 1.0f - 2 * FLT_EPSILON};  // one joint per sphere: every vertex weighs it fully
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
  const json good = json::parse(WriteSphereSetJson(TwoSpheres()));
  struct Case {
    const char* what;
    std::function<void(json&)> edit;
    ErrorCode code;
    const char* message_part;
  };
  const std::vector<Case> cases = {
      {"format", [](json& j) { j["format"] = "other"; }, ErrorCode::kInvalidData, "not a sphere set"},
      {"version", [](json& j) { j["version"] = 4; }, ErrorCode::kVersionMismatch, "version 4"},
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
