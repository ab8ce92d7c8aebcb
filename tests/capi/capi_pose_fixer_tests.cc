// The C API's pose fixer against the C++ runtime::PoseFixer (the same corrected rotations, bit for
// bit, and the same result), the tests' own skinning and the sphere-free brute-force contacts
// (the fixed pose within the touch tolerance), the asset's reference held by the fixer, and the
// refusal of every wrong call. Reads the built-in character's fixture (support/character_fixture.h).
#include <gtest/gtest.h>

#include <cstring>
#include <vector>

#include "runtime/posed_characters.h"
#include "skinspheres/runtime/fix/pose_fixer.h"
#include "skinspheres/skinspheres.h"

namespace rt = skinspheres::runtime;
namespace sk = skinspheres::skinning;

namespace {

std::vector<float> Pack(const std::vector<sk::Transform>& locals) {
  std::vector<float> out;
  for (const auto& t : locals) {
    out.insert(out.end(), {t.translation.x(), t.translation.y(), t.translation.z(), t.rotation.x(), t.rotation.y(),
                           t.rotation.z(), t.rotation.w(), t.scale.x(), t.scale.y(), t.scale.z()});
  }
  return out;
}

TEST(CapiPoseFixer, SameAsTheRuntimeAndOutOfTheChest) {
  auto fc = skinspheres::test::LoadFitted("builtin");
  ASSERT_TRUE(fc);
  const std::string path = (skinspheres::test::FixtureDir() / "builtin.ssb").string();
  skinspheres_asset* asset = nullptr;
  ASSERT_EQ(skinspheres_asset_load_file(path.c_str(), &asset), SKINSPHERES_OK) << skinspheres_last_error();
  skinspheres_pose_fixer* fixer = nullptr;
  ASSERT_EQ(skinspheres_pose_fixer_create(asset, &fixer), SKINSPHERES_OK) << skinspheres_last_error();
  skinspheres_asset_release(asset);  // the fixer keeps its own reference (ASan in .ci/run)
  const sk::AnimationClip* touch = nullptr;
  for (const auto& clip : fc->character.clips) touch = clip.name == "touch" ? &clip : touch;
  ASSERT_TRUE(touch);
  const std::vector<sk::Transform> source = skinspheres::test::SampleLocal(fc->character, *touch, 1.2f);
  std::vector<float> packed = Pack(source);
  skinspheres_pose_fix_result result{};
  ASSERT_EQ(skinspheres_pose_fixer_fix(fixer, packed.data(), source.size(), 0.0f, &result), SKINSPHERES_OK)
      << skinspheres_last_error();
  // The C++ runtime on the same pose.
  auto cpp_asset = rt::CharacterAsset::Create(fc->set);
  ASSERT_TRUE(cpp_asset.ok());
  auto cpp = rt::PoseFixer::Create(*cpp_asset);
  ASSERT_TRUE(cpp.ok());
  std::vector<sk::Transform> locals = source;
  auto expected = cpp->Fix(locals, {});
  ASSERT_TRUE(expected.ok());
  EXPECT_EQ(result.holds, expected->holds ? 1 : 0);
  EXPECT_EQ(result.steps, expected->steps);
  EXPECT_EQ(result.deepest_before, expected->deepest_before);
  EXPECT_EQ(result.deepest_after, expected->deepest_after);
  const std::vector<float> want = Pack(locals);
  EXPECT_EQ(std::memcmp(packed.data(), want.data(), want.size() * sizeof(float)), 0);
  // The oracle: the tests' own skinning of the fixed pose, every triangle pair of the mesh.
  const float tolerance = (*cpp_asset)->narrow_phase()->touch_tolerance();
  rt::FrameContacts oracle;
  const auto positions = skinspheres::test::Skin(fc->character, skinspheres::test::WorldOf(fc->character, locals));
  ASSERT_TRUE(
      rt::FindContactsBruteForce(fc->set, *(*cpp_asset)->narrow_phase(), (*cpp_asset)->filter(), positions, &oracle));
  for (const rt::PartContact& p : oracle.parts) EXPECT_LE(p.depth, tolerance) << p.part_a << "-" << p.part_b;
  EXPECT_GT(result.deepest_before, 2.0f * tolerance);
  EXPECT_EQ(result.holds, 1);
  // Refusals.
  EXPECT_EQ(skinspheres_pose_fixer_fix(fixer, packed.data(), source.size() - 1, 0.0f, nullptr),
            SKINSPHERES_INVALID_ARGUMENT);
  EXPECT_EQ(skinspheres_pose_fixer_fix(fixer, nullptr, source.size(), 0.0f, nullptr), SKINSPHERES_INVALID_ARGUMENT);
  EXPECT_EQ(skinspheres_pose_fixer_fix(nullptr, packed.data(), source.size(), 0.0f, nullptr),
            SKINSPHERES_INVALID_ARGUMENT);
  skinspheres_pose_fixer_destroy(fixer);
  skinspheres_pose_fixer* none = nullptr;
  EXPECT_EQ(skinspheres_pose_fixer_create(nullptr, &none), SKINSPHERES_INVALID_ARGUMENT);
  EXPECT_EQ(none, nullptr);
  skinspheres_pose_fixer_destroy(nullptr);
}

}  // namespace
