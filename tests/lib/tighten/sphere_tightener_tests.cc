#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <random>

#include "lib/analytic_shapes.h"
#include "skinspheres/lib/body_parts/body_parts.h"
#include "skinspheres/lib/character/builtin_character.h"
#include "skinspheres/lib/fit/sphere_fitter.h"
#include "skinspheres/lib/geometry/enclosing_sphere.h"
#include "skinspheres/lib/geometry/mesh_helpers.h"
#include "skinspheres/lib/metrics/fit_metrics.h"
#include "skinspheres/lib/tighten/sphere_tightener.h"

namespace skinspheres::lib {
namespace {

// The fitter's spheres before the tightening pass (paper + ownership + refine), as its input.
std::vector<TightSphere> Untightened(const RawCharacter& ch, const BodyParts& parts) {
  FitSettings settings;
  settings.tighten = false;
  auto fit = FitSpheres(ch, parts, settings);
  EXPECT_TRUE(fit.ok()) << fit.error().message;
  std::vector<TightSphere> out;
  const auto& set = fit->spheres;
  for (size_t s = 0; s < set.size(); ++s) {
    TightSphere t;
    t.center = set.centers_rest[s];
    t.radius = set.radii_rest[s];
    t.reference_radius = set.radii_rest[s];
    t.part = set.sphere_part[s];
    t.origin = static_cast<uint32_t>(s);
    t.triangles.assign(set.triangles.begin() + set.triangle_offsets[s],
                       set.triangles.begin() + set.triangle_offsets[s + 1]);
    out.push_back(std::move(t));
  }
  return out;
}

// Independent oracle: every triangle owned by exactly one sphere, of the triangle's own part, its
// three vertices inside (double), and each radius no larger than needed (the holding radius).
void ExpectExactOwnership(const RawCharacter& ch, const BodyParts& parts, const std::vector<TightSphere>& spheres) {
  std::vector<int> owners(ch.triangle_count(), 0);
  for (const auto& s : spheres) {
    ASSERT_FALSE(s.triangles.empty());
    EXPECT_TRUE(std::is_sorted(s.triangles.begin(), s.triangles.end()));
    double farthest = 0.0;
    for (uint32_t t : s.triangles) {
      ++owners[t];
      EXPECT_EQ(parts.triangle_part[t], s.part) << "triangle " << t << " left its part";
      for (int v = 0; v < 3; ++v) {
        const double d = (ch.positions_rest[ch.triangles[t][v]].cast<double>() - s.center.cast<double>()).norm();
        EXPECT_LE(d, double(s.radius)) << "triangle " << t << " sticks out";
        farthest = std::max(farthest, d);
      }
    }
    EXPECT_LE(double(s.radius), farthest * (1.0 + 1e-6) + 1e-12);
  }
  for (size_t t = 0; t < owners.size(); ++t) ASSERT_EQ(owners[t], 1) << "triangle " << t;
}

FitMetrics Measure(const RawCharacter& ch, const std::vector<TightSphere>& spheres) {
  std::vector<Eigen::Vector3f> c;
  std::vector<float> r;
  for (const auto& s : spheres) c.push_back(s.center), r.push_back(s.radius);
  FitMetricsInput in;
  in.positions = ch.positions_rest;
  in.triangles = ch.triangles;
  in.centers = c;
  in.radii = r;
  auto m = MeasureFit(in);
  EXPECT_TRUE(m.ok());
  return *m;
}

class TightenBuiltin : public ::testing::Test {
 protected:
  void SetUp() override {
    auto p = SplitBodyParts(ch_);
    ASSERT_TRUE(p.ok());
    parts_ = *p;
    input_ = Untightened(ch_, parts_);
  }
  RawCharacter ch_ = MakeBuiltinCharacter();
  BodyParts parts_;
  std::vector<TightSphere> input_;
};

TEST_F(TightenBuiltin, KeepsOwnershipExactAndTightensTheUnionAsMeasured) {
  std::vector<TightSphere> out = input_;
  TightenSettings settings;
  settings.target_standoff = 0.0f;  // split while it pays, up to the budget
  settings.max_spheres = static_cast<int>(input_.size()) + 40;
  const TightenReport rep = TightenSpheres(ch_, settings, &out);
  ExpectExactOwnership(ch_, parts_, out);
  EXPECT_LE(out.size(), input_.size() + 40);
  EXPECT_GT(rep.splits, 0);
  EXPECT_LT(rep.exposure_after, rep.exposure_before);
  EXPECT_LT(rep.standoff_after, rep.standoff_before);
  // The independent measuring tool agrees: a tighter volume and a closer boundary.
  const FitMetrics before = Measure(ch_, input_), after = Measure(ch_, out);
  EXPECT_LT(after.volume_ratio, before.volume_ratio);
  EXPECT_LT(after.boundary_distance_mean_rel, 0.8 * before.boundary_distance_mean_rel);
  EXPECT_EQ(after.uncovered_triangles, 0u);
}

TEST_F(TightenBuiltin, SplitGainZeroNeverSplitsAndTheBudgetHolds) {
  std::vector<TightSphere> out = input_;
  TightenSettings settings;
  settings.split_gain = 0.0f;
  const TightenReport rep = TightenSpheres(ch_, settings, &out);
  EXPECT_EQ(rep.splits, 0);
  EXPECT_LE(out.size(), input_.size());
  ExpectExactOwnership(ch_, parts_, out);

  out = input_;
  settings.split_gain = 1.0f;
  settings.target_standoff = 0.0f;
  settings.max_spheres = static_cast<int>(input_.size()) + 3;
  TightenSpheres(ch_, settings, &out);
  EXPECT_LE(out.size(), input_.size() + 3);
  ExpectExactOwnership(ch_, parts_, out);
}

TEST_F(TightenBuiltin, StopsAtTheTargetStandoff) {
  TightenSettings loose;
  loose.target_standoff = 0.02f;  // already met by the untightened set's ~1.1%? then no split
  std::vector<TightSphere> a = input_, b = input_;
  const TightenReport ra = TightenSpheres(ch_, loose, &a);
  TightenSettings strict;
  strict.target_standoff = 0.004f;
  const TightenReport rb = TightenSpheres(ch_, strict, &b);
  EXPECT_LT(ra.splits, rb.splits);
  EXPECT_LT(a.size(), b.size());
  EXPECT_GT(rb.standoff_after, 0.0);
}

TEST_F(TightenBuiltin, AStrayTriangleFarAwayDoesNotInflateTheSet) {
  std::vector<TightSphere> plain = input_;
  TightenSpheres(ch_, TightenSettings{}, &plain);
  // The same character with one small triangle 200 units away, owned by its own sphere.
  RawCharacter stray = ch_;
  BodyParts stray_parts = parts_;
  const int base = static_cast<int>(stray.positions_rest.size());
  for (const Eigen::Vector3f& p :
       {Eigen::Vector3f(200, 0, 0), Eigen::Vector3f(200.01f, 0, 0), Eigen::Vector3f(200, 0.01f, 0)}) {
    stray.positions_rest.push_back(p);
  }
  stray.triangles.emplace_back(base, base + 1, base + 2);
  stray_parts.triangle_part.push_back(0);
  std::vector<TightSphere> spheres = input_;
  TightSphere lone;
  lone.center = Eigen::Vector3f(200, 0, 0);
  lone.part = 0;
  lone.triangles = {static_cast<uint32_t>(stray.triangle_count() - 1)};
  spheres.push_back(lone);
  TightenSpheres(stray, TightenSettings{}, &spheres);
  ExpectExactOwnership(stray, stray_parts, spheres);
  EXPECT_LE(spheres.size(), plain.size() + 3);  // not a flood of splits chasing a coarse field
}

// The budget (step 3b) alone: one sphere fewer, and the pair merged is the one whose joint ball
// adds least volume to the pair's union, by an independent Monte Carlo estimate of that volume
// for every pair of a part (the merge itself prices it in closed form).
TEST_F(TightenBuiltin, TheBudgetMergesThePairThatAddsLeastVolume) {
  std::vector<TightSphere> out = input_;
  TightenSettings settings;
  settings.budget_only = true;
  settings.max_spheres = static_cast<int>(input_.size()) - 1;
  const TightenReport rep = TightenSpheres(ch_, settings, &out);
  ASSERT_EQ(out.size(), input_.size() - 1);
  EXPECT_EQ(rep.budget_merges, 1);
  EXPECT_EQ(rep.splits, 0);
  ExpectExactOwnership(ch_, parts_, out);

  // Added volume of merging a and b, sampled: vol(J) - vol(a u b), J the minimum ball of their
  // triangles (the cost the merge prices), as box volume x the mean of 1_J - 1_(a u b) over 40,000
  // points of a box holding J, a and b, with its standard error (a or b may stick out of J).
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  struct Estimate {
    double value, sigma;
  };
  auto added = [&](const TightSphere& a, const TightSphere& b) {
    std::vector<Eigen::Vector3f> pts;
    for (const auto* s : {&a, &b}) {
      for (uint32_t t : s->triangles) {
        for (int v = 0; v < 3; ++v) pts.push_back(ch_.positions_rest[ch_.triangles[t][v]]);
      }
    }
    const Ball ball = MinimumBall(pts);
    Eigen::Vector3d lo = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity()), hi = -lo;
    for (const auto& [c, r] :
         {std::pair{ball.center, ball.radius}, std::pair{a.center, a.radius}, std::pair{b.center, b.radius}}) {
      lo = lo.cwiseMin(c.cast<double>() - Eigen::Vector3d::Constant(r));
      hi = hi.cwiseMax(c.cast<double>() + Eigen::Vector3d::Constant(r));
    }
    const int n = 40000;
    double sum = 0.0, sum2 = 0.0;
    for (int k = 0; k < n; ++k) {
      const Eigen::Vector3d p = lo + (hi - lo).cwiseProduct(Eigen::Vector3d(unit(rng), unit(rng), unit(rng)));
      const bool in_j = (p - ball.center.cast<double>()).norm() <= ball.radius;
      const bool in_ab =
          (p - a.center.cast<double>()).norm() <= a.radius || (p - b.center.cast<double>()).norm() <= b.radius;
      const double x = double(in_j) - double(in_ab);
      sum += x;
      sum2 += x * x;
    }
    const double box = (hi - lo).prod(), mean = sum / n;
    return Estimate{box * mean, box * std::sqrt(std::max(0.0, sum2 / n - mean * mean) / n)};
  };
  // Which input pair became one output sphere.
  std::vector<uint32_t> merged_triangles;
  for (const auto& s : out) {
    const bool unchanged = std::any_of(input_.begin(), input_.end(), [&](const TightSphere& in) {
      return in.triangles == s.triangles && in.center == s.center;
    });
    if (!unchanged) merged_triangles = s.triangles;
  }
  ASSERT_FALSE(merged_triangles.empty());
  Estimate best{std::numeric_limits<double>::infinity(), 0.0}, chosen{-1.0, 0.0};
  bool found = false;
  for (size_t a = 0; a < input_.size(); ++a) {
    for (size_t b = a + 1; b < input_.size(); ++b) {
      if (input_[a].part != input_[b].part) continue;
      const Estimate v = added(input_[a], input_[b]);
      if (v.value < best.value) best = v;
      std::vector<uint32_t> both = input_[a].triangles;
      both.insert(both.end(), input_[b].triangles.begin(), input_[b].triangles.end());
      std::sort(both.begin(), both.end());
      if (both == merged_triangles) chosen = v, found = true;
    }
  }
  ASSERT_TRUE(found) << "the merged sphere is not the union of two input spheres of one part";
  // Within four standard errors of the two estimates.
  const double slack = 4.0 * (chosen.sigma + best.sigma);
  EXPECT_LE(chosen.value, best.value + slack)
      << "merged a pair adding " << chosen.value << " where one adds " << best.value << " (slack " << slack << ")";
}

// Budgets from the part count up: never more spheres than the budget, ownership exact, and a larger
// budget never measures looser (the independent evaluator's union volume).
TEST_F(TightenBuiltin, TheBudgetHoldsFromOneSpherePerPartUp) {
  std::vector<uint16_t> parts;
  for (const auto& s : input_) parts.push_back(s.part);
  std::sort(parts.begin(), parts.end());
  const int part_count = static_cast<int>(std::unique(parts.begin(), parts.end()) - parts.begin());
  double previous = std::numeric_limits<double>::infinity();
  for (int budget : {part_count, 20, 40}) {
    std::vector<TightSphere> out = input_;
    TightenSettings settings;
    settings.max_spheres = budget;
    const TightenReport rep = TightenSpheres(ch_, settings, &out);
    EXPECT_LE(static_cast<int>(out.size()), budget);
    EXPECT_GT(rep.budget_merges, 0);
    ExpectExactOwnership(ch_, parts_, out);
    const FitMetrics m = Measure(ch_, out);
    EXPECT_EQ(m.uncovered_triangles, 0u);
    EXPECT_LT(m.volume_ratio, previous) << "budget " << budget;
    previous = m.volume_ratio;
  }
}

TEST_F(TightenBuiltin, IsDeterministic) {
  std::vector<TightSphere> a = input_, b = input_;
  TightenSpheres(ch_, TightenSettings{}, &a);
  TightenSpheres(ch_, TightenSettings{}, &b);
  ASSERT_EQ(a.size(), b.size());
  for (size_t s = 0; s < a.size(); ++s) {
    EXPECT_EQ(a[s].center, b[s].center);
    EXPECT_EQ(a[s].radius, b[s].radius);
    EXPECT_EQ(a[s].triangles, b[s].triangles);
  }
}

TEST(Tighten, ASphereMeshHeldByOneOffCentreSphereEndsAsItsOwnBall) {
  // The surface of a sphere of radius 1 is a shell: the best single ball is the sphere itself, and
  // no cut pays (each half, and each patch, stands off more than the ball that follows the shell).
  RawCharacter ch = test::SphereMesh(1.0f, Eigen::Vector3f::Zero());
  BodyParts parts = test::MakeSinglePart(ch, -1.0f, 1.0f, PartKind::kHead);
  TightSphere t;
  t.center = Eigen::Vector3f(0.2f, -0.1f, 0.05f);
  t.part = 0;
  for (uint32_t k = 0; k < ch.triangle_count(); ++k) t.triangles.push_back(k);
  std::vector<TightSphere> spheres = {t};
  TightenSettings settings;
  settings.target_standoff = 0.0f;
  TightenSpheres(ch, settings, &spheres);
  ExpectExactOwnership(ch, parts, spheres);
  ASSERT_EQ(spheres.size(), 1u);
  EXPECT_LT(spheres[0].center.norm(), 0.03f);
  EXPECT_NEAR(spheres[0].radius, 1.0f, 0.03f);
}

TEST(Tighten, EmptySpheresAreDroppedAndTheRestKept) {
  RawCharacter ch = test::EllipticPrism(0.1f, 0.1f, 0.0f, 1.0f);
  BodyParts parts = test::MakeSinglePart(ch, 0.0f, 1.0f, PartKind::kChain);
  TightSphere all, none;
  all.center = Eigen::Vector3f(0.0f, 0.5f, 0.0f);
  for (uint32_t k = 0; k < ch.triangle_count(); ++k) all.triangles.push_back(k);
  none.center = Eigen::Vector3f(5.0f, 5.0f, 5.0f);
  std::vector<TightSphere> spheres = {none, all};
  const TightenReport rep = TightenSpheres(ch, TightenSettings{}, &spheres);
  EXPECT_GE(rep.dropped, 1);
  ExpectExactOwnership(ch, parts, spheres);
}

}  // namespace
}  // namespace skinspheres::lib
