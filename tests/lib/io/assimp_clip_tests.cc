// Tests for the clip reading both Assimp readers share (lib/src/io/assimp_nodes.h: ReadClipHeader,
// AppendChannelKeys): the character reader and the animation-file reader take a clip's name,
// duration and keys from an aiAnimation the same way. The inputs are aiAnimations built here key by
// key; the oracle is the rule in the header, applied by hand to those keys.
#include <assimp/anim.h>
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <memory>
#include <string>
#include <tuple>
#include <vector>

#include "../../../lib/src/io/assimp_nodes.h"

namespace skinspheres::lib::detail {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kInf = std::numeric_limits<double>::infinity();
const std::filesystem::path kFile = "dir/anim.fbx";

// A channel on node `node` with position keys (time in ticks, x), rotation keys (time, w, x) and
// scale keys (time, s); y and z are 0 for positions and rotations, scales are uniform.
struct Keys {
  std::vector<std::pair<double, float>> positions = {};
  std::vector<std::tuple<double, float, float>> rotations = {};
  std::vector<std::pair<double, float>> scales = {};
};
// (Held by unique_ptr: aiNodeAnim owns its key arrays, and its copy is shallow.)
std::unique_ptr<aiNodeAnim> MakeChannel(const std::string& node, const Keys& keys) {
  auto owner = std::make_unique<aiNodeAnim>();
  aiNodeAnim& c = *owner;
  c.mNodeName = aiString(node);
  c.mNumPositionKeys = static_cast<unsigned>(keys.positions.size());
  c.mPositionKeys = new aiVectorKey[keys.positions.size()];
  for (size_t k = 0; k < keys.positions.size(); ++k)
    c.mPositionKeys[k] = aiVectorKey(keys.positions[k].first, aiVector3D(keys.positions[k].second, 0, 0));
  c.mNumRotationKeys = static_cast<unsigned>(keys.rotations.size());
  c.mRotationKeys = new aiQuatKey[keys.rotations.size()];
  for (size_t k = 0; k < keys.rotations.size(); ++k) {
    const auto [t, w, x] = keys.rotations[k];
    c.mRotationKeys[k] = aiQuatKey(t, aiQuaternion(w, x, 0, 0));
  }
  c.mNumScalingKeys = static_cast<unsigned>(keys.scales.size());
  c.mScalingKeys = new aiVectorKey[keys.scales.size()];
  for (size_t k = 0; k < keys.scales.size(); ++k) {
    const float s = keys.scales[k].second;
    c.mScalingKeys[k] = aiVectorKey(keys.scales[k].first, aiVector3D(s, s, s));
  }
  return owner;
}

std::unique_ptr<aiAnimation> MakeAnimation(const std::string& name, double duration_ticks, double ticks_per_second) {
  auto owner = std::make_unique<aiAnimation>();
  aiAnimation& a = *owner;
  a.mName = aiString(name);
  a.mDuration = duration_ticks;
  a.mTicksPerSecond = ticks_per_second;
  return owner;
}

TEST(AssimpClip, HeaderNamesTheClipAndTimesItInSeconds) {
  const auto h = ReadClipHeader(*MakeAnimation("walk", 60.0, 30.0), 3, kFile);
  ASSERT_TRUE(h.ok()) << h.error().message;
  EXPECT_EQ(h->clip.name, "walk");
  EXPECT_FLOAT_EQ(h->clip.duration_s, 2.0f);
  EXPECT_EQ(h->ticks_per_second, 30.0);
  EXPECT_TRUE(h->clip.tracks.empty());
  // No name: "animation_<index>"; a rate of 0 (Assimp's "not given"): Assimp's default of 25 per
  // second.
  const auto d = ReadClipHeader(*MakeAnimation("", 50.0, 0.0), 3, kFile);
  ASSERT_TRUE(d.ok()) << d.error().message;
  EXPECT_EQ(d->clip.name, "animation_3");
  EXPECT_EQ(d->ticks_per_second, 25.0);
  EXPECT_FLOAT_EQ(d->clip.duration_s, 2.0f);
}

TEST(AssimpClip, BadTickRatesAreRefusedNamingFileAndClip) {
  for (double tps : {-5.0, kNaN, kInf}) {
    const auto h = ReadClipHeader(*MakeAnimation("run", 30.0, tps), 0, kFile);
    ASSERT_FALSE(h.ok()) << tps;
    EXPECT_EQ(h.error().code, ErrorCode::kInvalidData);
    EXPECT_EQ(h.error().message, "dir/anim.fbx: animation \"run\" has a bad tick rate");
  }
}

TEST(AssimpClip, BadDurationsAreRefusedNamingFileAndClip) {
  for (double duration : {-1.0, kNaN, kInf, 1e300}) {
    const auto h = ReadClipHeader(*MakeAnimation("run", duration, 30.0), 0, kFile);
    ASSERT_FALSE(h.ok()) << duration;
    EXPECT_EQ(h.error().code, ErrorCode::kInvalidData);
    EXPECT_EQ(h.error().message, "dir/anim.fbx: animation \"run\" has a bad duration");
  }
  EXPECT_TRUE(ReadClipHeader(*MakeAnimation("still", 0.0, 30.0), 0, kFile).ok());
}

TEST(AssimpClip, KeysAreInSecondsStrictlyIncreasingWithRepeatsReplaced) {
  const auto h = ReadClipHeader(*MakeAnimation("walk", 90.0, 30.0), 0, kFile);
  ASSERT_TRUE(h.ok());
  // Positions: 0, 30, 30 (replaces), 15 (earlier: ignored), NaN time (ignored), 60.
  const auto c = MakeChannel("hips", {.positions = {{0, 1}, {30, 2}, {30, 3}, {15, 4}, {kNaN, 5}, {60, 6}},
                                      .rotations = {{0, 2, 0}, {90, 0, 3}},
                                      .scales = {{45, 2}}});
  skinning::JointTrack track;
  track.joint = 7;
  ASSERT_EQ(AppendChannelKeys(*c, *h, kFile, &track), std::nullopt);
  EXPECT_EQ(track.joint, 7);
  EXPECT_EQ(track.translation.times_s, (std::vector<float>{0.0f, 1.0f, 2.0f}));
  ASSERT_EQ(track.translation.values.size(), 3u);
  EXPECT_EQ(track.translation.values[0].x(), 1.0f);
  EXPECT_EQ(track.translation.values[1].x(), 3.0f);
  EXPECT_EQ(track.translation.values[2].x(), 6.0f);
  // Rotations are stored normalised: (2,0,0,0) -> identity, (0,3,0,0) -> (0,1,0,0).
  EXPECT_EQ(track.rotation.times_s, (std::vector<float>{0.0f, 3.0f}));
  ASSERT_EQ(track.rotation.values.size(), 2u);
  EXPECT_FLOAT_EQ(track.rotation.values[0].w(), 1.0f);
  EXPECT_FLOAT_EQ(track.rotation.values[1].x(), 1.0f);
  EXPECT_FLOAT_EQ(track.rotation.values[1].norm(), 1.0f);
  EXPECT_EQ(track.scale.times_s, (std::vector<float>{1.5f}));
  EXPECT_EQ(track.scale.values[0], Eigen::Vector3f(2, 2, 2));
  // A second channel on the same joint (the animation-file reader merges them) appends after.
  const auto later = MakeChannel("hips", {.positions = {{75, 7}, {30, 8}}});
  ASSERT_EQ(AppendChannelKeys(*later, *h, kFile, &track), std::nullopt);
  EXPECT_EQ(track.translation.times_s, (std::vector<float>{0.0f, 1.0f, 2.0f, 2.5f}));
}

TEST(AssimpClip, NonFiniteKeyValuesAreRefusedNamingClipAndNode) {
  const auto h = ReadClipHeader(*MakeAnimation("wave", 30.0, 30.0), 0, kFile);
  ASSERT_TRUE(h.ok());
  const float nan = std::numeric_limits<float>::quiet_NaN(), inf = std::numeric_limits<float>::infinity();
  const Keys bad[] = {
      {.positions = {{0, 0}, {10, nan}}}, {.rotations = {{0, 1, 0}, {10, inf, 0}}}, {.scales = {{5, -inf}}}};
  for (const Keys& keys : bad) {
    const auto c = MakeChannel("mixamorig:LeftHand", keys);
    skinning::JointTrack track;
    const auto e = AppendChannelKeys(*c, *h, kFile, &track);
    ASSERT_TRUE(e.has_value());
    EXPECT_EQ(e->code, ErrorCode::kInvalidData);
    EXPECT_EQ(e->message,
              "dir/anim.fbx: animation \"wave\" has a key value that is NaN or infinite on node mixamorig:LeftHand");
  }
}

// A rotation key is normalised in double: components far beyond float's squared range still give
// a unit quaternion, and one of zero length, which is no rotation, is refused.
TEST(AssimpClip, RotationKeysBecomeUnitOrAreRefusedWhenOfZeroLength) {
  const auto h = ReadClipHeader(*MakeAnimation("wave", 30.0, 30.0), 0, kFile);
  ASSERT_TRUE(h.ok());
  skinning::JointTrack track;
  const auto huge = MakeChannel("spine", {.rotations = {{0, 3e30f, 4e30f}}});
  ASSERT_EQ(AppendChannelKeys(*huge, *h, kFile, &track), std::nullopt);
  ASSERT_EQ(track.rotation.values.size(), 1u);
  EXPECT_FLOAT_EQ(track.rotation.values[0].w(), 0.6f);
  EXPECT_FLOAT_EQ(track.rotation.values[0].x(), 0.8f);
  const auto zero = MakeChannel("spine", {.rotations = {{0, 1, 0}, {10, 0, 0}}});
  skinning::JointTrack other;
  const auto e = AppendChannelKeys(*zero, *h, kFile, &other);
  ASSERT_TRUE(e.has_value());
  EXPECT_EQ(e->code, ErrorCode::kInvalidData);
  EXPECT_EQ(e->message, "dir/anim.fbx: animation \"wave\" has a rotation key of zero length on node spine");
}

}  // namespace
}  // namespace skinspheres::lib::detail
