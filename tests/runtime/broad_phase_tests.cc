// Tests for pair_filter.h and broad_phase.h: the sort-and-sweep self-collision query against the
// all-pairs oracle on random sets (touching spheres, identical centres, zero radii, coordinates
// shared on the sweep axis), frame sequences (the coherent insertion-sort path), crowds at 1 and 2
// threads, refusals, and no allocation per frame.
#include "skinspheres/runtime/broad_phase.h"

#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdlib>
#include <limits>
#include <new>
#include <random>
#include <vector>

#include "skinspheres/runtime/pair_filter.h"

// Allocation counter: every operator new in this executable goes through here; tests switch
// counting on around the calls that must not allocate. (GCC cannot see that the replaced new and
// delete pair malloc with free.)
#pragma GCC diagnostic ignored "-Wmismatched-new-delete"
namespace {
std::atomic<bool> g_count_allocations{false};
std::atomic<size_t> g_allocations{0};
}  // namespace

void* operator new(std::size_t size) {
  if (g_count_allocations.load(std::memory_order_relaxed)) g_allocations.fetch_add(1);
  if (void* p = std::malloc(size == 0 ? 1 : size)) return p;
  throw std::bad_alloc();
}
void operator delete(void* p) noexcept { std::free(p); }
void operator delete(void* p, std::size_t) noexcept { std::free(p); }
// The nothrow forms too (std::stable_sort's buffer uses them): every new/delete pair must match.
void* operator new(std::size_t size, const std::nothrow_t&) noexcept {
  if (g_count_allocations.load(std::memory_order_relaxed)) g_allocations.fetch_add(1);
  return std::malloc(size == 0 ? 1 : size);
}
void operator delete(void* p, const std::nothrow_t&) noexcept { std::free(p); }

