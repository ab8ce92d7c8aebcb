// Narrow phase (narrow_phase.h) through the engine API:
//  - the job's contacts equal the brute-force oracle (every triangle pair of every sphere pair the
//    filter allows, the same rules) on random poses and clip frames of the built-in character and
//    of every shared character, in exact and fast refit, with and without a margin;
//  - fast mode with lazy skinning equals exact mode fed the fully skinned mesh, field by field;
//  - identical output for 1, 2, 3 threads and TBB; no allocation after warm-up;
//  - version-1 sets and margins too large refused; mode (b) needs joint matrices and finite input.
// The exclusion rules and the depth estimate on hand-made meshes: narrow_phase_rules_tests.cc.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstring>
#include <numbers>
#include <optional>
#include <random>

#include "allocation_counter.h"
#include "narrow_phase/internal.h"
#include "runtime/narrow_phase/same_contacts.h"
#include "runtime/posed_characters.h"
#include "skinspheres/runtime/api/character.h"
#include "skinspheres/runtime/crowd/crowd.h"
#include "skinspheres/runtime/narrow_phase/narrow_phase.h"
#include "skinspheres/runtime/narrow_phase/triangle_contact.h"
#include "skinspheres/skinning/skinning_job.h"
#include "skinspheres/skinning/skinning_matrices_job.h"

