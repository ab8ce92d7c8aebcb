// Tests for the broad phase on the workloads it is benchmarked on, and for characters sharing one
// space (PairFilter::Combine), each against an oracle that does not use the query:
// - the coherent cloud (spheres wiggling in a 1.8 x 1.8 x 0.3 box, small and large amplitude)
//   against the all-pairs loop on every frame and every instruction set;
// - constant density from 1,000 to 16,000 spheres: the counted work (pairs tested by the builds
//   plus candidates tested per frame) grows at most as n^1.2, and every checked frame equals a
//   grid oracle;
// - a crowd of the built-in character in one space: with pairs between characters off, exactly
//   each character's own all-pairs result (indices shifted); with them on, that plus a brute-force
//   loop over the pairs of two characters; while the characters walk and change pose;
// - 50,000 spheres of fitted characters in one space: the filter's storage is the listed
//   exclusions (not n^2) and the contacts equal the per-character oracle plus a grid oracle;
// - several spaces run by RunParallel on 1 and 2 TBB threads, an engine-style pool and
//   serially: identical contacts on every frame;
// - no allocation per frame once warmed up, for one space and for a crowd under TBB.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>
#include <vector>

#include "allocation_counter.h"
#include "runtime/broad_phase/broad_phase_oracles.h"
#include "runtime/posed_characters.h"
#include "skinspheres/runtime/api/character.h"
#include "skinspheres/runtime/broad_phase/broad_phase.h"
#include "skinspheres/runtime/broad_phase/pair_filter.h"

