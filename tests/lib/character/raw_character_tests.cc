// Tests for RawCharacter::Validate: the built-in character passes; each rule, broken on its own in
// a copy of it, is refused with kInvalidData and one line naming the character and the problem;
// the stages that rely on the rules (the body-part split, the fitter, the GLB exporter) refuse the
// same character with the same message.
#include <gtest/gtest.h>

#include <functional>
#include <string>

#include "skinspheres/lib/body_parts/body_parts.h"
#include "skinspheres/lib/character/builtin_character.h"
#include "skinspheres/lib/character/raw_character.h"
#include "skinspheres/lib/fit/sphere_fitter.h"
#include "skinspheres/lib/io/glb_exporter.h"
#include "test_support.h"

namespace skinspheres::lib {
namespace {

struct BrokenRule {
  std::string rule;
  std::function<void(RawCharacter&)> do_break;
  std::string message;  // what Validate says after "<name>: "
};

// Vertex 0's weight sum once its first weight is 2 (the rule below), summed as Validate sums.
double WeightSumWithFirstSetTo2() {
  const auto& skin = test::BuiltinCharacter().skin;
  double sum = 2.0;
  for (uint32_t k = skin.influence_offsets[0] + 1; k < skin.influence_offsets[1]; ++k) sum += skin.influence_weights[k];
  return sum;
}

std::vector<BrokenRule> BrokenRules() {
  return {
      {"no joints", [](RawCharacter& c) { c.skeleton = {}; }, "skeleton has no joints"},
      {"parents not first", [](RawCharacter& c) { c.skeleton.parents[0] = 1; },
       "skeleton arrays disagree in size or parents are not ordered parents-first"},
      {"triangle index past the vertices",
       [](RawCharacter& c) { c.triangles[7][1] = static_cast<int>(c.positions_rest.size()); },
       "triangle 7 uses vertex " + std::to_string(test::BuiltinCharacter().vertex_count()) + " of " +
           std::to_string(test::BuiltinCharacter().vertex_count())},
      {"negative triangle index", [](RawCharacter& c) { c.triangles[0][2] = -1; },
       "triangle 0 uses vertex -1 of " + std::to_string(test::BuiltinCharacter().vertex_count())},
      {"skin for another mesh", [](RawCharacter& c) { c.skin.positions_bind.pop_back(); },
       "skin has " + std::to_string(test::BuiltinCharacter().vertex_count() - 1) + " vertices, mesh has " +
           std::to_string(test::BuiltinCharacter().vertex_count())},
      {"influence arrays of different sizes", [](RawCharacter& c) { c.skin.influence_weights.pop_back(); },
       "skin influence arrays disagree in size"},
      {"offsets that decrease",
       [](RawCharacter& c) { std::swap(c.skin.influence_offsets[3], c.skin.influence_offsets[4]); },
       "skin influence offsets decrease at vertex 3"},
      {"bind entry on no joint", [](RawCharacter& c) { c.skin.binds[2].joint = 1000; },
       "bind entry 2 names joint 1000 of " + std::to_string(test::BuiltinCharacter().skeleton.size())},
      {"influence on no bind entry",
       [](RawCharacter& c) { c.skin.influence_binds[5] = static_cast<uint16_t>(c.skin.binds.size()); },
       "influence 5 uses bind entry " + std::to_string(test::BuiltinCharacter().skin.binds.size()) + " of " +
           std::to_string(test::BuiltinCharacter().skin.binds.size())},
      {"non-finite weight", [](RawCharacter& c) { c.skin.influence_weights[9] = std::nanf(""); },
       "influence 9 has a non-finite weight"},
      {"weights not summing to 1",
       [](RawCharacter& c) { c.skin.influence_weights[c.skin.influence_offsets[0]] = 2.0f; },
       "vertex 0 has skin weights summing to " + std::to_string(WeightSumWithFirstSetTo2()) +
           ", not 1 (normalise them)"},
      {"rigid joint past the skeleton", [](RawCharacter& c) { c.meshes[1].rigid_joint = 500; },
       "mesh '" + test::BuiltinCharacter().meshes[1].name + "' follows joint 500 of " +
           std::to_string(test::BuiltinCharacter().skeleton.size())},
  };
}

TEST(RawCharacterValidate, TheBuiltinCharacterPasses) {
  EXPECT_FALSE(test::BuiltinCharacter().Validate().has_value());
  RawCharacter without_skin = test::BuiltinCharacter();
  without_skin.skin = {};  // a character without a skin skips the skin's rules
  EXPECT_FALSE(without_skin.Validate().has_value());
}

TEST(RawCharacterValidate, EachBrokenRuleIsNamedOnOneLine) {
  for (const BrokenRule& b : BrokenRules()) {
    SCOPED_TRACE(b.rule);
    RawCharacter c = test::BuiltinCharacter();
    c.source_file = "broken.glb";
    b.do_break(c);
    const auto error = c.Validate();
    ASSERT_TRUE(error.has_value());
    EXPECT_EQ(error->code, ErrorCode::kInvalidData);
    EXPECT_EQ(error->message, "broken.glb: " + b.message);
    EXPECT_EQ(error->message.find('\n'), std::string::npos);
  }
}

TEST(RawCharacterValidate, UnnamedCharactersAreCalledCharacter) {
  RawCharacter c = test::BuiltinCharacter();
  c.source_file.clear();
  EXPECT_EQ(c.Name(), "<character>");
  c.skeleton = {};
  ASSERT_TRUE(c.Validate().has_value());
  EXPECT_EQ(c.Validate()->message, "<character>: skeleton has no joints");
}

// The split, the fitter and the exporter start with Validate: the same refusal, word for word.
TEST(RawCharacterValidate, TheStagesRefuseWithValidatesMessage) {
  const auto parts = SplitBodyParts(test::BuiltinCharacter());
  ASSERT_TRUE(parts.ok()) << parts.error().message;
  for (const BrokenRule& b : BrokenRules()) {
    SCOPED_TRACE(b.rule);
    RawCharacter c = test::BuiltinCharacter();
    c.source_file = "broken.glb";
    b.do_break(c);
    const std::string expected = "broken.glb: " + b.message;

    const auto split = SplitBodyParts(c);
    ASSERT_FALSE(split.ok());
    EXPECT_EQ(split.error().code, ErrorCode::kInvalidData);
    EXPECT_EQ(split.error().message, expected);

    if (c.triangle_count() == test::BuiltinCharacter().triangle_count()) {  // parts made for this mesh
      const auto fit = FitSpheres(c, *parts, FitSettings{});
      ASSERT_FALSE(fit.ok());
      EXPECT_EQ(fit.error().code, ErrorCode::kInvalidData);
      EXPECT_EQ(fit.error().message, expected);
    }

    const auto glb = ExportGlbToMemory(c, "broken");
    ASSERT_FALSE(glb.ok());
    EXPECT_EQ(glb.error().code, ErrorCode::kInvalidArgument);
    EXPECT_EQ(glb.error().message, "ExportGlb broken: " + expected);
  }
}

}  // namespace
}  // namespace skinspheres::lib
