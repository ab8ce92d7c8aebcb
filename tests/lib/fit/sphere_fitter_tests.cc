#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <algorithm>
#include <array>
#include <cstdio>
#include <limits>
#include <string>

#include "lib/analytic_shapes.h"
#include "skinspheres/lib/body_parts/body_parts.h"
#include "skinspheres/lib/character/builtin_character.h"
#include "skinspheres/lib/fit/sphere_fitter.h"
#include "skinspheres/runtime/format/sphere_set_io.h"

namespace skinspheres::lib {
namespace {

// Independent coverage oracle: each triangle owned by exactly one sphere, its three vertices inside,
// or cut (docs/TRIANGLE_PIECES.md) with each of its level² pieces owned once, the piece's corners
// (barycentric points taken here in double) inside its owner.
void ExpectEveryTriangleCovered(const RawCharacter& ch, const runtime::SphereSet& set) {
  std::vector<int> owners(ch.triangle_count(), 0);
  std::vector<std::vector<int>> piece_owners(ch.triangle_count());
  for (size_t s = 0; s < set.size(); ++s) {
    for (const runtime::TrianglePiece& p : set.PiecesOf(s)) {
      auto& seen = piece_owners[p.triangle];
      seen.resize(size_t{p.level} * p.level, 0);
      ++seen[p.index];
      uint8_t c[3][2];
      ASSERT_TRUE(runtime::PieceCorners(p.level, p.index, c));
      const Eigen::Vector3i& tri = ch.triangles[p.triangle];
      for (const auto& g : c) {
        const double l = p.level;
        const Eigen::Vector3d q =
            ((l - g[0] - g[1]) * ch.positions_rest[tri[0]].cast<double>() +
             g[0] * ch.positions_rest[tri[1]].cast<double>() + g[1] * ch.positions_rest[tri[2]].cast<double>()) /
            l;
        const Eigen::Vector3d centre = set.centers_rest[s].cast<double>();
        ASSERT_LE((q - centre).norm(), set.radii_rest[s] + 1e-6 * (set.radii_rest[s] + centre.norm()))
            << "piece " << p.index << " of triangle " << p.triangle << " sticks out of sphere " << s;
      }
    }
  }
  for (size_t t = 0; t < piece_owners.size(); ++t) {
    if (piece_owners[t].empty()) continue;
    for (size_t k = 0; k < piece_owners[t].size(); ++k) ASSERT_EQ(piece_owners[t][k], 1) << t << " piece " << k;
    owners[t] = 1;  // counted whole below would make it 2
  }
  for (size_t s = 0; s < set.size(); ++s) {
    for (uint32_t k = set.triangle_offsets[s]; k < set.triangle_offsets[s + 1]; ++k) {
      const uint32_t t = set.triangles[k];
      ++owners[t];
      for (int v = 0; v < 3; ++v) {
        const double d = (ch.positions_rest[ch.triangles[t][v]] - set.centers_rest[s]).cast<double>().norm();
        ASSERT_LE(d, set.radii_rest[s] * (1.0 + 1e-6)) << "triangle " << t << " sticks out of sphere " << s;
      }
      // The sphere's source vertices include the triangle's vertices.
      for (int v = 0; v < 3; ++v) {
        const auto first = set.vertices.begin() + set.vertex_offsets[s];
        const auto last = set.vertices.begin() + set.vertex_offsets[s + 1];
        ASSERT_TRUE(std::binary_search(first, last, static_cast<uint32_t>(ch.triangles[t][v])));
      }
    }
  }
  for (size_t t = 0; t < owners.size(); ++t) ASSERT_EQ(owners[t], 1) << "triangle " << t;
}

// The set's mesh (version 2) is the character's: same triangles, and skinning it at rest (in double,
// independently of the skinning library) gives the rest positions the spheres were fitted on.
void ExpectMeshReproducesTheRestPose(const RawCharacter& ch, const runtime::SphereSet& set) {
  ASSERT_TRUE(set.has_mesh());
  ASSERT_EQ(set.triangle_vertices.size(), 3 * ch.triangle_count());
  for (size_t t = 0; t < ch.triangle_count(); ++t) {
    for (int c = 0; c < 3; ++c) ASSERT_EQ(set.triangle_vertices[3 * t + c], static_cast<uint32_t>(ch.triangles[t][c]));
  }
  const auto& m = set.mesh;
  ASSERT_EQ(m.vertex_count(), ch.vertex_count());
  double extent = 0.0;
  for (const auto& p : ch.positions_rest) extent = std::max(extent, p.cast<double>().cwiseAbs().maxCoeff());
  for (size_t v = 0; v < m.vertex_count(); ++v) {
    Eigen::Vector4d p = Eigen::Vector4d::Zero();
    for (uint32_t k = m.influence_offsets[v]; k < m.influence_offsets[v + 1]; ++k) {
      const auto& b = m.binds[m.influence_binds[k]];
      p += m.influence_weights[k] * (set.joint_rest_world[b.joint].cast<double>() * b.inverse_bind.cast<double>() *
                                     m.positions_bind[v].cast<double>().homogeneous());
    }
    ASSERT_LE((p.head<3>() - ch.positions_rest[v].cast<double>()).norm(), 1e-5 * extent) << "vertex " << v;
  }
  EXPECT_FALSE(set.Validate().has_value());
}

FitResult Fit(const RawCharacter& ch, const BodyParts& parts, const FitSettings& settings) {
  auto r = FitSpheres(ch, parts, settings);
  EXPECT_TRUE(r.ok()) << (r.ok() ? "" : r.error().message);
  return r.ok() ? std::move(r).value() : FitResult{};
}

TEST(SphereFitterTest, CylinderIsCoveredByOneChainOfRoundSpheres) {
  RawCharacter ch = test::EllipticPrism(0.1f, 0.1f, 0.0f, 1.0f);
  BodyParts parts = test::MakeSinglePart(ch, 0.0f, 1.0f, PartKind::kChain);
  for (auto method : {SphereMethod::kM1, SphereMethod::kM2, SphereMethod::kM1A}) {
    FitSettings settings;
    settings.method = method;
    const FitResult fit = Fit(ch, parts, settings);
    ExpectEveryTriangleCovered(ch, fit.spheres);
    ExpectMeshReproducesTheRestPose(ch, fit.spheres);
    // A tube of radius R: spheres centred on the axis, radius >= R, and levels spaced by about
    // (1 - PD) * 2R: 1 / (1.4 * 0.1) ~ 7 levels plus the ends.
    ASSERT_GE(fit.spheres.size(), 6u);
    ASSERT_LE(fit.spheres.size(), 14u);
    for (size_t s = 0; s < fit.spheres.size(); ++s) {
      const auto& c = fit.spheres.centers_rest[s];
      EXPECT_LT(std::hypot(c.x(), c.z()), 0.01f) << ToString(method);
      EXPECT_GE(fit.spheres.radii_rest[s], 0.0999f);
      EXPECT_LT(fit.spheres.radii_rest[s], 0.16f);
    }
    // Ring contact points lie on the circle: F ~ 0.
    EXPECT_LT(fit.report.f_max, 0.003f) << ToString(method);
  }
}

TEST(SphereFitterTest, SphereMeshWithDegenerateTrianglesIsCovered) {
  RawCharacter ch = test::SphereMesh(0.5f, Eigen::Vector3f(0, 2, 0));
  BodyParts parts = test::MakeSinglePart(ch, 1.5f, 2.5f, PartKind::kChain);
  const FitResult fit = Fit(ch, parts, FitSettings{});
  ExpectEveryTriangleCovered(ch, fit.spheres);
  EXPECT_EQ(fit.report.triangles_covered, static_cast<int>(ch.triangle_count()));
  for (size_t s = 0; s < fit.spheres.size(); ++s)
    EXPECT_LE(fit.spheres.radii_rest[s], 0.5f * 1.3f);  // levels 1.4 r apart: the slab between grows a sphere
}

TEST(SphereFitterTest, EllipticPrismTwoAndFourSpheresPerLevelBeatOneOnMeanF) {
  RawCharacter ch = test::EllipticPrism(0.3f, 0.12f, 0.0f, 1.0f);
  BodyParts parts = test::MakeSinglePart(ch, 0.0f, 1.0f, PartKind::kTorso);
  for (auto method : {SphereMethod::kM1, SphereMethod::kM2, SphereMethod::kM1A}) {
    float f[5] = {};
    size_t count[5] = {};
    for (int p : {1, 2, 4}) {
      FitSettings settings;
      settings.tighten = false;  // the paper's spheres (§4.2-4.3): counts per level, not the pass
      settings.per_level = p;
      settings.method = method;
      const FitResult fit = Fit(ch, parts, settings);
      ExpectEveryTriangleCovered(ch, fit.spheres);
      f[p] = fit.report.f_mean;
      count[p] = fit.spheres.size();
    }
    EXPECT_LT(f[2], f[1]) << ToString(method);
    EXPECT_LT(f[4], f[1]) << ToString(method);
    EXPECT_GT(count[2], count[1]) << ToString(method);
  }
}

TEST(SphereFitterTest, M1AIsNoWorseThanM1OnTheEllipse) {
  RawCharacter ch = test::EllipticPrism(0.3f, 0.12f, 0.0f, 1.0f);
  BodyParts parts = test::MakeSinglePart(ch, 0.0f, 1.0f, PartKind::kTorso);
  FitSettings settings;
  settings.per_level = 2;
  settings.method = SphereMethod::kM1;
  const float m1 = Fit(ch, parts, settings).report.f_mean;
  settings.method = SphereMethod::kM1A;
  const float m1a = Fit(ch, parts, settings).report.f_mean;
  EXPECT_LE(m1a, m1 * 1.0001f);
}

TEST(SphereFitterTest, MoreOverlapGivesMoreLevels) {
  RawCharacter ch = test::EllipticPrism(0.1f, 0.1f, 0.0f, 1.0f);
  BodyParts parts = test::MakeSinglePart(ch, 0.0f, 1.0f, PartKind::kChain);
  FitSettings settings;
  settings.tighten = false;  // §4.3 levels, before the tightening pass re-splits them
  settings.overlap = 0.0f;
  const size_t loose = Fit(ch, parts, settings).spheres.size();
  settings.overlap = 0.6f;
  const size_t dense = Fit(ch, parts, settings).spheres.size();
  EXPECT_GT(dense, loose);
}

TEST(SphereFitterTest, SameOutputForOneAndTwoThreads) {
  RawCharacter ch = test::EllipticPrism(0.3f, 0.12f, 0.0f, 1.0f);
  BodyParts parts = test::MakeSinglePart(ch, 0.0f, 1.0f, PartKind::kTorso);
  std::string one, two;
  {
    tbb::global_control c(tbb::global_control::max_allowed_parallelism, 1);
    one = runtime::WriteSphereSetJson(Fit(ch, parts, FitSettings{}).spheres);
  }
  {
    tbb::global_control c(tbb::global_control::max_allowed_parallelism, 2);
    two = runtime::WriteSphereSetJson(Fit(ch, parts, FitSettings{}).spheres);
  }
  EXPECT_EQ(one, two);
}

TEST(SphereFitterTest, BadSettingsAreRefused) {
  RawCharacter ch = test::EllipticPrism(0.1f, 0.1f, 0.0f, 1.0f);
  BodyParts parts = test::MakeSinglePart(ch, 0.0f, 1.0f, PartKind::kChain);
  FitSettings s;
  s.per_level = 3;
  EXPECT_FALSE(FitSpheres(ch, parts, s).ok());
  s = FitSettings{};
  s.overlap = 1.0f;
  EXPECT_FALSE(FitSpheres(ch, parts, s).ok());
  s = FitSettings{};
  s.rays = 2;
  EXPECT_FALSE(FitSpheres(ch, parts, s).ok());
  s = FitSettings{};
  s.step = 0.0f;
  EXPECT_FALSE(FitSpheres(ch, parts, s).ok());
  s = FitSettings{};
  s.target_standoff = -0.01f;
  EXPECT_FALSE(FitSpheres(ch, parts, s).ok());
  s = FitSettings{};
  s.split_gain = std::numeric_limits<float>::quiet_NaN();
  EXPECT_FALSE(FitSpheres(ch, parts, s).ok());
  for (int rounds : {0, -1, 65}) {
    s = FitSettings{};
    s.split_rounds = rounds;
    auto fit = FitSpheres(ch, parts, s);
    ASSERT_FALSE(fit.ok());
    EXPECT_NE(fit.error().message.find("--split-rounds must be in 1..64"), std::string::npos) << fit.error().message;
  }
}

TEST(SphereFitterTest, HugeOrNonFinitePositionsAreRefusedByName) {
  for (float bad : {3e19f, std::numeric_limits<float>::infinity(), std::numeric_limits<float>::quiet_NaN()}) {
    RawCharacter ch = test::EllipticPrism(0.1f, 0.1f, 0.0f, 1.0f);
    BodyParts parts = test::MakeSinglePart(ch, 0.0f, 1.0f, PartKind::kChain);
    ch.positions_rest[7].x() = bad;
    const auto fit = FitSpheres(ch, parts, FitSettings{});
    ASSERT_FALSE(fit.ok());
    EXPECT_EQ(fit.error().code, ErrorCode::kInvalidData);
    EXPECT_NE(fit.error().message.find("vertex 7"), std::string::npos) << fit.error().message;
  }
}

TEST(SphereFitterTest, PartsThatDoNotPartitionTheMeshAreRefused) {
  RawCharacter ch = test::EllipticPrism(0.1f, 0.1f, 0.0f, 1.0f);
  BodyParts parts = test::MakeSinglePart(ch, 0.0f, 1.0f, PartKind::kChain);
  BodyParts twice = parts;
  twice.parts.push_back(parts.parts[0]);  // every triangle in two parts
  EXPECT_EQ(FitSpheres(ch, twice, FitSettings{}).error().code, ErrorCode::kInvalidData);
  BodyParts bad_joint = parts;
  bad_joint.triangle_joint[3] = 7;
  EXPECT_EQ(FitSpheres(ch, bad_joint, FitSettings{}).error().code, ErrorCode::kInvalidData);
  BodyParts bad_chain = parts;
  bad_chain.parts[0].chain.push_back(9);
  EXPECT_EQ(FitSpheres(ch, bad_chain, FitSettings{}).error().code, ErrorCode::kInvalidData);
}

TEST(SphereFitterTest, ExclusionsFollowTheSkeleton) {
  RawCharacter ch = test::EllipticPrism(0.1f, 0.1f, 0.0f, 1.0f);
  BodyParts parts = test::MakeSinglePart(ch, 0.0f, 1.0f, PartKind::kChain);
  const FitResult fit = Fit(ch, parts, FitSettings{});
  // One joint owns every triangle: every pair is a same-joint pair, and the rules are on triangles.
  EXPECT_EQ(fit.spheres.contact_rules, runtime::ContactRules::kTriangles);
  EXPECT_EQ(fit.spheres.contact_hops, 1u);
  const size_t n = fit.spheres.size();
  ASSERT_EQ(fit.spheres.excluded_pairs.size(), n * (n - 1) / 2);
  for (const auto& p : fit.spheres.excluded_pairs) EXPECT_EQ(p.reason, runtime::ExclusionReason::kSameJoint);
}

}  // namespace
}  // namespace skinspheres::lib

