// CharacterAsset / CharacterInstance / CrowdUpdateAndFindSpherePairs: asset matching, updates equal to the
// RefitJob, contacts equal to the all-pairs broad-phase oracle, the touch clip's hand-chest contact
// is found, NaN input fails only its instance, crowd = serial for 1 and 2 threads, no allocation
// per frame after the first.

#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <bit>
#include <cstdlib>
#include <limits>
#include <memory>
#include <new>
#include <random>
#include <set>

#include "allocation_counter.h"
#include "crowd/crowd_query.h"     // runtime/src: counts the crowd's batched queries
#include "refit/refit_internal.h"  // runtime/src: pins the crowd's refit level (and so its batch width)
#include "runtime/posed_characters.h"
#include "runtime/refit/refit_levels.h"
#include "skinspheres/runtime/api/character.h"
#include "skinspheres/runtime/crowd/crowd.h"

namespace skinspheres::runtime {
namespace {

std::shared_ptr<const CharacterAsset> BuiltinAsset(std::shared_ptr<const test::FittedCharacter>* fitted = nullptr) {
  auto fc = test::LoadFitted("builtin");
  if (!fc) return nullptr;
  if (fitted) *fitted = fc;
  auto asset = CharacterAsset::Create(fc->set);
  EXPECT_TRUE(asset.ok()) << (asset.ok() ? "" : asset.error().message);
  return asset.ok() ? *asset : nullptr;
}

struct PinnedLevel {  // the crowd's refit level (and batch width) pinned for a scope
  bool ok;
  explicit PinnedLevel(SimdLevel level) : ok(internal::PinRefitSimd(level)) {}
  ~PinnedLevel() { internal::PinRefitSimd(SimdLevel::kAuto); }
  PinnedLevel(const PinnedLevel&) = delete;
  PinnedLevel& operator=(const PinnedLevel&) = delete;
};

CharacterInstance MakeInstance(std::shared_ptr<const CharacterAsset> asset) {
  auto inst = CharacterInstance::Create(std::move(asset));
  EXPECT_TRUE(inst.ok());
  return std::move(inst).value();
}

TEST(CharacterAssetTest, MatchesOnlyItsOwnCharacter) {
  std::shared_ptr<const test::FittedCharacter> fc;
  auto asset = BuiltinAsset(&fc);
  ASSERT_TRUE(asset);
  const auto& names = fc->character.skeleton.joint_names;
  const size_t vertices = fc->character.vertex_count();
  EXPECT_FALSE(asset->Matches(names, vertices).has_value());

  auto err = asset->Matches(names, vertices + 1);
  ASSERT_TRUE(err.has_value());
  EXPECT_EQ(err->code, ErrorCode::kMismatchedAsset);
  EXPECT_NE(err->message.find(std::to_string(vertices)), std::string::npos) << err->message;
  EXPECT_NE(err->message.find(std::to_string(vertices + 1)), std::string::npos) << err->message;

  std::vector<std::string> renamed = names;
  renamed[3] = "mixamorig:Renamed";
  err = asset->Matches(renamed, vertices);
  ASSERT_TRUE(err.has_value());
  EXPECT_EQ(err->code, ErrorCode::kMismatchedAsset);
  EXPECT_NE(err->message.find("mixamorig:Renamed"), std::string::npos) << err->message;
  EXPECT_NE(err->message.find(names[3]), std::string::npos) << err->message;

  std::vector<std::string> fewer(names.begin(), names.end() - 1);
  err = asset->Matches(fewer, vertices);
  ASSERT_TRUE(err.has_value());
  EXPECT_EQ(err->code, ErrorCode::kMismatchedAsset);

  // Another character's set (a shared asset when present) is refused for the built-in one.
  const auto other_path = test::Asset("CesiumMan.glb");
  if (!other_path.empty()) {
    auto other = test::LoadFitted("CesiumMan.glb");
    ASSERT_TRUE(other);
    auto other_asset = CharacterAsset::Create(other->set);
    ASSERT_TRUE(other_asset.ok());
    err = (*other_asset)->Matches(names, vertices);
    ASSERT_TRUE(err.has_value());
    EXPECT_NE(err->message.find("CesiumMan"), std::string::npos) << err->message;
  }
}

TEST(CharacterAssetTest, InvalidSetsAreRefused) {
  std::shared_ptr<const test::FittedCharacter> fc;
  ASSERT_TRUE(BuiltinAsset(&fc));
  SphereSet bad = fc->set;
  bad.source_file = "bad_set.json";
  bad.radii_rest.pop_back();
  auto asset = CharacterAsset::Create(bad);
  ASSERT_FALSE(asset.ok());
  EXPECT_NE(asset.error().message.find("bad_set.json"), std::string::npos) << asset.error().message;
  EXPECT_FALSE(CharacterInstance::Create(nullptr).ok());
}

TEST(CharacterInstanceTest, UpdatesMatchTheJobAndQueryMatchesAllPairs) {
  std::shared_ptr<const test::FittedCharacter> fc;
  auto asset = BuiltinAsset(&fc);
  ASSERT_TRUE(asset);
  CharacterInstance inst = MakeInstance(asset);
  EXPECT_TRUE(inst.FindSpherePairs().empty()) << "no update yet";
  EXPECT_FALSE(inst.status().ok());
  std::vector<SpherePair> oracle;
  std::vector<skinspheres::Vec4f> expected(asset->size());
  size_t total_contacts = 0;
  for (const test::Pose& pose : test::ClipPoses(fc->character, 20)) {
    for (RefitMode mode : {RefitMode::kExact, RefitMode::kFast}) {
      const FrameStatus st =
          mode == RefitMode::kFast ? inst.UpdateFast(pose.world) : inst.UpdateExact(pose.positions, pose.world);
      ASSERT_TRUE(st.ok()) << st.message;
      RefitJob job{mode, &asset->sphere_set(), &asset->rest(), pose.world, pose.positions, expected};
      ASSERT_TRUE(job.Run());
      ASSERT_EQ(inst.spheres().size(), expected.size());
      for (size_t s = 0; s < expected.size(); ++s) ASSERT_EQ(inst.spheres()[s], expected[s]);
      const auto contacts = inst.FindSpherePairs();
      ASSERT_TRUE(inst.status().ok()) << inst.status().message;
      ASSERT_TRUE(FindSpherePairsBruteForce(inst.spheres(), asset->filter(), &oracle));
      ASSERT_EQ(std::vector<SpherePair>(contacts.begin(), contacts.end()), oracle) << pose.label;
      total_contacts += contacts.size();
    }
  }
  EXPECT_GT(total_contacts, 0u);
}

// The touch clip puts both hands into the chest (t in [0.8, 1.6] s): a conservative refit must
// report an arm-torso contact in both modes (never miss a contact).
TEST(CharacterInstanceTest, TouchClipHandsOnChestAndHeadAreReportedAndNotAtRest) {
  std::shared_ptr<const test::FittedCharacter> fc;
  auto asset = BuiltinAsset(&fc);
  ASSERT_TRUE(asset);
  const auto& set = asset->sphere_set();
  int torso = -1, head = -1;
  for (size_t p = 0; p < set.parts.size(); ++p) {
    if (set.parts[p].name == "torso") torso = static_cast<int>(p);
    if (set.parts[p].name == "head") head = static_cast<int>(p);
  }
  ASSERT_GE(torso, 0);
  ASSERT_GE(head, 0);
  // A hand sphere: its dominant joint is LeftHand or RightHand (the built-in character's names).
  auto hand_side = [&](uint32_t s) -> int {
    const std::string& j = set.joint_names[set.sphere_joint[s]];
    if (j.rfind("LeftHand", 0) == 0) return 0;
    if (j.rfind("RightHand", 0) == 0) return 1;
    return -1;
  };
  const skinning::AnimationClip* touch = nullptr;
  const skinning::AnimationClip* walk = nullptr;
  for (const auto& clip : fc->character.clips) {
    if (clip.name == "touch") touch = &clip;
    if (clip.name == "walk") walk = &clip;
  }
  ASSERT_NE(touch, nullptr);
  ASSERT_NE(walk, nullptr);
  CharacterInstance inst = MakeInstance(asset);
  // Which hands touch `target` at time t of `clip`, in `mode`.
  auto hands_on = [&](const skinning::AnimationClip& clip, float t, RefitMode mode, int target) {
    const test::Pose pose = test::MakePose(fc->character, test::SampleLocal(fc->character, clip, t), clip.name);
    EXPECT_TRUE(inst.Update(mode, pose.world, pose.positions).ok());
    std::set<int> sides;
    for (const SpherePair& c : inst.FindSpherePairs()) {
      if (c.part_j == target && hand_side(c.sphere_i) >= 0) sides.insert(hand_side(c.sphere_i));
      if (c.part_i == target && hand_side(c.sphere_j) >= 0) sides.insert(hand_side(c.sphere_j));
    }
    return sides.size();
  };
  for (RefitMode mode : {RefitMode::kExact, RefitMode::kFast}) {
    for (float t : {0.9f, 1.2f, 1.5f})
      EXPECT_EQ(hands_on(*touch, t, mode, torso), 2u) << "chest, t=" << t << " " << ToString(mode);
    for (float t : {2.5f, 2.8f, 3.1f})
      EXPECT_EQ(hands_on(*touch, t, mode, head), 2u) << "head, t=" << t << " " << ToString(mode);
    // Rest pose (the clip's start) and the whole walk: hands touch neither.
    for (int target : {torso, head}) {
      EXPECT_EQ(hands_on(*touch, 0.0f, mode, target), 0u) << "rest " << ToString(mode);
      for (float t = 0.0f; t <= walk->duration_s; t += 0.1f) {
        EXPECT_EQ(hands_on(*walk, t, mode, target), 0u) << "walk t=" << t << " " << ToString(mode);
      }
    }
  }
}

TEST(CharacterInstanceTest, BadInputFailsThatUpdateOnly) {
  std::shared_ptr<const test::FittedCharacter> fc;
  auto asset = BuiltinAsset(&fc);
  ASSERT_TRUE(asset);
  CharacterInstance inst = MakeInstance(asset);
  const test::Pose pose = test::MakePose(fc->character, fc->character.skeleton.rest_local, "rest");
  ASSERT_TRUE(inst.UpdateFast(pose.world).ok());
  EXPECT_TRUE(inst.spheres_valid());
  // Short spans.
  FrameStatus st = inst.UpdateFast(std::span<const skinspheres::Mat4f>(pose.world).first(pose.world.size() - 1));
  EXPECT_EQ(st.code, ErrorCode::kInvalidArgument);
  EXPECT_FALSE(inst.spheres_valid());
  EXPECT_TRUE(inst.FindSpherePairs().empty());
  EXPECT_EQ(inst.status().code, ErrorCode::kInvalidArgument) << "FindSpherePairs keeps the update's reason";
  st = inst.UpdateExact(std::span<const Eigen::Vector3f>(pose.positions).first(10), pose.world);
  EXPECT_EQ(st.code, ErrorCode::kInvalidArgument);
  // NaN joint matrix / position.
  std::vector<skinspheres::Mat4f> world = pose.world;
  world[5](0, 0) = std::numeric_limits<float>::quiet_NaN();
  st = inst.UpdateFast(world);
  EXPECT_EQ(st.code, ErrorCode::kInvalidData);
  EXPECT_NE(std::string(st.message).find("non-finite"), std::string::npos);
  EXPECT_TRUE(inst.FindSpherePairs().empty());
  std::vector<Eigen::Vector3f> positions = pose.positions;
  positions[asset->sphere_set().vertices[0]].x() = std::numeric_limits<float>::infinity();
  EXPECT_EQ(inst.UpdateExact(positions, pose.world).code, ErrorCode::kInvalidData);
  // Recovers on good input.
  EXPECT_TRUE(inst.UpdateExact(pose.positions, pose.world).ok());
  inst.FindSpherePairs();
  EXPECT_TRUE(inst.status().ok());
}

TEST(CharacterCrowdTest, CrowdEqualsSerialAndNaNFailsOnlyItsInstance) {
  std::shared_ptr<const test::FittedCharacter> fc;
  auto asset = BuiltinAsset(&fc);
  ASSERT_TRUE(asset);
  constexpr int kCount = 12;
  std::mt19937 rng(99);
  std::vector<test::Pose> poses;
  for (int i = 0; i < kCount; ++i) {
    poses.push_back(test::MakePose(fc->character, test::RandomLocal(fc->character, rng, 60.0f, 0.2f), "r"));
  }
  const int bad = 5;
  poses[bad].world[2](1, 3) = std::numeric_limits<float>::quiet_NaN();
  std::vector<CharacterFrameInput> inputs;
  for (const auto& p : poses) inputs.push_back({p.world, p.positions});

  for (RefitMode mode : {RefitMode::kExact, RefitMode::kFast}) {
    // Serial reference.
    std::vector<CharacterInstance> serial;
    for (int i = 0; i < kCount; ++i) {
      serial.push_back(MakeInstance(asset));
      serial.back().Update(mode, poses[i].world, poses[i].positions);
      serial.back().FindSpherePairs();
    }
    // TBB with 1 and 2 threads, then an engine's own job system (3 threads, reversed order).
    for (int threads : {1, 2, 3}) {
      std::vector<CharacterInstance> crowd;
      for (int i = 0; i < kCount; ++i) crowd.push_back(MakeInstance(asset));
      std::vector<CharacterInstance*> ptrs;
      for (auto& c : crowd) ptrs.push_back(&c);
      FrameStatus st;
      const ParallelFor engine = test::EngineStyleFor(threads);
      // Two frames: the second exercises the broad phase's frame-to-frame memory.
      for (int frame = 0; frame < 2; ++frame) {
        if (threads == 3) {
          st = CrowdUpdateAndFindSpherePairs(ptrs, inputs, mode, engine);
        } else {
          test::WithDefaultThreads(threads, [&] { st = CrowdUpdateAndFindSpherePairs(ptrs, inputs, mode); });
        }
      }
      EXPECT_EQ(st.code, ErrorCode::kInvalidData);
      for (int i = 0; i < kCount; ++i) {
        EXPECT_EQ(crowd[i].status().ok(), i != bad) << i;
        EXPECT_EQ(crowd[i].spheres_valid(), i != bad) << i;
        if (i == bad) {
          EXPECT_TRUE(crowd[i].sphere_pairs().empty());
          continue;
        }
        ASSERT_TRUE(serial[i].status().ok());
        for (size_t s = 0; s < asset->size(); ++s) ASSERT_EQ(crowd[i].spheres()[s], serial[i].spheres()[s]);
        EXPECT_EQ(std::vector<SpherePair>(crowd[i].sphere_pairs().begin(), crowd[i].sphere_pairs().end()),
                  std::vector<SpherePair>(serial[i].sphere_pairs().begin(), serial[i].sphere_pairs().end()));
      }
      if (mode == RefitMode::kFast) {
        // The broad-phase-only call keeps no joint matrices: FindContacts without positions (mode b)
        // is refused, saying why, until an update that keeps them.
        CharacterInstance& first = crowd[0];
        EXPECT_EQ(first.FindContacts().code, ErrorCode::kInvalidArgument);
        EXPECT_NE(std::string(first.status().message).find("CrowdUpdateAndFindSpherePairs"), std::string::npos)
            << first.status().message;
        ASSERT_TRUE(first.UpdateFast(poses[0].world).ok());
        EXPECT_TRUE(first.FindContacts().ok()) << first.status().message;
      }
    }
  }
  // Caller errors: mismatched spans, null instance.
  std::vector<CharacterInstance*> none(2, nullptr);
  EXPECT_EQ(
      CrowdUpdateAndFindSpherePairs(none, std::span<const CharacterFrameInput>(inputs).first(1), RefitMode::kFast).code,
      ErrorCode::kInvalidArgument);
  EXPECT_EQ(
      CrowdUpdateAndFindSpherePairs(none, std::span<const CharacterFrameInput>(inputs).first(2), RefitMode::kFast).code,
      ErrorCode::kInvalidArgument);
}

// The crowd calls refit several instances of one asset at once (one per vector lane: 16 at AVX-512,
// 8 at AVX2, 4 at SSE2 and portable) and must give every instance the spheres, contacts and triangle
// contacts it gets alone. 37 instances: 32 of one asset (full batches) then 5 of another (a batch
// ends where the asset changes: a partial one at 16 and 8 lanes; at 4, a full one and one instance
// alone), two of them in an engine's joint order (a mapping), one with a NaN joint matrix (it alone
// fails), one given too few joint matrices (refused before the refit); both crowd calls, on the
// calling thread and on TBB, and CrowdRange over an engine's ranges of 16; at every level the CPU
// has (portable and SSE2 on any x86-64).
TEST(CharacterCrowdTest, BatchedRefitEqualsEachInstanceAlone) {
  std::shared_ptr<const test::FittedCharacter> fc;
  auto first = BuiltinAsset(&fc);
  ASSERT_TRUE(first);
  auto second = BuiltinAsset();  // the same set, another asset: batches do not mix assets
  ASSERT_TRUE(second);
  const auto& names = fc->character.skeleton.joint_names;
  std::vector<std::string> reversed(names.rbegin(), names.rend());
  auto mapping = MapJoints(first->sphere_set(), reversed);
  ASSERT_TRUE(mapping.ok()) << mapping.error().message;
  constexpr int kCount = 37;
  const int nan_at = 20, short_at = 9, huge_at = 12;
  const std::set<int> mapped = {3, 30};
  std::mt19937 rng(5);
  std::vector<test::Pose> poses;
  std::vector<std::vector<Mat4f>> engine_order(kCount);
  for (int i = 0; i < kCount; ++i) {
    poses.push_back(test::MakePose(fc->character, test::RandomLocal(fc->character, rng, 60.0f, 0.2f), "r"));
    engine_order[i].assign(poses[i].world.rbegin(), poses[i].world.rend());
  }
  poses[nan_at].world[fc->set.influence_joints[0]](0, 3) = std::numeric_limits<float>::quiet_NaN();
  // Finite spheres the broad phase refuses (centres beyond its 1e18 bound): the batch's query too.
  for (Mat4f& g : poses[huge_at].world) g(0, 3) += 4e18f;
  const auto asset_of = [&](int i) { return i < 32 ? first : second; };
  const auto make = [&](int i) {
    if (mapped.count(i)) {
      auto inst = CharacterInstance::Create(asset_of(i), *mapping);
      EXPECT_TRUE(inst.ok());
      return std::move(inst).value();
    }
    return MakeInstance(asset_of(i));
  };
  std::vector<CharacterFrameInput> inputs;
  for (int i = 0; i < kCount; ++i) {
    std::span<const Mat4f> world = mapped.count(i) ? engine_order[i] : poses[i].world;
    if (i == short_at) world = world.first(world.size() - 1);
    inputs.push_back({world, {}});
  }
  // Each instance alone, one at a time (the batch is not used by Update).
  std::vector<CharacterInstance> alone;
  for (int i = 0; i < kCount; ++i) {
    alone.push_back(make(i));
    alone.back().Update(RefitMode::kFast, inputs[i].joint_world, {});
    if (alone.back().status().ok()) {
      alone.back().FindSpherePairs();
      alone.back().FindContacts();
    }
  }
  ASSERT_FALSE(alone[nan_at].status().ok());
  ASSERT_FALSE(alone[short_at].status().ok());
  ASSERT_FALSE(alone[huge_at].status().ok());
  ASSERT_TRUE(alone[huge_at].spheres_valid());
  for (const SimdLevel level : {SimdLevel::kPortable, SimdLevel::kSse2, SimdLevel::kAvx2, SimdLevel::kAvx512}) {
    const PinnedLevel pin(level);
    if (!pin.ok) {
      std::printf("%s: not on this CPU, not checked\n", internal::RefitLevelName(level));
      continue;
    }
    for (const bool find_contacts : {false, true}) {
      for (const int loop_kind : {0, 1, 2}) {  // serial, TBB, CrowdRange over ranges of 16
        std::vector<CharacterInstance> crowd;
        for (int i = 0; i < kCount; ++i) crowd.push_back(make(i));
        std::vector<CharacterInstance*> ptrs;
        for (auto& c : crowd) ptrs.push_back(&c);
        internal::NoteRefitSimdRun(SimdLevel::kAuto);
        FrameStatus st;
        if (loop_kind == 2) {
          for (size_t begin = 0; begin < ptrs.size(); begin += 16) {
            const size_t count = std::min<size_t>(16, ptrs.size() - begin);
            const FrameStatus range =
                CrowdRange(std::span(ptrs).subspan(begin, count), std::span(inputs).subspan(begin, count),
                           RefitMode::kFast, find_contacts);
            if (!range.ok()) st = range;
          }
        } else {
          const ParallelFor& loop = loop_kind == 1 ? DefaultParallelFor() : SerialFor();
          st = find_contacts ? CrowdUpdateAndFindContacts(ptrs, inputs, RefitMode::kFast, loop)
                             : CrowdUpdateAndFindSpherePairs(ptrs, inputs, RefitMode::kFast, loop);
        }
        const std::string what = std::string(internal::RefitLevelName(level)) +
                                 (find_contacts ? ", find contacts" : ", query") +
                                 (loop_kind == 0   ? ", serial"
                                  : loop_kind == 1 ? ", TBB"
                                                   : ", CrowdRange");
        if (loop_kind != 1) {
          EXPECT_EQ(internal::LastRefitSimdRun(), level) << what;
        }
        EXPECT_EQ(st.code, ErrorCode::kInvalidData) << what;
        for (int i = 0; i < kCount; ++i) {
          ASSERT_EQ(crowd[i].status().ok(), alone[i].status().ok()) << what << ", instance " << i;
          ASSERT_EQ(crowd[i].status().code, alone[i].status().code) << what << ", instance " << i;
          EXPECT_EQ(crowd[i].spheres_valid(), alone[i].spheres_valid()) << what << ", instance " << i;
          if (!alone[i].status().ok()) continue;
          for (size_t s = 0; s < crowd[i].spheres().size(); ++s) {
            ASSERT_EQ(crowd[i].spheres()[s], alone[i].spheres()[s]) << what << ", instance " << i << ", sphere " << s;
          }
          EXPECT_TRUE(std::ranges::equal(crowd[i].sphere_pairs(), alone[i].sphere_pairs()))
              << what << ", instance " << i;
          if (find_contacts) {
            EXPECT_EQ(crowd[i].contacts(), alone[i].contacts()) << what << ", instance " << i;
          }
        }
      }
    }
  }
}

// The crowd at each refit level the CPU has, pinned for the test: AVX-512 (16 lanes), AVX2 (8), SSE2
// and portable (4).
class CharacterCrowdLevelTest : public ::testing::TestWithParam<SimdLevel> {
 protected:
  void SetUp() override {
    if (!internal::PinRefitSimd(GetParam())) GTEST_SKIP() << "the CPU lacks " << internal::RefitLevelName(GetParam());
  }
  void TearDown() override { internal::PinRefitSimd(SimdLevel::kAuto); }
};

INSTANTIATE_TEST_SUITE_P(Levels, CharacterCrowdLevelTest, test::AllRefitLevels(), test::RefitLevelName);

// The crowd's batched query (the instances of one asset side by side in vector lanes) against the all-pairs
// oracle over a clip, every instance at its own point of the clip, frames of the crowd call
// alternating with frames where each instance runs alone (its candidate cache then restarts from
// a state the batch left behind), every frame's contacts equal to the oracle's; and the crowd call
// allocates nothing once warm.
TEST_P(CharacterCrowdLevelTest, BatchedQueryMatchesAllPairsOverAClip) {
  std::shared_ptr<const test::FittedCharacter> fc;
  auto asset = BuiltinAsset(&fc);
  ASSERT_TRUE(asset);
  const std::vector<test::Pose> poses = test::ClipPoses(fc->character, 24);
  // Every joint collapsed to one point (a zero linear part): all the spheres of such an instance
  // share one centre, so every allowed pair touches, far more than the batch's hit buffer holds.
  std::vector<Mat4f> collapsed(poses[0].world.size(), Mat4f::Zero());
  for (Mat4f& g : collapsed) g.col(3) << 0.5f, 1.0f, -0.25f, 1.0f;
  constexpr size_t kCount = 21;  // batches of 16 and 5, 8 8 and 5, or five of 4 and one alone
  std::vector<CharacterInstance> crowd;
  for (size_t k = 0; k < kCount; ++k) crowd.push_back(MakeInstance(asset));
  std::vector<CharacterInstance*> ptrs;
  for (auto& c : crowd) ptrs.push_back(&c);
  std::vector<SpherePair> oracle;
  size_t total = 0, batched_frames = 0;
  const auto frame = [&](size_t f, bool alone) {
    std::vector<CharacterFrameInput> inputs;
    for (size_t k = 0; k < kCount; ++k) inputs.push_back({poses[(f + 5 * k) % poses.size()].world, {}});
    if (f % 4 == 1) {
      for (size_t k = f % 3; k < kCount; k += 3) inputs[k].joint_world = collapsed;
    }
    if (alone) {
      for (size_t k = 0; k < kCount; ++k) {
        ASSERT_TRUE(crowd[k].UpdateFast(inputs[k].joint_world).ok());
        crowd[k].FindSpherePairs();
      }
    } else {
      const uint64_t batches = internal::CrowdQueryBatches();
      ASSERT_TRUE(CrowdUpdateAndFindSpherePairs(ptrs, inputs, RefitMode::kFast, SerialFor()).ok());
      batched_frames += internal::CrowdQueryBatches() > batches;
    }
    for (size_t k = 0; k < kCount; ++k) {
      ASSERT_TRUE(crowd[k].status().ok()) << crowd[k].status().message;
      ASSERT_TRUE(FindSpherePairsBruteForce(crowd[k].spheres(), asset->filter(), &oracle));
      ASSERT_EQ(std::vector<SpherePair>(crowd[k].sphere_pairs().begin(), crowd[k].sphere_pairs().end()), oracle)
          << "frame " << f << ", instance " << k << (alone ? ", alone" : ", crowd");
      for (size_t c = 0; c < oracle.size(); ++c) {  // == compares depths as floats: their bits too
        ASSERT_EQ(std::bit_cast<uint32_t>(crowd[k].sphere_pairs()[c].depth), std::bit_cast<uint32_t>(oracle[c].depth));
      }
      total += oracle.size();
      if (f % 4 == 1 && k >= f % 3 && (k - f % 3) % 3 == 0) {
        EXPECT_GT(oracle.size(), 64u) << "collapsed: every allowed pair touches";
      }
    }
  };
  for (size_t f = 0; f < 2 * poses.size(); ++f) {
    frame(f, f % 3 == 2);
    if (HasFatalFailure()) return;
  }
  EXPECT_GT(total, 0u);
  std::vector<CharacterFrameInput> inputs;
  inputs.reserve(kCount);
  for (size_t k = 0; k < kCount; ++k) inputs.push_back({poses[(3 + 5 * k) % poses.size()].world, {}});
  ASSERT_TRUE(CrowdUpdateAndFindSpherePairs(ptrs, inputs, RefitMode::kFast, SerialFor()).ok());  // warm-up
  {  // warm now: the crowd call allocates nothing
    test::AllocationCounter counter;
    for (size_t f = 0; f < poses.size(); ++f) {
      for (size_t k = 0; k < kCount; ++k) inputs[k].joint_world = poses[(f + 5 * k) % poses.size()].world;
      ASSERT_TRUE(CrowdUpdateAndFindSpherePairs(ptrs, inputs, RefitMode::kFast, SerialFor()).ok());
    }
    EXPECT_EQ(counter.count(), 0);
  }
  // An instance listed twice in one range (serially: CrowdRange) is updated twice, in order, as
  // CrowdStep would: its spheres and contacts are the second input's, each contact once.
  std::vector<CharacterInstance*> twice = {ptrs[0], ptrs[1], ptrs[2], ptrs[0], ptrs[3]};
  std::vector<CharacterFrameInput> twice_inputs;
  for (size_t k = 0; k < twice.size(); ++k) twice_inputs.push_back({poses[(2 + 3 * k) % poses.size()].world, {}});
  ASSERT_TRUE(CrowdRange(twice, twice_inputs, RefitMode::kFast, false).ok());
  CharacterInstance expected = MakeInstance(asset);
  ASSERT_TRUE(expected.UpdateFast(twice_inputs[3].joint_world).ok());
  expected.FindSpherePairs();
  EXPECT_TRUE(std::ranges::equal(crowd[0].spheres(), expected.spheres()));
  EXPECT_TRUE(std::ranges::equal(crowd[0].sphere_pairs(), expected.sphere_pairs()));
  EXPECT_EQ(batched_frames, 2 * poses.size() - poses.size() * 2 / 3) << "every crowd frame queried at once";
}

// The batched crowd on the shared characters (fits of files no one here made), at every level the CPU
// has: 37 instances of one asset, each at its own frame of the character's clips or in a random pose
// (joints turned up to 60 degrees: limbs through the body; a character without clips has only
// these), every instance's spheres and sphere pairs equal to running it alone.
class SharedCharacterCrowd : public ::testing::TestWithParam<std::string> {};

TEST_P(SharedCharacterCrowd, BatchEqualsEachInstanceAlone) {
  SKINSPHERES_REQUIRE_ASSET(path, GetParam());
  (void)path;
  auto fc = test::LoadFitted(GetParam());
  ASSERT_TRUE(fc);
  auto asset = CharacterAsset::Create(fc->set);
  ASSERT_TRUE(asset.ok()) << asset.error().message;
  std::vector<test::Pose> poses = test::ClipPoses(fc->character, 12);
  std::mt19937 rng(29);
  for (int k = 0; k < 12; ++k) {
    poses.push_back(test::MakePose(fc->character, test::RandomLocal(fc->character, rng, 60.0f, 0.0f),
                                   "random#" + std::to_string(k)));
  }
  constexpr size_t kCount = 37;
  std::vector<CharacterFrameInput> inputs;
  std::vector<CharacterInstance> alone;
  size_t pairs = 0;
  for (size_t k = 0; k < kCount; ++k) {
    inputs.push_back({poses[(7 * k) % poses.size()].world, {}});
    alone.push_back(MakeInstance(*asset));
    ASSERT_TRUE(alone[k].UpdateFast(inputs[k].joint_world).ok());
    pairs += alone[k].FindSpherePairs().size();
  }
  EXPECT_GT(pairs, 0u);
  for (const SimdLevel level : {SimdLevel::kPortable, SimdLevel::kSse2, SimdLevel::kAvx2, SimdLevel::kAvx512}) {
    const PinnedLevel pin(level);
    if (!pin.ok) continue;
    std::vector<CharacterInstance> crowd;
    for (size_t k = 0; k < kCount; ++k) crowd.push_back(MakeInstance(*asset));
    std::vector<CharacterInstance*> ptrs;
    for (auto& c : crowd) ptrs.push_back(&c);
    const uint64_t batches = internal::CrowdQueryBatches();
    ASSERT_TRUE(CrowdUpdateAndFindSpherePairs(ptrs, inputs, RefitMode::kFast, SerialFor()).ok());
    EXPECT_GT(internal::CrowdQueryBatches(), batches) << internal::RefitLevelName(level) << ": queried in batches";
    for (size_t k = 0; k < kCount; ++k) {
      ASSERT_TRUE(std::ranges::equal(crowd[k].spheres(), alone[k].spheres()))
          << internal::RefitLevelName(level) << ", instance " << k;
      ASSERT_TRUE(std::ranges::equal(crowd[k].sphere_pairs(), alone[k].sphere_pairs()))
          << internal::RefitLevelName(level) << ", instance " << k;
    }
  }
  std::printf("%s: %zu spheres, %zu sphere pairs over %zu instances\n", GetParam().c_str(), (*asset)->size(), pairs,
              kCount);
}

INSTANTIATE_TEST_SUITE_P(Assets, SharedCharacterCrowd, ::testing::ValuesIn(test::SharedCharacters()),
                         [](const auto& param_info) {
                           std::string n = param_info.param;
                           return n.substr(0, n.find('.'));
                         });

// An instance the crowd calls only ever query in a batch never holds the single query's candidate
// cache: Create leaves it unsized (ReserveSpherePairs sizes it: more bytes), warm batched frames
// allocate nothing, and the instance's first FindSpherePairs alone allocates it, giving the
// oracle's pairs, the next one nothing.
TEST_P(CharacterCrowdLevelTest, BatchedInstancesHoldNoQueryCache) {
  std::shared_ptr<const test::FittedCharacter> fc;
  auto asset = BuiltinAsset(&fc);
  ASSERT_TRUE(asset);
  const std::vector<test::Pose> poses = test::ClipPoses(fc->character, 12);
  size_t created_bytes = 0, reserved_bytes = 0;
  {
    test::AllocationCounter counter;
    CharacterInstance created = MakeInstance(asset);
    created_bytes = counter.bytes();
  }
  {
    test::AllocationCounter counter;
    CharacterInstance reserved = MakeInstance(asset);
    reserved.ReserveSpherePairs(0);
    reserved_bytes = counter.bytes();
  }
  EXPECT_GT(reserved_bytes, created_bytes + 1024) << "the query cache is more than a kilobyte";
  std::printf("bytes per instance at Create: %zu; with the single query's cache: %zu\n", created_bytes, reserved_bytes);
  constexpr size_t kCount = 16;
  std::vector<CharacterInstance> crowd;
  for (size_t k = 0; k < kCount; ++k) crowd.push_back(MakeInstance(asset));
  std::vector<CharacterInstance*> ptrs;
  for (auto& c : crowd) ptrs.push_back(&c);
  std::vector<CharacterFrameInput> inputs(kCount);
  const auto frame = [&](size_t f) {
    for (size_t k = 0; k < kCount; ++k) inputs[k] = {poses[(f + k) % poses.size()].world, {}};
    return CrowdUpdateAndFindSpherePairs(ptrs, inputs, RefitMode::kFast, SerialFor()).ok();
  };
  ASSERT_TRUE(frame(0));  // warm-up: the thread's batch buffers
  {
    test::AllocationCounter counter;
    for (size_t f = 1; f < poses.size(); ++f) ASSERT_TRUE(frame(f));
    EXPECT_EQ(counter.count(), 0);
  }
  std::vector<SpherePair> oracle;
  ASSERT_TRUE(crowd[3].UpdateFast(poses[5].world).ok());
  {
    test::AllocationCounter counter;
    crowd[3].FindSpherePairs();
    EXPECT_GE(counter.bytes(), reserved_bytes - created_bytes) << "the first query alone sizes the cache";
  }
  ASSERT_TRUE(FindSpherePairsBruteForce(crowd[3].spheres(), asset->filter(), &oracle));
  EXPECT_EQ(std::vector<SpherePair>(crowd[3].sphere_pairs().begin(), crowd[3].sphere_pairs().end()), oracle);
  ASSERT_TRUE(crowd[3].UpdateFast(poses[6].world).ok());
  {
    test::AllocationCounter counter;
    crowd[3].FindSpherePairs();
    EXPECT_EQ(counter.count(), 0);
  }
}

// A set of n spheres on two joints (sphere s on joint s % 2, owning vertex s and triangle s), centres
// spread over a box a few radii wide so that many pairs touch; exclusions: none, or every pair. With
// parts > 2: the spheres of each part in a small cluster of its own on a ring, the whole part on one
// joint (part % 2), the parts' spheres interleaved (sphere s in part s % parts) or in runs (sphere s
// in part s * parts / n).
SphereSet CrowdTestSet(size_t n, bool exclude_all, std::mt19937& rng, uint32_t parts = 2, bool interleaved = true) {
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  SphereSet set;
  set.source_vertex_count = n;
  set.source_triangle_count = n;
  set.joint_names = {"a", "b"};
  set.joint_parents = {-1, 0};
  set.joint_rest_world = {Mat4f::Identity(), Mat4f::Identity()};
  for (uint32_t p = 0; p < parts; ++p) set.parts.push_back({"p" + std::to_string(p), {static_cast<uint16_t>(p % 2)}});
  set.vertex_offsets = {0};
  set.triangle_offsets = {0};
  set.influence_offsets = {0};
  for (uint32_t k = 0; k < n; ++k) {
    const auto part = static_cast<uint32_t>(interleaved ? k % parts : size_t{k} * parts / n);
    const uint32_t joint = parts > 2 ? part % 2 : k % 2;
    if (parts > 2) {
      const float angle = 6.2831853f * float(part) / float(parts);
      set.centers_rest.emplace_back(2.5f * std::cos(angle) + 0.3f * u(rng), 2.5f * std::sin(angle) + 0.3f * u(rng),
                                    0.3f * u(rng));
      set.radii_rest.push_back(0.06f + 0.03f * u(rng));
    } else {
      set.centers_rest.emplace_back(2.0f * u(rng), 2.0f * u(rng), 0.5f * u(rng));
      set.radii_rest.push_back(0.2f + 0.1f * u(rng));
    }
    set.radii_fast.push_back(set.radii_rest.back());
    set.sphere_part.push_back(static_cast<uint16_t>(part));
    set.sphere_joint.push_back(static_cast<uint16_t>(joint));
    set.sphere_level.push_back(0);
    set.vertices.push_back(k);
    set.vertex_offsets.push_back(k + 1);
    set.triangles.push_back(k);
    set.triangle_offsets.push_back(k + 1);
    set.influence_joints.push_back(static_cast<uint16_t>(joint));
    set.influence_weights.push_back(1.0f);
    set.influence_offsets.push_back(k + 1);
  }
  for (uint32_t i = 0; exclude_all && i < n; ++i) {
    for (uint32_t j = i + 1; j < n; ++j) set.excluded_pairs.push_back({i, j, ExclusionReason::kSameJoint});
  }
  return set;
}

// The batched query's bounds: sets of 1, 2, 255, 256 (every pair listed), 257 and 1024 (grouped by
// row and part, two parts spread everywhere: no box culls), 400 in 12 small clusters, their spheres
// interleaved (the grouped order is not (i, j)'s: each instance's pairs are sorted after) or in runs
// (it is), 1025 (too many: one by one), and one whose every pair is excluded. Each crowd of 20
// instances (batches of 16 and 4, 8 8 and 4, or five of 4) under random rigid motions gives every
// instance the oracle's contacts; the batch queries at once only from 2 to 1024 spheres with some
// pair allowed, and one by one otherwise.
TEST_P(CharacterCrowdLevelTest, BatchedQueryBoundsBySphereCount) {
  std::mt19937 rng(11);
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  bool batched_any = false;
  struct Case {
    size_t n;
    bool exclude_all;
    uint32_t parts;
    bool interleaved;
  };
  for (const Case& set : std::vector<Case>{{1, false, 2, true},
                                           {2, false, 2, true},
                                           {255, false, 2, true},
                                           {256, false, 2, true},
                                           {257, false, 2, true},
                                           {400, false, 12, true},
                                           {400, false, 12, false},
                                           {1024, false, 2, true},
                                           {1025, false, 2, true},
                                           {40, true, 2, true}}) {
    const size_t n = set.n;
    const bool exclude_all = set.exclude_all;
    auto asset = CharacterAsset::Create(CrowdTestSet(n, exclude_all, rng, set.parts, set.interleaved));
    ASSERT_TRUE(asset.ok()) << asset.error().message;
    constexpr size_t kCount = 20;
    std::vector<CharacterInstance> crowd;
    for (size_t k = 0; k < kCount; ++k) crowd.push_back(MakeInstance(*asset));
    std::vector<CharacterInstance*> ptrs;
    for (auto& c : crowd) ptrs.push_back(&c);
    std::vector<std::vector<Mat4f>> worlds(kCount, std::vector<Mat4f>(2, Mat4f::Identity()));
    std::vector<CharacterFrameInput> inputs(kCount);
    std::vector<SpherePair> oracle;
    const std::string what = std::to_string(n) + " spheres, " + std::to_string(set.parts) + " parts" +
                             (set.interleaved ? "" : " in runs") + (exclude_all ? ", every pair excluded" : "");
    for (int frame = 0; frame < 3; ++frame) {
      for (size_t k = 0; k < kCount; ++k) {
        for (Mat4f& g : worlds[k]) {
          g.topLeftCorner<3, 3>() =
              Eigen::AngleAxisf(3.0f * u(rng), Eigen::Vector3f(u(rng), u(rng), 1.0f).normalized()).toRotationMatrix();
          g.col(3).head<3>() = Eigen::Vector3f(0.3f * u(rng), 0.3f * u(rng), 0.3f * u(rng));
        }
        inputs[k] = {worlds[k], {}};
      }
      const uint64_t batches = internal::CrowdQueryBatches();
      ASSERT_TRUE(CrowdUpdateAndFindSpherePairs(ptrs, inputs, RefitMode::kFast, SerialFor()).ok()) << what;
      const bool batched = internal::CrowdQueryBatches() > batches;
      batched_any |= batched;
      if (batched) {
        EXPECT_TRUE(n >= 2 && n <= 1024 && !exclude_all) << what;
      }
      size_t touching = 0;
      for (size_t k = 0; k < kCount; ++k) {
        ASSERT_TRUE(crowd[k].status().ok()) << what;
        ASSERT_TRUE(FindSpherePairsBruteForce(crowd[k].spheres(), (*asset)->filter(), &oracle));
        ASSERT_EQ(std::vector<SpherePair>(crowd[k].sphere_pairs().begin(), crowd[k].sphere_pairs().end()), oracle)
            << what << ", frame " << frame << ", instance " << k;
        touching += oracle.size();
      }
      if (n > 2 && !exclude_all) {
        EXPECT_GT(touching, 0u) << what;
      }
      if (internal::RefitBatchUsable() && n >= 2 && n <= 1024 && !exclude_all) {
        EXPECT_TRUE(batched) << what;
      }
    }
  }
  EXPECT_TRUE(batched_any);
}

// ReserveContacts at set-up sizes the narrow phase's scratch too: the first FindContacts (with
// positions) then allocates nothing; without it, the first FindContacts sizes the scratch itself.
TEST(CharacterInstanceTest, ReserveContactsSizesTheNarrowPhase) {
  std::shared_ptr<const test::FittedCharacter> fc;
  auto asset = BuiltinAsset(&fc);
  ASSERT_TRUE(asset);
  ASSERT_NE(asset->narrow_phase(), nullptr);
  const std::vector<test::Pose> poses = test::ClipPoses(fc->character, 15);
  const test::Pose& pose = poses[poses.size() / 2];
  CharacterInstance reserved = MakeInstance(asset);
  reserved.ReserveContacts(4096);
  ASSERT_TRUE(reserved.UpdateExact(pose.positions, pose.world).ok());
  reserved.FindSpherePairs();
  {
    test::AllocationCounter counter;
    EXPECT_TRUE(reserved.FindContacts(pose.positions).ok());
    EXPECT_EQ(counter.count(), 0);
  }
  CharacterInstance plain = MakeInstance(asset);
  ASSERT_TRUE(plain.UpdateExact(pose.positions, pose.world).ok());
  plain.FindSpherePairs();
  {
    test::AllocationCounter counter;
    EXPECT_TRUE(plain.FindContacts(pose.positions).ok());
    EXPECT_GE(counter.count(), 1);
  }
  EXPECT_EQ(reserved.contacts(), plain.contacts());
}

// ReserveSpherePairs pins FindSpherePairs' list without the narrow phase's scratch. Every vertex on one
// point makes the spheres collapse onto it, so nearly every allowed pair touches: far more
// sphere pairs than Create's room (4 per sphere). The reserved instance's first frame allocates
// nothing, an unreserved one grows its list, both give the same sphere pairs, and the reserved
// instance's first FindContacts still sizes the narrow phase's scratch (ReserveSpherePairs
// did not).
TEST(CharacterInstanceTest, ReserveSpherePairsPinsOnlyTheSpherePairs) {
  std::shared_ptr<const test::FittedCharacter> fc;
  auto asset = BuiltinAsset(&fc);
  ASSERT_TRUE(asset);
  ASSERT_NE(asset->narrow_phase(), nullptr);
  const size_t n = asset->size();
  const std::vector<Eigen::Vector3f> collapsed(fc->character.vertex_count(), Eigen::Vector3f(0.1f, 1.0f, 0.05f));
  const size_t room = n * (n - 1) / 2;
  CharacterInstance reserved = MakeInstance(asset);
  reserved.ReserveSpherePairs(room);
  CharacterInstance plain = MakeInstance(asset);
  CharacterInstance both = MakeInstance(asset);  // the control: ReserveContacts sizes the narrow phase
  both.ReserveContacts(room);
  {
    test::AllocationCounter counter;
    ASSERT_TRUE(reserved.UpdateExact(collapsed, {}).ok());
    reserved.FindSpherePairs();
    EXPECT_EQ(counter.count(), 0);
  }
  ASSERT_TRUE(reserved.status().ok());
  EXPECT_GT(reserved.sphere_pairs().size(), 4 * n);
  {
    test::AllocationCounter counter;
    ASSERT_TRUE(plain.UpdateExact(collapsed, {}).ok());
    plain.FindSpherePairs();
    EXPECT_GE(counter.count(), 1);
  }
  EXPECT_TRUE(std::ranges::equal(plain.sphere_pairs(), reserved.sphere_pairs()));
  ASSERT_TRUE(both.UpdateExact(collapsed, {}).ok());
  both.FindSpherePairs();
  {
    test::AllocationCounter counter;
    EXPECT_TRUE(both.FindContacts(collapsed).ok()) << both.status().message;
    EXPECT_EQ(counter.count(), 0);
  }
  {
    test::AllocationCounter counter;
    EXPECT_TRUE(reserved.FindContacts(collapsed).ok()) << reserved.status().message;
    EXPECT_GE(counter.count(), 1);
  }
  EXPECT_EQ(reserved.contacts(), both.contacts());
}

TEST(CharacterInstanceTest, NoAllocationPerFrameAfterTheFirst) {
  std::shared_ptr<const test::FittedCharacter> fc;
  auto asset = BuiltinAsset(&fc);
  ASSERT_TRUE(asset);
  CharacterInstance inst = MakeInstance(asset);
  const std::vector<test::Pose> poses = test::ClipPoses(fc->character, 15);
  auto run_all = [&] {
    for (const auto& p : poses) {
      inst.UpdateExact(p.positions, p.world);
      inst.FindSpherePairs();
      inst.UpdateFast(p.world);
      inst.FindSpherePairs();
    }
  };
  run_all();  // warm-up: the contact list reaches its largest size
  {
    test::AllocationCounter counter;
    run_all();
    EXPECT_EQ(counter.count(), 0);
  }
  // The counter does count (so the zero above means something).
  test::AllocationCounter counter;
  auto probe = std::make_unique<std::vector<int>>(10);
  EXPECT_GE(counter.count(), 1);
}

}  // namespace
}  // namespace skinspheres::runtime
