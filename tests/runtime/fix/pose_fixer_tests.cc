// PoseFixer: one pose corrected so that no part pair penetrates deeper than the limit. Checked with
// the tests' own sampler, forward kinematics and skinning (support/clip_eval_for_tests.h) and the
// sphere-free brute-force contacts (FindContactsBruteForce), never with the fixer's own figures.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <memory>
#include <optional>

#include "runtime/posed_characters.h"
#include "skinspheres/runtime/fix/pose_fixer.h"
#include "skinspheres/runtime/narrow_phase/narrow_phase.h"

namespace skinspheres::runtime {
namespace {

using test::LoadFitted;

// The deepest penetration of the pose among pairs deeper than the touch tolerance, by the oracle.
float OracleDeepest(const test::FittedCharacter& fc, const CharacterAsset& asset,
                    const std::vector<skinning::Transform>& locals) {
  const auto world = test::WorldOf(fc.character, locals);
  const auto positions = test::Skin(fc.character, world);
  FrameContacts oracle;
  EXPECT_TRUE(FindContactsBruteForce(fc.set, *asset.narrow_phase(), asset.filter(), positions, &oracle));
  float deepest = 0.0f;
  for (const PartContact& p : oracle.parts) {
    if (p.kind == PartContactKind::kPenetrating) deepest = std::max(deepest, p.depth);
  }
  return deepest;
}

const skinning::AnimationClip& Clip(const test::FittedCharacter& fc, const std::string& name) {
  for (const auto& clip : fc.character.clips) {
    if (clip.name == name) return clip;
  }
  ADD_FAILURE() << "no clip " << name;
  return fc.character.clips.front();
}

// The built-in character's fixture, its asset and a fixer over it.
struct Builtin {
  std::shared_ptr<const test::FittedCharacter> fc;
  std::shared_ptr<const CharacterAsset> asset;
  std::optional<PoseFixer> fixer;
  bool Load() {
    fc = LoadFitted("builtin");
    if (!fc) return false;
    auto created = CharacterAsset::Create(fc->set);
    if (!created.ok()) return false;
    asset = *created;
    auto made = PoseFixer::Create(asset);
    if (!made.ok()) return false;
    fixer.emplace(std::move(*made));
    return true;
  }
};

TEST(PoseFixer, TheHandsComeOutOfTheChestWithSmallTurns) {
  auto fc = LoadFitted("builtin");
  ASSERT_TRUE(fc);
  ASSERT_EQ(fc->set.joint_names, fc->character.skeleton.joint_names);  // the set's joint order
  auto asset = CharacterAsset::Create(fc->set);
  ASSERT_TRUE(asset.ok()) << asset.error().message;
  auto fixer = PoseFixer::Create(*asset);
  ASSERT_TRUE(fixer.ok()) << fixer.error().message;
  const float tolerance = (*asset)->narrow_phase()->touch_tolerance();
  int fixed_poses = 0;
  for (float t : {0.8f, 1.0f, 1.2f, 1.4f}) {  // hands on the chest (builtin_character.h: 0.8-1.6 s)
    std::vector<skinning::Transform> locals = test::SampleLocal(fc->character, Clip(*fc, "touch"), t);
    const std::vector<skinning::Transform> source = locals;
    const float before = OracleDeepest(*fc, **asset, locals);
    ASSERT_GT(before, 2.0f * tolerance) << "t=" << t << ": the hands are in the chest";
    auto result = fixer->Fix(locals, {});
    ASSERT_TRUE(result.ok()) << result.error().message;
    EXPECT_TRUE(result->holds) << "t=" << t;
    const float after = OracleDeepest(*fc, **asset, locals);
    EXPECT_LE(after, tolerance) << "t=" << t << ": before " << before;
    // Only rotations changed, and none by more than 20 degrees; most joints untouched.
    int changed = 0;
    for (size_t j = 0; j < locals.size(); ++j) {
      EXPECT_EQ(locals[j].translation, source[j].translation);
      EXPECT_EQ(locals[j].scale, source[j].scale);
      const float angle = 2.0f * std::acos(std::min(1.0f, std::abs(locals[j].rotation.dot(source[j].rotation))));
      EXPECT_LT(angle, 20.0f * 3.14159265f / 180.0f) << fc->character.skeleton.joint_names[j];
      changed += angle > 1e-5f;
    }
    EXPECT_GT(changed, 0);
    EXPECT_LE(changed, static_cast<int>(locals.size()) / 2);
    fixed_poses += after <= tolerance;
  }
  EXPECT_EQ(fixed_poses, 4);
}

TEST(PoseFixer, ACleanPoseIsLeftAsItIs) {
  Builtin b;
  ASSERT_TRUE(b.Load());
  const auto& fc = b.fc;
  auto& fixer = b.fixer;
  const auto* asset = &b.asset;
  std::vector<skinning::Transform> locals = test::SampleLocal(fc->character, Clip(*fc, "walk"), 0.3f);
  const std::vector<skinning::Transform> source = locals;
  ASSERT_EQ(OracleDeepest(*fc, **asset, locals), 0.0f);
  auto result = fixer->Fix(locals, {});
  ASSERT_TRUE(result.ok());
  EXPECT_TRUE(result->holds);
  EXPECT_EQ(result->steps, 0);
  for (size_t j = 0; j < locals.size(); ++j) EXPECT_EQ(locals[j].rotation.coeffs(), source[j].rotation.coeffs());
}

TEST(PoseFixer, AllowedPairsAndBadInput) {
  Builtin b;
  ASSERT_TRUE(b.Load());
  const auto& fc = b.fc;
  auto& fixer = b.fixer;
  std::vector<skinning::Transform> locals = test::SampleLocal(fc->character, Clip(*fc, "touch"), 1.2f);
  const std::vector<skinning::Transform> source = locals;
  // Every part pair allowed: nothing to fix, nothing changed.
  PoseSolveSettings all;
  for (size_t p = 0; p < fc->set.parts.size(); ++p) {
    for (size_t q = p; q < fc->set.parts.size(); ++q) all.allow.emplace_back(uint16_t(p), uint16_t(q));
  }
  auto result = fixer->Fix(locals, all);
  ASSERT_TRUE(result.ok());
  EXPECT_TRUE(result->holds);
  for (size_t j = 0; j < locals.size(); ++j) EXPECT_EQ(locals[j].rotation.coeffs(), source[j].rotation.coeffs());
  std::vector<skinning::Transform> short_pose(locals.begin(), locals.end() - 1);
  EXPECT_EQ(fixer->Fix(short_pose, {}).error().code, ErrorCode::kInvalidArgument);
  EXPECT_EQ(PoseFixer::Create(nullptr).error().code, ErrorCode::kInvalidArgument);
  // Poses and limits that mean nothing are refused, the pose untouched.
  for (int k = 0; k < 4; ++k) {
    std::vector<skinning::Transform> bad = source;
    if (k == 0) bad[3].rotation.coeffs().setZero();
    if (k == 1) bad[3].scale.setZero();
    if (k == 2) bad[3].translation.x() = std::nanf("");
    if (k == 3) bad[3].rotation.coeffs().setConstant(std::numeric_limits<float>::infinity());
    const std::vector<skinning::Transform> given = bad;
    EXPECT_EQ(fixer->Fix(bad, {}).error().code, ErrorCode::kInvalidArgument) << k;
    EXPECT_EQ(bad[3].rotation.coeffs(), given[3].rotation.coeffs()) << k;
  }
  for (float depth : {-1.0f, std::nanf(""), std::numeric_limits<float>::infinity()}) {
    PoseSolveSettings s;
    s.max_depth = depth;
    std::vector<skinning::Transform> pose = source;
    EXPECT_EQ(fixer->Fix(pose, s).error().code, ErrorCode::kInvalidArgument) << depth;
  }
}

}  // namespace
}  // namespace skinspheres::runtime
