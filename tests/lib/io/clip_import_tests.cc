// Tests for clips from animation files (clip_import.h). The files are the built-in character's
// skeleton and clips without a mesh (ExportGlb / ExportFbxAscii), joints renamed as rigs name them;
// the oracle is the built-in character's own clips, sampled by the test-only sampler.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <string>

#include "skinspheres/lib/character/builtin_character.h"
#include "skinspheres/lib/io/clip_import.h"
#include "skinspheres/lib/io/glb_exporter.h"
#include "skinspheres/lib/io/importer.h"
#include "skinspheres/lib/retarget/retarget.h"
#include "support/clip_eval_for_tests.h"
#include "test_support.h"

namespace skinspheres::lib {
namespace {

// The built-in character's skeleton and clips only, joints named prefix + name.
RawCharacter AnimationOnly(const std::string& prefix) {
  RawCharacter c = WithoutMesh(MakeBuiltinCharacter());
  EXPECT_TRUE(c.triangles.empty() && c.meshes.empty() && c.skin.vertex_count() == 0);
  for (auto& n : c.skeleton.joint_names) n = prefix + n;
  return c;
}

std::filesystem::path Write(const RawCharacter& c, const std::string& folder, const std::string& name) {
  const auto path = test::TempDir(folder) / name;
  const auto r = path.extension() == ".fbx" ? ExportFbxAscii(c, path) : ExportGlb(c, path);
  EXPECT_TRUE(r.ok()) << (r.ok() ? "" : r.error().message);
  return path;
}

const skinning::AnimationClip& ClipNamed(const std::vector<skinning::AnimationClip>& clips, const std::string& name) {
  for (const auto& c : clips) {
    if (c.name == name) return c;
  }
  ADD_FAILURE() << "no clip " << name;
  return clips.front();
}

// Largest distance between the skinned built-in character under clip `a` and under clip `b`
// (both on the built-in's skeleton) at time t.
float PoseDistance(const skinning::AnimationClip& a, const skinning::AnimationClip& b, float t) {
  const auto pa = test::PoseAt(test::BuiltinCharacter(), a, t), pb = test::PoseAt(test::BuiltinCharacter(), b, t);
  float worst = 0.0f;
  for (size_t v = 0; v < pa.size(); ++v) worst = std::max(worst, (pa[v] - pb[v]).norm());
  return worst;
}

TEST(ClipImport, MatchKeyDropsRigPrefixesAndCase) {
  EXPECT_EQ(MatchKey("mixamorig:LeftHand"), "lefthand");
  EXPECT_EQ(MatchKey("mixamorig1:LeftHand"), "lefthand");
  EXPECT_EQ(MatchKey("Armature|mixamorig:LeftHand"), "lefthand");
  EXPECT_EQ(MatchKey("mixamorig_LeftHand"), "lefthand");
  EXPECT_EQ(MatchKey("mixamorigLeftHand"), "lefthand");
  EXPECT_EQ(MatchKey("LeftHand"), "lefthand");
  EXPECT_EQ(MatchKey("Hips"), "hips");
  EXPECT_EQ(MatchKey("mixamorig"), "mixamorig");  // nothing after the prefix: kept
  EXPECT_EQ(MatchKey("Bip01 L Hand"), "l hand");
}

// GLB without a mesh, joints "mixamorig:<name>": every clip comes back on the built-in's joints
// and poses the character as its own clip does (LINEAR keys exactly; the CUBICSPLINE hips track
// within the exporter's chord error).
TEST(ClipImport, GlbAnimationFileDrivesTheCharacterAsItsOwnClips) {
  const auto path = Write(AnimationOnly("mixamorig:"), "clip_import_glb", "anim.glb");
  const auto file = ReadAnimationFile(path);
  ASSERT_TRUE(file.ok()) << file.error().message;
  EXPECT_EQ(file->mesh_count, 0u);
  EXPECT_EQ(file->nodes.size(), test::BuiltinCharacter().skeleton.size());
  ASSERT_EQ(file->clips.size(), test::BuiltinCharacter().clips.size());
  RetargetReport report;
  const auto clips = RetargetClips(*file, test::BuiltinCharacter(), {}, &report);
  ASSERT_TRUE(clips.ok()) << clips.error().message;
  EXPECT_EQ(report.mapped.size(), test::BuiltinCharacter().skeleton.size());
  EXPECT_FALSE(report.transferred);
  EXPECT_TRUE(report.dropped_nodes.empty());
  EXPECT_TRUE(report.rescaled_joints.empty());
  for (const auto& own : test::BuiltinCharacter().clips) {
    const auto& read = ClipNamed(*clips, own.name);
    EXPECT_NEAR(read.duration_s, own.duration_s, 1e-5f);
    for (int i = 0; i <= 40; ++i) {
      const float t = own.duration_s * static_cast<float>(i) / 40.0f + (i % 2 ? 0.0013f : 0.0f);
      EXPECT_LT(PoseDistance(own, read, t), 2e-4f) << own.name << " t=" << t;
    }
  }
}

// ASCII FBX without a mesh (Assimp's reader): the same poses at every key of the touch clip (FBX
// curves are Euler angles, which Assimp interpolates per axis: between keys the two differ).
TEST(ClipImport, FbxAnimationFileMatchesAtTheKeys) {
  const auto path = Write(AnimationOnly("mixamorig:"), "clip_import_fbx", "anim.fbx");
  const auto file = ReadAnimationFile(path);
  ASSERT_TRUE(file.ok()) << file.error().message;
  EXPECT_EQ(file->mesh_count, 0u);
  EXPECT_GE(file->nodes.size(), test::BuiltinCharacter().skeleton.size());
  const auto clips = RetargetClips(*file, test::BuiltinCharacter(), {});
  ASSERT_TRUE(clips.ok()) << clips.error().message;
  const auto& own = ClipNamed(test::BuiltinCharacter().clips, "touch");
  const auto& read = ClipNamed(*clips, "touch");
  std::vector<float> keys;
  for (const auto& tr : own.tracks) {  // the arms' keys (HeadTop_End's STEP keys fall mid-transition)
    if (tr.rotation.interpolation == skinning::Interpolation::kLinear) {
      keys.insert(keys.end(), tr.rotation.times_s.begin(), tr.rotation.times_s.end());
    }
  }
  ASSERT_FALSE(keys.empty());
  for (float t : keys) EXPECT_LT(PoseDistance(own, read, t), 1e-4f) << "t=" << t;
  // Inside the documented hold windows the pose does not change, so it matches throughout.
  for (float t = kTouchChestBegin_s; t <= kTouchChestEnd_s; t += 0.1f)
    EXPECT_LT(PoseDistance(own, read, t), 1e-4f) << "t=" << t;
}

// The same rig exported in centimetres (every rest and key translation x100) drives the character
// in metres: translation tracks are rescaled per joint.
TEST(ClipImport, OtherUnitsAreRescaled) {
  RawCharacter cm = AnimationOnly("");
  for (auto& t : cm.skeleton.rest_local) t.translation *= 100.0f;
  for (auto& clip : cm.clips) {
    for (auto& tr : clip.tracks) {
      for (auto& v : tr.translation.values) v *= 100.0f;
    }
  }
  const auto path = Write(cm, "clip_import_units", "anim_cm.glb");
  const auto file = ReadAnimationFile(path);
  ASSERT_TRUE(file.ok()) << file.error().message;
  RetargetReport report;
  const auto clips = RetargetClips(*file, test::BuiltinCharacter(), {}, &report);
  ASSERT_TRUE(clips.ok()) << clips.error().message;
  EXPECT_FALSE(report.rescaled_joints.empty());
  const auto& own = ClipNamed(test::BuiltinCharacter().clips, "walk");
  for (int i = 0; i <= 20; ++i) {
    const float t = own.duration_s * static_cast<float>(i) / 20.0f;
    EXPECT_LT(PoseDistance(own, ClipNamed(*clips, "walk"), t), 5e-4f) << "t=" << t;
  }
}

// A file whose joints match none of the core humanoid joints is refused in one line naming the
// file and each of them; a deforming joint the file lacks is kept at rest and reported.
TEST(ClipImport, UnmatchedJointsAreListed) {
  const auto path = Write(AnimationOnly("Rig_"), "clip_import_unmatched", "other_rig.glb");
  const auto file = ReadAnimationFile(path);
  ASSERT_TRUE(file.ok()) << file.error().message;
  const auto clips = RetargetClips(*file, test::BuiltinCharacter(), {});
  ASSERT_FALSE(clips.ok());
  const std::string& m = clips.error().message;
  EXPECT_EQ(clips.error().code, ErrorCode::kNotFound);
  EXPECT_NE(m.find("other_rig.glb: "), std::string::npos) << m;
  EXPECT_EQ(m.find('\n'), std::string::npos) << m;
  for (const char* joint : {"hips (Hips)", "spine (Spine)", "left upper arm (LeftArm)", "right upper arm (RightArm)",
                            "left thigh (LeftUpLeg)", "right thigh (RightUpLeg)"}) {
    EXPECT_NE(m.find(joint), std::string::npos) << joint << " not listed: " << m;
  }

  // One deforming joint missing from the file (renamed there): kept at rest, reported.
  RawCharacter one = AnimationOnly("mixamorig:");
  one.skeleton.joint_names[static_cast<size_t>(one.skeleton.Find("mixamorig:LeftHand"))] = "mixamorig:LeftPaw";
  const auto path1 = Write(one, "clip_import_one_missing", "paw.glb");
  const auto file1 = ReadAnimationFile(path1);
  ASSERT_TRUE(file1.ok()) << file1.error().message;
  RetargetReport report;
  const auto clips1 = RetargetClips(*file1, test::BuiltinCharacter(), {}, &report);
  ASSERT_TRUE(clips1.ok()) << clips1.error().message;
  EXPECT_EQ(report.unmapped_deforming, std::vector<std::string>{"LeftHand"});
  EXPECT_EQ(report.unmapped_joints, 1u);
  const int32_t hand = test::BuiltinCharacter().skeleton.Find("LeftHand");
  for (const auto& clip : *clips1) {
    for (const auto& tr : clip.tracks) EXPECT_NE(tr.joint, hand) << clip.name;
  }
}

TEST(ClipImport, AnimatedNodesTheCharacterLacksAreDroppedAndReported) {
  RawCharacter c = AnimationOnly("");
  c.skeleton.joint_names.push_back("Prop");
  c.skeleton.parents.push_back(c.skeleton.Find("RightHand"));
  c.skeleton.rest_local.push_back(skinning::Transform{});
  skinning::JointTrack prop;
  prop.joint = static_cast<int32_t>(c.skeleton.size() - 1);
  prop.translation.times_s = {0.0f, 1.0f};
  prop.translation.values = {Eigen::Vector3f::Zero(), Eigen::Vector3f(0.0f, 0.1f, 0.0f)};
  c.clips[0].tracks.push_back(prop);
  const auto path = Write(c, "clip_import_prop", "prop.glb");
  const auto file = ReadAnimationFile(path);
  ASSERT_TRUE(file.ok()) << file.error().message;
  RetargetReport report;
  const auto clips = RetargetClips(*file, test::BuiltinCharacter(), {}, &report);
  ASSERT_TRUE(clips.ok()) << clips.error().message;
  EXPECT_EQ(report.dropped_nodes, std::vector<std::string>{"Prop"});
  for (const auto& clip : *clips) {
    for (const auto& tr : clip.tracks)
      EXPECT_LT(static_cast<size_t>(tr.joint), test::BuiltinCharacter().skeleton.size());
  }
}

// ImportCharacter (and so `fit`) on an animation-only file says what the file is.
TEST(ClipImport, ImportingAnAnimationFileSaysWhatItIs) {
  for (const char* name : {"anim.glb", "anim.fbx"}) {
    const auto path = Write(AnimationOnly("mixamorig:"), std::string("clip_import_describe_") + (name + 5), name);
    const auto imported = ImportCharacter(path);
    ASSERT_FALSE(imported.ok()) << name;
    EXPECT_EQ(imported.error().code, ErrorCode::kFormatRejected);
    EXPECT_EQ(imported.error().message,
              path.string() + ": no skinned mesh (" + std::to_string(ReadAnimationFile(path)->nodes.size()) +
                  " nodes, 2 animations, 0 meshes): an animation-only file; use it with play --clips");
  }
  // A real character is not described that way, and a file that is neither keeps its own error.
  EXPECT_EQ(DescribeAnimationOnlyFile(test::TempDir("clip_import_none") / "missing.glb"), "");
}

TEST(ClipImport, BadFilesAreOneLineErrors) {
  const auto dir = test::TempDir("clip_import_bad");
  const auto missing = ReadAnimationFile(dir / "none.fbx");
  ASSERT_FALSE(missing.ok());
  EXPECT_EQ(missing.error().code, ErrorCode::kFileNotFound);
  EXPECT_NE(missing.error().message.find("none.fbx: file not found"), std::string::npos);
  const auto directory = ReadAnimationFile(dir);
  ASSERT_FALSE(directory.ok());
  EXPECT_EQ(directory.error().code, ErrorCode::kFileUnreadable);
  { std::ofstream(dir / "junk.fbx") << "this is not an FBX file\n"; }
  const auto junk = ReadAnimationFile(dir / "junk.fbx");
  ASSERT_FALSE(junk.ok());
  EXPECT_NE(junk.error().message.find("junk.fbx: "), std::string::npos);
  EXPECT_EQ(junk.error().message.find('\n'), std::string::npos);
  // A file with no animation at all cannot give clips.
  RawCharacter still = AnimationOnly("");
  still.clips.clear();
  const auto path = Write(still, "clip_import_still", "still.glb");
  const auto file = ReadAnimationFile(path);
  ASSERT_TRUE(file.ok()) << file.error().message;
  const auto clips = RetargetClips(*file, test::BuiltinCharacter(), {});
  ASSERT_FALSE(clips.ok());
  EXPECT_NE(clips.error().message.find("still.glb: has no animations"), std::string::npos);
}

}  // namespace
}  // namespace skinspheres::lib
