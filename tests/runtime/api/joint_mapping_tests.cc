// Joint mapping (joint_mapping.h) and instances fed in the engine's joint order: an engine lists
// its skin joints in its own order, with extras and without the set's non-joint ancestors; the
// mapped instance gives exactly the spheres and contacts of an instance fed in the set's order;
// what is missing or extra is reported by name; Matches names the loaded set file; no allocation
// per frame.
#include <gtest/gtest.h>

#include <algorithm>
#include <limits>
#include <set>

#include "allocation_counter.h"
#include "runtime/posed_characters.h"
#include "skinspheres/runtime/api/character.h"
#include "skinspheres/runtime/api/joint_mapping.h"
#include "skinspheres/runtime/format/sphere_set_io.h"
#include "test_support.h"

namespace skinspheres::runtime {
namespace {

// What an engine importing the file would have: the skin's joints (the bind entries' joints), in
// an order of its own (reversed), plus joints of its own the set never heard of.
struct EngineRig {
  std::vector<std::string> names;
  std::vector<int32_t> skeleton_joint;  // per engine joint: the character's skeleton joint, or -1
};

EngineRig EngineRigOf(const test::Character& c, bool with_extras) {
  std::set<int32_t> skin;
  for (const skinning::BindEntry& b : c.skin.binds) skin.insert(b.joint);
  EngineRig rig;
  for (auto it = skin.rbegin(); it != skin.rend(); ++it) {
    rig.names.push_back(c.skeleton.joint_names[static_cast<size_t>(*it)]);
    rig.skeleton_joint.push_back(*it);
    if (with_extras && rig.names.size() == 3) {
      rig.names.push_back("IK_hand_target");
      rig.skeleton_joint.push_back(-1);
    }
  }
  if (with_extras) {
    rig.names.push_back("camera_bone");
    rig.skeleton_joint.push_back(-1);
  }
  return rig;
}

// The pose's matrices in the engine's order; joints the set does not know get NaN, which the
// runtime must never read.
std::vector<Mat4f> InEngineOrder(const EngineRig& rig, const std::vector<Mat4f>& world) {
  std::vector<Mat4f> out(rig.names.size(), Mat4f::Constant(std::numeric_limits<float>::quiet_NaN()));
  for (size_t k = 0; k < rig.names.size(); ++k) {
    if (rig.skeleton_joint[k] >= 0) out[k] = world[static_cast<size_t>(rig.skeleton_joint[k])];
  }
  return out;
}

TEST(JointMappingTest, SetOrderIsTheIdentity) {
  auto fc = test::LoadFitted("builtin");
  ASSERT_TRUE(fc);
  auto m = MapJoints(fc->set, fc->set.joint_names);
  ASSERT_TRUE(m.ok()) << m.error().message;
  EXPECT_TRUE(m->identity());
  EXPECT_TRUE(m->unmapped_set_joints.empty());
  EXPECT_TRUE(m->extra_engine_joints.empty());
}

TEST(JointMappingTest, TheSetListsTheSkinJointsAndTheirAncestorsAndReadsOnlySkinJoints) {
  auto fc = test::LoadFitted("builtin");
  ASSERT_TRUE(fc);
  const test::Character& c = fc->character;
  EXPECT_EQ(fc->set.joint_names, c.skeleton.joint_names);
  std::set<int32_t> skin;
  for (const skinning::BindEntry& b : c.skin.binds) skin.insert(b.joint);
  const std::vector<bool> read = JointsReadPerFrame(fc->set);
  ASSERT_EQ(read.size(), fc->set.joint_count());
  for (size_t j = 0; j < read.size(); ++j) {
    if (read[j]) {
      EXPECT_TRUE(skin.count(static_cast<int32_t>(j))) << fc->set.joint_names[j] << " is read but not a skin joint";
    }
  }
  // The built-in character's root `Armature` is one of its skin's joints, so it is read; Xbot's
  // `Armature` is not (XbotSkinJointsMatchTheSixtySixJointSet).
  EXPECT_EQ(fc->set.joint_names[0], "Armature");
}

TEST(JointMappingTest, EngineOrderGivesTheSameSpheresAndContacts) {
  auto fc = test::LoadFitted("builtin");
  ASSERT_TRUE(fc);
  const EngineRig rig = EngineRigOf(fc->character, /*with_extras=*/true);
  auto m = MapJoints(fc->set, rig.names);
  ASSERT_TRUE(m.ok()) << m.error().message;
  EXPECT_FALSE(m->identity());
  EXPECT_EQ(m->engine_joint_count, rig.names.size());
  EXPECT_EQ(m->extra_engine_joints, (std::vector<std::string>{"IK_hand_target", "camera_bone"}));

  auto asset = CharacterAsset::Create(fc->set);
  ASSERT_TRUE(asset.ok());
  EXPECT_FALSE((*asset)->Matches(rig.names, fc->character.vertex_count()).has_value());
  auto plain = CharacterInstance::Create(*asset);
  auto mapped = CharacterInstance::Create(*asset, *m);
  ASSERT_TRUE(plain.ok() && mapped.ok()) << (mapped.ok() ? "" : mapped.error().message);
  EXPECT_EQ(plain->joint_input_count(), fc->set.joint_count());
  EXPECT_EQ(mapped->joint_input_count(), rig.names.size());
  size_t contacts = 0;
  for (const test::Pose& pose : test::ClipPoses(fc->character, 10)) {
    const std::vector<Mat4f> engine = InEngineOrder(rig, pose.world);
    for (RefitMode mode : {RefitMode::kFast, RefitMode::kExact}) {
      ASSERT_TRUE(plain->Update(mode, pose.world, pose.positions).ok()) << pose.label;
      const FrameStatus st = mapped->Update(mode, engine, pose.positions);
      ASSERT_TRUE(st.ok()) << pose.label << ": " << st.message;
      EXPECT_TRUE(std::equal(plain->spheres().begin(), plain->spheres().end(), mapped->spheres().begin(),
                             mapped->spheres().end()))
          << pose.label;
      const std::vector<SpherePair> a(plain->FindSpherePairs().begin(), plain->FindSpherePairs().end());
      const auto b = mapped->FindSpherePairs();
      EXPECT_TRUE(std::equal(a.begin(), a.end(), b.begin(), b.end())) << pose.label;
      contacts += a.size();
    }
  }
  EXPECT_GT(contacts, 0u);
  // Too few matrices for the engine's joint count: refused, instance invalid.
  const std::vector<Mat4f> short_list(rig.names.size() - 1, Mat4f::Identity());
  EXPECT_EQ(mapped->UpdateFast(short_list).code, ErrorCode::kInvalidArgument);
  EXPECT_TRUE(mapped->FindSpherePairs().empty());
}

TEST(JointMappingTest, MissingAndRepeatedJointsAreNamedWithTheSetFile) {
  auto fc = test::LoadFitted("builtin");
  ASSERT_TRUE(fc);
  const auto dir = test::TempDir("joint_mapping");
  ASSERT_FALSE(SaveSphereSet(fc->set, dir / "builtin.ssb").has_value());
  auto loaded = LoadSphereSet(dir / "builtin.ssb");
  ASSERT_TRUE(loaded.ok());
  EngineRig rig = EngineRigOf(fc->character, false);
  const std::vector<bool> read = JointsReadPerFrame(*loaded);
  // Drop two joints the spheres move with.
  std::vector<std::string> dropped;
  for (size_t k = 0; k < rig.names.size() && dropped.size() < 2;) {
    const int32_t j = rig.skeleton_joint[k];
    if (j >= 0 && read[static_cast<size_t>(j)]) {
      dropped.push_back(rig.names[k]);
      rig.names.erase(rig.names.begin() + static_cast<ptrdiff_t>(k));
      rig.skeleton_joint.erase(rig.skeleton_joint.begin() + static_cast<ptrdiff_t>(k));
    } else {
      ++k;
    }
  }
  ASSERT_EQ(dropped.size(), 2u);
  rig.names.push_back("mixamorig:Renamed");
  auto m = MapJoints(*loaded, rig.names);
  ASSERT_FALSE(m.ok());
  const std::string& msg = m.error().message;
  EXPECT_EQ(m.error().code, ErrorCode::kMismatchedAsset);
  EXPECT_NE(msg.find("builtin.ssb"), std::string::npos) << msg;
  for (const std::string& d : dropped) EXPECT_NE(msg.find("'" + d + "'"), std::string::npos) << msg;
  EXPECT_NE(msg.find("'mixamorig:Renamed'"), std::string::npos) << msg;

  auto asset = CharacterAsset::Create(*loaded);
  ASSERT_TRUE(asset.ok());
  auto err = (*asset)->Matches(rig.names, fc->character.vertex_count());
  ASSERT_TRUE(err.has_value());
  EXPECT_EQ(err->message, msg);
  err = (*asset)->Matches(fc->set.joint_names, fc->character.vertex_count() + 1);
  ASSERT_TRUE(err.has_value());
  EXPECT_NE(err->message.find("sphere set '" + (dir / "builtin.ssb").string() + "'"), std::string::npos)
      << err->message;

  const size_t first_read = static_cast<size_t>(std::find(read.begin(), read.end(), true) - read.begin());
  ASSERT_LT(first_read, read.size());
  std::vector<std::string> twice = fc->set.joint_names;
  twice.push_back(twice[first_read]);
  auto repeated = MapJoints(*loaded, twice);
  ASSERT_FALSE(repeated.ok());
  EXPECT_NE(repeated.error().message.find("'" + twice[first_read] + "' appears more than once"), std::string::npos)
      << repeated.error().message;

  // A set whose own list repeats a name (RobotExpressive names mesh nodes like joints): its own
  // list in its own order still maps, by position; by name it is ambiguous.
  SphereSet dup = *loaded;
  dup.joint_names[first_read + 1] = dup.joint_names[first_read];
  auto own = MapJoints(dup, dup.joint_names);
  ASSERT_TRUE(own.ok()) << own.error().message;
  EXPECT_TRUE(own->identity());
  std::vector<std::string> reversed(dup.joint_names.rbegin(), dup.joint_names.rend());
  EXPECT_FALSE(MapJoints(dup, reversed).ok());

  // A mapping made for another set is refused by Create.
  JointMapping wrong = *MapJoints(*loaded, fc->set.joint_names);
  wrong.engine_index.pop_back();
  EXPECT_EQ(CharacterInstance::Create(*asset, wrong).error().code, ErrorCode::kInvalidArgument);
}

TEST(JointMappingTest, NoAllocationPerFrameInEngineOrder) {
  auto fc = test::LoadFitted("builtin");
  ASSERT_TRUE(fc);
  const EngineRig rig = EngineRigOf(fc->character, true);
  auto asset = CharacterAsset::Create(fc->set);
  ASSERT_TRUE(asset.ok());
  auto inst = CharacterInstance::Create(*asset, *MapJoints(fc->set, rig.names));
  ASSERT_TRUE(inst.ok());
  const auto poses = test::ClipPoses(fc->character, 8);
  std::vector<std::vector<Mat4f>> engine;
  for (const auto& p : poses) engine.push_back(InEngineOrder(rig, p.world));
  for (const auto& e : engine) {  // warm-up: the contact list reaches its largest size
    ASSERT_TRUE(inst->UpdateFast(e).ok());
    inst->FindSpherePairs();
  }
  test::AllocationCounter counter;
  for (int round = 0; round < 3; ++round) {
    for (const auto& e : engine) {
      inst->UpdateFast(e);
      inst->FindSpherePairs();
    }
  }
  EXPECT_EQ(counter.count(), 0);
}

TEST(JointMappingTest, XbotSkinJointsMatchTheSixtySixJointSet) {
  SKINSPHERES_REQUIRE_ASSET(path, "Xbot.glb");
  auto fc = test::LoadFitted("Xbot.glb");
  ASSERT_TRUE(fc);
  const EngineRig rig = EngineRigOf(fc->character, false);
  EXPECT_EQ(fc->set.joint_count(), 66u);
  EXPECT_EQ(fc->set.joint_names[0], "Armature");
  EXPECT_EQ(rig.names.size(), 65u);
  auto asset = CharacterAsset::Create(fc->set);
  ASSERT_TRUE(asset.ok());
  EXPECT_FALSE((*asset)->Matches(rig.names, fc->character.vertex_count()).has_value());
  auto m = MapJoints(fc->set, rig.names);
  ASSERT_TRUE(m.ok()) << m.error().message;
  EXPECT_EQ(m->unmapped_set_joints, std::vector<std::string>{"Armature"});
  EXPECT_TRUE(m->extra_engine_joints.empty());
  auto plain = CharacterInstance::Create(*asset);
  auto mapped = CharacterInstance::Create(*asset, *m);
  ASSERT_TRUE(plain.ok() && mapped.ok());
  for (const test::Pose& pose : test::ClipPoses(fc->character, 4)) {
    ASSERT_TRUE(plain->UpdateFast(pose.world).ok());
    ASSERT_TRUE(mapped->UpdateFast(InEngineOrder(rig, pose.world)).ok());
    EXPECT_TRUE(std::equal(plain->spheres().begin(), plain->spheres().end(), mapped->spheres().begin(),
                           mapped->spheres().end()))
        << pose.label;
  }
}

}  // namespace
}  // namespace skinspheres::runtime