namespace skinspheres::runtime {
namespace {

using Eigen::Vector3f;

// Every vertex skinned by SkinningJob (CSR, no subset): the mesh an engine would skin in full.
std::vector<Vector3f> SkinAll(const SphereSet& set, std::span<const Mat4f> joint_world) {
  std::vector<Mat4f> matrices(set.mesh.binds.size());
  EXPECT_TRUE((skinning::SkinningMatricesJob{set.mesh.binds, joint_world, matrices}.Run()));
  std::vector<Vector3f> out(set.mesh.vertex_count(), Vector3f::Zero());
  skinning::SkinningJob job;
  job.joint_matrices = matrices;
  job.vertex_count = set.mesh.vertex_count();
  job.in_positions = {reinterpret_cast<const float*>(set.mesh.positions_bind.data()), 3 * out.size()};
  job.out_positions = {reinterpret_cast<float*>(out.data()), 3 * out.size()};
  job.influence_offsets = set.mesh.influence_offsets;
  job.influence_binds = set.mesh.influence_binds;
  job.influence_weights = set.mesh.influence_weights;
  EXPECT_TRUE(job.Run());
  return out;
}

float BodyHeight(const test::Character& c) {
  float lo = INFINITY, hi = -INFINITY;
  for (const auto& p : c.positions_rest) {
    lo = std::min(lo, p.y());
    hi = std::max(hi, p.y());
  }
  return hi - lo;
}

struct Totals {
  size_t frames = 0, intersecting = 0, within = 0, part_pairs = 0, triangle_tests = 0, still_patch_pairs = 0;
};

// For each pose and refit mode: the instance's contacts equal the oracle's, with the positions given
// (mode a: the motion bound measured on them) and skinned by the job (mode b: the bound from the
// joint matrices; the oracle then on SkinAll's positions, which are the job's to the bit).
void CheckAgainstOracle(const test::FittedCharacter& fc, const std::vector<test::Pose>& poses, float margin,
                        Totals* totals) {
  auto asset = CharacterAsset::Create(fc.set, NarrowPhaseSettings{margin});
  ASSERT_TRUE(asset.ok()) << asset.error().message;
  ASSERT_NE((*asset)->narrow_phase(), nullptr);
  auto inst = CharacterInstance::Create(*asset);
  ASSERT_TRUE(inst.ok());
  FrameContacts oracle, oracle_skinned;
  for (const test::Pose& pose : poses) {
    ASSERT_TRUE(FindContactsBruteForce(fc.set, *(*asset)->narrow_phase(), (*asset)->filter(), pose.positions, &oracle));
    ASSERT_TRUE(FindContactsBruteForce(fc.set, *(*asset)->narrow_phase(), (*asset)->filter(),
                                       SkinAll(fc.set, pose.world), &oracle_skinned));
    for (RefitMode mode : {RefitMode::kExact, RefitMode::kFast}) {
      ASSERT_TRUE(inst->Update(mode, pose.world, pose.positions).ok());
      const FrameStatus st = inst->FindContacts(pose.positions);
      ASSERT_TRUE(st.ok()) << st.message;
      EXPECT_SAME_CONTACTS(inst->contacts(), oracle, pose.label << " " << ToString(mode));
      totals->triangle_tests += inst->narrow_phase_stats().triangle_tests;
      totals->still_patch_pairs += inst->narrow_phase_stats().still_patch_pairs;
      const FrameStatus lazy = inst->FindContacts();
      ASSERT_TRUE(lazy.ok()) << lazy.message;
      EXPECT_SAME_CONTACTS(inst->contacts(), oracle_skinned,
                           pose.label << " " << ToString(mode) << " skinned by the job");
    }
    ++totals->frames;
    totals->part_pairs += oracle.parts.size();
    for (const auto& c : oracle.triangle_pairs) {
      (c.kind == TriangleContactKind::kIntersecting ? totals->intersecting : totals->within) += 1;
    }
  }
}

std::vector<test::Pose> RandomPoses(const test::Character& c, int count, float max_deg, uint32_t seed) {
  std::mt19937 rng(seed);
  std::vector<test::Pose> poses;
  for (int k = 0; k < count; ++k) {
    poses.push_back(test::MakePose(c, test::RandomLocal(c, rng, max_deg, 0.0f), "random " + std::to_string(k)));
  }
  return poses;
}

// Poses near rest, where the motion bound skips most patch pairs: the rest pose itself, and joints
// turned by up to 1 and 4 degrees.
std::vector<test::Pose> NearRestPoses(const test::Character& c, uint32_t seed) {
  std::mt19937 rng(seed);
  std::vector<test::Pose> poses;
  poses.push_back(test::MakePose(c, test::RandomLocal(c, rng, 0.0f, 0.0f), "rest"));
  for (float deg : {1.0f, 4.0f}) {
    poses.push_back(test::MakePose(c, test::RandomLocal(c, rng, deg, 0.0f), "near rest " + std::to_string(deg)));
  }
  return poses;
}

void PrintTotals(const std::string& name, float margin, const Totals& t) {
  std::printf(
      "[oracle] %s margin %.4f: %zu frames, %zu intersecting + %zu within-margin triangle pairs in %zu part-pair "
      "groups, %.0f triangle tests per frame and mode, %zu patch pairs skipped as still\n",
      name.c_str(), margin, t.frames, t.intersecting, t.within, t.part_pairs,
      t.frames ? double(t.triangle_tests) / double(2 * t.frames) : 0.0, t.still_patch_pairs);
}

TEST(NarrowPhaseOracle, BuiltinRandomPosesAndClips) {
  auto fc = test::LoadFitted("builtin");
  ASSERT_TRUE(fc);
  std::vector<test::Pose> poses = RandomPoses(fc->character, 12, 60.0f, 1);
  for (auto& p : test::ClipPoses(fc->character, 12)) poses.push_back(std::move(p));
  for (auto& p : NearRestPoses(fc->character, 5)) poses.push_back(std::move(p));
  Totals totals;
  CheckAgainstOracle(*fc, poses, 0.0f, &totals);
  PrintTotals("builtin", 0.0f, totals);
  EXPECT_GT(totals.intersecting, 100u) << "the poses must produce contacts for the comparison to mean anything";
  const float margin = 0.005f * BodyHeight(fc->character);
  Totals with_margin;
  CheckAgainstOracle(*fc, RandomPoses(fc->character, 6, 60.0f, 2), margin, &with_margin);
  PrintTotals("builtin", margin, with_margin);
  EXPECT_GT(with_margin.within, 10u);
}

class NarrowPhaseShared : public ::testing::TestWithParam<std::string> {};

TEST_P(NarrowPhaseShared, MatchesTheOracle) {
  SKINSPHERES_REQUIRE_ASSET(path, GetParam());
  auto fc = test::LoadFitted(GetParam());
  ASSERT_TRUE(fc);
  std::vector<test::Pose> poses = RandomPoses(fc->character, 3, 45.0f, 3);
  for (auto& p : test::ClipPoses(fc->character, 2)) poses.push_back(std::move(p));
  for (auto& p : NearRestPoses(fc->character, 6)) poses.push_back(std::move(p));
  Totals totals;
  CheckAgainstOracle(*fc, poses, 0.0f, &totals);
  PrintTotals(GetParam(), 0.0f, totals);
  EXPECT_GT(totals.intersecting, 0u);
  EXPECT_GT(totals.still_patch_pairs, 0u) << "the motion bound never skipped: the comparison did not test it";
  // A margin of 0.3% of the height: sphere pairs that do not overlap but lie within the margin hold
  // within-margin triangle pairs (Soldier's and RobotExpressive's clips), which the instance must
  // find too (CharacterInstance::FindContacts grows the spheres for its query). Pairs nearer than the
  // rest gap (1%) at rest stay excluded; a margin as large as the gap reports every pair of Xbot's
  // fingers that closes in by a hair (about a million per frame).
  Totals with_margin;
  const float margin = 0.003f * BodyHeight(fc->character);
  std::vector<test::Pose> margin_poses = RandomPoses(fc->character, 1, 45.0f, 4);
  for (auto& p : test::ClipPoses(fc->character, 4)) margin_poses.push_back(std::move(p));
  CheckAgainstOracle(*fc, margin_poses, margin, &with_margin);
  PrintTotals(GetParam(), margin, with_margin);
}

INSTANTIATE_TEST_SUITE_P(SharedCharacters, NarrowPhaseShared, ::testing::ValuesIn(test::SharedCharacters()),
                         [](const auto& param_info) { return param_info.param.substr(0, param_info.param.find('.')); });

// ------------------------------------------------------------------ the built-in character

// The largest weight of one of triangle t's vertices is on a joint whose name contains `name`.
bool OnJoint(const test::Character& c, uint32_t t, const std::string& name) {
  for (int k = 0; k < 3; ++k) {
    const int v = c.triangles[t][k];
    float best = 0;
    int32_t joint = -1;
    for (uint32_t i = c.skin.influence_offsets[v]; i < c.skin.influence_offsets[v + 1]; ++i) {
      if (c.skin.influence_weights[i] > best)
        best = c.skin.influence_weights[i], joint = c.skin.binds[c.skin.influence_binds[i]].joint;
    }
    if (c.skeleton.joint_names[joint].find(name) != std::string::npos) return true;
  }
  return false;
}

TEST(NarrowPhase, BuiltinWalkTouchesNothingAndTouchOnlyWithTheHands) {
  auto fc = test::LoadFitted("builtin");
  ASSERT_TRUE(fc);
  auto asset = CharacterAsset::Create(fc->set);
  ASSERT_TRUE(asset.ok());
  auto inst = CharacterInstance::Create(*asset);
  const auto& set = fc->set;
  const test::Character& c = fc->character;
  for (const auto& clip : c.clips) {
    int contact_frames = 0;
    for (int f = 0; f <= int(clip.duration_s * 30.0f + 1e-3f); ++f) {
      const float t = f / 30.0f;
      const test::Pose pose = test::MakePose(c, test::SampleLocal(c, clip, t), clip.name);
      for (RefitMode mode : {RefitMode::kExact, RefitMode::kFast}) {
        ASSERT_TRUE(inst->Update(mode, pose.world, pose.positions).ok());
        ASSERT_TRUE(inst->FindContacts(mode == RefitMode::kExact ? std::span<const Vector3f>(pose.positions)
                                                                 : std::span<const Vector3f>())
                        .ok());
        const FrameContacts& out = inst->contacts();
        if (clip.name == "walk") {
          ASSERT_TRUE(out.empty()) << "walk t=" << t << ": " << set.parts[out.parts[0].part_a].name << " - "
                                   << set.parts[out.parts[0].part_b].name;
          continue;
        }
        for (const PartContact& p : out.parts) {
          const std::string a = set.parts[p.part_a].name, b = set.parts[p.part_b].name;
          ASSERT_TRUE((a == "torso" || a == "head") && b.rfind("arm_", 0) == 0)
              << "touch t=" << t << ": " << a << " - " << b;
          EXPECT_GT(p.depth, 0.0f);
          EXPECT_LT(p.depth, 0.06f) << "the hands sink at most a few cm";
          for (uint32_t k = p.first_triangle_pair; k < p.first_triangle_pair + p.triangle_pair_count; ++k) {
            ASSERT_TRUE(OnJoint(c, out.triangle_pairs[k].triangle_b, "Hand"))
                << "touch t=" << t << ": arm triangle " << out.triangle_pairs[k].triangle_b << " is not the hand's";
          }
        }
        contact_frames += !out.empty() && mode == RefitMode::kExact;
      }
    }
    if (clip.name == "touch") {
      EXPECT_GE(contact_frames, 50) << "hands on the chest and on the head for 0.8 s each";
    }
  }
}

// ------------------------------------------------------------------ lazy skinning, threads

// The built-in character, then each shared character present on this machine (the shared ones
// absent here are reported by the parameterised NarrowPhaseShared tests, which skip them).
std::vector<std::string> BuiltinAndPresentSharedCharacters() {
  std::vector<std::string> names = {"builtin"};
  for (const auto& n : test::SharedCharacters()) {
    if (!test::Asset(n).empty()) names.push_back(n);
  }
  return names;
}

// Runs mode (b) on one frame's pairs with a fresh context and checks what it skinned: every vertex
// of the spheres it tested (those of the pairs its motion bound did not skip whole, and the
// self-tested ones) equals the whole-mesh skinning `all` to the bit, and the count skinned is at least
// theirs (the depth estimate may add spheres) and at most the mesh.
void ExpectLazyPositionsAreTheWholeMeshs(const SphereSet& set, const CharacterAsset& asset,
                                         std::span<const Vec4f> spheres, std::span<const SpherePair> pairs,
                                         std::span<const Mat4f> world, const std::vector<Vector3f>& all,
                                         const std::string& label) {
  const NarrowPhaseData& data = *asset.narrow_phase();
  NarrowPhaseContext ctx;
  ctx.Resize(data, true);
  FrameContacts out;
  NarrowPhaseJob job{&set, &data, spheres, pairs, {}, world, &ctx, &out};
  ASSERT_TRUE(job.Run()) << label;
  std::vector<char> needed(set.source_vertex_count, 0);
  for (uint32_t s : ctx.tested_spheres()) {
    for (uint32_t k = set.triangle_offsets[s]; k < set.triangle_offsets[s + 1]; ++k) {
      for (int c = 0; c < 3; ++c) needed[set.triangle_vertices[3 * size_t{set.triangles[k]} + c]] = 1;
    }
  }
  const auto lazy = ctx.lazy_positions();
  ASSERT_EQ(lazy.size(), all.size()) << label;
  size_t count = 0, differ = 0;
  for (size_t v = 0; v < needed.size(); ++v) {
    if (!needed[v]) continue;
    ++count;
    differ += std::memcmp(lazy[v].data(), all[v].data(), sizeof(float) * 3) != 0;
  }
  EXPECT_EQ(differ, 0u) << label << ": of " << count << " vertices of the spheres tested";
  EXPECT_GE(ctx.last_stats().skinned_vertices, count) << label;
  EXPECT_LE(ctx.last_stats().skinned_vertices, set.source_vertex_count) << label;
}

TEST(NarrowPhase, FastModeWithLazySkinningEqualsExactModeOnTheFullySkinnedMesh) {
  for (const std::string& name : BuiltinAndPresentSharedCharacters()) {
    auto fc = test::LoadFitted(name);
    ASSERT_TRUE(fc);
    auto asset = CharacterAsset::Create(fc->set);
    ASSERT_TRUE(asset.ok());
    auto lazy = CharacterInstance::Create(*asset), full = CharacterInstance::Create(*asset);
    size_t contacts = 0, frames = 0, clip_frames = 0, clip_skinned = 0;
    // Random poses (contacts everywhere) and the character's own clips (ordinary frames).
    std::vector<test::Pose> poses = RandomPoses(fc->character, name == "builtin" ? 10 : 3, 50.0f, 5);
    const size_t random_count = poses.size();
    for (auto& p : test::ClipPoses(fc->character, 6)) poses.push_back(std::move(p));
    for (size_t k = 0; k < poses.size(); ++k) {
      const test::Pose& pose = poses[k];
      const std::vector<Vector3f> all = SkinAll(fc->set, pose.world);
      ASSERT_TRUE(full->UpdateExact(all, pose.world).ok());
      ASSERT_TRUE(full->FindContacts(all).ok());
      ASSERT_TRUE(lazy->UpdateFast(pose.world).ok());
      ASSERT_TRUE(lazy->FindContacts().ok()) << lazy->status().message;
      EXPECT_SAME_CONTACTS(lazy->contacts(), full->contacts(), name << " " << pose.label);
      // The same frame through the job itself: the vertices of every sphere in a pair are skinned
      // bit for bit as the whole mesh (equal contacts alone would not show a run left unskinned).
      ExpectLazyPositionsAreTheWholeMeshs(fc->set, **asset, lazy->spheres(), lazy->sphere_pairs(), pose.world, all,
                                          name + " " + pose.label);
      contacts += full->contacts().triangle_pairs.size();
      EXPECT_LE(lazy->narrow_phase_stats().skinned_vertices, fc->set.source_vertex_count);
      if (k >= random_count) {
        ++clip_frames;
        clip_skinned += lazy->narrow_phase_stats().skinned_vertices;
      }
      ++frames;
    }
    const double skinned_share = double(clip_skinned) / double(clip_frames) / double(fc->set.source_vertex_count);
    std::printf(
        "[lazy] %s: %zu triangle pairs over %zu poses; on clip frames fast mode skinned %.0f%% of the %u "
        "vertices\n",
        name.c_str(), contacts, frames, 100.0 * skinned_share, fc->set.source_vertex_count);
    EXPECT_LT(skinned_share, 1.0) << name << ": clip frames skinned the whole mesh";
    EXPECT_GT(contacts, 0u) << name;
  }
}

// Mode (b)'s layout: the runs tile the prepared slots, every sphere vertex has exactly one slot, and
// a sphere's groups' runs, and its run bitset, hold exactly the vertices of its triangles (what the
// job must skin for it).
TEST(NarrowPhase, LazySkinningRunsHoldEachSpheresVerticesOnce) {
  for (const std::string& name : BuiltinAndPresentSharedCharacters()) {
    auto fc = test::LoadFitted(name);
    ASSERT_TRUE(fc);
    auto asset = CharacterAsset::Create(fc->set);
    ASSERT_TRUE(asset.ok());
    const NarrowPhaseData& d = *(*asset)->narrow_phase();
    const NarrowPhaseData::Layout& l = narrow_phase::Access::Of(d);  // the friend: the layout itself
    const auto& lazy = l.lazy_influences;
    ASSERT_EQ(l.run_begin.front(), 0u);
    ASSERT_EQ(l.run_begin.back(), lazy.size()) << name;
    for (size_t r = 0; r < l.run_count(); ++r) EXPECT_LT(l.run_begin[r], l.run_begin[r + 1]) << name;
    std::vector<uint32_t> slots_of(fc->set.source_vertex_count, 0);
    for (uint32_t v : lazy.vertices()) ++slots_of[v];
    std::vector<uint32_t> owner_of_run(l.run_count(), UINT32_MAX);
    for (uint32_t g = 0; g < l.group_count(); ++g) {
      uint32_t size = 0;
      for (uint32_t k = l.group_run_offsets[g]; k < l.group_run_offsets[g + 1]; ++k) {
        const uint32_t r = l.group_runs[k];
        EXPECT_EQ(owner_of_run[r], UINT32_MAX) << name << ": run " << r << " in two groups";
        owner_of_run[r] = g;
        size += l.run_begin[r + 1] - l.run_begin[r];
      }
      EXPECT_EQ(size, l.group_sizes[g]) << name << ": group " << g;
    }
    for (uint32_t owner : owner_of_run) EXPECT_NE(owner, UINT32_MAX) << name << ": a run of no group";
    for (uint32_t s = 0; s < d.sphere_count(); ++s) {
      std::vector<uint32_t> skinned;
      for (uint32_t k = l.sphere_group_offsets[s]; k < l.sphere_group_offsets[s + 1]; ++k) {
        const uint32_t g = l.sphere_groups[k];
        for (uint32_t q = l.group_run_offsets[g]; q < l.group_run_offsets[g + 1]; ++q) {
          const uint32_t r = l.group_runs[q];
          for (uint32_t slot = l.run_begin[r]; slot < l.run_begin[r + 1]; ++slot)
            skinned.push_back(lazy.vertices()[slot]);
        }
      }
      std::sort(skinned.begin(), skinned.end());
      // Oracle: the vertices of the triangles sphere s owns, straight from the set.
      std::vector<uint32_t> needed;
      for (uint32_t k = fc->set.triangle_offsets[s]; k < fc->set.triangle_offsets[s + 1]; ++k) {
        for (int c = 0; c < 3; ++c) needed.push_back(fc->set.triangle_vertices[3 * size_t{fc->set.triangles[k]} + c]);
      }
      std::sort(needed.begin(), needed.end());
      needed.erase(std::unique(needed.begin(), needed.end()), needed.end());
      ASSERT_EQ(skinned, needed) << name << ": sphere " << s;
      for (uint32_t v : needed) EXPECT_EQ(slots_of[v], 1u) << name << ": vertex " << v;
      // The same runs as the bitset a frame ORs in: words ascending, no empty mask.
      std::vector<uint32_t> from_bits;
      for (uint32_t k = l.sphere_run_offsets[s]; k < l.sphere_run_offsets[s + 1]; ++k) {
        const uint32_t word = l.sphere_run_words[k];
        if (k > l.sphere_run_offsets[s]) {
          EXPECT_LT(l.sphere_run_words[k - 1], word) << name << ": sphere " << s;
        }
        EXPECT_NE(l.sphere_run_bits[k], 0u) << name << ": sphere " << s;
        for (int b = 0; b < 64; ++b) {
          if (!(l.sphere_run_bits[k] >> b & 1)) continue;
          const size_t r = size_t{word} * 64 + size_t(b);
          ASSERT_LT(r, l.run_count()) << name << ": sphere " << s;
          for (uint32_t slot = l.run_begin[r]; slot < l.run_begin[r + 1]; ++slot)
            from_bits.push_back(lazy.vertices()[slot]);
        }
      }
      std::sort(from_bits.begin(), from_bits.end());
      EXPECT_EQ(from_bits, needed) << name << ": sphere " << s << "'s run bitset";
    }
  }
}

TEST(NarrowPhase, IdenticalForAnyThreadCount) {
  auto fc = test::LoadFitted("builtin");
  ASSERT_TRUE(fc);
  auto asset = CharacterAsset::Create(fc->set);
  ASSERT_TRUE(asset.ok());
  auto inst = CharacterInstance::Create(*asset);
  size_t total = 0;
  for (const test::Pose& pose : RandomPoses(fc->character, 8, 60.0f, 6)) {
    ASSERT_TRUE(inst->UpdateFast(pose.world).ok());
    ASSERT_TRUE(inst->FindContacts({}, SerialFor()).ok());
    const FrameContacts serial = inst->contacts();
    total += serial.triangle_pairs.size();
    for (int threads : {1, 2, 3, 7}) {
      ASSERT_TRUE(inst->FindContacts({}, test::EngineStyleFor(threads)).ok());
      EXPECT_SAME_CONTACTS(inst->contacts(), serial, threads << " threads");
      ASSERT_TRUE(inst->FindContacts(pose.positions, test::EngineStyleFor(threads)).ok());
    }
    ASSERT_TRUE(inst->FindContacts({}, DefaultParallelFor()).ok());
    EXPECT_SAME_CONTACTS(inst->contacts(), serial, "TBB");
  }
  EXPECT_GT(total, 0u);
}

TEST(NarrowPhase, CrowdEqualsInstancesRunAlone) {
  auto fc = test::LoadFitted("builtin");
  ASSERT_TRUE(fc);
  auto asset = CharacterAsset::Create(fc->set);
  ASSERT_TRUE(asset.ok());
  const std::vector<test::Pose> poses = RandomPoses(fc->character, 6, 60.0f, 7);
  for (RefitMode mode : {RefitMode::kExact, RefitMode::kFast}) {
    std::vector<CharacterInstance> crowd, alone;
    for (size_t k = 0; k < poses.size(); ++k) {
      crowd.push_back(CharacterInstance::Create(*asset).value());
      alone.push_back(CharacterInstance::Create(*asset).value());
    }
    std::vector<CharacterInstance*> pointers;
    std::vector<CharacterFrameInput> inputs;
    for (size_t k = 0; k < poses.size(); ++k) {
      pointers.push_back(&crowd[k]);
      inputs.push_back({poses[k].world, poses[k].positions});
    }
    for (int threads : {1, 2}) {
      ASSERT_TRUE(CrowdUpdateAndFindContacts(pointers, inputs, mode, test::EngineStyleFor(threads)).ok());
      for (size_t k = 0; k < poses.size(); ++k) {
        ASSERT_TRUE(alone[k].Update(mode, poses[k].world, poses[k].positions).ok());
        ASSERT_TRUE(alone[k]
                        .FindContacts(mode == RefitMode::kExact ? std::span<const Vector3f>(poses[k].positions)
                                                                : std::span<const Vector3f>())
                        .ok());
        EXPECT_SAME_CONTACTS(crowd[k].contacts(), alone[k].contacts(), "instance " << k);
      }
    }
  }
}

TEST(NarrowPhase, NoAllocationAfterWarmUp) {
  auto fc = test::LoadFitted("builtin");
  ASSERT_TRUE(fc);
  auto asset = CharacterAsset::Create(fc->set, NarrowPhaseSettings{0.005f});
  ASSERT_TRUE(asset.ok());
  auto inst = CharacterInstance::Create(*asset);
  const std::vector<test::Pose> poses = RandomPoses(fc->character, 6, 60.0f, 8);
  const ParallelFor threads = test::EngineStyleFor(1);  // a serial engine loop that allocates nothing
  // Warm-up: every pose once in each mode (the outputs reach their largest size).
  size_t contacts = 0;
  std::optional<test::AllocationCounter> counter;
  for (int round = 0; round < 2; ++round) {
    if (round == 1) counter.emplace();
    for (const test::Pose& pose : poses) {
      ASSERT_TRUE(inst->UpdateFast(pose.world).ok());
      ASSERT_TRUE(inst->FindContacts({}, threads).ok());
      contacts += inst->contacts().triangle_pairs.size();
      ASSERT_TRUE(inst->UpdateExact(pose.positions, pose.world).ok());
      ASSERT_TRUE(inst->FindContacts(pose.positions).ok());
    }
  }
  EXPECT_EQ(counter->count(), 0) << "the narrow phase allocated after warm-up";
  counter.reset();
  EXPECT_GT(contacts, 0u) << "the frames must have contacts for the check to mean anything";
}

// ------------------------------------------------------------------ set-up and rules

TEST(NarrowPhaseData, VersionOneSetsAreRefusedWithTheReason) {
  auto fc = test::LoadFitted("builtin");
  ASSERT_TRUE(fc);
  SphereSet v1 = fc->set;
  v1.source_file = "old.spheres.json";
  v1.mesh = {};
  v1.triangle_vertices.clear();
  auto filter = PairFilter::FromSphereSet(v1);
  ASSERT_TRUE(filter.ok());
  auto data = NarrowPhaseData::Create(v1, *filter);
  ASSERT_FALSE(data.ok());
  EXPECT_EQ(data.error().code, ErrorCode::kVersionMismatch);
  EXPECT_NE(data.error().message.find("old.spheres.json"), std::string::npos) << data.error().message;
  EXPECT_NE(data.error().message.find("version 1"), std::string::npos) << data.error().message;
  // The asset still works for the broad phase; FindContacts says why it cannot run.
  auto asset = CharacterAsset::Create(v1);
  ASSERT_TRUE(asset.ok());
  EXPECT_EQ((*asset)->narrow_phase(), nullptr);
  auto inst = CharacterInstance::Create(*asset);
  const auto pose = test::ClipPoses(fc->character, 1).front();
  ASSERT_TRUE(inst->UpdateFast(pose.world).ok());
  const FrameStatus st = inst->FindContacts();
  EXPECT_EQ(st.code, ErrorCode::kVersionMismatch);
  EXPECT_TRUE(inst->contacts().empty());
  // A negative margin is refused.
  EXPECT_FALSE(CharacterAsset::Create(fc->set, NarrowPhaseSettings{-1.0f}).ok());
  EXPECT_FALSE(CharacterAsset::Create(fc->set, NarrowPhaseSettings{NAN}).ok());
}

// A margin beyond kMaxMarginShareOfSize of the character's rest size (the largest extent of its
// mesh at rest, computed here independently) is refused naming that size; at the limit it is
// accepted and finds within-margin pairs.
TEST(NarrowPhaseData, MarginsBeyondAShareOfTheCharactersSizeAreRefused) {
  auto fc = test::LoadFitted("builtin");
  ASSERT_TRUE(fc);
  Eigen::AlignedBox3f box;
  for (const auto& p : fc->character.skin.positions_bind) box.extend(p);
  const float size = box.sizes().maxCoeff();
  ASSERT_GT(size, 1.0f);  // the built-in character is about 1.9 m tall
  auto filter = PairFilter::FromSphereSet(fc->set);
  ASSERT_TRUE(filter.ok());
  for (const float margin : {1e30f, 2.0f * kMaxMarginShareOfSize * size, 1.01f * kMaxMarginShareOfSize * size}) {
    auto data = NarrowPhaseData::Create(fc->set, *filter, NarrowPhaseSettings{margin});
    ASSERT_FALSE(data.ok()) << margin;
    EXPECT_EQ(data.error().code, ErrorCode::kInvalidArgument);
    EXPECT_NE(data.error().message.find("is more than 0.05 of the character's rest size"), std::string::npos)
        << data.error().message;
  }
  auto at_limit = CharacterAsset::Create(fc->set, NarrowPhaseSettings{0.99f * kMaxMarginShareOfSize * size});
  ASSERT_TRUE(at_limit.ok()) << at_limit.error().message;
  auto inst = CharacterInstance::Create(*at_limit);
  ASSERT_TRUE(inst.ok());
  size_t within = 0;
  for (const auto& pose : test::ClipPoses(fc->character, 4)) {
    ASSERT_TRUE(inst->UpdateFast(pose.world).ok());
    ASSERT_TRUE(inst->FindContacts().ok());
    for (const auto& t : inst->contacts().triangle_pairs) within += t.kind == TriangleContactKind::kWithinMargin;
  }
  EXPECT_GT(within, 0u);
}

TEST(NarrowPhase, ModeBNeedsJointMatricesAndFiniteInput) {
  auto fc = test::LoadFitted("builtin");
  ASSERT_TRUE(fc);
  auto asset = CharacterAsset::Create(fc->set);
  ASSERT_TRUE(asset.ok());
  auto inst = CharacterInstance::Create(*asset);
  const auto pose = RandomPoses(fc->character, 1, 60.0f, 9).front();
  ASSERT_TRUE(inst->UpdateExact(pose.positions, {}).ok());
  EXPECT_EQ(inst->FindContacts().code, ErrorCode::kInvalidArgument) << "no joints, no positions";
  EXPECT_TRUE(inst->FindContacts(pose.positions).ok());
  const std::vector<Vector3f> short_buffer(10, Vector3f::Zero());
  EXPECT_EQ(inst->FindContacts(short_buffer).code, ErrorCode::kInvalidArgument);
  // NaN positions: the job refuses the frame instead of answering from garbage.
  ASSERT_TRUE(inst->UpdateExact(pose.positions, pose.world).ok());
  std::vector<Vector3f> bad = pose.positions;
  for (auto& p : bad) p.x() = NAN;
  EXPECT_FALSE(inst->FindContacts(bad).ok());
  EXPECT_TRUE(inst->contacts().empty());
  // One non-finite coordinate, y or z, of one vertex of a sphere in a reported pair is enough.
  ASSERT_FALSE(inst->sphere_pairs().empty());
  const SphereSet& set = fc->set;
  const uint32_t s = inst->sphere_pairs().front().sphere_i;
  ASSERT_LT(set.triangle_offsets[s], set.triangle_offsets[s + 1]);
  const uint32_t v = set.triangle_vertices[3 * size_t{set.triangles[set.triangle_offsets[s]]} + 1];
  for (int axis : {1, 2}) {
    for (float value : {INFINITY, -INFINITY, NAN}) {
      std::vector<Vector3f> one = pose.positions;
      one[v][axis] = value;
      EXPECT_FALSE(inst->FindContacts(one).ok()) << "axis " << axis << ", " << value;
      EXPECT_TRUE(inst->FindContacts(pose.positions).ok());
    }
  }
}

}  // namespace
}  // namespace skinspheres::runtime
