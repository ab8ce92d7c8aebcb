// The broad phase's sweep (above kAllPairsMax spheres) on its hard cases, against the all-pairs
// and grid oracles: the direct sweep's output bound, spheres closer than their squares resolve, a
// space of characters at large coordinates and in a row along each axis, no allocation after a
// space's first frame, listed exclusions at every index distance, spheres changing strips, one
// context across filters and sizes, and 50,000 spheres with exclusions.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <span>
#include <vector>

#include "allocation_counter.h"
#include "runtime/broad_phase/broad_phase_oracles.h"
#include "runtime/broad_phase/random_sphere_sets.h"
#include "skinspheres/runtime/broad_phase/broad_phase.h"
#include "skinspheres/runtime/broad_phase/pair_filter.h"
#include "test_support.h"

namespace skinspheres::runtime {
namespace {

using Spheres = std::vector<skinspheres::Vec4f>;
using test::Combined;
using test::GridOracle;
using test::MakeFilter;
using test::Oracle;
using test::RandomParts;
using test::RandomSpheres;
using test::SupportedLevels;

TEST(BroadPhaseTest, DirectSweepOutputHoldsNoMoreThanTheContacts) {
  for (const SimdLevel level : SupportedLevels()) {
    Spheres line(600);
    for (size_t k = 0; k < line.size(); ++k) line[k] = {1e-25f * float(k), 0.0f, 0.0f, 0.0f};
    std::mt19937 rng(53);
    const PairFilter f = MakeFilter(line.size(), 0.3, rng);
    const std::vector<SpherePair> expected = Oracle(line, f);
    ASSERT_GT(expected.size(), 50 * line.size());
    BroadPhaseContext ctx(line.size());
    std::vector<SpherePair> out;
    out.reserve(expected.size());
    long allocations = 0;
    {
      test::AllocationCounter counter;
      ASSERT_TRUE((BroadPhaseJob{line, &f, &ctx, &out, level}.Run()));
      allocations = counter.count();
    }
    EXPECT_EQ(ctx.last_method(), BroadPhaseMethod::kSweepDirect) << ToString(level);
    EXPECT_EQ(out, expected) << ToString(level);
    EXPECT_EQ(allocations, 0) << ToString(level);
  }
}

TEST(BroadPhaseTest, SpheresCloserThanTheirSquaresResolveTouchOnEveryPath) {
  // Centres closer than about 2^-75 touch whatever their radii (the squares underflow to 0), so
  // the boxes and intervals the paths compare must be padded by more than that.
  for (const SimdLevel level : SupportedLevels()) {
    // 600 zero-radius spheres 1e-25 apart on a line: ~260 neighbours each touch, far more than
    // any cache holds, so the job sweeps straight into the output.
    Spheres line(600);
    for (size_t k = 0; k < line.size(); ++k) line[k] = {1e-25f * float(k), 0.0f, 0.0f, 0.0f};
    std::mt19937 rng(47);
    const PairFilter f = MakeFilter(line.size(), 0.0, rng);
    BroadPhaseContext ctx(line.size());
    std::vector<SpherePair> out;
    ASSERT_TRUE((BroadPhaseJob{line, &f, &ctx, &out, level}.Run()));
    EXPECT_EQ(ctx.last_method(), BroadPhaseMethod::kSweepDirect);
    const std::vector<SpherePair> expected = Oracle(line, f);
    EXPECT_GT(expected.size(), 100 * line.size());
    EXPECT_EQ(out, expected) << ToString(level);
    // Two characters whose only contact is two zero-radius spheres 1e-23 apart.
    Spheres two(600);
    for (size_t k = 0; k < 300; ++k) {
      two[k] = {k == 0 ? 0.0f : -float(k), 0.0f, 0.0f, k == 0 ? 0.0f : 0.1f};
      two[300 + k] = {k == 0 ? 1e-23f : float(k), 0.0f, 0.0f, k == 0 ? 0.0f : 0.1f};
    }
    const std::vector<PairFilter> members = {MakeFilter(300, 0.0, rng), MakeFilter(300, 0.0, rng)};
    const PairFilter space = Combined(members, {.pairs_within_members = false});
    BroadPhaseContext space_ctx(two.size());
    ASSERT_TRUE((BroadPhaseJob{two, &space, &space_ctx, &out, level}.Run()));
    EXPECT_EQ(space_ctx.last_method(), BroadPhaseMethod::kGroups);
    ASSERT_EQ(Oracle(two, space).size(), 1u);
    EXPECT_EQ(out, Oracle(two, space)) << ToString(level);
  }
}

TEST(BroadPhaseTest, ASpaceOfCharactersAtLargeCoordinatesAndInARowAlongEachAxis) {
  // Six characters of 150..400 spheres (2 wide) in a row along x, y or z (the sweep of their boxes
  // picks the axis), 2.4 apart, far from the origin, moving a little each frame.
  for (float offset : {0.0f, -3.0e4f}) {  // float steps of 0.002 there
    for (int axis = 0; axis < 3; ++axis) {
      std::mt19937 rng(unsigned(49 + axis));
      std::vector<PairFilter> members;
      Spheres all;
      for (int c = 0; c < 6; ++c) {
        const size_t n = 150 + 50 * size_t(c);
        Spheres s = RandomSpheres(n, 0, rng);
        for (auto& v : s) {
          v[axis] += 2.4f * float(c);
          v.head<3>() += Eigen::Vector3f::Constant(offset);
        }
        all.insert(all.end(), s.begin(), s.end());
        members.push_back(MakeFilter(n, 0.2, rng));
      }
      const PairFilter space = Combined(members, {true, true});
      BroadPhaseContext ctx(all.size());
      std::vector<SpherePair> out;
      size_t across = 0;
      for (int frame = 0; frame < 6; ++frame) {
        for (size_t k = 0; k < all.size(); ++k) all[k][(axis + 1) % 3] += (offset * 1e-7f + 0.01f) * float(k % 3);
        ASSERT_TRUE((BroadPhaseJob{all, &space, &ctx, &out}.Run()));
        ASSERT_EQ(out, Oracle(all, space)) << offset << " " << axis << " " << frame;
        ASSERT_EQ(ctx.last_method(), BroadPhaseMethod::kGroups) << offset << " " << axis << " " << frame;
        for (const SpherePair& c : out) across += space.group(c.sphere_i) != space.group(c.sphere_j) ? 1 : 0;
      }
      EXPECT_GT(across, 0u) << offset << " " << axis;
    }
  }
}

TEST(BroadPhaseTest, ASpaceOfCharactersAllocatesNothingAfterItsFirstFrame) {
  std::mt19937 rng(43);
  std::vector<PairFilter> members;
  Spheres all;
  for (int c = 0; c < 10; ++c) {
    Spheres s = RandomSpheres(100, 0, rng);
    for (auto& v : s) v.x() += 1.8f * float(c);
    all.insert(all.end(), s.begin(), s.end());
    members.push_back(MakeFilter(100, 0.2, rng));
  }
  const PairFilter space = Combined(members, {true, true});
  BroadPhaseContext ctx(all.size());
  std::vector<SpherePair> out;
  out.reserve(all.size() * 50);
  ASSERT_TRUE((BroadPhaseJob{all, &space, &ctx, &out}.Run()));
  ASSERT_EQ(ctx.last_method(), BroadPhaseMethod::kGroups);
  bool ok = true;
  long allocations = 0;
  int by_character = 0;
  {
    test::AllocationCounter counter;
    for (int frame = 0; frame < 30; ++frame) {
      for (auto& v : all) v.y() += (frame % 10 == 9 ? 0.3f : 0.001f) * float(frame % 5);
      ok &= BroadPhaseJob{all, &space, &ctx, &out}.Run();
      by_character += ctx.last_method() == BroadPhaseMethod::kGroups ? 1 : 0;
    }
    allocations = counter.count();
  }
  EXPECT_TRUE(ok);
  EXPECT_EQ(by_character, 30);
  EXPECT_EQ(allocations, 0);
  EXPECT_EQ(out, Oracle(all, space));
}

TEST(BroadPhaseTest, ListedExclusionsAtEveryIndexDistanceAreLeftOutByTheSweep) {
  // Every pair of a clump touches; the listed pairs sit at index distances on both sides of the
  // sweep's exclusion bits (|i - j| up to 256 on one side, 255 on the other) and far past them.
  const uint32_t n = 1100;
  std::mt19937 rng(77);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  Spheres s(n);
  for (auto& v : s) v = {u(rng), u(rng), u(rng), 1.0f};
  std::vector<ExcludedPair> pairs;
  for (uint32_t i = 0; i < n; ++i) {
    for (uint32_t d : {1u, 2u, 63u, 64u, 65u, 254u, 255u, 256u, 257u, 300u, 511u, 512u, 700u, 1099u}) {
      if (i + d >= n || (i + d) % 3 == 0) continue;
      const bool swap = (i + d) % 2 == 0;  // both orders of a listed pair
      pairs.push_back({swap ? i + d : i, swap ? i : i + d, ExclusionReason::kSameJoint});
    }
  }
  const PairFilter f = PairFilter::Create(n, {}, pairs).value();
  // The expected list, independently: every pair but the listed ones.
  std::set<std::pair<uint32_t, uint32_t>> listed;
  for (const auto& p : pairs) listed.insert({std::min(p.i, p.j), std::max(p.i, p.j)});
  std::vector<std::pair<uint32_t, uint32_t>> expected;
  for (uint32_t i = 0; i < n; ++i) {
    for (uint32_t j = i + 1; j < n; ++j) {
      if (!listed.count({i, j})) expected.push_back({i, j});
    }
  }
  for (auto level : SupportedLevels()) {
    BroadPhaseContext ctx(n, size_t{n} * n / 2);
    std::vector<SpherePair> out;
    BroadPhaseJob job{s, &f, &ctx, &out};
    job.simd = level;
    ASSERT_TRUE(job.Run());
    ASSERT_EQ(ctx.last_method(), BroadPhaseMethod::kSweepBuild) << ToString(ctx.last_method());
    ASSERT_EQ(out.size(), expected.size()) << ToString(level);
    for (size_t k = 0; k < out.size(); ++k) {
      ASSERT_EQ(std::make_pair(out[k].sphere_i, out[k].sphere_j), expected[k]) << k << " " << ToString(level);
    }
    EXPECT_EQ(out, Oracle(s, f));
  }
}

TEST(BroadPhaseTest, SpheresChangingStripsKeepTheSweepOrderWithoutAFullSort) {
  // A slab whose spheres swing across the strips by about a strip's width every frame (and
  // barely along the sweep axis), so many change strips at each build: the previous order still
  // serves.
  std::mt19937 rng(8);
  const size_t n = 6000;
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  Spheres base(n);
  for (auto& v : base) v = {60.0f * u(rng), 0.3f * u(rng), 40.0f * u(rng), 0.05f + 0.1f * u(rng)};
  const PairFilter f = MakeFilter(n, 0.0, rng);
  for (auto level : SupportedLevels()) {
    BroadPhaseContext ctx(n);
    std::vector<SpherePair> out;
    size_t builds = 0, full_sorts = 0;
    for (int frame = 0; frame < 40; ++frame) {
      Spheres s = base;
      for (size_t k = 0; k < n; ++k) {
        s[k].x() += 0.02f * std::sin(0.7f * float(frame) + float(k));
        s[k].z() += 0.4f * std::cos(0.7f * float(frame) + float(k));
      }
      BroadPhaseJob job{s, &f, &ctx, &out};
      job.simd = level;
      ASSERT_TRUE(job.Run());
      ASSERT_EQ(out, GridOracle(s, f)) << frame << " " << ToString(ctx.last_method());
      if (frame > 0 && ctx.last_method() == BroadPhaseMethod::kSweepBuild) {
        ++builds;
        full_sorts += ctx.last_full_sort() ? 1 : 0;
      }
    }
    // The first builds may still change the strip width while the skins settle (that sorts from
    // scratch by design); an insertion sort of whole strips overran its budget on every build here.
    EXPECT_GT(builds, 15u) << ToString(level);
    EXPECT_LE(full_sorts, builds / 4) << "of " << builds << " builds, " << ToString(level);
  }
}

TEST(BroadPhaseTest, OneContextAcrossFiltersAndSizesNeverUsesAnotherFiltersExclusions) {
  // The sweep's exclusion bits are made per filter and size: one context serves filter A, then
  // B (other listed pairs), then A again, then a smaller set, each checked against the oracle.
  std::mt19937 rng(31);
  const size_t n = 1500, m = 900;
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  Spheres s(n);
  for (auto& v : s) v = {3.0f * u(rng), 3.0f * u(rng), 0.2f * u(rng), 0.15f};  // ~6 contacts per sphere
  const Spheres small(s.begin(), s.begin() + m);
  const PairFilter a = MakeFilter(n, 0.2, rng);
  const PairFilter b = MakeFilter(n, 0.2, rng);
  const PairFilter c = MakeFilter(m, 0.2, rng);
  BroadPhaseContext ctx(n);
  std::vector<SpherePair> out;
  size_t sweeps = 0;
  const std::vector<std::pair<const Spheres*, const PairFilter*>> runs = {
      {&s, &a}, {&s, &b}, {&s, &a}, {&small, &c}, {&s, &b}};
  for (const auto& [set, filter] : runs) {
    ASSERT_TRUE((BroadPhaseJob{*set, filter, &ctx, &out}.Run()));
    ASSERT_EQ(out, Oracle(*set, *filter)) << ToString(ctx.last_method());
    sweeps += ctx.last_method() == BroadPhaseMethod::kSweepBuild ? 1 : 0;
  }
  EXPECT_EQ(sweeps, 5u);
  EXPECT_NE(Oracle(s, a), Oracle(s, b));  // the filters do differ where it shows
}

TEST(BroadPhaseTest, FiftyThousandSpheresWithExclusionsMatchAGridOracle) {
  // A slab of 50,000 spheres (a crowd's floor), each excluding its next eight by index.
  std::mt19937 rng(41);
  const uint32_t n = 50000;
  Spheres s(n);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  for (auto& v : s) v = {30.0f * u(rng), 30.0f * u(rng), 0.3f * u(rng), 0.02f + 0.06f * u(rng)};
  std::vector<ExcludedPair> pairs;
  for (uint32_t i = 0; i < n; ++i) {
    for (uint32_t d = 1; d <= 8 && i + d < n; ++d) pairs.push_back({i, i + d, ExclusionReason::kSameJoint});
  }
  const PairFilter f = PairFilter::Create(n, RandomParts(n, rng), pairs).value();
  const auto expected = GridOracle(s, f);
  ASSERT_GT(expected.size(), 15000u);
  BroadPhaseContext ctx(n);
  std::vector<SpherePair> out;
  for (int frame = 0; frame < 3; ++frame) {  // the same frame again: now from the cache
    ASSERT_TRUE((BroadPhaseJob{s, &f, &ctx, &out}.Run()));
    ASSERT_EQ(out, expected) << frame << " " << ToString(ctx.last_method());
  }
  // The grid oracle itself agrees with the O(n^2) loop on a part of the set.
  const Spheres part(s.begin(), s.begin() + 3000);
  const PairFilter f_part = PairFilter::Create(3000, {}, std::span(pairs).first(8 * 2990)).value();
  EXPECT_EQ(GridOracle(part, f_part), Oracle(part, f_part));
}

}  // namespace
}  // namespace skinspheres::runtime
