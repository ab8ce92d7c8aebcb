// Tests of colliders.h against independent oracles: the round cone's distance against the union of
// the balls it sweeps (brute force over the segment), the fit's coverage and the evaluation's
// figures recomputed here vertex by vertex on the built-in character, and the per-bone baseline.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

#include "skinspheres/lib/character/builtin_character.h"
#include "skinspheres/lib/colliders/colliders.h"
#include "skinspheres/lib/geometry/mesh_helpers.h"
#include "skinspheres/lib/retarget/bake_clip.h"

namespace skinspheres::lib {
namespace {

// The hull of two balls is the union of the balls swept between them with the radius interpolated:
// outside it, the distance is the smallest over that sweep, |p - c(t)| - r(t), convex in t (a norm of
// an affine function minus an affine one), so a ternary search finds it.
float SweptDistance(const Eigen::Vector3f& p, const Eigen::Vector3f& a, float ra, const Eigen::Vector3f& b, float rb) {
  const Eigen::Vector3d pd = p.cast<double>(), ad = a.cast<double>(), bd = b.cast<double>();
  auto f = [&](double t) { return (pd - (ad + t * (bd - ad))).norm() - (ra + t * (rb - ra)); };
  double lo = 0.0, hi = 1.0;
  for (int i = 0; i < 100; ++i) {
    const double m1 = lo + (hi - lo) / 3.0, m2 = hi - (hi - lo) / 3.0;
    (f(m1) < f(m2) ? hi : lo) = f(m1) < f(m2) ? m2 : m1;
  }
  return static_cast<float>(std::min({f(0.0), f(1.0), f(0.5 * (lo + hi))}));
}

TEST(ColliderDistance, MatchesTheSweptBallsOutsideAndIsNegativeInside) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> u(-1.0f, 1.0f), r(0.05f, 0.6f);
  for (int shape = 0; shape < 40; ++shape) {
    const Eigen::Vector3f a(u(rng), u(rng), u(rng)), b = shape % 5 == 0 ? a : Eigen::Vector3f(u(rng), u(rng), u(rng));
    const float ra = r(rng), rb = shape % 7 == 0 ? ra : r(rng);
    for (int k = 0; k < 50; ++k) {
      const Eigen::Vector3f p(2 * u(rng), 2 * u(rng), 2 * u(rng));
      const float swept = SweptDistance(p, a, ra, b, rb);
      const float d = ColliderDistance(p, a, ra, b, rb);
      if (swept > 0.0f) {
        EXPECT_NEAR(d, swept, 2e-4f) << "shape " << shape << " point " << k;
      } else {
        EXPECT_LE(d, 1e-5f) << "shape " << shape << " point " << k;
        EXPECT_GE(d, swept - 1e-4f);  // no deeper than inside the deepest swept ball
      }
    }
  }
}

TEST(ColliderDistance, SphereAndStraightCapsuleByHand) {
  const Eigen::Vector3f o = Eigen::Vector3f::Zero(), x(1, 0, 0);
  EXPECT_NEAR(ColliderDistance({3, 0, 0}, o, 1.0f, o, 1.0f), 2.0f, 1e-6f);
  EXPECT_NEAR(ColliderDistance({0.5f, 2, 0}, o, 0.5f, x, 0.5f), 1.5f, 1e-6f);
  EXPECT_NEAR(ColliderDistance({0.5f, 0, 0}, o, 0.5f, x, 0.5f), -0.5f, 1e-6f);
  EXPECT_NEAR(ColliderDistance({3, 0, 0}, o, 0.5f, x, 0.5f), 1.5f, 1e-6f);
}

// The built-in character over its clips at 10 fps.
struct Builtin {
  RawCharacter character = MakeBuiltinCharacter();
  std::vector<std::vector<skinning::Transform>> poses;
  std::vector<std::string> parts;
  Builtin() {
    poses.push_back(character.skeleton.rest_local);
    for (const auto& clip : character.clips) {
      auto frames = SampleFrames(clip, character.skeleton, 10.0f);
      EXPECT_TRUE(frames.ok());
      for (auto& f : *frames) poses.push_back(std::move(f));
    }
    parts.assign(character.skeleton.size(), "body");
  }
};

// Per pose, the share of vertices within `tolerance` of some collider, by brute force.
std::vector<float> CoveredByHand(const Builtin& b, const std::vector<Collider>& colliders, float tolerance) {
  std::vector<float> out;
  for (const auto& pose : b.poses) {
    const auto posed = PoseCharacter(b.character, pose);
    EXPECT_TRUE(posed.ok());
    size_t covered = 0;
    for (const auto& v : posed->vertices) {
      float d = std::numeric_limits<float>::infinity();
      for (const auto& c : colliders) {
        const PlacedCollider p = PlaceCollider(c, posed->joint_world[c.joint]);
        d = std::min(d, SweptDistance(v, p.head, p.head_radius, p.tail, p.tail_radius));
      }
      covered += d <= tolerance ? 1 : 0;
    }
    out.push_back(static_cast<float>(covered) / static_cast<float>(posed->vertices.size()));
  }
  return out;
}

TEST(FitColliders, WithinBudgetCoveringEveryFittedPoseAndMeasuredAlike) {
  Builtin b;
  b.poses.resize(std::min<size_t>(b.poses.size(), 12));  // brute force below is slow
  ColliderSettings settings;
  settings.budget = 12;
  const auto fit = FitColliders(b.character, std::span(b.poses).subspan(1), b.parts, settings);
  ASSERT_TRUE(fit.ok()) << fit.error().message;
  ASSERT_LE(fit->colliders.size(), 12u);
  ASSERT_GE(fit->colliders.size(), 10u);  // the budget is spent (22 joints merge down to it)
  for (const auto& c : fit->colliders) {
    EXPECT_LT(c.joint, b.character.skeleton.size());
    EXPECT_GT(c.head_radius, 0.0f);
    EXPECT_EQ(c.part, "body");
  }
  const float height = BodyHeight(b.character.positions_rest);
  const float tolerance = settings.tolerance_share * height;
  const auto coverage = EvaluateColliders(b.character, b.poses, fit->colliders, settings.tolerance_share);
  ASSERT_TRUE(coverage.ok()) << coverage.error().message;
  const std::vector<float> by_hand = CoveredByHand(b, fit->colliders, tolerance * (1.0f + 1e-3f));
  ASSERT_EQ(coverage->poses.size(), by_hand.size());
  for (size_t p = 0; p < by_hand.size(); ++p) {
    EXPECT_EQ(by_hand[p], 1.0f) << "pose " << p << ": every fitted pose is covered within the tolerance";
    EXPECT_NEAR(coverage->poses[p].covered, by_hand[p], 1e-6f) << "pose " << p;
  }
}

TEST(EvaluateColliders, StandoffAndPokeOfOneBallByHand) {
  Builtin b;
  b.poses.resize(1);
  const auto rest = PoseCharacter(b.character, b.poses[0]);
  ASSERT_TRUE(rest.ok());
  // One ball on the root joint, centred on the rest mesh's centroid, half the height across.
  const float height = BodyHeight(b.character.positions_rest);
  Eigen::Vector3f centre = Eigen::Vector3f::Zero();
  for (const auto& v : rest->vertices) centre += v;
  centre /= static_cast<float>(rest->vertices.size());
  const Mat4f frame = RigidFrame(rest->joint_world[0]);
  const Eigen::Vector3f local = frame.block<3, 3>(0, 0).transpose() * (centre - frame.block<3, 1>(0, 3));
  const Collider ball{0, local, local, 0.25f * height, 0.25f * height, "body"};
  const auto coverage = EvaluateColliders(b.character, b.poses, std::vector<Collider>{ball}, 0.01f);
  ASSERT_TRUE(coverage.ok());
  double depth = 0.0;
  size_t covered = 0;
  std::vector<float> poke;
  for (const auto& v : rest->vertices) {
    const float d = (v - centre).norm() - 0.25f * height;
    depth += std::max(0.0f, -d);
    covered += d <= 0.01f * height ? 1 : 0;
    poke.push_back(std::max(0.0f, d));
  }
  const double n = static_cast<double>(rest->vertices.size());
  std::sort(poke.begin(), poke.end());
  EXPECT_NEAR(coverage->poses[0].covered, covered / n, 1e-6);
  EXPECT_NEAR(coverage->poses[0].standoff, depth / n, 1e-4 * height);
  EXPECT_NEAR(coverage->poke_p95, poke[static_cast<size_t>(0.95 * (n - 1))], 1e-4 * height);
  EXPECT_GT(coverage->poses[0].surface_gap, 0.0f);
}

TEST(PerBoneCapsules, CoveringOnesHoldTheirBonesVerticesAtRest) {
  Builtin b;
  const auto capsules = PerBoneCapsules(b.character, 1000, true);
  ASSERT_FALSE(capsules.empty());
  const auto rest = PoseCharacter(b.character, b.poses[0]);
  ASSERT_TRUE(rest.ok());
  size_t inside = 0;
  for (const auto& v : rest->vertices) {
    for (const auto& c : capsules) {
      const PlacedCollider p = PlaceCollider(c, rest->joint_world[c.joint]);
      if (ColliderDistance(v, p.head, p.head_radius, p.tail, p.tail_radius) <= 1e-4f) {
        ++inside;
        break;
      }
    }
  }
  EXPECT_EQ(inside, rest->vertices.size());
  const auto median = PerBoneCapsules(b.character, 4, false);
  EXPECT_EQ(median.size(), 4u);
}

TEST(FitColliders, Refusals) {
  Builtin b;
  ColliderSettings settings;
  settings.budget = 0;
  EXPECT_FALSE(FitColliders(b.character, {}, b.parts, settings).ok());
  settings.budget = 4;
  std::vector<std::vector<skinning::Transform>> bad{std::vector<skinning::Transform>(2)};
  const auto res = FitColliders(b.character, bad, b.parts, settings);
  ASSERT_FALSE(res.ok());
  EXPECT_NE(res.error().message.find("joint transforms"), std::string::npos) << res.error().message;
}

}  // namespace
}  // namespace skinspheres::lib
