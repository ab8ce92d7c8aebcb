#include "skinspheres/runtime/sphere_set_io.h"

#include <gtest/gtest.h>

#include <fstream>
#include <nlohmann/json.hpp>

#include "runtime/sample_sphere_set.h"
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
      {"version", [](json& j) { j["version"] = 2; }, ErrorCode::kVersionMismatch, "version 2"},
      {"missing spheres", [](json& j) { j.erase("spheres"); }, ErrorCode::kInvalidData, "$.spheres is missing"},
      {"center size", [](json& j) { j["spheres"][1]["center"] = {1, 2}; }, ErrorCode::kInvalidData, "$.spheres[1].center"},
      {"radius type", [](json& j) { j["spheres"][0]["radius"] = "big"; }, ErrorCode::kInvalidData, "$.spheres[0].radius"},
      {"vertex range", [](json& j) { j["spheres"][0]["vertices"][0] = 99; }, ErrorCode::kInvalidData, "vertex 99"},
      {"negative index", [](json& j) { j["spheres"][0]["vertices"][0] = -1; }, ErrorCode::kInvalidData, "out of range"},
      {"reason", [](json& j) { j["excluded_pairs"][0][2] = "because"; }, ErrorCode::kInvalidData, "because"},
      {"pair order", [](json& j) { j["excluded_pairs"][0] = {1, 0, "same_joint"}; }, ErrorCode::kInvalidData, "i < j"},
      {"id", [](json& j) { j["spheres"][1]["id"] = 5; }, ErrorCode::kInvalidData, "id is not its index"},
      {"huge unsigned", [](json& j) { j["skeleton"]["joints"][0]["parent"] = 18446744073709551615ull; },
       ErrorCode::kInvalidData, "parent is out of range"},
  };
  for (const auto& c : cases) {
    json j = good;
    c.edit(j);
    auto read = ReadSphereSetJson(j.dump(), "bad.json");
    ASSERT_FALSE(read.ok()) << c.what;
    EXPECT_EQ(read.error().code, c.code) << c.what << ": " << read.error().message;
    EXPECT_NE(read.error().message.find(c.message_part), std::string::npos) << c.what << ": " << read.error().message;
    EXPECT_EQ(read.error().message.rfind("bad.json: ", 0), 0u) << read.error().message;
  }
}

}  // namespace
}  // namespace skinspheres::runtime