namespace skinspheres::lib {
namespace {

TEST(SphereFitterTest, TighteningKeepsCoverageAndTheSphereBudget) {
  // A long tube with a disk step as long as the tube: two levels, each sphere owning half the tube,
  // which the tightening pass cuts into rounder pieces.
  RawCharacter ch = test::EllipticPrism(0.1f, 0.1f, 0.0f, 2.0f);
  BodyParts parts = test::MakeSinglePart(ch, 0.0f, 2.0f, PartKind::kChain);
  FitSettings settings;
  settings.step = 1.0f;
  settings.tighten = false;
  const FitResult plain = Fit(ch, parts, settings);
  settings.tighten = true;
  settings.target_standoff = 0.0f;  // split while it pays
  settings.split_gain = 0.95f;
  settings.max_spheres = static_cast<int>(plain.spheres.size()) + 5;
  const FitResult split = Fit(ch, parts, settings);
  ExpectEveryTriangleCovered(ch, split.spheres);
  EXPECT_GT(split.spheres.size(), plain.spheres.size());
  EXPECT_LE(split.spheres.size(), plain.spheres.size() + 5);
  EXPECT_GT(split.report.spheres_split, 0);
  double v_plain = 0.0, v_split = 0.0;
  for (float r : plain.spheres.radii_rest) v_plain += double(r) * r * r;
  for (float r : split.spheres.radii_rest) v_split += double(r) * r * r;
  EXPECT_LT(v_split, v_plain);  // pieces of a long tube are much smaller balls
  EXPECT_LT(split.report.standoff_after, split.report.standoff_before);
  // split_gain 0 never splits; the centre search and hand-over still run.
  settings.split_gain = 0.0f;
  const FitResult unsplit = Fit(ch, parts, settings);
  EXPECT_EQ(unsplit.report.spheres_split, 0);
  EXPECT_LE(unsplit.spheres.size(), plain.spheres.size());
  ExpectEveryTriangleCovered(ch, unsplit.spheres);
}

// A tube whose sides are single triangles as long as the tube (two rings, eight segments): whole,
// every sphere holding one is at least half the tube long. Cut into pieces (piece_edge), the spheres
// hold pieces of them: each piece inside its owner (the independent oracle above), the set valid,
// its spheres' summed volume (r³) and the tightening pass's standoff estimate far below the whole
// fit's, the same set with 1 and 2 threads, and the report's triangle counts those of the input.
TEST(SphereFitterTest, TrianglePiecesLetSpheresHoldPartsOfLongTriangles) {
  RawCharacter ch = test::EllipticPrism(0.2f, 0.2f, 0.0f, 2.0f, 2, 8);
  BodyParts parts = test::MakeSinglePart(ch, 0.0f, 2.0f, PartKind::kChain);
  FitSettings settings;
  const FitResult whole = Fit(ch, parts, settings);
  ASSERT_FALSE(whole.spheres.has_pieces());
  settings.piece_edge = 0.05f;
  std::string one, two;
  FitResult cut;
  {
    tbb::global_control c(tbb::global_control::max_allowed_parallelism, 1);
    cut = Fit(ch, parts, settings);
    one = runtime::WriteSphereSetJson(cut.spheres);
  }
  {
    tbb::global_control c(tbb::global_control::max_allowed_parallelism, 2);
    two = runtime::WriteSphereSetJson(Fit(ch, parts, settings).spheres);
  }
  EXPECT_EQ(one, two);
  ASSERT_TRUE(cut.spheres.has_pieces());
  EXPECT_EQ(cut.spheres.Validate(), std::nullopt);
  ExpectEveryTriangleCovered(ch, cut.spheres);
  ExpectEveryTriangleCovered(ch, whole.spheres);
  double v_whole = 0.0, v_cut = 0.0;
  for (float r : whole.spheres.radii_rest) v_whole += double(r) * r * r;
  for (float r : cut.spheres.radii_rest) v_cut += double(r) * r * r;
  std::printf("tube: whole %zu spheres, sum r^3 %.4f, standoff %.4f; pieces %zu spheres, sum r^3 %.4f, standoff %.4f\n",
              whole.spheres.size(), v_whole, whole.report.standoff_after, cut.spheres.size(), v_cut,
              cut.report.standoff_after);
  EXPECT_LT(v_cut, 0.5 * v_whole);
  EXPECT_LT(cut.report.standoff_after, whole.report.standoff_after);
  // The per-part report counts the character's triangles (a cut one once), not the cut mesh's.
  for (const FitResult* fit : std::array<const FitResult*, 2>{&whole, &cut}) {
    int reported = 0;
    for (const PartFitReport& part : fit->report.parts) reported += part.triangles;
    EXPECT_EQ(reported, static_cast<int>(ch.triangle_count()));
  }
}

}  // namespace
}  // namespace skinspheres::lib