namespace skinspheres::runtime {
namespace {

using Spheres = std::vector<Vec4f>;

using test::ByPair;
using test::GridOracle;
using test::SupportedLevels;
using test::TestPair;

// The coherent cloud: std::mt19937 seed 3; per sphere in order x = sx U - sx/2, y = sy U,
// z = sz U - sz/2, r = 0.02 + 0.06 U; frame f moves sphere i by A (sin(0.05 f + i), cos(0.05 f + i))
// in x and y from where it was generated.
Spheres Cloud(size_t n, float sx, float sy, float sz) {
  std::mt19937 rng(3);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  Spheres s(n);
  for (auto& v : s) {
    const float x = sx * u(rng) - 0.5f * sx, y = sy * u(rng), z = sz * u(rng) - 0.5f * sz;
    v = Vec4f(x, y, z, 0.02f + 0.06f * u(rng));
  }
  return s;
}

Spheres CloudFrame(const Spheres& base, float amplitude, int frame) {
  Spheres s = base;
  for (size_t i = 0; i < s.size(); ++i) {
    const double phase = 0.05 * frame + double(i);
    s[i].x() = float(double(base[i].x()) + amplitude * std::sin(phase));
    s[i].y() = float(double(base[i].y()) + amplitude * std::cos(phase));
  }
  return s;
}

// ------------------------------------------------------------------------------------ workloads

TEST(BroadPhaseWorkloadTest, CoherentCloudMatchesAllPairsEveryFrame) {
  const auto levels = SupportedLevels();
  ASSERT_FALSE(levels.empty());
  for (size_t n : {150, 300, 1000}) {
    const Spheres base = Cloud(n, 1.8f, 1.8f, 0.3f);
    const PairFilter none = PairFilter::Create(n, {}, {}).value();
    for (float amplitude : {0.02f, 0.3f}) {
      std::vector<BroadPhaseContext> contexts(levels.size());
      for (auto& c : contexts) c.Resize(n);
      std::vector<SpherePair> out, expected;
      size_t cached = 0, contacts = 0;
      const int frames = 120;
      for (int f = 0; f < frames; ++f) {
        const Spheres s = CloudFrame(base, amplitude, f);
        ASSERT_TRUE(FindSpherePairsBruteForce(s, none, &expected));
        contacts += expected.size();
        for (size_t l = 0; l < levels.size(); ++l) {
          BroadPhaseJob job{s, &none, &contexts[l], &out};
          job.simd = levels[l];
          ASSERT_TRUE(job.Run());
          ASSERT_EQ(out, expected) << "n " << n << " amplitude " << amplitude << " frame " << f << " "
                                   << ToString(levels[l]) << " " << ToString(contexts[l].last_method());
          if (f >= frames / 2) cached += contexts[l].last_method() == BroadPhaseMethod::kCached ? 1 : 0;
        }
      }
      EXPECT_GT(contacts, size_t(frames) * n / 5) << n;  // the cloud collides: 0.25 to 2 contacts per sphere
      // Motion of a millimetre per frame: once the lookahead has adapted (second half), the cache
      // holds for most frames.
      if (amplitude < 0.1f) {
        EXPECT_GT(cached, levels.size() * frames / 2 * 3 / 4) << n;
      }
    }
  }
}

// Work counted by the query itself (pairs the builds tested plus candidates given the exact test),
// not time: deterministic, so it can be asserted.
TEST(BroadPhaseWorkloadTest, ConstantDensityWorkGrowsNearlyLinearly) {
  // The cloud's density (300 spheres in 1.8 x 1.8 x 0.3) in a slab growing in x and y. At every
  // instruction set: the counts depend on the vector width (a block sweep tests whole blocks), so
  // each level gets its own slope.
  const auto work_at = [](size_t n, SimdLevel level, std::vector<SpherePair>* last, Spheres* last_spheres,
                          const PairFilter& f) {
    const float side = 1.8f * std::sqrt(float(n) / 300.0f);
    const Spheres base = Cloud(n, side, side, 0.3f);
    BroadPhaseContext ctx(n);
    double work = 0.0;
    const int frames = 24;
    for (int k = 0; k < frames; ++k) {
      *last_spheres = CloudFrame(base, 0.02f, k);
      BroadPhaseJob job{*last_spheres, &f, &ctx, last};
      job.simd = level;
      EXPECT_TRUE(job.Run());
      work += double(ctx.last_build_tests()) + double(ctx.last_candidate_count());
    }
    return work / frames;
  };
  for (const SimdLevel level : test::SupportedLevels()) {
    std::vector<std::pair<size_t, double>> points;
    for (size_t n : {1000, 4000, 16000}) {
      const PairFilter none = PairFilter::Create(n, {}, {}).value();
      std::vector<SpherePair> out;
      Spheres s;
      points.emplace_back(n, work_at(n, level, &out, &s, none));
      ASSERT_EQ(out, GridOracle(s, none)) << n << " at " << ToString(level);
    }
    const double slope = std::log(points.back().second / points.front().second) /
                         std::log(double(points.back().first) / double(points.front().first));
    std::printf("%s: work per frame %.0f / %.0f / %.0f, slope %.3f\n", ToString(level), points[0].second,
                points[1].second, points[2].second, slope);
    EXPECT_LE(slope, 1.2) << ToString(level);
    EXPECT_GT(slope, 0.5) << ToString(level);  // and the counter does count the work (it grows with n)
  }
}

// ---------------------------------------------------------------------------- one space, crowds

struct Crowd {
  std::shared_ptr<const test::FittedCharacter> fitted;
  PairFilter member;           // the character's own filter (fitted exclusions and parts)
  std::vector<Spheres> poses;  // the character's spheres in a few poses
  float height = 0.0f;         // of the rest pose's spheres
};

const Crowd* BuiltinCrowd() {
  static Crowd crowd;
  if (!crowd.poses.empty()) return &crowd;
  crowd.fitted = test::LoadFitted("builtin");
  if (!crowd.fitted) return nullptr;
  auto asset = CharacterAsset::Create(crowd.fitted->set);
  EXPECT_TRUE(asset.ok());
  if (!asset.ok()) return nullptr;
  auto instance = CharacterInstance::Create(*asset);
  EXPECT_TRUE(instance.ok());
  if (!instance.ok()) return nullptr;
  crowd.member = (*asset)->filter();
  std::mt19937 rng(17);
  const test::Character& c = crowd.fitted->character;
  for (int p = 0; p < 6; ++p) {
    const auto local = p == 0 ? c.skeleton.rest_local : test::RandomLocal(c, rng, 50.0f, 0.0f);
    EXPECT_TRUE(instance->UpdateFast(test::WorldOf(c, local)).ok());
    crowd.poses.emplace_back(instance->spheres().begin(), instance->spheres().end());
  }
  float lo = 1e30f, hi = -1e30f;
  for (const auto& v : crowd.poses[0]) lo = std::min(lo, v.y() - v.w()), hi = std::max(hi, v.y() + v.w());
  crowd.height = hi - lo;
  EXPECT_GT(crowd.height, 0.0f);
  return &crowd;
}

// `count` characters on a square grid `spacing` body heights apart in x and z, character k in pose
// (k + frame / 3) % poses, walking in x at a speed of its own; laid end to end.
Spheres CrowdFrame(const Crowd& crowd, size_t count, float spacing, int frame) {
  const size_t side = size_t(std::ceil(std::sqrt(double(count))));
  const size_t m = crowd.poses[0].size();
  Spheres all(count * m);
  for (size_t k = 0; k < count; ++k) {
    const Spheres& pose = crowd.poses[(k + size_t(frame) / 3) % crowd.poses.size()];
    const float walk = 0.01f * float(k % 5) * crowd.height * float(frame);
    const Vec4f offset(spacing * crowd.height * float(k % side) + walk, 0.0f, spacing * crowd.height * float(k / side),
                       0.0f);
    for (size_t s = 0; s < m; ++s) all[k * m + s] = pose[s] + offset;
  }
  return all;
}

// Each character alone, by the all-pairs oracle with its own filter, indices shifted.
std::vector<SpherePair> EachAlone(const Spheres& all, const PairFilter& member, size_t count) {
  const size_t m = member.size();
  std::vector<SpherePair> expected, one;
  for (size_t k = 0; k < count; ++k) {
    const Spheres s(all.begin() + long(k * m), all.begin() + long((k + 1) * m));
    EXPECT_TRUE(FindSpherePairsBruteForce(s, member, &one));
    for (SpherePair c : one) {
      c.sphere_i += uint32_t(k * m);
      c.sphere_j += uint32_t(k * m);
      expected.push_back(c);
    }
  }
  return expected;
}

TEST(BroadPhaseSpaceTest, CrowdInOneSpaceIsEachAlonePlusThePairsBetween) {
  const Crowd* crowd = BuiltinCrowd();
  ASSERT_TRUE(crowd);
  const size_t count = 9, m = crowd->member.size();
  std::vector<const PairFilter*> members(count, &crowd->member);
  size_t between_seen = 0;
  for (bool between : {false, true}) {
    const PairFilter space = PairFilter::Combine(members, {.pairs_between_members = between}).value();
    ASSERT_EQ(space.size(), count * m);
    BroadPhaseContext ctx(space.size());
    std::vector<SpherePair> out;
    for (int frame = 0; frame < 40; ++frame) {
      const Spheres all = CrowdFrame(*crowd, count, 0.3f, frame);
      std::vector<SpherePair> expected = EachAlone(all, crowd->member, count);
      if (between) {  // every pair of spheres of two different characters, brute force
        for (uint32_t i = 0; i < all.size(); ++i) {
          for (uint32_t j = uint32_t((i / m + 1) * m); j < all.size(); ++j) TestPair(all, i, j, space, &expected);
        }
      }
      std::sort(expected.begin(), expected.end(), ByPair);
      ASSERT_TRUE((BroadPhaseJob{all, &space, &ctx, &out}.Run()));
      ASSERT_EQ(out, expected) << "between " << between << " frame " << frame << " " << ToString(ctx.last_method());
      for (const SpherePair& c : out) {
        ASSERT_EQ(space.group(c.sphere_i), c.sphere_i / m);
        between_seen += space.group(c.sphere_i) != space.group(c.sphere_j) ? 1 : 0;
      }
    }
  }
  EXPECT_GT(between_seen, 0u);  // the characters do touch each other
}

TEST(BroadPhaseSpaceTest, FiftyThousandSpheresOfCharactersInOneSpace) {
  const Crowd* crowd = BuiltinCrowd();
  ASSERT_TRUE(crowd);
  const size_t m = crowd->member.size();
  const size_t count = (50000 + m - 1) / m;
  std::vector<const PairFilter*> members(count, &crowd->member);
  const PairFilter space = PairFilter::Combine(members, {}).value();
  const size_t n = space.size();
  ASSERT_GE(n, 50000u);
  // Storage: one offset per sphere and two entries per listed exclusion, nothing per pair of spheres.
  ASSERT_GT(crowd->member.excluded_pair_count(), 0u);
  EXPECT_EQ(space.excluded_pair_count(), count * crowd->member.excluded_pair_count());
  EXPECT_EQ(space.row_begin()[n], 2 * space.excluded_pair_count());
  const size_t bytes = 4 * (n + 1) + 4 * space.row_begin()[n] + 2 * n + 4 * n;
  EXPECT_LT(bytes, 100 * n) << bytes;

  // The pairs between characters by a grid over a filter that allows only those; then each alone.
  const PairFilter only_between = PairFilter::Combine(members, {.pairs_within_members = false}).value();
  BroadPhaseContext ctx(n);
  std::vector<SpherePair> out;
  size_t across = 0;
  for (int frame : {0, 1, 2, 9}) {
    const Spheres all = CrowdFrame(*crowd, count, 0.3f, frame);
    std::vector<SpherePair> expected = EachAlone(all, crowd->member, count);
    const std::vector<SpherePair> between = GridOracle(all, only_between);
    across = between.size();
    expected.insert(expected.end(), between.begin(), between.end());
    std::sort(expected.begin(), expected.end(), ByPair);
    ASSERT_TRUE((BroadPhaseJob{all, &space, &ctx, &out}.Run()));
    ASSERT_EQ(out, expected) << "frame " << frame << " " << ToString(ctx.last_method());
  }
  EXPECT_GT(across, count);  // neighbours touch
}

// Several spaces of characters (different sizes and rules) as one crowd of jobs.
struct Spaces {
  std::vector<PairFilter> filters;
  std::vector<size_t> counts;
  std::vector<Spheres> spheres;  // this frame's
};

Spaces MakeSpaces(const Crowd& crowd) {
  Spaces sp;
  for (size_t k = 0; k < 7; ++k) {
    const size_t count = 1 + 5 * k;
    std::vector<const PairFilter*> members(count, &crowd.member);
    sp.filters.push_back(PairFilter::Combine(members, {.pairs_between_members = k % 3 != 1}).value());
    sp.counts.push_back(count);
  }
  sp.spheres.resize(sp.counts.size());
  return sp;
}

void SpacesFrame(const Crowd& crowd, int frame, Spaces* sp) {
  for (size_t k = 0; k < sp->counts.size(); ++k)
    sp->spheres[k] = CrowdFrame(crowd, sp->counts[k], 0.25f + 0.05f * k, frame);
}

TEST(BroadPhaseSpaceTest, SpacesAreIdenticalForAnyThreadCount) {
  const Crowd* crowd = BuiltinCrowd();
  ASSERT_TRUE(crowd);
  Spaces sp = MakeSpaces(*crowd);
  const size_t jobs_count = sp.counts.size();
  // One set of contexts and outputs per way of running, each kept across the frames.
  constexpr int kWays = 4;  // TBB on 1 thread, TBB on 2, an engine-style pool of 3, serial
  std::vector<std::vector<BroadPhaseContext>> contexts(kWays, std::vector<BroadPhaseContext>(jobs_count));
  std::vector<std::vector<std::vector<SpherePair>>> outs(kWays, std::vector<std::vector<SpherePair>>(jobs_count));
  for (auto& c : contexts) {
    for (size_t k = 0; k < jobs_count; ++k) c[k].Resize(sp.filters[k].size());
  }
  const ParallelFor engine = test::EngineStyleFor(3);
  for (int frame = 0; frame < 12; ++frame) {
    SpacesFrame(*crowd, frame, &sp);
    for (int way = 0; way < kWays; ++way) {
      std::vector<BroadPhaseJob> jobs(jobs_count);
      for (size_t k = 0; k < jobs_count; ++k)
        jobs[k] = {sp.spheres[k], &sp.filters[k], &contexts[way][k], &outs[way][k]};
      bool ok = false;
      if (way < 2) {
        test::WithDefaultThreads(way + 1, [&] { ok = RunParallel(jobs); });
      } else {
        ok = RunParallel(jobs, way == 2 ? engine : SerialFor());
      }
      ASSERT_TRUE(ok);
    }
    for (int way = 1; way < kWays; ++way) ASSERT_EQ(outs[way], outs[0]) << "way " << way << " frame " << frame;
    if (frame % 4 == 0) {
      for (size_t k = 0; k < jobs_count; ++k) {
        std::vector<SpherePair> expected;
        ASSERT_TRUE(FindSpherePairsBruteForce(sp.spheres[k], sp.filters[k], &expected));
        ASSERT_EQ(outs[0][k], expected) << "space " << k << " frame " << frame;
      }
    }
  }
}

TEST(BroadPhaseSpaceTest, NoAllocationPerFrameInOneSpaceOrACrowdOfSpaces) {
  const Crowd* crowd = BuiltinCrowd();
  ASSERT_TRUE(crowd);
  Spaces sp = MakeSpaces(*crowd);
  const size_t jobs_count = sp.counts.size();
  std::vector<BroadPhaseContext> contexts(jobs_count);
  std::vector<std::vector<SpherePair>> outs(jobs_count);
  std::vector<BroadPhaseJob> jobs(jobs_count);
  for (size_t k = 0; k < jobs_count; ++k) {
    contexts[k].Resize(sp.filters[k].size());
    outs[k].reserve(64 * sp.filters[k].size());
  }
  std::vector<std::vector<Spheres>> frames(30);  // precomputed: making a frame allocates
  for (int f = 0; f < 30; ++f) {
    SpacesFrame(*crowd, f, &sp);
    frames[f] = sp.spheres;
  }
  size_t contacts = 0;
  const auto run = [&](int first, int last) {
    bool ok = true;
    for (int f = first; f < last; ++f) {
      for (size_t k = 0; k < jobs_count; ++k) jobs[k] = {frames[f][k], &sp.filters[k], &contexts[k], &outs[k]};
      ok &= RunRange(jobs, 0, 1);  // a single character, then every space under TBB
      ok &= RunParallel(jobs);
      for (const auto& o : outs) contacts += o.size();
    }
    return ok;
  };
  long allocations = -1;
  test::WithDefaultThreads(2, [&] {
    ASSERT_TRUE(run(0, 3));  // warm-up: TBB's workers and the first builds
    test::AllocationCounter counter;
    ASSERT_TRUE(run(3, 30));
    allocations = counter.count();
  });
  EXPECT_EQ(allocations, 0);
  EXPECT_GT(contacts, 0u);
  // The counter does count.
  test::AllocationCounter counter;
  auto probe = std::make_unique<std::vector<int>>(10);
  EXPECT_GE(counter.count(), 1);
}

}  // namespace
}  // namespace skinspheres::runtime
