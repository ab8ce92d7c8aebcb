// The fitter's tightness targets, measured by lib/metrics/fit_metrics.h (an independent tool: voxel
// volumes and exact point-triangle distances) on the default fit of every character we have:
// at most 300 spheres, the union at most 2x the body's volume, the union's boundary on average
// within 1.5% of the body height, no triangle outside its sphere. RobotExpressive misses the
// boundary figure (docs/FIT_REPORT.md: its head is a box of triangles up to half the body height
// long, and a sphere holding one is at least a quarter of the height in radius); for it the test
// holds the tightening pass to a real improvement instead, so a regression still shows.
#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <string>

#include "skinspheres/lib/body_parts/body_parts.h"
#include "skinspheres/lib/character/builtin_character.h"
#include "skinspheres/lib/fit/sphere_fitter.h"
#include "skinspheres/lib/io/importer.h"
#include "skinspheres/lib/metrics/fit_metrics.h"
#include "skinspheres/runtime/format/sphere_set_io.h"
#include "test_support.h"

namespace skinspheres::lib {
namespace {

struct Measured {
  size_t spheres = 0;
  FitMetrics metrics;
  FitReport report;
};

Measured FitAndMeasure(const RawCharacter& ch, const FitSettings& settings, std::string* json = nullptr) {
  auto parts = SplitBodyParts(ch);
  EXPECT_TRUE(parts.ok());
  auto fit = FitSpheres(ch, *parts, settings);
  EXPECT_TRUE(fit.ok()) << fit.error().message;
  if (json) *json = runtime::WriteSphereSetJson(fit->spheres);
  auto m = MeasureFit(ch, fit->spheres);
  EXPECT_TRUE(m.ok()) << m.error().message;
  return {fit->spheres.size(), *m, fit->report};
}

Measured FitAndMeasure(const RawCharacter& ch, bool tighten) {
  FitSettings settings;
  settings.tighten = tighten;
  return FitAndMeasure(ch, settings);
}

void ExpectIssueTargets(const RawCharacter& ch, const std::string& name) {
  const Measured m = FitAndMeasure(ch, true);
  SCOPED_TRACE(name + ": " + std::to_string(m.spheres) + " spheres, volume x" + std::to_string(m.metrics.volume_ratio) +
               ", boundary " + std::to_string(100.0 * m.metrics.boundary_distance_mean_rel) + "% of height");
  EXPECT_LE(m.spheres, 300u);
  EXPECT_LE(m.metrics.volume_ratio, 2.0);
  EXPECT_EQ(m.metrics.uncovered_triangles, 0u);
  EXPECT_EQ(m.metrics.triangles_outside_owner, 0u);
  if (name == "RobotExpressive.glb") {
    const Measured paper = FitAndMeasure(ch, false);
    EXPECT_LT(m.metrics.boundary_distance_mean_rel, 0.8 * paper.metrics.boundary_distance_mean_rel);
    EXPECT_LT(m.metrics.volume_ratio, paper.metrics.volume_ratio);
  } else {
    EXPECT_LE(m.metrics.boundary_distance_mean_rel, 0.015);
  }
}

TEST(Tightness, BuiltinCharacterMeetsTheIssueTargets) { ExpectIssueTargets(MakeBuiltinCharacter(), "built-in"); }

// Split rounds (tighten/sphere_tightener.h): with no standoff target, the budget of 200 is what stops
// splitting. One greedy loop stops where no single split pays (the built-in character at 187
// spheres, 0.49%); further rounds, after the spheres have been searched, handed triangles and
// merged, split again. Measured by the independent evaluator: a tighter union at most 200 spheres,
// every triangle still inside its owner. `tighter` is the share of one round's mean standoff the
// rounds must reach (measured 0.78-0.82 on every character, 2026-12-06). The pass's own estimate
// never gets worse: a round that does not lower it is undone. Returns the rounds' fit.
Measured ExpectRoundsTighten(const RawCharacter& ch, const std::string& name, double tighter) {
  FitSettings settings;
  settings.target_standoff = 0.0f;
  settings.split_rounds = 1;
  const Measured one = FitAndMeasure(ch, settings);
  settings.split_rounds = 8;
  const Measured rounds = FitAndMeasure(ch, settings);
  SCOPED_TRACE(name + ": one round " + std::to_string(one.spheres) + " spheres, x" +
               std::to_string(one.metrics.volume_ratio) + ", " +
               std::to_string(100.0 * one.metrics.boundary_distance_mean_rel) + "%; rounds " +
               std::to_string(rounds.spheres) + " spheres, x" + std::to_string(rounds.metrics.volume_ratio) + ", " +
               std::to_string(100.0 * rounds.metrics.boundary_distance_mean_rel) + "%");
  EXPECT_LE(rounds.spheres, 200u);
  EXPECT_EQ(rounds.metrics.uncovered_triangles, 0u);
  EXPECT_EQ(rounds.metrics.triangles_outside_owner, 0u);
  EXPECT_LT(rounds.metrics.boundary_distance_mean_rel, tighter * one.metrics.boundary_distance_mean_rel);
  EXPECT_LT(rounds.metrics.volume_ratio, one.metrics.volume_ratio);
  EXPECT_EQ(one.report.split_rounds, 1);
  EXPECT_GT(rounds.report.split_rounds, 1);
  EXPECT_LE(rounds.report.split_rounds, 8);
  EXPECT_LT(rounds.report.standoff_after, one.report.standoff_after);
  return rounds;
}

TEST(Tightness, SplitRoundsTightenTheBuiltinCharacter) {
  const RawCharacter ch = MakeBuiltinCharacter();
  const Measured m = ExpectRoundsTighten(ch, "built-in", 0.85);
  // At that budget the built-in character meets issue 25's targets: union <= 1.35x, mean standoff
  // <= 0.6% of the height, at most 200 spheres (1.19x, 0.35% measured).
  EXPECT_LE(m.metrics.volume_ratio, 1.35);
  EXPECT_LE(m.metrics.boundary_distance_mean_rel, 0.006);
}

// The rounds are sequential: with several rounds run, the same set with 1 and 2 threads.
TEST(Tightness, SplitRoundsGiveTheSameSetForAnyThreadCount) {
  const RawCharacter ch = MakeBuiltinCharacter();
  FitSettings settings;
  settings.target_standoff = 0.0f;
  std::string one, two;
  Measured m;
  {
    tbb::global_control c(tbb::global_control::max_allowed_parallelism, 1);
    m = FitAndMeasure(ch, settings, &one);
  }
  {
    tbb::global_control c(tbb::global_control::max_allowed_parallelism, 2);
    FitAndMeasure(ch, settings, &two);
  }
  EXPECT_GT(m.report.split_rounds, 1);
  EXPECT_EQ(one, two);
}

// A fit that stops at its standoff target (the default settings) never runs a second round, so the
// rounds leave it as it was: the same set with 1 and 8 rounds allowed, and with 1 and 2 threads.
TEST(Tightness, SplitRoundsLeaveAFitThatReachedItsTargetAlone) {
  const RawCharacter ch = MakeBuiltinCharacter();
  FitSettings settings;
  settings.split_rounds = 1;
  std::string one, eight, eight_two_threads;
  FitAndMeasure(ch, settings, &one);
  settings.split_rounds = 8;
  {
    tbb::global_control c(tbb::global_control::max_allowed_parallelism, 1);
    FitAndMeasure(ch, settings, &eight);
  }
  {
    tbb::global_control c(tbb::global_control::max_allowed_parallelism, 2);
    FitAndMeasure(ch, settings, &eight_two_threads);
  }
  // The settings are written into the file (the flat object "params"): compare all but them.
  auto without_params = [](std::string json) {
    const size_t at = json.find("\"params\":{");
    if (at != std::string::npos) json.erase(at, json.find('}', at) + 1 - at);
    return json;
  };
  ASSERT_NE(without_params(one), one);
  EXPECT_EQ(without_params(one), without_params(eight));
  EXPECT_EQ(eight, eight_two_threads);
}

class SharedTightness : public ::testing::TestWithParam<std::string> {};

TEST_P(SharedTightness, MeetsTheIssueTargets) {
  SKINSPHERES_REQUIRE_ASSET(path, GetParam());
  auto ch = ImportCharacter(path);
  ASSERT_TRUE(ch.ok()) << ch.error().message;
  ExpectIssueTargets(*ch, GetParam());
}

TEST_P(SharedTightness, SplitRoundsTighten) {
  SKINSPHERES_REQUIRE_ASSET(path, GetParam());
  auto ch = ImportCharacter(path);
  ASSERT_TRUE(ch.ok()) << ch.error().message;
  ExpectRoundsTighten(*ch, GetParam(), 0.85);
}

std::string CharacterName(const ::testing::TestParamInfo<std::string>& param) {
  return param.param.substr(0, param.param.find('.'));
}
INSTANTIATE_TEST_SUITE_P(Assets, SharedTightness, ::testing::ValuesIn(test::SharedCharacters()), CharacterName);

}  // namespace
}  // namespace skinspheres::lib