#include "skinspheres/lib/io/importer.h"
#include "test_support.h"

namespace skinspheres::lib {
namespace {

class SharedCharacterFit : public ::testing::TestWithParam<std::string> {};

// Every triangle covered, each owned once, and the same set with 1 and 2 threads.
TEST_P(SharedCharacterFit, CoversEveryTriangleAndIsThreadIndependent) {
  SKINSPHERES_REQUIRE_ASSET(path, GetParam());
  auto ch = ImportCharacter(path);
  ASSERT_TRUE(ch.ok()) << ch.error().message;
  auto parts = SplitBodyParts(*ch);
  ASSERT_TRUE(parts.ok()) << parts.error().message;
  std::string one, two;
  {
    tbb::global_control c(tbb::global_control::max_allowed_parallelism, 1);
    const FitResult fit = Fit(*ch, *parts, FitSettings{});
    ExpectEveryTriangleCovered(*ch, fit.spheres);
    ExpectMeshReproducesTheRestPose(*ch, fit.spheres);
    EXPECT_LE(fit.spheres.size(), 300u);
    one = runtime::WriteSphereSetJson(fit.spheres);
  }
  {
    tbb::global_control c(tbb::global_control::max_allowed_parallelism, 2);
    two = runtime::WriteSphereSetJson(Fit(*ch, *parts, FitSettings{}).spheres);
  }
  EXPECT_EQ(one, two);
}

INSTANTIATE_TEST_SUITE_P(Assets, SharedCharacterFit,
                         ::testing::Values("CesiumMan.glb", "RobotExpressive.glb", "Soldier.glb", "Xbot.glb"),
                         [](const auto& p) { return p.param.substr(0, p.param.find('.')); });

// FitSettings::group_blends (on by default) stores the reach groups' blends where they pay, which
// they do on the built-in character (its fast radii over eight fixed poses 0.991 of those without);
// off, the same set without them: every other array equal, the params saying so, and Validate()
// passing.
TEST(SphereFitterTest, GroupBlendsAreStoredUnlessTurnedOff) {
  const RawCharacter ch = MakeBuiltinCharacter();
  auto parts = SplitBodyParts(ch);
  ASSERT_TRUE(parts.ok());
  FitSettings settings;
  const FitResult with = Fit(ch, *parts, settings);
  ASSERT_FALSE(with.spheres.reach_group_blend.empty());
  EXPECT_EQ(with.spheres.reach_group_blend.size(), with.spheres.reach_group_weights.size());
  EXPECT_EQ(with.spheres.reach_group_deviation.size(), with.spheres.reach_group_weights.size());
  settings.group_blends = false;
  const FitResult without = Fit(ch, *parts, settings);
  EXPECT_TRUE(without.spheres.reach_group_blend.empty() && without.spheres.reach_group_deviation.empty());
  EXPECT_FALSE(without.spheres.Validate().has_value());
  runtime::SphereSet stripped = with.spheres;
  stripped.reach_group_blend.clear();
  stripped.reach_group_deviation.clear();
  stripped.params_json = without.spheres.params_json;
  EXPECT_EQ(runtime::WriteSphereSetJson(stripped), runtime::WriteSphereSetJson(without.spheres));
  EXPECT_NE(without.spheres.params_json.find("\"group_blends\":false"), std::string::npos)
      << without.spheres.params_json;
}

// --max-spheres is a budget: the built-in character's 70 spheres merge down to it, with or without
// the tightening pass, every triangle still inside its sphere; below the part count it is refused
// with a message naming both counts.
TEST(SphereFitterTest, TheSphereBudgetIsMetByMergingAndRefusedBelowThePartCount) {
  const RawCharacter ch = MakeBuiltinCharacter();
  auto parts = SplitBodyParts(ch);
  ASSERT_TRUE(parts.ok());
  FitSettings settings;
  const FitResult full = Fit(ch, *parts, settings);
  std::vector<uint16_t> used(full.spheres.sphere_part.begin(), full.spheres.sphere_part.end());
  std::sort(used.begin(), used.end());
  const int part_count = static_cast<int>(std::unique(used.begin(), used.end()) - used.begin());
  for (bool tighten : {true, false}) {
    for (int budget : {part_count, 25, static_cast<int>(full.spheres.size()) - 1}) {
      settings.tighten = tighten;
      settings.max_spheres = budget;
      const FitResult fit = Fit(ch, *parts, settings);
      EXPECT_LE(static_cast<int>(fit.spheres.size()), budget) << "tighten " << tighten;
      EXPECT_GT(fit.report.spheres_merged_for_budget, 0);
      ExpectEveryTriangleCovered(ch, fit.spheres);
      EXPECT_EQ(CountUncoveredTriangles(ch, fit.spheres), 0);
    }
  }
  settings.max_spheres = part_count - 1;
  auto refused = FitSpheres(ch, *parts, settings);
  ASSERT_FALSE(refused.ok());
  EXPECT_EQ(refused.error().code, ErrorCode::kInvalidArgument);
  EXPECT_NE(refused.error().message.find("max spheres " + std::to_string(part_count - 1) + " is below its " +
                                         std::to_string(part_count) + " body parts"),
            std::string::npos)
      << refused.error().message;
}

}  // namespace
}  // namespace skinspheres::lib