namespace skinspheres::runtime {
namespace {

using Spheres = std::vector<skinspheres::Vec4f>;

// Random exclusions: each pair with probability p, listed in random order (i > j allowed).
std::vector<ExcludedPair> RandomExclusions(size_t n, double p, std::mt19937& rng) {
  std::vector<ExcludedPair> pairs;
  std::bernoulli_distribution pick(p), swap(0.5);
  for (uint32_t i = 0; i < n; ++i) {
    for (uint32_t j = i + 1; j < n; ++j) {
      if (!pick(rng)) continue;
      pairs.push_back(swap(rng) ? ExcludedPair{j, i, ExclusionReason::kBindOverlap}
                                : ExcludedPair{i, j, ExclusionReason::kSameJoint});
    }
  }
  std::shuffle(pairs.begin(), pairs.end(), rng);
  return pairs;
}

std::vector<uint16_t> RandomParts(size_t n, std::mt19937& rng) {
  std::uniform_int_distribution<int> part(0, 6);
  std::vector<uint16_t> parts(n);
  for (auto& p : parts) p = static_cast<uint16_t>(part(rng));
  return parts;
}

// Several kinds of random set, chosen by `kind`, to hit the edge cases of the sweep.
Spheres RandomSpheres(size_t n, int kind, std::mt19937& rng) {
  std::uniform_real_distribution<float> u(-1.0f, 1.0f), ur(0.0f, 0.3f);
  std::uniform_int_distribution<int> grid(-3, 3), coin(0, 3);
  Spheres s(n);
  for (size_t k = 0; k < n; ++k) {
    skinspheres::Vec4f& v = s[k];
    switch (kind) {
      case 0:  // uniform
        v = {u(rng), u(rng), u(rng), ur(rng)};
        break;
      case 1:  // integer lattice, radii 0, 0.5, 1: many exactly touching spheres, shared coordinates
        v = {float(grid(rng)), float(grid(rng)), float(grid(rng)), 0.5f * float(coin(rng) % 3)};
        break;
      case 2:  // a few identical centres, some zero radii
        v = {0.25f * float(coin(rng)), 0.5f, -0.125f * float(coin(rng)),
             coin(rng) == 0 ? 0.0f : 0.1f * float(coin(rng))};
        break;
      case 3:  // all centres on one plane x = 0.5 (coincident on that axis), thin in y
        v = {0.5f, 0.01f * u(rng), 4.0f * u(rng), 0.5f * ur(rng)};
        break;
      case 4:  // a long thin limb-like chain plus noise, large coordinates
        v = {1000.0f + 0.05f * float(k) + 0.01f * u(rng), -500.0f + 0.02f * u(rng),
             250.0f + 0.02f * u(rng), 0.04f + 0.02f * ur(rng)};
        break;
      default:  // sparse: few contacts
        v = {20.0f * u(rng), 20.0f * u(rng), 20.0f * u(rng), ur(rng)};
        break;
    }
  }
  return s;
}

PairFilter MakeFilter(size_t n, double p_exclude, std::mt19937& rng) {
  auto parts = RandomParts(n, rng);
  auto pairs = RandomExclusions(n, p_exclude, rng);
  auto filter = PairFilter::Create(n, parts, pairs);
  EXPECT_TRUE(filter.ok()) << (filter.ok() ? "" : filter.error().message);
  return std::move(filter).value();
}

std::vector<Contact> Oracle(const Spheres& s, const PairFilter& f) {
  std::vector<Contact> out;
  EXPECT_TRUE(SelfCollisionAllPairs(s, f, &out));
  return out;
}

// ------------------------------------------------------------------------------------------ filter

TEST(PairFilterTest, SymmetricBitsDiagonalPartsAndCount) {
  const std::vector<uint16_t> parts = {3, 1, 4, 1, 5};
  const std::vector<ExcludedPair> pairs = {{0, 2, ExclusionReason::kSameJoint},
                                           {4, 1, ExclusionReason::kAdjacentJoints},
                                           {2, 0, ExclusionReason::kBindOverlap}};  // duplicate
  auto f = PairFilter::Create(5, parts, pairs);
  ASSERT_TRUE(f.ok());
  EXPECT_EQ(f->size(), 5u);
  EXPECT_EQ(f->excluded_pair_count(), 2u);
  for (uint32_t i = 0; i < 5; ++i) {
    EXPECT_EQ(f->part(i), parts[i]);
    for (uint32_t j = 0; j < 5; ++j) {
      const bool expected = i == j || (std::min(i, j) == 0 && std::max(i, j) == 2) ||
                            (std::min(i, j) == 1 && std::max(i, j) == 4);
      EXPECT_EQ(f->excluded(i, j), expected) << i << "," << j;
    }
  }
}

TEST(PairFilterTest, RowsSpanSeveralWords) {
  std::mt19937 rng(7);
  auto pairs = RandomExclusions(200, 0.1, rng);
  auto f = PairFilter::Create(200, {}, pairs);
  ASSERT_TRUE(f.ok());
  EXPECT_EQ(f->words_per_row(), 4u);
  std::vector<std::vector<bool>> expected(200, std::vector<bool>(200, false));
  for (const auto& p : pairs) expected[p.i][p.j] = expected[p.j][p.i] = true;
  for (uint32_t i = 0; i < 200; ++i) {
    EXPECT_EQ(f->part(i), 0);
    for (uint32_t j = 0; j < 200; ++j) ASSERT_EQ(f->excluded(i, j), i == j || expected[i][j]);
  }
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
  EXPECT_EQ(c[0], (Contact{0, 1, 0.5f, 0, 1}));
  EXPECT_EQ(c[1], (Contact{1, 2, 0.0f, 1, 1}));

  BroadPhaseContext ctx(4);
  std::vector<Contact> out;
  SelfCollisionJob job{s, &*f, &ctx, &out};
  ASSERT_TRUE(job.Run());
  EXPECT_EQ(out, c);
}

// ------------------------------------------------------------------------------- fast vs oracle

TEST(BroadPhaseTest, RandomSetsMatchAllPairs) {
  BroadPhaseContext ctx(320);
  std::vector<Contact> out;
  size_t total_contacts = 0;
  for (int seed = 0; seed < 600; ++seed) {
    std::mt19937 rng(seed);
    const int kind = seed % 6;
    const size_t n = std::uniform_int_distribution<size_t>(0, seed % 10 == 0 ? 8 : 320)(rng);
    const Spheres s = RandomSpheres(n, kind, rng);
    const PairFilter f = MakeFilter(n, seed % 3 == 0 ? 0.0 : 0.2, rng);
    const auto expected = Oracle(s, f);
    total_contacts += expected.size();
    // A fresh context, and the shared one (which has just held another set).
    BroadPhaseContext fresh(n);
    for (BroadPhaseContext* c : {&fresh, &ctx}) {
      SelfCollisionJob job{s, &f, c, &out};
      ASSERT_TRUE(job.Run()) << "seed " << seed;
      ASSERT_EQ(out, expected) << "seed " << seed << " kind " << kind << " n " << n;
      ASSERT_LE(c->last_candidate_count(), n * (n ? n - 1 : 0) / 2);
    }
  }
  EXPECT_GT(total_contacts, 10000u);  // the sets do collide
}

TEST(BroadPhaseTest, EveryContactIsRealAndEveryMissedPairIsApartOrExcluded) {
  // Independent of the shared arithmetic: double precision with a margin.
  std::mt19937 rng(99);
  const Spheres s = RandomSpheres(250, 0, rng);
  const PairFilter f = MakeFilter(250, 0.3, rng);
  BroadPhaseContext ctx(250);
  std::vector<Contact> out;
  ASSERT_TRUE((SelfCollisionJob{s, &f, &ctx, &out}.Run()));
  std::vector<std::vector<int>> found(250, std::vector<int>(250, 0));
  for (const Contact& c : out) {
    ASSERT_LT(c.i, c.j);
    found[c.i][c.j] = 1;
    EXPECT_FALSE(f.excluded(c.i, c.j));
    EXPECT_EQ(c.part_i, f.part(c.i));
    EXPECT_EQ(c.part_j, f.part(c.j));
    const double d = (s[c.i].head<3>().cast<double>() - s[c.j].head<3>().cast<double>()).norm();
    EXPECT_NEAR(c.depth, double(s[c.i].w()) + s[c.j].w() - d, 1e-5);
  }
  for (uint32_t i = 0; i < 250; ++i) {
    for (uint32_t j = i + 1; j < 250; ++j) {
      if (found[i][j] || f.excluded(i, j)) continue;
      const double d = (s[i].head<3>().cast<double>() - s[j].head<3>().cast<double>()).norm();
      EXPECT_GT(d, double(s[i].w()) + s[j].w() - 1e-5) << i << "," << j;
    }
  }
}

// --------------------------------------------------------------------------- coherent frames

TEST(BroadPhaseTest, FrameSequenceMatchesAllPairsEveryFrame) {
  for (int seed = 0; seed < 6; ++seed) {
    std::mt19937 rng(1000 + seed);
    const size_t n = 150 + 30 * seed;
    Spheres s = RandomSpheres(n, 0, rng);
    const PairFilter f = MakeFilter(n, 0.1, rng);
    std::vector<skinspheres::Vec4f> velocity(n);
    std::normal_distribution<float> g(0.0f, 0.01f);
    for (auto& v : velocity) v = {g(rng), g(rng), g(rng), 0.0f};
    BroadPhaseContext ctx(n);
    std::vector<Contact> out;
    int full_sorts = 0;
    for (int frame = 0; frame < 300; ++frame) {
      for (size_t k = 0; k < n; ++k) {
        s[k] += velocity[k];
        for (int a = 0; a < 3; ++a) {
          if (std::abs(s[k][a]) > 1.0f) velocity[k][a] = -velocity[k][a];  // bounce in the box
        }
      }
      if (frame == 150) {  // a teleport: scrambles the order, the budget must fall back
        std::shuffle(s.begin(), s.end(), rng);
      }
      if (frame >= 200) {  // stretch along z so the variance axis changes (re-chosen periodically)
        for (auto& v : s) v.z() *= 1.02f;
      }
      ASSERT_TRUE((SelfCollisionJob{s, &f, &ctx, &out}.Run()));
      ASSERT_EQ(out, Oracle(s, f)) << "seed " << seed << " frame " << frame;
      full_sorts += ctx.last_full_sort() ? 1 : 0;
    }
    EXPECT_EQ(ctx.sweep_axis(), 2);
    EXPECT_LE(full_sorts, 6) << "the coherent path should serve almost every frame";
    EXPECT_GE(full_sorts, 2) << "first frame and the teleport sort fully";
  }
}

TEST(BroadPhaseTest, NoAllocationAfterTheFirstFrame) {
  std::mt19937 rng(5);
  const size_t n = 300;
  Spheres s = RandomSpheres(n, 0, rng);
  const PairFilter f = MakeFilter(n, 0.1, rng);
  BroadPhaseContext ctx(n);
  std::vector<Contact> out;
  out.reserve(n * 8);
  const auto* data_before = out.data();
  ASSERT_TRUE((SelfCollisionJob{s, &f, &ctx, &out}.Run()));
  ASSERT_GT(out.size(), 0u);
  g_allocations = 0;
  g_count_allocations = true;
  bool ok = true;
  for (int frame = 0; frame < 50; ++frame) {
    for (auto& v : s) v.x() += 0.001f * float(frame % 5);
    ok &= SelfCollisionJob{s, &f, &ctx, &out}.Run();
  }
  g_count_allocations = false;
  EXPECT_TRUE(ok);
  EXPECT_EQ(g_allocations.load(), 0u);
  EXPECT_EQ(out.data(), data_before);
}

// ------------------------------------------------------------------------------------------ crowd

TEST(BroadPhaseTest, CrowdIsIdenticalForOneAndTwoThreadsAndEqualsPerCharacterRuns) {
  const size_t characters = 60;
  std::vector<Spheres> spheres;
  std::vector<PairFilter> filters;
  for (size_t c = 0; c < characters; ++c) {
    std::mt19937 rng(static_cast<unsigned>(500 + c));
    const size_t n = 20 + (c * 37) % 280;
    spheres.push_back(RandomSpheres(n, static_cast<int>(c % 6), rng));
    filters.push_back(MakeFilter(n, 0.1, rng));
  }
  auto run = [&](int threads, int frames) {
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, threads);
    std::vector<BroadPhaseContext> contexts(characters);
    std::vector<std::vector<Contact>> outs(characters);
    std::vector<SelfCollisionJob> jobs(characters);
    for (size_t c = 0; c < characters; ++c) {
      contexts[c].Resize(spheres[c].size());
      jobs[c] = {spheres[c], &filters[c], &contexts[c], &outs[c]};
    }
    for (int k = 0; k < frames; ++k) EXPECT_TRUE(RunSelfCollisionJobs(jobs));
    return outs;
  };
  const auto one = run(1, 3);
  const auto two = run(2, 3);
  ASSERT_EQ(one, two);
  size_t total = 0;
  for (size_t c = 0; c < characters; ++c) {
    ASSERT_EQ(one[c], Oracle(spheres[c], filters[c])) << "character " << c;
    total += one[c].size();
  }
  EXPECT_GT(total, 0u);

