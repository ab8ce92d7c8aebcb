// Tests for retargeting (retarget.h). The oracle is the built-in character itself: exported as
// other rigs (rig_variants.h: its joints' local frames turned, its bones longer) its clips say in
// other local terms what the built-in's own clips say, so played back on the built-in character
// they must put its joints where its own clips do (sampled by the test-only sampler,
// clip_eval_for_tests.h). The copy of local tracks, wrong across rigs, must fail the same check.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <string>

#include "skinspheres/lib/character/builtin_character.h"
#include "skinspheres/lib/character/rig_variants.h"
#include "skinspheres/lib/io/clip_import.h"
#include "skinspheres/lib/io/glb_exporter.h"
#include "skinspheres/lib/io/importer.h"
#include "skinspheres/lib/retarget/retarget.h"
#include "support/clip_eval_for_tests.h"
#include "test_support.h"

namespace skinspheres::lib {
namespace {

const skinning::AnimationClip& ClipNamed(const std::vector<skinning::AnimationClip>& clips, const std::string& name) {
  for (const auto& c : clips) {
    if (c.name == name) return c;
  }
  ADD_FAILURE() << "no clip " << name;
  return clips.front();
}

// The built-in character as another rig, written to a GLB (with its mesh and skin: its rest
// pose) or without a mesh (an animation-only file).
std::filesystem::path WriteRig(const std::string& name, uint32_t seed, float bone_scale, bool mesh) {
  RawCharacter rig = MakeBuiltinCharacter();
  if (bone_scale != 1.0f) ScaleBones(rig, bone_scale);
  if (auto err = RotateJointFrames(rig, seed)) ADD_FAILURE() << err->message;
  if (!mesh) rig = WithoutMesh(std::move(rig));
  const auto path = test::TempDir("retarget_" + name) / (name + ".glb");
  const auto written = ExportGlb(rig, path);
  EXPECT_TRUE(written.ok()) << (written.ok() ? "" : written.error().message);
  return path;
}

// Largest distance between the built-in's joints under `a` and under its own clip `b` at time t.
float JointDistance(const skinning::AnimationClip& a, const skinning::AnimationClip& b, float t) {
  const RawCharacter& c = test::BuiltinCharacter();
  const auto wa = test::WorldOf(c, test::SampleLocal(c, a, t)), wb = test::WorldOf(c, test::SampleLocal(c, b, t));
  float worst = 0.0f;
  for (size_t j = 0; j < wa.size(); ++j) {
    worst = std::max(worst, (wa[j].topRightCorner<3, 1>() - wb[j].topRightCorner<3, 1>()).norm());
  }
  return worst;
}

// Largest joint distance over 41 times of every clip, against the built-in's own clip.
float WorstOverClips(const std::vector<skinning::AnimationClip>& clips) {
  float worst = 0.0f;
  for (const auto& own : test::BuiltinCharacter().clips) {
    const auto& other = ClipNamed(clips, own.name);
    EXPECT_NEAR(other.duration_s, own.duration_s, 1e-5f);
    for (int i = 0; i <= 40; ++i) {
      const float t = own.duration_s * static_cast<float>(i) / 40.0f + (i % 2 ? 0.0013f : 0.0f);
      worst = std::max(worst, JointDistance(own, other, std::min(t, own.duration_s)));
    }
  }
  return worst;
}

struct Retargeted {
  std::vector<skinning::AnimationClip> clips;
  RetargetReport report;
};

// The file's clips on the built-in character, its own rest pose (its skin) as the source's.
Retargeted FromFile(const std::filesystem::path& path, RetargetOptions options = {}) {
  const auto file = ReadAnimationFile(path);
  EXPECT_TRUE(file.ok()) << file.error().message;
  const auto rig = ReadFileRestRig(*file);
  EXPECT_TRUE(rig.ok()) << rig.error().message;
  if (rig.ok() && rig->has_value() && options.source_rest.kind == SourceRest::Kind::kNone) {
    options.source_rest = {SourceRest::Kind::kRig, &**rig, 0.0f, "the file's skin"};
  }
  Retargeted out;
  auto clips = RetargetClips(*file, test::BuiltinCharacter(), options, &out.report);
  EXPECT_TRUE(clips.ok()) << clips.error().message;
  if (clips.ok()) out.clips = std::move(*clips);
  return out;
}

TEST(Retarget, MatchKeyDropsBipedPrefixes) {
  EXPECT_EQ(MatchKey("Bip01 L Hand"), "l hand");
  EXPECT_EQ(MatchKey("Bip001 Pelvis"), "pelvis");
  EXPECT_EQ(MatchKey("Character1:Bip01_Spine"), "spine");
  EXPECT_EQ(MatchKey("Bip01"), "bip01");
}

// Other rest frames (every joint's frame turned 30-150°): the transfer puts every joint where the
// built-in's own clips do, within float round-off; the copy of local tracks does not.
TEST(Retarget, RotatedFramesGiveTheCharactersOwnJointPositions) {
  const auto path = WriteRig("rotated", 7, 1.0f, true);
  const Retargeted r = FromFile(path);
  ASSERT_EQ(r.clips.size(), test::BuiltinCharacter().clips.size());
  EXPECT_TRUE(r.report.transferred);
  EXPECT_EQ(r.report.mapped.size(), test::BuiltinCharacter().skeleton.size());
  EXPECT_FALSE(r.report.offsets_differ_at.empty());
  EXPECT_NEAR(r.report.hip_scale, 1.0f, 1e-4f);
  EXPECT_LT(r.report.alignment_degrees, 0.05f);
  EXPECT_LT(r.report.largest_rest_difference.degrees, 0.05f);
  EXPECT_LT(WorstOverClips(r.clips), 2e-4f);

  RetargetOptions copy;
  copy.mode = RetargetMode::kCopy;
  const Retargeted copied = FromFile(path, copy);
  EXPECT_FALSE(copied.report.transferred);
  EXPECT_GT(WorstOverClips(copied.clips), 0.1f) << "the oracle must tell a wrong retarget";
}

// Other rest frames and bones 1.3 times as long: the joints still go where the built-in's own
// clips put them (bone lengths stay the target's; the hips move by the ratio of hip heights).
TEST(Retarget, RotatedFramesAndLongerBonesGiveTheCharactersOwnJointPositions) {
  const auto path = WriteRig("rotated_longer", 11, 1.3f, true);
  const Retargeted r = FromFile(path);
  EXPECT_TRUE(r.report.transferred);
  EXPECT_NEAR(r.report.hip_scale, 1.0f / 1.3f, 1e-4f);
  EXPECT_EQ(r.report.root_joint, "Hips");
  EXPECT_LT(WorstOverClips(r.clips), 2e-4f);
}

// The same rig (rest frames agree): the tracks are copied as they are, bit for bit; the transfer,
// when asked for, gives the same poses within round-off.
TEST(Retarget, TheSameRigIsCopiedBitForBit) {
  RawCharacter same = WithoutMesh(MakeBuiltinCharacter());
  for (auto& name : same.skeleton.joint_names) name = "mixamorig:" + name;
  const auto path = test::TempDir("retarget_same") / "same.glb";
  ASSERT_TRUE(ExportGlb(same, path).ok());
  const auto file = ReadAnimationFile(path);
  ASSERT_TRUE(file.ok()) << file.error().message;
  RetargetReport report;
  const auto clips = RetargetClips(*file, test::BuiltinCharacter(), {}, &report);
  ASSERT_TRUE(clips.ok()) << clips.error().message;
  EXPECT_FALSE(report.transferred);
  EXPECT_TRUE(report.offsets_differ_at.empty());
  ASSERT_EQ(clips->size(), file->clips.size());
  for (size_t k = 0; k < clips->size(); ++k) {
    const auto& in = file->clips[k];
    const auto& out = (*clips)[k];
    ASSERT_EQ(in.tracks.size(), out.tracks.size());
    for (size_t t = 0; t < in.tracks.size(); ++t) {
      const auto& a = in.tracks[t];
      const auto& b = out.tracks[t];
      EXPECT_EQ(MatchKey(file->nodes.joint_names[static_cast<size_t>(a.joint)]),
                MatchKey(test::BuiltinCharacter().skeleton.joint_names[static_cast<size_t>(b.joint)]));
      EXPECT_EQ(a.rotation.times_s, b.rotation.times_s);
      ASSERT_EQ(a.rotation.values.size(), b.rotation.values.size());
      for (size_t v = 0; v < a.rotation.values.size(); ++v) {
        EXPECT_EQ(a.rotation.values[v].coeffs(), b.rotation.values[v].coeffs()) << "bit for bit";
      }
      EXPECT_EQ(a.translation.values, b.translation.values);
    }
  }
  RetargetOptions world;
  world.mode = RetargetMode::kWorld;
  world.source_rest = {SourceRest::Kind::kNodes, nullptr, 0.0f, "nodes"};
  RetargetReport transferred;
  const auto via_world = RetargetClips(*file, test::BuiltinCharacter(), world, &transferred);
  ASSERT_TRUE(via_world.ok()) << via_world.error().message;
  EXPECT_TRUE(transferred.transferred);
  EXPECT_LT(WorstOverClips(*via_world), 2e-4f);
}

// An animation-only file of another rig has no rest pose: refused in one line that names the
// option; with --source-rest nodes (its nodes stand at rest), a frame in the rest pose, or the
// rig's skinned file, it plays right.
TEST(Retarget, ANoRestPoseFileNamesTheOptionAndEachSourceRestWorks) {
  const auto anim = WriteRig("no_rest", 5, 1.0f, false);
  const auto file = ReadAnimationFile(anim);
  ASSERT_TRUE(file.ok()) << file.error().message;
  const auto own = ReadFileRestRig(*file);
  ASSERT_TRUE(own.ok());
  EXPECT_FALSE(own->has_value());
  const auto refused = RetargetClips(*file, test::BuiltinCharacter(), {});
  ASSERT_FALSE(refused.ok());
  EXPECT_EQ(refused.error().code, ErrorCode::kInvalidArgument);
  EXPECT_EQ(refused.error().message.find('\n'), std::string::npos);
  EXPECT_EQ(refused.error().message.rfind(anim.string() + ": ", 0), 0u) << refused.error().message;
  EXPECT_NE(refused.error().message.find("--source-rest"), std::string::npos) << refused.error().message;

  RetargetOptions nodes;
  nodes.source_rest = {SourceRest::Kind::kNodes, nullptr, 0.0f, "nodes"};
  const auto by_nodes = RetargetClips(*file, test::BuiltinCharacter(), nodes);
  ASSERT_TRUE(by_nodes.ok()) << by_nodes.error().message;
  EXPECT_LT(WorstOverClips(*by_nodes), 2e-4f);

  // The rig's skinned file (the same seed: the same frames).
  const auto rig_file = WriteRig("no_rest_rig", 5, 1.0f, true);
  const auto rig = ImportCharacter(rig_file);
  ASSERT_TRUE(rig.ok()) << rig.error().message;
  RetargetOptions by_rig;
  by_rig.source_rest = {SourceRest::Kind::kRig, &*rig, 0.0f, "rig"};
  const auto via_rig = RetargetClips(*file, test::BuiltinCharacter(), by_rig);
  ASSERT_TRUE(via_rig.ok()) << via_rig.error().message;
  EXPECT_LT(WorstOverClips(*via_rig), 2e-4f);

  // The touch clip starts in the T-pose, the rest pose: its frame 0 is a rest pose.
  RetargetOptions frame0;
  frame0.source_rest = {SourceRest::Kind::kTime, nullptr, 0.0f, "frame 0"};
  const auto via_frame = RetargetClips(*file, test::BuiltinCharacter(), frame0);
  ASSERT_TRUE(via_frame.ok()) << via_frame.error().message;
  const auto& own_touch = ClipNamed(test::BuiltinCharacter().clips, "touch");
  for (float t = 0.0f; t <= kTouchDuration_s; t += 0.1f)
    EXPECT_LT(JointDistance(own_touch, ClipNamed(*via_frame, "touch"), t), 2e-4f) << "t=" << t;

  // A rest time past a clip's end is refused, naming the clip (the sampler would hold its last key:
  // a pose nobody chose); given as a frame, the message names the clip's last frame. Each clip's
  // own end counts: the walk (1 s) ends before the touch clip.
  const auto& walk = ClipNamed(test::BuiltinCharacter().clips, "walk");
  for (const float fps : {0.0f, 30.0f}) {
    RetargetOptions past;
    past.source_rest = {SourceRest::Kind::kTime, nullptr, walk.duration_s + 1.0f / 30.0f, "frame 31", fps};
    const auto refused_past = RetargetClips(*file, test::BuiltinCharacter(), past);
    ASSERT_FALSE(refused_past.ok()) << "fps " << fps;
    EXPECT_EQ(refused_past.error().code, ErrorCode::kInvalidArgument);
    EXPECT_NE(refused_past.error().message.find("frame 31 lies past the end of clip \"walk\""), std::string::npos)
        << refused_past.error().message;
    EXPECT_EQ(refused_past.error().message.find("its last frame is 30 at 30 fps") != std::string::npos, fps > 0.0f)
        << refused_past.error().message;
    RetargetOptions last = past;
    last.source_rest.time_s = walk.duration_s;  // the walk's last frame, within every clip of the file
    const auto at_last = RetargetClips(*file, test::BuiltinCharacter(), last);
    EXPECT_TRUE(at_last.ok()) << at_last.error().message;
  }
}

// An A-pose rig: the same skeleton and keys, but the upper arms' rest rotations lowered 45° (an
// animation-only file whose nodes stand in that rest pose). The report measures 45° on both
// arms; with the character's rest directions kept the arms stay 45° off, while laying the bones
// along the clip's rest directions gives the character's own joint positions again.
TEST(Retarget, AnAPoseRigIsMeasuredAndItsRestDirectionsCanBeMatched) {
  RawCharacter a_pose = WithoutMesh(MakeBuiltinCharacter());
  for (const char* arm : {"LeftArm", "RightArm"}) {
    const int32_t j = a_pose.skeleton.Find(arm);
    ASSERT_GE(j, 0);
    const float down = (std::string(arm) == "LeftArm" ? -1.0f : 1.0f) * static_cast<float>(M_PI / 4);
    auto& rest = a_pose.skeleton.rest_local[static_cast<size_t>(j)].rotation;
    rest = Quatf(rest * Eigen::AngleAxisf(down, Eigen::Vector3f::UnitZ()));
  }
  const auto path = test::TempDir("retarget_a_pose") / "a_pose.glb";
  ASSERT_TRUE(ExportGlb(a_pose, path).ok());
  const auto file = ReadAnimationFile(path);
  ASSERT_TRUE(file.ok()) << file.error().message;
  RetargetOptions keep;
  keep.mode = RetargetMode::kWorld;  // the offsets agree: the same rig by its offsets, so ask for the transfer
  keep.source_rest = {SourceRest::Kind::kNodes, nullptr, 0.0f, "nodes"};
  RetargetReport kept_report;
  const auto kept = RetargetClips(*file, test::BuiltinCharacter(), keep, &kept_report);
  ASSERT_TRUE(kept.ok()) << kept.error().message;
  ASSERT_FALSE(kept_report.rest_differences.empty());
  EXPECT_NEAR(kept_report.largest_rest_difference.degrees, 45.0f, 0.1f);
  for (const RestDifference& d : kept_report.rest_differences) {  // the arms' bones only
    if (d.degrees > 0.1f) {
      EXPECT_NE(d.joint.find("Arm"), std::string::npos) << d.joint << " " << d.degrees;
    }
  }
  EXPECT_GT(WorstOverClips(*kept), 0.1f) << "the arms keep the 45° difference";

  RetargetOptions match = keep;
  match.match_rest_directions = true;
  RetargetReport matched_report;
  const auto matched = RetargetClips(*file, test::BuiltinCharacter(), match, &matched_report);
  ASSERT_TRUE(matched.ok()) << matched.error().message;
  EXPECT_TRUE(matched_report.rest_directions_matched);
  EXPECT_LT(WorstOverClips(*matched), 2e-4f);
}

// A clip that would bake into more keys than a file may hold is refused in one line, before the
// bake allocates them (700,000 key times x 26 joints).
TEST(Retarget, AClipTooLongToBakeIsRefused) {
  RawCharacter rig = WithoutMesh(MakeBuiltinCharacter());
  ASSERT_FALSE(RotateJointFrames(rig, 13).has_value());
  SourceRig source;
  source.source_file = "long.glb";
  source.nodes = rig.skeleton;
  skinning::AnimationClip clip;
  clip.name = "long";
  clip.duration_s = 7000.0f;
  skinning::JointTrack track;
  track.joint = rig.skeleton.Find("Hips");
  for (int k = 0; k < 700000; ++k) {
    track.rotation.times_s.push_back(0.01f * static_cast<float>(k));
    track.rotation.values.push_back(Quatf::Identity());
  }
  clip.tracks.push_back(std::move(track));
  source.clips.push_back(std::move(clip));
  RetargetOptions options;
  options.source_rest = {SourceRest::Kind::kNodes, nullptr, 0.0f, "nodes"};
  const auto refused = RetargetClips(source, test::BuiltinCharacter(), options);
  ASSERT_FALSE(refused.ok());
  EXPECT_EQ(refused.error().code, ErrorCode::kInvalidData);
  EXPECT_EQ(refused.error().message.rfind("long.glb: clip \"long\" would be baked at ", 0), 0u)
      << refused.error().message;
}

// A skin bound in another space than the world (all IBMs after a Z-up turn C, the bind positions
// before it): the bind pose in world space is still the rest pose.
TEST(Retarget, BindPoseWorldUndoesTheSkinsOwnSpace) {
  RawCharacter c = MakeBuiltinCharacter();
  Mat4f turn = Mat4f::Identity();
  turn.topLeftCorner<3, 3>() =
      Eigen::AngleAxisf(static_cast<float>(M_PI / 2), Eigen::Vector3f::UnitX()).toRotationMatrix();
  for (auto& b : c.skin.binds) b.inverse_bind = b.inverse_bind * turn.inverse();
  for (auto& p : c.skin.positions_bind) p = turn.topLeftCorner<3, 3>() * p;
  const std::vector<Mat4f> bind = BindPoseWorld(c);
  std::vector<Mat4f> rest(c.skeleton.size());
  c.skeleton.RestWorld(rest);
  for (size_t j = 0; j < rest.size(); ++j) EXPECT_LT((bind[j] - rest[j]).cwiseAbs().maxCoeff(), 1e-5f) << j;
}

// Hostile maps: each refused in one line that names the map file and the problem.
class JointMapFiles : public ::testing::Test {
 protected:
  std::filesystem::path Map(const std::string& name, const std::string& text) {
    const auto path = test::TempDir("retarget_maps_" + name) / (name + ".json");
    std::ofstream(path) << text;
    return path;
  }
  // The map refused when loaded or when applied to the rotated rig's clips.
  Error Refusal(const std::filesystem::path& map_file) {
    auto map = LoadJointMap(map_file);
    if (!map.ok()) return map.error();
    static const auto anim = WriteRig("maps", 3, 1.0f, true);
    const auto file = ReadAnimationFile(anim);
    EXPECT_TRUE(file.ok());
    RetargetOptions options;
    options.joint_map = &*map;
    options.source_rest = {SourceRest::Kind::kNodes, nullptr, 0.0f, "nodes"};
    auto clips = RetargetClips(*file, test::BuiltinCharacter(), options);
    EXPECT_FALSE(clips.ok()) << map_file << " was accepted";
    return clips.ok() ? Error{} : clips.error();
  }
  void ExpectRefused(const std::string& name, const std::string& text, const std::string& says) {
    const auto path = Map(name, text);
    const Error e = Refusal(path);
    EXPECT_EQ(e.message.rfind(path.string() + ": ", 0), 0u) << name << ": " << e.message;
    EXPECT_EQ(e.message.find('\n'), std::string::npos) << e.message;
    EXPECT_NE(e.message.find(says), std::string::npos) << name << ": " << e.message;
  }
};

TEST_F(JointMapFiles, UnknownJointsCyclesAndRepeatsAreRefused) {
  ExpectRefused("unknown_source", R"({"NoSuchJoint": "Hips"})", "\"NoSuchJoint\" names no joint of");
  ExpectRefused("unknown_target", R"({"Hips": "Pelvis9"})", "\"Pelvis9\" names no joint of");
  ExpectRefused("cycle", R"({"LeftArm": "RightArm", "RightArm": "LeftArm"})", "is a cycle");
  ExpectRefused("long_cycle", R"({"LeftHand": "Head", "Head": "Neck", "Neck": "LeftHand"})", "is a cycle");
  ExpectRefused("reversed", R"({"Spine": "Spine1", "Spine1": "Spine"})", "is a cycle");
  ExpectRefused("reversed_hierarchy", R"({"LeftHand": "LeftArm", "LeftArm": "LeftForeArm"})", "reverse the hierarchy");
  ExpectRefused("key_twice", R"({"Hips": "Hips", "Hips": "Spine"})", "\"Hips\" is mapped twice");
  ExpectRefused("target_twice", R"({"Hips": "Spine", "Spine1": "Spine"})", "\"Spine\" is named twice");
  ExpectRefused("source_twice", R"({"Hips": "Hips", "hips": "Spine"})", "is named twice");
  ExpectRefused("not_object", R"(["Hips", "Hips"])", "expected a JSON object");
  ExpectRefused("number", R"({"Hips": 3})", "maps to a number");
  ExpectRefused("malformed", R"({"Hips": )", "malformed JSON");
  ExpectRefused("empty", "", "malformed JSON");
  ExpectRefused("deep", std::string(200, '[') + std::string(200, ']'), "nests 200 deep");
  // Not a regular file, and no file.
  const auto dir = test::TempDir("retarget_maps_dir");
  const auto folder = LoadJointMap(dir);
  ASSERT_FALSE(folder.ok());
  EXPECT_EQ(folder.error().code, ErrorCode::kFileUnreadable);
  const auto missing = LoadJointMap(dir / "none.json");
  ASSERT_FALSE(missing.ok());
  EXPECT_EQ(missing.error().code, ErrorCode::kFileNotFound);
}

// A map that renames joints the names would not match, and null to leave one out.
TEST_F(JointMapFiles, AMapMatchesWhatNamesDoNot) {
  RawCharacter rig = MakeBuiltinCharacter();
  ASSERT_FALSE(RotateJointFrames(rig, 9).has_value());
  for (auto& name : rig.skeleton.joint_names) name = "Bone_" + name;  // no key matches
  std::string text = "{";
  for (const auto& name : test::BuiltinCharacter().skeleton.joint_names) {
    text += (text.size() > 1 ? ", \"" : "\"") + std::string("Bone_") + name +
            "\": " + (name == "HeadTop_End" ? std::string("null") : "\"" + name + "\"");
  }
  const auto map_file = Map("rename", text + "}");
  const auto anim = test::TempDir("retarget_rename") / "bones.glb";
  ASSERT_TRUE(ExportGlb(rig, anim).ok());
  auto map = LoadJointMap(map_file);
  ASSERT_TRUE(map.ok()) << map.error().message;
  RetargetOptions options;
  options.joint_map = &*map;
  const Retargeted r = FromFile(anim, options);
  EXPECT_TRUE(r.report.transferred);
  EXPECT_EQ(r.report.mapped.size() + 1, test::BuiltinCharacter().skeleton.size());
  EXPECT_LT(WorstOverClips(r.clips), 2e-4f);
}

}  // namespace
}  // namespace skinspheres::lib
