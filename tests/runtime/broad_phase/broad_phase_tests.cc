// Tests for broad_phase.h (pair_filter.h has its own, pair_filter_tests.cc): the self-collision query against the
// all-pairs oracle on random sets (touching spheres, identical centres, zero radii, dense clumps, large coordinates),
// frame sequences (the candidate cache under coherent, fast, rigid, growing and teleporting motion), every instruction
// set, several characters in one space (PairFilter::Combine), the shared characters' own clips, crowds at 1 and 2
// threads and on an engine-style loop, refusals, and no allocation per frame. The sweep's own cases are in
// sweep_tests.cc.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <limits>
#include <map>
#include <new>
#include <random>
#include <set>
#include <span>
#include <vector>

#include "allocation_counter.h"
#include "runtime/broad_phase/broad_phase_oracles.h"
#include "runtime/broad_phase/random_sphere_sets.h"
#include "runtime/posed_characters.h"
#include "skinspheres/runtime/api/character.h"
#include "skinspheres/runtime/broad_phase/broad_phase.h"
#include "skinspheres/runtime/broad_phase/pair_filter.h"
#include "skinspheres/skinning/local_to_model_job.h"
#include "skinspheres/skinning/sampling_job.h"
#include "test_support.h"

namespace skinspheres::runtime {
namespace {

using Spheres = std::vector<skinspheres::Vec4f>;
using test::Combined;
using test::GridOracle;
using test::kKinds;
using test::MakeFilter;
using test::Oracle;
using test::RandomSpheres;
using test::SupportedLevels;

// ------------------------------------------------------------------------------------------ oracle

TEST(BroadPhaseTest, OracleOnAHandMadeSet) {
  // 0-1 overlap by 0.5, 1-2 touch exactly, 2-3 excluded overlap, 0-3 apart.
  const Spheres s = {{0, 0, 0, 1}, {1.5f, 0, 0, 1}, {3.5f, 0, 0, 1}, {4, 0, 0, 1}};
  const std::vector<uint16_t> parts = {0, 1, 1, 2};
  const std::vector<ExcludedPair> pairs = {{2, 3, ExclusionReason::kSameJoint}};
  auto f = PairFilter::Create(4, parts, pairs);
  ASSERT_TRUE(f.ok());
  const auto c = Oracle(s, *f);
  ASSERT_EQ(c.size(), 2u);
  EXPECT_EQ(c[0], (SpherePair{0, 1, 0.5f, 0, 1}));
  EXPECT_EQ(c[1], (SpherePair{1, 2, 0.0f, 1, 1}));

  BroadPhaseContext ctx(4);
  std::vector<SpherePair> out;
  BroadPhaseJob job{s, &*f, &ctx, &out};
  ASSERT_TRUE(job.Run());
  EXPECT_EQ(out, c);
}

// ------------------------------------------------------------------------------- fast vs oracle

TEST(BroadPhaseTest, RandomSetsMatchAllPairsOnEveryInstructionSet) {
  const auto levels = SupportedLevels();
  ASSERT_FALSE(levels.empty());
  std::map<SimdLevel, BroadPhaseContext> shared;
  for (auto l : levels) shared[l].Resize(900);
  std::vector<SpherePair> out;
  size_t total_contacts = 0;
  std::set<BroadPhaseMethod> methods;
  for (int seed = 0; seed < 420; ++seed) {
    std::mt19937 rng(seed);
    const int kind = seed % kKinds;
    const size_t n = std::uniform_int_distribution<size_t>(0, seed % 10 == 0 ? 8 : seed % 7 == 3 ? 900 : 320)(rng);
    const Spheres s = RandomSpheres(n, kind, rng);
    const PairFilter f = MakeFilter(n, seed % 3 == 0 ? 0.0 : 0.2, rng);
    const auto expected = Oracle(s, f);
    total_contacts += expected.size();
    for (auto level : levels) {
      // A fresh context, one that has just held another set, and one with room for 8 candidates.
      BroadPhaseContext fresh(n), tiny(n, 8);
      for (BroadPhaseContext* c : {&fresh, &shared[level], &tiny}) {
        BroadPhaseJob job{s, &f, c, &out};
        job.simd = level;
        ASSERT_TRUE(job.Run()) << "seed " << seed;
        ASSERT_EQ(out, expected) << "seed " << seed << " kind " << kind << " n " << n << " " << ToString(level) << " "
                                 << ToString(c->last_method());
        methods.insert(c->last_method());
      }
    }
  }
  EXPECT_GT(total_contacts, 10000u);  // the sets do collide
  // Every way of answering was exercised.
  for (auto m : {BroadPhaseMethod::kAllPairsBuild, BroadPhaseMethod::kSweepBuild, BroadPhaseMethod::kAllPairsDirect,
                 BroadPhaseMethod::kSweepDirect}) {
    EXPECT_TRUE(methods.count(m)) << ToString(m);
  }
}

TEST(BroadPhaseTest, EveryContactIsRealAndEveryMissedPairIsApartOrExcluded) {
  // Independent of the shared arithmetic: double precision with a margin.
  std::mt19937 rng(99);
  const Spheres s = RandomSpheres(250, 0, rng);
  const PairFilter f = MakeFilter(250, 0.3, rng);
  BroadPhaseContext ctx(250);
  std::vector<SpherePair> out;
  ASSERT_TRUE((BroadPhaseJob{s, &f, &ctx, &out}.Run()));
  std::vector<std::vector<int>> found(250, std::vector<int>(250, 0));
  for (const SpherePair& c : out) {
    ASSERT_LT(c.sphere_i, c.sphere_j);
    found[c.sphere_i][c.sphere_j] = 1;
    EXPECT_FALSE(f.excluded(c.sphere_i, c.sphere_j));
    EXPECT_EQ(c.part_i, f.part(c.sphere_i));
    EXPECT_EQ(c.part_j, f.part(c.sphere_j));
    const double d = (s[c.sphere_i].head<3>().cast<double>() - s[c.sphere_j].head<3>().cast<double>()).norm();
    EXPECT_NEAR(c.depth, double(s[c.sphere_i].w()) + s[c.sphere_j].w() - d, 1e-5);
  }
  for (uint32_t i = 0; i < 250; ++i) {
    for (uint32_t j = i + 1; j < 250; ++j) {
      if (found[i][j] || f.excluded(i, j)) continue;
      const double d = (s[i].head<3>().cast<double>() - s[j].head<3>().cast<double>()).norm();
      EXPECT_GT(d, double(s[i].w()) + s[j].w() - 1e-5) << i << "," << j;
    }
  }
}

// --------------------------------------------------------------------------- frame sequences

enum class Motion { kCoherent, kFast, kWalk, kGrow, kTeleport };

// Frames of one set under a motion: the cache must give the oracle's answer on every frame.
void CheckSequence(size_t n, int kind, Motion motion, unsigned seed, size_t* cached_frames, size_t* frames) {
  std::mt19937 rng(seed);
  Spheres s = RandomSpheres(n, kind, rng);
  const PairFilter f = MakeFilter(n, 0.1, rng);
  std::vector<skinspheres::Vec4f> velocity(n);
  const float speed = motion == Motion::kFast ? 0.05f : 0.003f;
  std::normal_distribution<float> g(0.0f, speed);
  for (auto& v : velocity) v = {g(rng), g(rng), g(rng), 0.0f};
  BroadPhaseContext ctx(n);
  std::vector<SpherePair> out;
  for (int frame = 0; frame < 80; ++frame) {
    for (size_t k = 0; k < n; ++k) {
      s[k] += velocity[k];
      for (int a = 0; a < 3; ++a) {
        if (std::abs(s[k][a]) > 25.0f) velocity[k][a] = -velocity[k][a];
      }
      if (motion == Motion::kWalk) s[k] += skinspheres::Vec4f(0.11f, 0.0f, -0.07f, 0.0f);  // every sphere alike
      if (motion == Motion::kGrow) s[k].w() *= (frame % 20 < 10 ? 1.01f : 0.99f);
    }
    if (motion == Motion::kTeleport && frame % 30 == 29) std::shuffle(s.begin(), s.end(), rng);
    ASSERT_TRUE((BroadPhaseJob{s, &f, &ctx, &out}.Run()));
    ASSERT_EQ(out, n > 400 ? GridOracle(s, f) : Oracle(s, f))
        << "n " << n << " kind " << kind << " motion " << int(motion) << " frame " << frame << " "
        << ToString(ctx.last_method());
    *cached_frames += ctx.last_method() == BroadPhaseMethod::kCached ? 1 : 0;
    ++*frames;
  }
}

TEST(BroadPhaseTest, FrameSequencesMatchAllPairsEveryFrame) {
  size_t cached = 0, frames = 0;
  unsigned seed = 1000;
  for (size_t n : {12, 150, 700, 1500}) {
    for (int kind : {0, 4, 5}) {
      if (n == 1500 && kind != 5) continue;
      for (Motion m : {Motion::kCoherent, Motion::kFast, Motion::kWalk, Motion::kGrow, Motion::kTeleport}) {
        CheckSequence(n, kind, m, seed++, &cached, &frames);
        if (HasFatalFailure()) return;
      }
    }
  }
  // The cache serves a good share of these frames (most of the coherent ones).
  EXPECT_GT(cached, frames / 4) << cached << " of " << frames;
}

TEST(BroadPhaseTest, CoherentAndWalkingSetsKeepTheirCache) {
  for (bool walk : {false, true}) {
    std::mt19937 rng(walk ? 5 : 6);
    const size_t n = 600;
    Spheres s = RandomSpheres(n, 5, rng);
    const PairFilter f = MakeFilter(n, 0.05, rng);
    BroadPhaseContext ctx(n);
    std::vector<SpherePair> out;
    for (int frame = 0; frame < 100; ++frame) {
      for (size_t k = 0; k < n; ++k) {
        s[k].x() += 0.002f * std::sin(0.1f * float(frame) + float(k));
        if (walk) s[k].z() += 0.3f;  // a character walking 0.3 units a frame
      }
      ASSERT_TRUE((BroadPhaseJob{s, &f, &ctx, &out}.Run()));
      ASSERT_EQ(out, GridOracle(s, f)) << frame;
    }
    EXPECT_LE(ctx.build_count(), 34u) << (walk ? "walking" : "standing");
  }
}

TEST(BroadPhaseTest, AnotherFilterOfTheSameSizeIsNeverServedFromTheCache) {
  std::mt19937 rng(8);
  const Spheres s = RandomSpheres(200, 0, rng);
  PairFilter a = MakeFilter(200, 0.0, rng);
  const PairFilter b = MakeFilter(200, 0.5, rng);
  BroadPhaseContext ctx(200);
  std::vector<SpherePair> out;
  for (int k = 0; k < 3; ++k) ASSERT_TRUE((BroadPhaseJob{s, &a, &ctx, &out}.Run()));
  ASSERT_TRUE((BroadPhaseJob{s, &b, &ctx, &out}.Run()));
  EXPECT_EQ(out, Oracle(s, b));
  a = b;  // same object, new content
  ASSERT_TRUE((BroadPhaseJob{s, &a, &ctx, &out}.Run()));
  EXPECT_EQ(out, Oracle(s, b));
}

TEST(BroadPhaseTest, LargeCoordinatesAndTinyRadii) {
  for (float offset : {0.0f, 3.0e4f, 1.0e7f, 1.0e17f}) {
    std::mt19937 rng(21);
    Spheres s = RandomSpheres(400, 0, rng);
    for (auto& v : s) {
      v.head<3>() = v.head<3>() * (offset > 0 ? offset * 1e-6f + 1.0f : 1.0f) + Eigen::Vector3f::Constant(offset);
    }
    const PairFilter f = MakeFilter(400, 0.1, rng);
    BroadPhaseContext ctx(400);
    std::vector<SpherePair> out;
    for (int frame = 0; frame < 10; ++frame) {
      for (auto& v : s) v.x() += offset * 1e-7f;
      ASSERT_TRUE((BroadPhaseJob{s, &f, &ctx, &out}.Run()));
      ASSERT_EQ(out, Oracle(s, f)) << offset << " " << frame;
    }
  }
  std::mt19937 rng(22);
  Spheres tiny = RandomSpheres(300, 0, rng);
  for (auto& v : tiny) v *= 1e-30f;
  const PairFilter f = MakeFilter(300, 0.0, rng);
  BroadPhaseContext ctx(300);
  std::vector<SpherePair> out;
  ASSERT_TRUE((BroadPhaseJob{tiny, &f, &ctx, &out}.Run()));
  EXPECT_EQ(out, Oracle(tiny, f));
}

// ----------------------------------------------------------------------- several in one space

TEST(BroadPhaseTest, SeveralCharactersInOneSpaceMatchTheOracle) {
  // Eight "characters" of 40..300 spheres side by side, overlapping their neighbours.
  std::mt19937 rng(31);
  std::vector<PairFilter> members;
  Spheres all;
  for (int c = 0; c < 8; ++c) {
    const size_t n = 40 + 37 * size_t(c);
    Spheres s = RandomSpheres(n, 0, rng);
    for (auto& v : s) v.x() += 1.5f * float(c);
    all.insert(all.end(), s.begin(), s.end());
    members.push_back(MakeFilter(n, 0.3, rng));
  }
  for (bool between : {true, false}) {
    for (bool within : {true, false}) {
      const PairFilter space = Combined(members, {within, between});
      // The oracle from the members' own filters, independently of Combine.
      std::vector<SpherePair> expected;
      for (uint32_t i = 0; i < all.size(); ++i) {
        for (uint32_t j = i + 1; j < all.size(); ++j) {
          const uint32_t g = space.group(i), h = space.group(j);
          const bool allowed =
              g == h ? within && !members[g].excluded(i - space.group_begin(g), j - space.group_begin(h)) : between;
          const float dx = all[j].x() - all[i].x(), dy = all[j].y() - all[i].y(), dz = all[j].z() - all[i].z();
          const float d2 = (dx * dx + dy * dy) + dz * dz, rs = all[i].w() + all[j].w();
          if (allowed && d2 <= rs * rs) expected.push_back({i, j, rs - std::sqrt(d2), space.part(i), space.part(j)});
        }
      }
      EXPECT_EQ(Oracle(all, space), expected);
      BroadPhaseContext ctx(all.size());
      std::vector<SpherePair> out;
      for (int frame = 0; frame < 5; ++frame) {
        ASSERT_TRUE((BroadPhaseJob{all, &space, &ctx, &out}.Run()));
        ASSERT_EQ(out, expected) << "between " << between << " within " << within;
      }
      if (between && within) {
        size_t across = 0;
        for (const auto& c : out) across += space.group(c.sphere_i) != space.group(c.sphere_j) ? 1 : 0;
        EXPECT_GT(across, 0u);
      }
    }
  }
}

TEST(BroadPhaseTest, ASpaceOfCharactersRunsEachOnItsOwnCacheAndMatchesTheOracleEveryFrame) {
  // Twelve characters of 20..270 spheres, of every kind of set, laid 1.0 apart along x (their
  // sets are 2 wide, so neighbours interpenetrate), stepping a whole unit along x every 8 frames
  // and wiggling in between (the lattice and clump kinds keep exact coordinates, so pairs between
  // characters touch exactly). Checked every frame, on every instruction set, with pairs within
  // and between characters on and off.
  std::mt19937 rng(41);
  const size_t characters = 12;
  std::vector<PairFilter> members;
  std::vector<Spheres> bodies;
  for (size_t c = 0; c < characters; ++c) {
    const size_t n = 20 + (c * 53) % 251;
    const int kind = static_cast<int>(c % kKinds);
    bodies.push_back(RandomSpheres(n, kind == 4 ? 0 : kind, rng));  // kind 4 sits far away
    members.push_back(MakeFilter(n, 0.2, rng));
  }
  const auto frame_of = [&](int frame) {
    Spheres all;
    for (size_t c = 0; c < characters; ++c) {
      const float step = float(c) + float((frame / 8 + int(c)) % 3) - 1.0f;
      const int kind = static_cast<int>(c % kKinds);
      const bool exact = kind == 1 || kind == 2;
      for (size_t k = 0; k < bodies[c].size(); ++k) {
        Vec4f v = bodies[c][k];
        v.x() += step;
        if (!exact) v.y() += 0.002f * std::sin(0.3f * float(frame) + float(k));
        all.push_back(v);
      }
    }
    return all;
  };
  const size_t total = frame_of(0).size();
  ASSERT_GT(total, BroadPhaseContext::kAllPairsMax);
  const int frames = 30;
  for (bool between : {true, false}) {
    for (bool within : {true, false}) {
      const PairFilter space = Combined(members, {within, between});
      const std::vector<SimdLevel> levels = SupportedLevels();
      std::vector<BroadPhaseContext> contexts(levels.size());
      for (auto& c : contexts) c.Resize(total);
      // And a context with the least room for candidates: the pairs between characters go
      // through it in many chunks.
      BroadPhaseContext small(total, 1);
      size_t across = 0, within_count = 0;
      std::vector<SpherePair> out;
      for (int frame = 0; frame < frames; ++frame) {
        const Spheres all = frame_of(frame);
        const std::vector<SpherePair> expected = Oracle(all, space);
        for (size_t l = 0; l < levels.size(); ++l) {
          ASSERT_TRUE((BroadPhaseJob{all, &space, &contexts[l], &out, levels[l]}.Run()));
          ASSERT_EQ(out, expected) << "between " << between << " within " << within << " frame " << frame << " "
                                   << ToString(levels[l]);
          // (With no pair allowed at all the job answers before choosing a method.)
          ASSERT_EQ(contexts[l].last_method(), within || between ? BroadPhaseMethod::kGroups : BroadPhaseMethod::kNone);
        }
        ASSERT_TRUE((BroadPhaseJob{all, &space, &small, &out}.Run()));
        ASSERT_EQ(out, expected) << "least room, frame " << frame;
        for (const auto& c : out) (space.group(c.sphere_i) != space.group(c.sphere_j) ? across : within_count) += 1;
      }
      EXPECT_EQ(across > 0, between) << within;
      EXPECT_EQ(within_count > 0, within) << between;
      // Each character kept its own cache while only it wiggled: far fewer builds than one per
      // character and frame (a cache over the whole space would rebuild on every frame).
      if (within) {
        EXPECT_LT(contexts[0].build_count(), characters * frames / 3) << between;
      }
      // The same context then serves another filter of the same size (one group), and the space again.
      const PairFilter one = MakeFilter(total, 0.1, rng);
      const Spheres all = frame_of(frames);
      ASSERT_TRUE((BroadPhaseJob{all, &one, &contexts[0], &out}.Run()));
      EXPECT_EQ(out, Oracle(all, one));
      EXPECT_NE(contexts[0].last_method(), BroadPhaseMethod::kGroups);
      ASSERT_TRUE((BroadPhaseJob{all, &space, &contexts[0], &out}.Run()));
      EXPECT_EQ(out, Oracle(all, space));
    }
  }
}

TEST(BroadPhaseTest, ASpaceOfCharactersInOneClumpHasMoreContactsBetweenThemThanTheContextHolds) {
  // Three clumps of 200 spheres at one place: about 120,000 contacts between characters, more
  // than the n the context keeps for them, so they go straight to the output, which is sorted.
  std::mt19937 rng(45);
  std::vector<PairFilter> members;
  Spheres all;
  for (int c = 0; c < 3; ++c) {
    const Spheres s = RandomSpheres(200, 2, rng);
    all.insert(all.end(), s.begin(), s.end());
    members.push_back(MakeFilter(200, 0.3, rng));
  }
  const PairFilter space = Combined(members, {true, true});
  const std::vector<SpherePair> expected = Oracle(all, space);
  size_t across = 0;
  for (const auto& c : expected) across += space.group(c.sphere_i) != space.group(c.sphere_j) ? 1 : 0;
  ASSERT_GT(across, all.size());
  for (const SimdLevel level : SupportedLevels()) {
    BroadPhaseContext ctx(all.size());
    std::vector<SpherePair> out;
    // By character on the first frame; then, the pairs between characters being far more than 16
    // per sphere, as one set for 64 frames; then by character again, and so on.
    std::vector<int> by_character;
    for (int frame = 0; frame < 67; ++frame) {
      ASSERT_TRUE((BroadPhaseJob{all, &space, &ctx, &out, level}.Run()));
      ASSERT_EQ(out, expected) << ToString(level) << " " << frame;
      if (ctx.last_method() == BroadPhaseMethod::kGroups) by_character.push_back(frame);
    }
    EXPECT_EQ(by_character, (std::vector<int>{0, 65})) << ToString(level);
  }
}

// The direct sweep (a set above kAllPairsMax too dense for any cache) writes only the contacts the
// filter allows. With the output reserved for exactly the frame's contacts, the frame allocates
// nothing: the touching pairs that the filter lists (30% here) no longer pass through the output
// first (which made ReserveContacts / ReserveSpherePairs of the contact count not enough).
// ------------------------------------------------------------------------ real characters' clips

TEST(BroadPhaseTest, SharedCharactersClipsMatchAllPairsWithAndWithoutExclusions) {
  size_t tested = 0;
  for (const std::string& name : test::SharedCharacters()) {
    const std::filesystem::path path = test::Asset(name);
    if (path.empty()) continue;
    const auto fc = test::LoadFitted(name);
    ASSERT_TRUE(fc);
    const test::Character* ch = &fc->character;
    auto asset = CharacterAsset::Create(fc->set);
    ASSERT_TRUE(asset.ok());
    auto instance = CharacterInstance::Create(*asset);
    ASSERT_TRUE(instance.ok());
    const PairFilter& fitted = (*asset)->filter();
    const PairFilter none = PairFilter::Create(fitted.size(), fitted.parts(), {}).value();
    const skinning::AnimationClip& clip = ch->clips[0];
    std::vector<skinning::Transform> locals(ch->skeleton.size());
    std::vector<Mat4f> world(ch->skeleton.size());
    BroadPhaseContext with(fitted.size()), without(fitted.size());
    std::vector<SpherePair> out;
    for (int f = 0; f < 45; ++f) {
      const float t = float(f) / 30.0f;
      ASSERT_TRUE((skinning::SamplingJob{&clip, &ch->skeleton, skinning::LoopTime(t, clip.duration_s), locals}.Run()));
      skinning::LocalToModelJob l2m;
      l2m.skeleton = &ch->skeleton;
      l2m.input = locals;
      l2m.output = world;
      ASSERT_TRUE(l2m.Run());
      ASSERT_TRUE(instance->UpdateFast(world).ok());
      Spheres s(instance->spheres().begin(), instance->spheres().end());
      if (f >= 20) {  // then walking forward fast
        for (auto& v : s) v.z() += 0.05f * float(f - 20) * v.w() * 10.0f;
      }
      ASSERT_TRUE((BroadPhaseJob{s, &fitted, &with, &out}.Run()));
      ASSERT_EQ(out, Oracle(s, fitted)) << name << " frame " << f;
      ASSERT_TRUE((BroadPhaseJob{s, &none, &without, &out}.Run()));
      ASSERT_EQ(out, Oracle(s, none)) << name << " frame " << f << " without exclusions";
    }
    ++tested;
  }
  if (tested == 0) GTEST_SKIP() << "no shared character under " SKINSPHERES_ASSET_DIR;
}

// -------------------------------------------------------------------------------------- no allocation

TEST(BroadPhaseTest, NoAllocationAfterTheFirstFrames) {
  // A small set (all-pairs builds), a large one (sweep builds), a dense clump (direct paths).
  for (const auto& [n, kind] : std::vector<std::pair<size_t, int>>{{300, 0}, {2000, 5}, {200, 2}, {600, 2}}) {
    std::mt19937 rng(5);
    Spheres s = RandomSpheres(n, kind, rng);
    const PairFilter f = MakeFilter(n, 0.1, rng);
    BroadPhaseContext ctx(n);
    std::vector<SpherePair> out;
    out.reserve(n * n / 2);
    const auto* data_before = out.data();
    ASSERT_TRUE((BroadPhaseJob{s, &f, &ctx, &out}.Run()));
    bool ok = true;
    long allocations = 0;
    {
      test::AllocationCounter counter;
      for (int frame = 0; frame < 30; ++frame) {
        for (auto& v : s) v.x() += (frame % 10 == 9 ? 0.5f : 0.001f) * float(frame % 5);
        ok &= BroadPhaseJob{s, &f, &ctx, &out}.Run();
      }
      allocations = counter.count();
    }
    EXPECT_TRUE(ok);
    EXPECT_EQ(allocations, 0) << n << " " << kind;
    EXPECT_EQ(out.data(), data_before);
  }
}

// ------------------------------------------------------------------------------------------ crowd

TEST(BroadPhaseTest, CrowdIsIdenticalForAnyThreadsAndEqualsPerCharacterRuns) {
  const size_t characters = 60;
  std::vector<Spheres> spheres;
  std::vector<PairFilter> filters;
  for (size_t c = 0; c < characters; ++c) {
    std::mt19937 rng(static_cast<unsigned>(500 + c));
    const size_t n = 20 + (c * 37) % 700;
    spheres.push_back(RandomSpheres(n, static_cast<int>(c % kKinds), rng));
    filters.push_back(MakeFilter(n, 0.1, rng));
  }
  const auto run = [&](const ParallelFor& pf, int frames) {
    std::vector<BroadPhaseContext> contexts(characters);
    std::vector<std::vector<SpherePair>> outs(characters);
    std::vector<BroadPhaseJob> jobs(characters);
    for (size_t c = 0; c < characters; ++c) {
      contexts[c].Resize(spheres[c].size());
      jobs[c] = {spheres[c], &filters[c], &contexts[c], &outs[c]};
    }
    for (int k = 0; k < frames; ++k) EXPECT_TRUE(RunParallel(jobs, pf));
    return outs;
  };
  std::vector<std::vector<SpherePair>> one, two;
  test::WithDefaultThreads(1, [&] { one = run(DefaultParallelFor(), 3); });
  test::WithDefaultThreads(2, [&] { two = run(DefaultParallelFor(), 3); });
  ASSERT_EQ(one, two);
  EXPECT_EQ(run(SerialFor(), 2), one);
  EXPECT_EQ(run(test::EngineStyleFor(3), 2), one);
  size_t total = 0;
  for (size_t c = 0; c < characters; ++c) {
    ASSERT_EQ(one[c], Oracle(spheres[c], filters[c])) << "character " << c;
    total += one[c].size();
  }
  EXPECT_GT(total, 0u);

  // The serial range runner gives the same.
  std::vector<BroadPhaseContext> contexts(characters);
  std::vector<std::vector<SpherePair>> outs(characters);
  std::vector<BroadPhaseJob> jobs(characters);
  for (size_t c = 0; c < characters; ++c) {
    contexts[c].Resize(spheres[c].size());
    jobs[c] = {spheres[c], &filters[c], &contexts[c], &outs[c]};
  }
  EXPECT_TRUE(RunRange(jobs, 0, 30));
  EXPECT_TRUE(RunRange(jobs, 30, characters));
  EXPECT_EQ(outs, one);
  EXPECT_FALSE(RunRange(jobs, 10, characters + 1));
}

TEST(BroadPhaseTest, CrowdReportsAFailingCharacterAndRunsTheOthers) {
  std::mt19937 rng(3);
  Spheres good = RandomSpheres(50, 0, rng);
  Spheres bad = good;
  bad[7].w() = -1.0f;
  const PairFilter f = MakeFilter(50, 0.1, rng);
  BroadPhaseContext c0(50), c1(50);
  std::vector<SpherePair> o0, o1 = {SpherePair{}};
  const std::vector<BroadPhaseJob> jobs = {{good, &f, &c0, &o0}, {bad, &f, &c1, &o1}};
  EXPECT_FALSE(RunParallel(jobs));
  EXPECT_EQ(o0, Oracle(good, f));
  EXPECT_TRUE(o1.empty());
}

// -------------------------------------------------------------------------------------- refusals

TEST(BroadPhaseTest, ValidateRefusals) {
  EXPECT_FALSE(BroadPhaseJob{}.Validate());
  EXPECT_FALSE(BroadPhaseJob{}.Run());

  std::mt19937 rng(1);
  const Spheres s = RandomSpheres(10, 0, rng);
  const PairFilter f = MakeFilter(10, 0.1, rng);
  const PairFilter f9 = MakeFilter(9, 0.1, rng);
  BroadPhaseContext ctx(10), small(9);
  std::vector<SpherePair> out;
  EXPECT_TRUE((BroadPhaseJob{s, &f, &ctx, &out}.Validate()));
  EXPECT_FALSE((BroadPhaseJob{s, nullptr, &ctx, &out}.Validate()));
  EXPECT_FALSE((BroadPhaseJob{s, &f, nullptr, &out}.Validate()));
  EXPECT_FALSE((BroadPhaseJob{s, &f, &ctx, nullptr}.Validate()));
  EXPECT_FALSE((BroadPhaseJob{s, &f9, &ctx, &out}.Validate()));   // size mismatch
  EXPECT_FALSE((BroadPhaseJob{s, &f, &small, &out}.Validate()));  // context too small
  EXPECT_FALSE((BroadPhaseJob{s, &f, &small, &out}.Run()));
  for (auto level : {SimdLevel::kAuto, SimdLevel::kSse2, SimdLevel::kAvx2, SimdLevel::kAvx512, SimdLevel::kPortable}) {
    BroadPhaseJob job{s, &f, &ctx, &out};
    job.simd = level;
    EXPECT_EQ(job.Validate(), SimdLevelSupported(level)) << ToString(level);
  }
  const PairFilter empty;
  EXPECT_TRUE((BroadPhaseJob{{}, &empty, &small, &out}.Run()));
  EXPECT_TRUE(out.empty());
}

TEST(BroadPhaseTest, BadValuesAreRefusedAndClearTheOutput) {
  std::mt19937 rng(2);
  const PairFilter f = MakeFilter(40, 0.0, rng);
  const Spheres good = RandomSpheres(40, 1, rng);
  BroadPhaseContext ctx(40);
  std::vector<SpherePair> out;
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const float inf = std::numeric_limits<float>::infinity();
  ASSERT_TRUE((BroadPhaseJob{good, &f, &ctx, &out}.Run()));  // a cache to keep or drop
  for (int field = 0; field < 4; ++field) {
    // 3e38: finite, but c + r overflows to infinity (an interval end past every padding lane).
    for (float bad_value : {nan, inf, -inf, -0.5f, 3e38f, -3e38f}) {
      if (field < 3 && bad_value == -0.5f) continue;    // negative coordinates are fine
      if (field == 3 && bad_value == -3e38f) continue;  // (a negative radius is covered by -0.5)
      Spheres s = good;
      s[17][field] = bad_value;
      out.assign(3, SpherePair{});
      EXPECT_FALSE((BroadPhaseJob{s, &f, &ctx, &out}.Run())) << field << " " << bad_value;
      EXPECT_TRUE(out.empty());
      std::vector<SpherePair> oracle_out;
      EXPECT_FALSE(FindSpherePairsBruteForce(s, f, &oracle_out));
    }
  }
  // And the context still works afterwards.
  ASSERT_TRUE((BroadPhaseJob{good, &f, &ctx, &out}.Run()));
  EXPECT_EQ(out, Oracle(good, f));
}

}  // namespace
}  // namespace skinspheres::runtime