  // The serial range runner gives the same.
  std::vector<BroadPhaseContext> contexts(characters);
  std::vector<std::vector<Contact>> outs(characters);
  std::vector<SelfCollisionJob> jobs(characters);
  for (size_t c = 0; c < characters; ++c) {
    contexts[c].Resize(spheres[c].size());
    jobs[c] = {spheres[c], &filters[c], &contexts[c], &outs[c]};
  }
  EXPECT_TRUE(RunSelfCollisionJobRange(jobs, 0, 30));
  EXPECT_TRUE(RunSelfCollisionJobRange(jobs, 30, characters));
  EXPECT_EQ(outs, one);
  EXPECT_FALSE(RunSelfCollisionJobRange(jobs, 10, characters + 1));
}

TEST(BroadPhaseTest, CrowdReportsAFailingCharacterAndRunsTheOthers) {
  std::mt19937 rng(3);
  Spheres good = RandomSpheres(50, 0, rng);
  Spheres bad = good;
  bad[7].w() = -1.0f;
  const PairFilter f = MakeFilter(50, 0.1, rng);
  BroadPhaseContext c0(50), c1(50);
  std::vector<Contact> o0, o1 = {Contact{}};
  const std::vector<SelfCollisionJob> jobs = {{good, &f, &c0, &o0}, {bad, &f, &c1, &o1}};
  EXPECT_FALSE(RunSelfCollisionJobs(jobs));
  EXPECT_EQ(o0, Oracle(good, f));
  EXPECT_TRUE(o1.empty());
}

// -------------------------------------------------------------------------------------- refusals

TEST(BroadPhaseTest, ValidateRefusals) {
  EXPECT_FALSE(SelfCollisionJob{}.Validate());
  EXPECT_FALSE(SelfCollisionJob{}.Run());

  std::mt19937 rng(1);
  const Spheres s = RandomSpheres(10, 0, rng);
  const PairFilter f = MakeFilter(10, 0.1, rng);
  const PairFilter f9 = MakeFilter(9, 0.1, rng);
  BroadPhaseContext ctx(10), small(9);
  std::vector<Contact> out;
  EXPECT_TRUE((SelfCollisionJob{s, &f, &ctx, &out}.Validate()));
  EXPECT_FALSE((SelfCollisionJob{s, nullptr, &ctx, &out}.Validate()));
  EXPECT_FALSE((SelfCollisionJob{s, &f, nullptr, &out}.Validate()));
  EXPECT_FALSE((SelfCollisionJob{s, &f, &ctx, nullptr}.Validate()));
  EXPECT_FALSE((SelfCollisionJob{s, &f9, &ctx, &out}.Validate()));    // size mismatch
  EXPECT_FALSE((SelfCollisionJob{s, &f, &small, &out}.Validate()));   // context too small
  EXPECT_FALSE((SelfCollisionJob{s, &f, &small, &out}.Run()));
  const PairFilter empty;
  EXPECT_TRUE((SelfCollisionJob{{}, &empty, &small, &out}.Run()));
  EXPECT_TRUE(out.empty());
}

TEST(BroadPhaseTest, BadValuesAreRefusedAndClearTheOutput) {
  std::mt19937 rng(2);
  const PairFilter f = MakeFilter(40, 0.0, rng);
  const Spheres good = RandomSpheres(40, 1, rng);
  BroadPhaseContext ctx(40);
  std::vector<Contact> out;
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const float inf = std::numeric_limits<float>::infinity();
  for (int field = 0; field < 4; ++field) {
    // 3e38: finite, but c + r overflows to infinity (an interval end past every padding lane).
    for (float bad_value : {nan, inf, -inf, -0.5f, 3e38f, -3e38f}) {
      if (field < 3 && bad_value == -0.5f) continue;  // negative coordinates are fine
      if (field == 3 && bad_value == -3e38f) continue;  // (a negative radius is covered by -0.5)
      Spheres s = good;
      s[17][field] = bad_value;
      out.assign(3, Contact{});
      EXPECT_FALSE((SelfCollisionJob{s, &f, &ctx, &out}.Run())) << field << " " << bad_value;
      EXPECT_TRUE(out.empty());
      std::vector<Contact> oracle_out;
      EXPECT_FALSE(SelfCollisionAllPairs(s, f, &oracle_out));
    }
  }
  // And the context still works afterwards.
  ASSERT_TRUE((SelfCollisionJob{good, &f, &ctx, &out}.Run()));
  EXPECT_EQ(out, Oracle(good, f));
}

}  // namespace
}  // namespace skinspheres::runtime
