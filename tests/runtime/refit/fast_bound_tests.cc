// The fast refit's bound on analytic cases (refit_job.h): one joint under rigid motion, uniform
// and non-uniform scale; the spread term of two joints; the influences' reach from the mesh
// weights and its analytic two-joint value; every vertex held on random poses; a set without reach
// or mesh gives the old bound bit for bit. Against the scalar formula (scalar_fast_refit.h) and
// closed-form answers.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cfloat>
#include <cmath>
#include <random>
#include <span>

#include "runtime/posed_characters.h"
#include "runtime/refit/random_poses.h"
#include "runtime/refit/scalar_fast_refit.h"
#include "runtime/sample_sphere_set.h"
#include "skinspheres/runtime/refit/mesh_bounds.h"
#include "skinspheres/runtime/refit/refit_job.h"

namespace skinspheres::runtime {
namespace {

using test::Pose;
using test::ScalarFastRefit;

// One joint, one sphere: analytic answers for rigid motion, uniform and non-uniform scale.
SphereSet OneJointSet(const skinspheres::Mat4f& rest_world) {
  SphereSet set = TwoSpheres();
  set.joint_rest_world = {rest_world};
  set.radii_fast = {1.5f, 1.0f};
  set.source_vertex_count = 4;
  return set;
}

TEST(RefitJobTest, FastModeSingleJointAnalytic) {
  skinspheres::Mat4f rest_world = skinspheres::Mat4f::Identity();
  rest_world.topRightCorner<3, 1>() = Eigen::Vector3f(0.5f, -1.0f, 2.0f);
  const SphereSet set = OneJointSet(rest_world);
  auto rest = RefitRestData::Create(set);
  ASSERT_TRUE(rest.ok()) << rest.error().message;
  std::vector<skinspheres::Vec4f> out(2);
  RefitJob job{RefitMode::kFast, &set, &*rest, {}, {}, out};

  Eigen::Affine3f motion =
      Eigen::Translation3f(3, 4, 5) * Eigen::AngleAxisf(0.7f, Eigen::Vector3f(1, 2, 3).normalized());
  auto expect = [&](const skinspheres::Mat4f& t, float s_max, const char* what) {
    const skinspheres::Mat4f g = t * rest_world;  // G(t) = T · G(rest)
    job.joint_world = std::span<const skinspheres::Mat4f>(&g, 1);
    ASSERT_TRUE(job.Run()) << what;
    for (int s = 0; s < 2; ++s) {
      const Eigen::Vector3f c = (t * set.centers_rest[s].homogeneous()).head<3>();
      EXPECT_LT((out[s].head<3>() - c).norm(), 1e-5f) << what;
      EXPECT_NEAR(out[s].w(), s_max * set.radii_fast[s], 1e-4f) << what;
    }
  };
  expect(motion.matrix(), 1.0f, "rigid");
  expect((motion * Eigen::Scaling(2.0f)).matrix(), 2.0f, "uniform scale");
  // Non-uniform diag(3, 1, 1), unrotated so the bound is exact: AᵀA = diag(9, 1, 1), largest row
  // sum 9, s_max = 3.
  expect(skinspheres::Mat4f(
             Eigen::Affine3f(Eigen::Translation3f(1, 0, 0) * Eigen::Scaling(Eigen::Vector3f(3, 1, 1))).matrix()),
         3.0f, "non-uniform scale");
}

TEST(RefitJobTest, TwoJointSpreadTermIsAdded) {
  // A sphere at the origin half on joint 0, half on joint 1; joint 1 moves by (2, 0, 0):
  // c' = (1, 0, 0), spread = 1, radius = 1 · radius_fast + 1.
  SphereSet set = TwoSpheres();
  set.joint_names = {"a", "b"};
  set.joint_parents = {-1, 0};
  set.joint_rest_world = {skinspheres::Mat4f::Identity(), skinspheres::Mat4f::Identity()};
  set.influence_offsets = {0, 2, 3};
  set.influence_joints = {0, 1, 0};
  set.influence_weights = {0.5f, 0.5f, 1.0f};
  auto rest = RefitRestData::Create(set);
  ASSERT_TRUE(rest.ok()) << rest.error().message;
  std::vector<skinspheres::Mat4f> world(2, skinspheres::Mat4f::Identity());
  world[1](0, 3) = 2.0f;
  std::vector<skinspheres::Vec4f> out(2);
  RefitJob job{RefitMode::kFast, &set, &*rest, world, {}, out};
  ASSERT_TRUE(job.Run());
  EXPECT_NEAR(out[0].x(), 1.0f, 1e-6f);
  EXPECT_NEAR(out[0].w(), set.radii_fast[0] + 1.0f, 1e-5f);
}

// The influences' reach, by hand (sample_sphere_set.h, TwoJointsWithMesh): the mesh gives it, the
// rest data takes it from the mesh when the set stores none, and 1 without a mesh.
TEST(RefitJobTest, InfluenceReachComesFromTheMeshWeights) {
  SphereSet set = TwoJointsWithMesh();
  ASSERT_FALSE(set.Validate().has_value()) << set.Validate()->message;
  auto reach = InfluenceReachFromMesh(set);
  ASSERT_TRUE(reach.ok()) << reach.error().message;
  EXPECT_EQ(*reach, (std::vector<float>{1.0f, 0.5f, 0.75f, 1.0f}));
  auto rest = RefitRestData::Create(set);
  ASSERT_TRUE(rest.ok()) << rest.error().message;
  EXPECT_TRUE(std::ranges::equal(rest->reach(), *reach));
  set.influence_reach = {1.0f, 0.75f, 0.75f, 1.0f};  // stored (larger than the mesh's: allowed)
  rest = RefitRestData::Create(set);
  ASSERT_TRUE(rest.ok()) << rest.error().message;
  EXPECT_TRUE(std::ranges::equal(rest->reach(), set.influence_reach));
  SphereSet no_mesh = TwoSpheres();
  rest = RefitRestData::Create(no_mesh);
  ASSERT_TRUE(rest.ok());
  EXPECT_TRUE(std::ranges::equal(rest->reach(), std::vector<float>(no_mesh.influence_joints.size(), 1.0f)));
}

// Joint b moves by t = (10, 0, 0). Sphere 0 (weights a 0.75, b 0.25): c' = c + 2.5 x, d_a = 2.5,
// d_b = 7.5; without reach the spread term is 7.5, with reach (a 1, b 0.5) 1 · 2.5 + 0.5 · 7.5 =
// 6.25. Sphere 1 (a 5/12, b 7/12): d_a = 70/12, d_b = 50/12; the weighted sum (0.75 · 70/12 +
// 50/12 = 102.5/12) exceeds the max, which stays.
TEST(RefitJobTest, FastModeReachAnalyticTwoJoints) {
  const SphereSet set = TwoJointsWithMesh();
  auto rest = RefitRestData::Create(set);
  ASSERT_TRUE(rest.ok()) << rest.error().message;
  std::vector<skinspheres::Mat4f> world(2, skinspheres::Mat4f::Identity());
  world[1](0, 3) = 10.0f;
  std::vector<skinspheres::Vec4f> out(2);
  RefitJob job{RefitMode::kFast, &set, &*rest, world, {}, out};
  ASSERT_TRUE(job.Run());
  EXPECT_NEAR(out[0].x(), 2.75f, 1e-5f);
  EXPECT_NEAR(out[0].w(), 0.5f + 6.25f, 1e-4f);
  EXPECT_NEAR(out[1].x(), 0.75f + 70.0f / 12.0f, 1e-5f);
  EXPECT_NEAR(out[1].w(), 0.5f + 70.0f / 12.0f, 1e-4f);
  const auto old = ScalarFastRefit(set, *rest, world, test::Bound::kWithoutReach);
  EXPECT_NEAR(old[0].w(), 0.5f + 7.5f, 1e-4f);
  EXPECT_LT(out[0].w(), old[0].w()) << "strictly tighter where the reach is below 1";
  EXPECT_EQ(out[1].w(), old[1].w()) << "the max where it is the smaller";
}

// Random poses of the two joints (rotations, translations, non-uniform scales), the four vertices
// skinned by the linear blend skinning formula in double: every vertex inside its fast spheres, the
// bound never above the one without reach, and below it on some poses.
TEST(RefitJobTest, FastModeWithReachHoldsEveryVertexOnRandomPoses) {
  const SphereSet set = TwoJointsWithMesh();
  auto rest = RefitRestData::Create(set);
  ASSERT_TRUE(rest.ok()) << rest.error().message;
  std::mt19937 rng(2026);
  std::uniform_real_distribution<float> angle(-3.1f, 3.1f), move(-3.0f, 3.0f), scale(0.3f, 3.0f);
  std::vector<skinspheres::Mat4f> world(2);
  std::vector<skinspheres::Vec4f> out(2);
  int tighter = 0;
  for (int p = 0; p < 2000; ++p) {
    for (auto& g : world) {
      const Eigen::Vector3f axis = Eigen::Vector3f(move(rng), move(rng), move(rng)).normalized();
      Eigen::Affine3f t = Eigen::Translation3f(move(rng), move(rng), move(rng)) * Eigen::AngleAxisf(angle(rng), axis);
      if (p % 2) t = t * Eigen::Scaling(Eigen::Vector3f(scale(rng), scale(rng), scale(rng)));
      g = t.matrix();
    }
    RefitJob job{RefitMode::kFast, &set, &*rest, world, {}, out};
    ASSERT_TRUE(job.Run());
    const auto old = ScalarFastRefit(set, *rest, world, test::Bound::kWithoutReach);
    for (size_t s = 0; s < 2; ++s) {
      ASSERT_LE(out[s].w(), old[s].w()) << "pose " << p << " sphere " << s;
      tighter += out[s].w() < old[s].w();
      for (uint32_t k = set.vertex_offsets[s]; k < set.vertex_offsets[s + 1]; ++k) {
        const uint32_t v = set.vertices[k];
        Eigen::Vector3d skinned = Eigen::Vector3d::Zero();
        for (uint32_t q = set.mesh.influence_offsets[v]; q < set.mesh.influence_offsets[v + 1]; ++q) {
          const skinning::BindEntry& b = set.mesh.binds[set.mesh.influence_binds[q]];
          const Eigen::Matrix4d m = world[static_cast<size_t>(b.joint)].cast<double>() * b.inverse_bind.cast<double>();
          skinned += double{set.mesh.influence_weights[q]} *
                     (m * set.mesh.positions_bind[v].cast<double>().homogeneous()).head<3>();
        }
        const double d = (skinned - out[s].head<3>().cast<double>()).norm();
        ASSERT_LE(d, out[s].w()) << "pose " << p << " sphere " << s << " vertex " << v;
      }
    }
  }
  EXPECT_GT(tighter, 100);
  std::printf("two joints: %d of 4000 fast spheres tighter with reach\n", tighter);
}

using test::RandomWorld;
using test::SkinnedInDouble;

// On `poses` random poses (RandomWorld, from `seed`): the fast refit gives the scalar formula's
// bits and holds every source vertex of every sphere, skinned in double.
void CheckRandomPosesAgainstScalarFormula(const SphereSet& set, const RefitRestData& rest, unsigned seed, int poses) {
  std::mt19937 rng(seed);
  std::vector<skinspheres::Mat4f> world(set.joint_count());
  std::vector<skinspheres::Vec4f> out(set.size());
  for (int p = 0; p < poses; ++p) {
    RandomWorld(rng, p, &world);
    ASSERT_TRUE((RefitJob{RefitMode::kFast, &set, &rest, world, {}, out}.Run()));
    const auto scalar = ScalarFastRefit(set, rest, world, test::Bound::kRestData);
    for (size_t s = 0; s < set.size(); ++s) {
      ASSERT_EQ(out[s], scalar[s]) << "pose " << p << " sphere " << s;
      for (uint32_t k = set.vertex_offsets[s]; k < set.vertex_offsets[s + 1]; ++k) {
        const uint32_t v = set.vertices[k];
        ASSERT_LE((SkinnedInDouble(set, world, v) - out[s].head<3>().cast<double>()).norm(), out[s].w())
            << "pose " << p << " sphere " << s << " vertex " << v;
      }
    }
  }
}

// A rest pose away from the bind pose (joint b's rest transform moved by (0.3, 0.1, 0); the bind
// pose is identity for both joints): each vertex's rest copies through its two joints lie apart,
// so radius_fast around the rest centre must hold both, and ChooseFastReference stores the bind
// pose as the reference instead (docs/REFIT.md#reference-frame).
// Checked: the bind reference is chosen and stored; at the bind pose its spheres are the tight ones
// (radius = farthest bind-space vertex from the centre, no spread) and smaller than the rest
// reference's (the same set without it); on 2000 random poses every vertex, skinned in double, is
// inside; the vector refit equals the scalar formula bit for bit; a stored radius one ulp below
// what the vertices need is refused.
TEST(RefitJobTest, ARestPoseAwayFromBindTakesTheBindPoseAsReference) {
  SphereSet set = TwoJointsRestAwayFromBind();
  ASSERT_FALSE(set.Validate().has_value()) << set.Validate()->message;
  // The rest reference: the set as it is, without a stored reference.
  SphereSet no_mesh = set;
  auto rest_only = RefitRestData::Create(no_mesh);
  ASSERT_TRUE(rest_only.ok()) << rest_only.error().message;
  EXPECT_FALSE(rest_only->bind_reference());
  auto chosen = ChooseFastReference(&set);
  ASSERT_TRUE(chosen.ok()) << chosen.error().message;
  ASSERT_TRUE(*chosen);
  ASSERT_EQ(set.fast_reference_inverse.size(), 2u);
  ASSERT_EQ(set.fast_reference_spheres.size(), 2u);
  ASSERT_FALSE(set.Validate().has_value()) << set.Validate()->message;
  auto rest = RefitRestData::Create(set);
  ASSERT_TRUE(rest.ok()) << rest.error().message;
  EXPECT_TRUE(rest->bind_reference());
  // A radius one ulp below the one the vertices need is refused by name.
  SphereSet too_small = set;
  too_small.fast_reference_spheres[1].w() = std::nextafter(too_small.fast_reference_spheres[1].w(), 0.0f);
  auto needed = FastReferenceRadiiFromMesh(set);
  ASSERT_TRUE(needed.ok());
  ASSERT_EQ((*needed)[1], set.fast_reference_spheres[1].w());
  const auto refused = too_small.Validate();
  ASSERT_TRUE(refused.has_value());
  EXPECT_NE(refused->message.find("sphere 1 has fast reference radius"), std::string::npos) << refused->message;

  std::vector<skinspheres::Mat4f> world(2, skinspheres::Mat4f::Identity());  // the bind pose
  std::vector<skinspheres::Vec4f> out(2), out_rest(2);
  ASSERT_TRUE((RefitJob{RefitMode::kFast, &set, &*rest, world, {}, out}.Run()));
  ASSERT_TRUE((RefitJob{RefitMode::kFast, &no_mesh, &*rest_only, world, {}, out_rest}.Run()));
  for (size_t s = 0; s < 2; ++s) {
    double farthest = 0.0;
    for (uint32_t k = set.vertex_offsets[s]; k < set.vertex_offsets[s + 1]; ++k) {
      farthest = std::max(
          farthest, (set.mesh.positions_bind[set.vertices[k]].cast<double>() - out[s].head<3>().cast<double>()).norm());
    }
    EXPECT_NEAR(out[s].w(), farthest, 1e-5) << "sphere " << s;
    EXPECT_LT(out[s].w(), out_rest[s].w()) << "sphere " << s;
  }

  CheckRandomPosesAgainstScalarFormula(set, *rest, 5, 2000);
}

// The fast radius needs each vertex's weighted mean copy distance Σ_b w_b |p_b - c|, not its
// farthest copy (docs/REFIT.md#fast-mode). TwoJointsRestAwayFromBind with the rest pose as the
// reference (none stored): vertices 1 and 2 weigh both joints, whose rest copies lie 0.32 apart.
// Checked against figures computed here in double: FastBoundVerticesFromMesh gives each vertex of
// sphere 0 its mean, below its farthest copy for those two; a radius_fast 0.1% below the largest
// mean (vertex 2's) is refused, and the farthest copy (what files written before store) is not. Then the pose that
// attains the bound: each joint turned about the sphere's centre c so that the vertex's copies point the same way (c' =
// c, every d_j = 0, s_max = 1), where the vertex, skinned in double, lies at its mean distance from c: inside the fast
// sphere, and at least the stored radius minus the refit's rounding margin away, so no smaller radius would be sound.
// On 2000 random poses every vertex, skinned in double, stays inside.
TEST(RefitJobTest, TheFastRadiusIsTheLargestMeanCopyDistance) {
  SphereSet set = TwoJointsRestAwayFromBind();
  ASSERT_TRUE(set.fast_reference_spheres.empty());
  auto vertices = FastBoundVerticesFromMesh(set);
  ASSERT_TRUE(vertices.ok()) << vertices.error().message;
  // Per point i of sphere s: its copies, mean and farthest distance from the rest centre.
  auto copies_of = [&](uint32_t v) {
    struct Copy {
      double weight;
      size_t joint;
      Eigen::Vector3d p;
    };
    std::vector<Copy> out;
    for (uint32_t q = set.mesh.influence_offsets[v]; q < set.mesh.influence_offsets[v + 1]; ++q) {
      const skinning::BindEntry& b = set.mesh.binds[set.mesh.influence_binds[q]];
      out.push_back({double{set.mesh.influence_weights[q]}, static_cast<size_t>(b.joint),
                     (set.joint_rest_world[static_cast<size_t>(b.joint)].cast<double>() *
                      b.inverse_bind.cast<double>() * set.mesh.positions_bind[v].cast<double>().homogeneous())
                         .head<3>()});
    }
    return out;
  };
  const size_t s = 0;
  const Eigen::Vector3d c = set.centers_rest[s].cast<double>();
  double largest_mean = 0.0;
  uint32_t widest = 0, widest_point = 0;
  for (uint32_t i = set.vertex_offsets[s]; i < set.vertex_offsets[s + 1]; ++i) {
    double mean = 0.0, farthest = 0.0;
    for (const auto& copy : copies_of(set.vertices[i])) {
      mean += copy.weight * (copy.p - c).norm();
      farthest = std::max(farthest, (copy.p - c).norm());
    }
    EXPECT_NEAR(vertices->radius[i], mean, 1e-6 * mean) << "point " << i;
    EXPECT_GE(vertices->radius[i], float(mean)) << "point " << i << ": rounded up";
    if (set.vertices[i] != 0) {
      EXPECT_LT(mean, 0.97 * farthest) << "vertex " << set.vertices[i] << "'s copies spread";
    }
    if (mean > largest_mean) largest_mean = mean, widest = set.vertices[i], widest_point = i;
  }
  ASSERT_EQ(widest, 2u) << "vertex 2 has the largest mean";
  set.radii_fast[s] = std::max(set.radii_rest[s], vertices->radius[widest_point]);
  ASSERT_FALSE(set.Validate().has_value()) << set.Validate()->message;
  // Validate() allows 2 ulps of float rounding (CheckFastRadii): one ulp below passes; 1e-3 and
  // 1e-5 below are refused, by name (1e-5 passed the 1e-4 allowed before 2026-12-06).
  SphereSet within_rounding = set;
  within_rounding.radii_fast[s] = std::nextafter(vertices->radius[widest_point], 0.0f);
  EXPECT_FALSE(within_rounding.Validate().has_value()) << within_rounding.Validate()->message;
  for (const float shrink : {0.999f, 0.99999f}) {
    SphereSet too_small = set;
    too_small.radii_fast[s] = vertices->radius[widest_point] * shrink;
    const auto refused = too_small.Validate();
    ASSERT_TRUE(refused.has_value()) << shrink;
    EXPECT_NE(refused->message.find("source vertex 2's rest copies need"), std::string::npos) << refused->message;
  }

  SphereSet older = set;
  older.radii_fast = TwoJointsRestAwayFromBind().radii_fast;  // the farthest copies
  EXPECT_GT(older.radii_fast[s], 1.02f * set.radii_fast[s]);
  EXPECT_FALSE(older.Validate().has_value());

  auto rest = RefitRestData::Create(set);
  ASSERT_TRUE(rest.ok()) << rest.error().message;
  std::vector<skinspheres::Mat4f> world(2);
  std::vector<skinspheres::Vec4f> out(2);
  // The attaining pose: T_j x = c + R_j (x - c), R_j turning vertex 2's copy through joint j to +Z
  // (its two entries on joint b have the same copy: both inverse bind matrices are the identity).
  const auto copies = copies_of(widest);
  double farthest = 0.0;
  for (size_t j = 0; j < 2; ++j) {
    const auto copy = std::find_if(copies.begin(), copies.end(), [&](const auto& e) { return e.joint == j; });
    ASSERT_NE(copy, copies.end());
    for (const auto& e : copies) {
      if (e.joint == j) {
        ASSERT_LT((e.p - copy->p).norm(), 1e-12);
      }
    }
    farthest = std::max(farthest, (copy->p - c).norm());
    const Eigen::Matrix3d r =
        Eigen::Quaterniond::FromTwoVectors(copy->p - c, Eigen::Vector3d::UnitZ()).toRotationMatrix();
    Eigen::Affine3d t = Eigen::Translation3d(c) * Eigen::Affine3d(r) * Eigen::Translation3d(-c);
    world[j] = (t.matrix() * set.joint_rest_world[j].cast<double>()).cast<float>();
  }
  ASSERT_TRUE((RefitJob{RefitMode::kFast, &set, &*rest, world, {}, out}.Run()));
  const Eigen::Vector3d skinned = SkinnedInDouble(set, world, widest);
  const double reach = (skinned - out[s].head<3>().cast<double>()).norm();
  EXPECT_NEAR(reach, largest_mean, 1e-5 * largest_mean);
  EXPECT_LE(reach, double(out[s].w()));
  const double margin = 16.0 * FLT_EPSILON * (out[s].head<3>().cast<double>().cwiseAbs().maxCoeff() + out[s].w());
  EXPECT_GE(reach, double(out[s].w()) - margin - 1e-5 * largest_mean)
      << "the bound is attained: no smaller radius holds";
  std::printf("vertex 2: mean copy distance %.6f, farthest copy %.6f, fast radius at the attaining pose %.6f\n",
              largest_mean, farthest, double(out[s].w()));

  std::mt19937 rng(17);
  for (int p = 0; p < 2000; ++p) {
    RandomWorld(rng, p, &world);
    ASSERT_TRUE((RefitJob{RefitMode::kFast, &set, &*rest, world, {}, out}.Run()));
    for (size_t t = 0; t < 2; ++t) {
      for (uint32_t k = set.vertex_offsets[t]; k < set.vertex_offsets[t + 1]; ++k) {
        const uint32_t v = set.vertices[k];
        ASSERT_LE((SkinnedInDouble(set, world, v) - out[t].head<3>().cast<double>()).norm(), out[t].w())
            << "pose " << p << " sphere " << t << " vertex " << v;
      }
    }
  }
}

// One reach group per sphere, by hand from the mesh's figures (FastBoundVerticesFromMesh): the
// radius holding its points and, per influence entry, the reach (the largest of the points'
// weights), the midpoint m of the weights and e the largest distance from it, rounded up; m = e = 0
// on an entry that repeats an earlier entry's joint (RepeatedInfluenceEntries).
void OneBlendedGroupPerSphere(SphereSet* set) {
  auto vertices = FastBoundVerticesFromMesh(*set);
  ASSERT_TRUE(vertices.ok()) << vertices.error().message;
  set->reach_group_offsets = {0};
  std::vector<uint8_t> repeated;
  for (size_t s = 0; s < set->size(); ++s) {
    const uint32_t k_count = set->influence_offsets[s + 1] - set->influence_offsets[s];
    RepeatedInfluenceEntries(*set, s, &repeated);
    std::vector<float> lo(k_count, 1.0f), hi(k_count, 0.0f);
    float radius = 0.0f;
    for (uint32_t i = set->vertex_offsets[s]; i < set->vertex_offsets[s + 1]; ++i) {
      radius = std::max(radius, vertices->radius[i]);
      for (uint32_t k = 0; k < k_count; ++k) {
        const float w = vertices->weights[vertices->weight_offsets[s] + (i - set->vertex_offsets[s]) * k_count + k];
        lo[k] = std::min(lo[k], w), hi[k] = std::max(hi[k], w);
      }
    }
    set->reach_group_radii.push_back(radius);
    set->reach_group_offsets.push_back(static_cast<uint32_t>(set->reach_group_radii.size()));
    for (uint32_t k = 0; k < k_count; ++k) {
      set->reach_group_weights.push_back(hi[k]);
      set->reach_group_blend.push_back(repeated[k] ? 0.0f : 0.5f * (lo[k] + hi[k]));
      set->reach_group_deviation.push_back(repeated[k] ? 0.0f : std::nextafter(0.5f * (hi[k] - lo[k]), 1.0f));
    }
  }
}

// The groups' blends (docs/REFIT.md#group-blends): TwoJointsWithMesh, one group per sphere with
// the reach of its vertices, and by hand per entry the midpoint m of the vertices' weights and
// e = the largest distance from it. Sphere 0's vertices weigh joint a 1, 0.75 and 0.5: m = 0.75,
// e = 0.25 there, where the reach is 1. Checked: Validate() accepts it; a deviation 1e-3 short of a
// vertex is refused by name; a blend without groups, or with the wrong length, is refused; on 2000
// random poses every vertex, skinned in double, is inside, the vector refit equals the scalar
// formula bit for bit, every radius is at most the same set's without the blends, and some are
// smaller.
TEST(RefitJobTest, GroupBlendsHoldEveryVertexAndNeverLoosenTheBound) {
  SphereSet set = TwoJointsWithMesh();
  ASSERT_NO_FATAL_FAILURE(OneBlendedGroupPerSphere(&set));
  ASSERT_EQ(set.reach_group_blend[0], 0.75f);
  ASSERT_FALSE(set.Validate().has_value()) << set.Validate()->message;
  {
    SphereSet short_of = set;
    short_of.reach_group_deviation[0] = 0.249f;
    const auto refused = short_of.Validate();
    ASSERT_TRUE(refused.has_value());
    EXPECT_NE(refused->message.find("sphere 0's source vertex"), std::string::npos) << refused->message;
    EXPECT_NE(refused->message.find("outside every group's blend and deviation"), std::string::npos)
        << refused->message;
    SphereSet without_groups = set;
    without_groups.reach_group_offsets.clear();
    without_groups.reach_group_radii.clear();
    without_groups.reach_group_weights.clear();
    ASSERT_TRUE(without_groups.Validate().has_value());
    EXPECT_NE(without_groups.Validate()->message.find("blends are given without the groups"), std::string::npos);
    SphereSet wrong_length = set;
    wrong_length.reach_group_deviation.pop_back();
    ASSERT_TRUE(wrong_length.Validate().has_value());
    EXPECT_NE(wrong_length.Validate()->message.find("blend and 3 deviation entries for 4"), std::string::npos)
        << wrong_length.Validate()->message;
  }
  SphereSet unblended = set;
  unblended.reach_group_blend.clear();
  unblended.reach_group_deviation.clear();
  auto rest = RefitRestData::Create(set), rest_unblended = RefitRestData::Create(unblended);
  ASSERT_TRUE(rest.ok() && rest_unblended.ok());
  std::mt19937 rng(23);
  std::vector<skinspheres::Mat4f> world(2);
  std::vector<skinspheres::Vec4f> out(2), out_unblended(2);
  int tighter = 0;
  for (int p = 0; p < 2000; ++p) {
    RandomWorld(rng, p, &world);
    ASSERT_TRUE((RefitJob{RefitMode::kFast, &set, &*rest, world, {}, out}.Run()));
    ASSERT_TRUE((RefitJob{RefitMode::kFast, &unblended, &*rest_unblended, world, {}, out_unblended}.Run()));
    const auto scalar = ScalarFastRefit(set, *rest, world, test::Bound::kRestData);
    for (size_t s = 0; s < 2; ++s) {
      ASSERT_EQ(out[s], scalar[s]) << "pose " << p << " sphere " << s;
      ASSERT_LE(out[s].w(), out_unblended[s].w()) << "pose " << p << " sphere " << s;
      tighter += out[s].w() < out_unblended[s].w();
      for (uint32_t k = set.vertex_offsets[s]; k < set.vertex_offsets[s + 1]; ++k) {
        const uint32_t v = set.vertices[k];
        ASSERT_LE((SkinnedInDouble(set, world, v) - out[s].head<3>().cast<double>()).norm(), out[s].w())
            << "pose " << p << " sphere " << s << " vertex " << v;
      }
    }
  }
  EXPECT_GT(tighter, 500);
  std::printf("two joints: %d of 4000 fast spheres tighter with blends\n", tighter);
}

// The blend term's rounding allowance (docs/REFIT.md#group-blends, ρ): four vertices weighed
// exactly 0.5 / 0.5 on joints a and b, one group per sphere with m = 0.5 / 0.5 and e = 0 (the review's
// case). Joint a translated by L·u and joint b by -L·u leave the vertices in place while each
// T_j c lies L away: the vector sum cancels, and without ρ the float rounding of T_j c - c' put up to
// 646 of 1200 vertices outside at L = 1e6 (45% of the radius). With ρ, for L from 10 to 1e6 and 200
// random directions and offsets each, every vertex skinned in double is inside, and the vector
// refit equals the scalar formula bit for bit. A group whose blends no weights summing to 1 fit is
// refused.
TEST(RefitJobTest, GroupBlendsHoldWhenJointsMoveFarApart) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  int checked = 0;
  for (float length : {10.0f, 100.0f, 1e3f, 1e4f, 1e5f, 1e6f}) {
    for (int trial = 0; trial < 200; ++trial) {
      const float ox = 0.3f * u(rng);
      SphereSet set = TwoJointsWithMesh();
      set.mesh.positions_bind = {Eigen::Vector3f(ox, 0, 0), Eigen::Vector3f(ox + 0.1f, 0, 0),
                                 Eigen::Vector3f(ox, 0.1f, 0), Eigen::Vector3f(ox + 0.1f, 0.1f, 0)};
      set.mesh.binds = {skinning::BindEntry{0, skinspheres::Mat4f::Identity()},
                        skinning::BindEntry{1, skinspheres::Mat4f::Identity()}};
      set.mesh.influence_offsets = {0, 2, 4, 6, 8};
      set.mesh.influence_binds = {0, 1, 0, 1, 0, 1, 0, 1};
      set.mesh.influence_weights.assign(8, 0.5f);
      set.influence_weights.assign(4, 0.5f);
      set.centers_rest = {Eigen::Vector3f(ox + 0.05f, 0.05f, 0), Eigen::Vector3f(ox + 0.05f, 0.05f, 0)};
      set.vertices = {0, 1, 2, 1, 2, 3};
      set.influence_reach.clear();
      set.radii_rest = set.radii_fast = {0.08f, 0.08f};  // replaced by the mesh's figure below
      auto vertices = FastBoundVerticesFromMesh(set);
      ASSERT_TRUE(vertices.ok()) << vertices.error().message;
      const float r = *std::max_element(vertices->radius.begin(), vertices->radius.end());
      set.radii_rest = set.radii_fast = {r, r};
      set.reach_group_offsets = {0, 1, 2};
      set.reach_group_radii = {r, r};
      set.reach_group_weights.assign(4, 0.5f);
      set.reach_group_blend.assign(4, 0.5f);
      set.reach_group_deviation.assign(4, 0.0f);
      ASSERT_FALSE(set.Validate().has_value()) << set.Validate()->message;
      auto rest = RefitRestData::Create(set);
      ASSERT_TRUE(rest.ok()) << rest.error().message;
      const Eigen::Vector3f dir = Eigen::Vector3f(u(rng), u(rng), u(rng)).normalized();
      std::vector<skinspheres::Mat4f> world = {Eigen::Affine3f(Eigen::Translation3f(length * dir)).matrix(),
                                               Eigen::Affine3f(Eigen::Translation3f(-length * dir)).matrix()};
      std::vector<skinspheres::Vec4f> out(2);
      ASSERT_TRUE((RefitJob{RefitMode::kFast, &set, &*rest, world, {}, out}.Run()));
      const auto scalar = ScalarFastRefit(set, *rest, world, test::Bound::kRestData);
      for (size_t s = 0; s < 2; ++s) {
        ASSERT_EQ(out[s], scalar[s]) << "L " << length << " trial " << trial << " sphere " << s;
        for (uint32_t k = set.vertex_offsets[s]; k < set.vertex_offsets[s + 1]; ++k) {
          ASSERT_LE((SkinnedInDouble(set, world, set.vertices[k]) - out[s].head<3>().cast<double>()).norm(), out[s].w())
              << "L " << length << " trial " << trial << " sphere " << s << " vertex " << set.vertices[k];
          ++checked;
        }
      }
    }
  }
  EXPECT_EQ(checked, 6 * 200 * 6);
  SphereSet set = TwoJointsWithMesh();
  set.reach_group_offsets = {0, 1, 2};
  set.reach_group_radii = {1.0f, 1.0f};
  set.reach_group_weights.assign(4, 1.0f);
  set.reach_group_blend = {0.2f, 0.2f, 0.5f, 0.5f};
  set.reach_group_deviation = {0.1f, 0.1f, 0.5f, 0.5f};  // sphere 0: weights within 0.3 + 0.3 < 1
  const auto refused = set.Validate();
  ASSERT_TRUE(refused.has_value());
  EXPECT_NE(
      refused->message.find("sphere 0's reach group 0 has blends and deviations that no weights summing to 1 fit"),
      std::string::npos)
      << refused->message;
}

// An influence entry that repeats an earlier entry's joint counts that joint once: its group blend
// and deviation must be 0 ("Group blends"). TwoJointsWithMesh with sphere 0's influences a, b, b
// (b's weight split over two entries) and its groups built by hand (OneBlendedGroupPerSphere, the
// repeated entry with m = e = 0): RepeatedInfluenceEntries marks entry 2 alone, Validate() accepts
// the set, and on 200 random poses the vector refit equals the scalar formula bit for bit with
// every vertex inside; a nonzero blend, or a nonzero deviation, on the repeated entry is refused,
// naming the sphere, the group and the entry.
TEST(RefitJobTest, GroupBlendsOnARepeatedJointAreRefused) {
  SphereSet set = TwoJointsWithMesh();
  set.influence_offsets = {0, 3, 5};
  set.influence_joints = {0, 1, 1, 0, 1};
  set.influence_weights = {0.75f, 0.125f, 0.125f, 5.0f / 12.0f, 7.0f / 12.0f};
  std::vector<uint8_t> repeated;
  RepeatedInfluenceEntries(set, 0, &repeated);
  EXPECT_EQ(repeated, (std::vector<uint8_t>{0, 0, 1}));
  RepeatedInfluenceEntries(set, 1, &repeated);
  EXPECT_EQ(repeated, (std::vector<uint8_t>{0, 0}));
  ASSERT_NO_FATAL_FAILURE(OneBlendedGroupPerSphere(&set));
  // The repeated entry: b's total weight as reach, as entry 1's; no blend, no deviation.
  ASSERT_EQ(set.reach_group_weights[2], 0.5f);
  ASSERT_EQ(set.reach_group_blend[2], 0.0f);
  ASSERT_EQ(set.reach_group_deviation[2], 0.0f);
  ASSERT_FALSE(set.Validate().has_value()) << set.Validate()->message;
  auto rest = RefitRestData::Create(set);
  ASSERT_TRUE(rest.ok()) << rest.error().message;
  ASSERT_NO_FATAL_FAILURE(CheckRandomPosesAgainstScalarFormula(set, *rest, 29, 200));
  for (const bool blend : {true, false}) {
    SphereSet refused_set = set;
    (blend ? refused_set.reach_group_blend : refused_set.reach_group_deviation)[2] = 0.125f;
    const auto refused = refused_set.Validate();
    ASSERT_TRUE(refused.has_value()) << (blend ? "blend" : "deviation");
    EXPECT_NE(refused->message.find("sphere 0's reach group 0 blends influence entry 2, which repeats an earlier "
                                    "entry's joint (its blend and deviation must be 0)"),
              std::string::npos)
        << refused->message;
  }
}

// The same with inverse bind matrices that are not the identity: the bind space moved by a rigid
// motion and a scale X (IBM_b <- IBM_b X^-1, p_bind <- X p_bind: the same skin), and the second of
// joint b's two bind entries shifted by (0.05, 0.02, 0), so vertex 2's copies through its two
// entries on b differ. The stored reference's radii hold each vertex's copies (a radius one ulp smaller is
// refused), and on 2000 random poses every vertex, skinned in double, is inside its fast sphere,
// with the reference alone and with reach groups built by hand (each vertex its own group).
TEST(RefitJobTest, TheBindReferenceHoldsWithInverseBindMatricesThatAreNotTheIdentity) {
  const Eigen::Affine3f x = Eigen::Translation3f(0.4f, -0.7f, 1.3f) *
                            Eigen::AngleAxisf(0.9f, Eigen::Vector3f(1, 2, 3).normalized()) * Eigen::Scaling(1.7f);
  SphereSet set = TwoJointsRestAwayFromBind([&](SphereSet& s) {
    for (auto& b : s.mesh.binds) b.inverse_bind = b.inverse_bind * x.inverse().matrix();
    for (auto& p : s.mesh.positions_bind) p = x * p;
    s.mesh.binds[2].inverse_bind =
        Eigen::Affine3f(Eigen::Translation3f(0.05f, 0.02f, 0.0f)).matrix() * s.mesh.binds[2].inverse_bind;
  });
  ASSERT_FALSE(set.Validate().has_value()) << set.Validate()->message;
  auto chosen = ChooseFastReference(&set);
  ASSERT_TRUE(chosen.ok()) << chosen.error().message;
  ASSERT_TRUE(*chosen);
  ASSERT_FALSE(set.Validate().has_value()) << set.Validate()->message;
  for (size_t s = 0; s < 2; ++s) {
    SphereSet too_small = set;
    too_small.fast_reference_spheres[s].w() = std::nextafter(too_small.fast_reference_spheres[s].w(), 0.0f);
    EXPECT_TRUE(too_small.Validate().has_value()) << "sphere " << s;
  }
  // Reach groups by hand: each source vertex its own group (its radius and weights).
  SphereSet grouped = set;
  auto vertices = FastBoundVerticesFromMesh(grouped);
  ASSERT_TRUE(vertices.ok()) << vertices.error().message;
  grouped.reach_group_offsets = {0};
  for (size_t s = 0; s < 2; ++s) {
    const uint32_t k_count = grouped.influence_offsets[s + 1] - grouped.influence_offsets[s];
    for (uint32_t i = grouped.vertex_offsets[s]; i < grouped.vertex_offsets[s + 1]; ++i) {
      grouped.reach_group_radii.push_back(vertices->radius[i]);
      const float* w =
          vertices->weights.data() + vertices->weight_offsets[s] + size_t{i - grouped.vertex_offsets[s]} * k_count;
      grouped.reach_group_weights.insert(grouped.reach_group_weights.end(), w, w + k_count);
    }
    grouped.reach_group_offsets.push_back(static_cast<uint32_t>(grouped.reach_group_radii.size()));
  }
  ASSERT_FALSE(grouped.Validate().has_value()) << grouped.Validate()->message;
  auto rest = RefitRestData::Create(set), rest_grouped = RefitRestData::Create(grouped);
  ASSERT_TRUE(rest.ok() && rest_grouped.ok());
  std::mt19937 rng(9);
  std::vector<skinspheres::Mat4f> world(2);
  std::vector<skinspheres::Vec4f> out(2), out_grouped(2);
  for (int p = 0; p < 2000; ++p) {
    RandomWorld(rng, p, &world);
    ASSERT_TRUE((RefitJob{RefitMode::kFast, &set, &*rest, world, {}, out}.Run()));
    ASSERT_TRUE((RefitJob{RefitMode::kFast, &grouped, &*rest_grouped, world, {}, out_grouped}.Run()));
    const auto scalar = ScalarFastRefit(grouped, *rest_grouped, world, test::Bound::kRestData);
    for (size_t s = 0; s < 2; ++s) {
      ASSERT_EQ(out_grouped[s], scalar[s]) << "pose " << p << " sphere " << s;
      ASSERT_LE(out_grouped[s].w(), out[s].w()) << "pose " << p << " sphere " << s;
      for (uint32_t k = set.vertex_offsets[s]; k < set.vertex_offsets[s + 1]; ++k) {
        const uint32_t v = set.vertices[k];
        const Eigen::Vector3d skinned = SkinnedInDouble(set, world, v);
        for (const skinspheres::Vec4f& sphere : {out[s], out_grouped[s]}) {
          ASSERT_LE((skinned - sphere.head<3>().cast<double>()).norm(), sphere.w())
              << "pose " << p << " sphere " << s << " vertex " << v;
        }
      }
    }
  }
}

// A set with neither reach nor mesh (a version-1 file, or a fast-only one written before reach)
// refits with the bound without reach bit for bit, and so does any set whose reach is all 1.
TEST(RefitJobTest, WithoutReachOrMeshTheFastBoundIsTheOldOneBitForBit) {
  auto fc = test::LoadFitted("builtin");
  ASSERT_TRUE(fc);
  // Files of those versions hold no reach groups either (sphere_set.h).
  SphereSet without_groups = fc->set;
  without_groups.ClearReachGroups();
  SphereSet old_set = without_groups;
  old_set.influence_reach.clear();
  old_set.mesh = {};
  old_set.triangle_vertices.clear();
  ASSERT_FALSE(old_set.Validate().has_value()) << old_set.Validate()->message;
  SphereSet ones = without_groups;
  ones.influence_reach.assign(ones.influence_joints.size(), 1.0f);
  std::mt19937 rng(5);
  for (const SphereSet* set : {&old_set, &ones}) {
    auto rest = RefitRestData::Create(*set);
    ASSERT_TRUE(rest.ok()) << rest.error().message;
    for (int p = 0; p < 40; ++p) {
      const Pose pose = test::MakePose(fc->character, test::RandomLocal(fc->character, rng, 90.0f, 0.3f), "random");
      const auto want = ScalarFastRefit(*set, *rest, pose.world, test::Bound::kWithoutReach);
      std::vector<skinspheres::Vec4f> got(set->size());
      ASSERT_TRUE((RefitJob{RefitMode::kFast, set, &*rest, pose.world, {}, got}.Run()));
      for (size_t s = 0; s < set->size(); ++s) {
        for (int c = 0; c < 4; ++c) {
          ASSERT_EQ(std::bit_cast<uint32_t>(got[s][c]), std::bit_cast<uint32_t>(want[s][c])) << "sphere " << s;
        }
      }
    }
  }
}

}  // namespace
}  // namespace skinspheres::runtime
