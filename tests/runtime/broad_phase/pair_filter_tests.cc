// Tests for pair_filter.h: which sphere pairs the broad phase may report (exclusions, parts), its
// storage growing with the exclusions (50,000 spheres), refusals, building it from a sphere set,
// combining several characters' filters into one space, and its identity.
#include <gtest/gtest.h>

#include <algorithm>
#include <random>
#include <set>
#include <utility>
#include <vector>

#include "runtime/broad_phase/random_sphere_sets.h"
#include "skinspheres/runtime/broad_phase/pair_filter.h"
#include "test_support.h"

namespace skinspheres::runtime {
namespace {

using test::MakeFilter;
using test::RandomExclusions;
using test::RandomParts;

TEST(PairFilterTest, ExclusionsPartsAndCount) {
  const std::vector<uint16_t> parts = {3, 1, 4, 1, 5};
  const std::vector<ExcludedPair> pairs = {{0, 2, ExclusionReason::kSameJoint},
                                           {4, 1, ExclusionReason::kAdjacentJoints},
                                           {2, 0, ExclusionReason::kBindOverlap}};  // duplicate
  auto f = PairFilter::Create(5, parts, pairs);
  ASSERT_TRUE(f.ok());
  EXPECT_EQ(f->size(), 5u);
  EXPECT_EQ(f->excluded_pair_count(), 2u);
  EXPECT_EQ(f->group_count(), 1u);
  for (uint32_t i = 0; i < 5; ++i) {
    EXPECT_EQ(f->part(i), parts[i]);
    EXPECT_EQ(f->group(i), 0u);
    for (uint32_t j = 0; j < 5; ++j) {
      const bool expected =
          i == j || (std::min(i, j) == 0 && std::max(i, j) == 2) || (std::min(i, j) == 1 && std::max(i, j) == 4);
      EXPECT_EQ(f->excluded(i, j), expected) << i << "," << j;
    }
  }
  EXPECT_EQ(std::vector<uint32_t>(f->excluded_partners(1).begin(), f->excluded_partners(1).end()),
            std::vector<uint32_t>{4});
}

TEST(PairFilterTest, ManyExclusionsMatchASetOfPairs) {
  std::mt19937 rng(7);
  auto pairs = RandomExclusions(200, 0.1, rng);
  auto f = PairFilter::Create(200, {}, pairs);
  ASSERT_TRUE(f.ok());
  EXPECT_EQ(f->excluded_pair_count(), pairs.size());
  std::vector<std::vector<bool>> expected(200, std::vector<bool>(200, false));
  for (const auto& p : pairs) expected[p.i][p.j] = expected[p.j][p.i] = true;
  for (uint32_t i = 0; i < 200; ++i) {
    EXPECT_EQ(f->part(i), 0);
    const auto row = f->excluded_partners(i);
    EXPECT_TRUE(std::is_sorted(row.begin(), row.end()));
    for (uint32_t j = 0; j < 200; ++j) ASSERT_EQ(f->excluded(i, j), i == j || expected[i][j]);
  }
}

TEST(PairFilterTest, StorageGrowsWithTheExclusionsAt50000Spheres) {
  // Every sphere excludes its next five: 250,000 pairs, stored as 500,000 partner entries.
  const uint32_t n = 50000;
  std::vector<ExcludedPair> pairs;
  for (uint32_t i = 0; i < n; ++i) {
    for (uint32_t d = 1; d <= 5 && i + d < n; ++d) pairs.push_back({i + d, i, ExclusionReason::kAdjacentJoints});
  }
  auto f = PairFilter::Create(n, {}, pairs);
  ASSERT_TRUE(f.ok()) << f.error().message;
  EXPECT_EQ(f->excluded_pair_count(), pairs.size());
  EXPECT_EQ(f->row_begin()[n], 2 * pairs.size());
  std::mt19937 rng(1);
  std::uniform_int_distribution<uint32_t> pick(0, n - 1), near(0, 7);
  for (int k = 0; k < 20000; ++k) {
    const uint32_t i = pick(rng), j = std::min(n - 1, i + near(rng));
    EXPECT_EQ(f->excluded(i, j), j - i <= 5) << i << "," << j;
    EXPECT_EQ(f->excluded(j, i), j - i <= 5);
  }
  EXPECT_FALSE(f->excluded(0, n - 1));
}

TEST(PairFilterTest, BadInputIsRefusedWithAMessage) {
  const std::vector<ExcludedPair> out_of_range = {{0, 5, ExclusionReason::kSameJoint}};
  auto a = PairFilter::Create(5, {}, out_of_range);
  ASSERT_FALSE(a.ok());
  EXPECT_EQ(a.error().code, ErrorCode::kInvalidArgument);
  EXPECT_NE(a.error().message.find("(0, 5)"), std::string::npos) << a.error().message;
  const std::vector<ExcludedPair> self = {{2, 2, ExclusionReason::kSameJoint}};
  EXPECT_FALSE(PairFilter::Create(5, {}, self).ok());
  const std::vector<uint16_t> parts = {0, 1};
  EXPECT_FALSE(PairFilter::Create(5, parts, {}).ok());
  EXPECT_FALSE(PairFilter::Create(PairFilter::kMaxSpheres + 1, {}, {}).ok());
}

TEST(PairFilterTest, FromSphereSet) {
  SphereSet set;
  set.source_file = "three.json";
  set.centers_rest = {{0, 0, 0}, {1, 0, 0}, {2, 0, 0}};
  set.radii_rest = {1, 1, 1};
  set.sphere_part = {0, 0, 2};
  set.excluded_pairs = {{0, 1, ExclusionReason::kSameJoint}};
  auto f = PairFilter::FromSphereSet(set);
  ASSERT_TRUE(f.ok());
  EXPECT_TRUE(f->excluded(1, 0));
  EXPECT_FALSE(f->excluded(1, 2));
  EXPECT_EQ(f->part(2), 2);

  set.excluded_pairs = {{0, 7, ExclusionReason::kSameJoint}};
  auto bad = PairFilter::FromSphereSet(set);
  ASSERT_FALSE(bad.ok());
  EXPECT_NE(bad.error().message.find("three.json"), std::string::npos) << bad.error().message;
  set.excluded_pairs.clear();
  set.sphere_part = {0};
  EXPECT_FALSE(PairFilter::FromSphereSet(set).ok());
}

TEST(PairFilterTest, CombineLaysMembersEndToEndWithTheirOwnRules) {
  std::mt19937 rng(11);
  std::vector<PairFilter> members;
  for (size_t n : {5, 0, 9, 4}) members.push_back(MakeFilter(n, 0.3, rng));
  std::vector<const PairFilter*> pointers;
  for (const auto& m : members) pointers.push_back(&m);
  for (bool within : {true, false}) {
    for (bool between : {true, false}) {
      auto c = PairFilter::Combine(pointers, {within, between});
      ASSERT_TRUE(c.ok()) << c.error().message;
      ASSERT_EQ(c->size(), 18u);
      ASSERT_EQ(c->group_count(), 4u);
      EXPECT_EQ(c->group_begin(0), 0u);
      EXPECT_EQ(c->group_begin(2), 5u);
      EXPECT_EQ(c->group_begin(3), 14u);
      EXPECT_EQ(c->group_begin(4), 18u);
      for (uint32_t i = 0; i < 18; ++i) {
        const uint32_t g = c->group(i), li = i - c->group_begin(g);
        EXPECT_EQ(c->part(i), members[g].part(li));
        for (uint32_t j = 0; j < 18; ++j) {
          const uint32_t h = c->group(j), lj = j - c->group_begin(h);
          const bool expected = i == j || (g == h ? (!within || members[g].excluded(li, lj)) : !between);
          ASSERT_EQ(c->excluded(i, j), expected) << i << "," << j << " within " << within << " between " << between;
        }
      }
    }
  }
  const std::vector<const PairFilter*> with_null = {&members[0], nullptr};
  EXPECT_FALSE(PairFilter::Combine(with_null, {}).ok());
  auto combined = PairFilter::Combine(pointers, {});
  const std::vector<const PairFilter*> nested = {&*combined};
  EXPECT_FALSE(PairFilter::Combine(nested, {}).ok());
}

TEST(PairFilterTest, IdentityFollowsTheContent) {
  std::mt19937 rng(3);
  PairFilter a = MakeFilter(10, 0.2, rng);
  PairFilter b = MakeFilter(10, 0.2, rng);
  EXPECT_NE(a.id(), 0u);
  EXPECT_NE(a.id(), b.id());
  const PairFilter copy = a;
  EXPECT_EQ(copy.id(), a.id());
  PairFilter moved = std::move(a);
  EXPECT_EQ(moved.id(), copy.id());
  EXPECT_EQ(a.size(), 0u);  // NOLINT(bugprone-use-after-move): a moved-from filter is empty
  EXPECT_EQ(a.id(), 0u);    // NOLINT(bugprone-use-after-move)
}

}  // namespace
}  // namespace skinspheres::runtime
