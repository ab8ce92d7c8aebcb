// RefitJob: conservativeness on the built-in and shared characters (clip frames and random poses
// with non-uniform scale, against a naive LBS of every vertex), exact radius = brute-force max
// distance, fast >= exact, the fast bound with the influences' reach never above the bound without
// it (and below it on a case built for it), 1 vs 2 threads, Validate() refusals, NaN. The analytic
// cases of the fast bound are in fast_bound_tests.cc.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <bit>
#include <cfloat>
#include <cmath>
#include <cstdio>
#include <limits>
#include <random>
#include <string>
#include <utility>

#include "refit/fast_reference.h"
#include "refit/refit_internal.h"  // runtime/src: pins the instruction set of the fast refit
#include "runtime/posed_characters.h"
#include "runtime/refit/refit_levels.h"
#include "runtime/refit/scalar_fast_refit.h"
#include "runtime/sample_sphere_set.h"
#include "skinspheres/runtime/refit/mesh_bounds.h"
#include "skinspheres/runtime/refit/refit_job.h"

namespace skinspheres::runtime {
namespace {

using test::FittedCharacter;
using test::Pose;

using test::ScalarFastRefit;

struct Refits {
  std::vector<skinspheres::Vec4f> exact, exact_box, fast;
};

Refits RunAll(const SphereSet& set, const RefitRestData& rest, const Pose& pose) {
  Refits r;
  r.exact.assign(set.size(), skinspheres::Vec4f::Zero());
  r.exact_box = r.fast = r.exact;
  RefitJob job;
  job.set = &set;
  job.rest = &rest;
  job.mode = RefitMode::kExact;
  job.joint_world = pose.world;
  job.positions = pose.positions;
  job.out = r.exact;
  EXPECT_TRUE(job.Run()) << pose.label;
  job.joint_world = {};
  job.out = r.exact_box;
  EXPECT_TRUE(job.Run()) << pose.label;
  job.mode = RefitMode::kFast;
  job.joint_world = pose.world;
  job.positions = {};
  job.out = r.fast;
  EXPECT_TRUE(job.Run()) << pose.label;
  return r;
}

// Every vertex of every owned triangle inside (in double, 1e-5 relative tolerance); exact radius =
// brute-force max distance over the source vertices; fast radius >= exact radius (same centre).
// Returns the number of failures found (stops reporting after a few).
double g_sum_exact = 0, g_sum_fast = 0, g_sum_old = 0;  // radius sums over the poses checked, for the printout
size_t g_old_spheres = 0,
       g_tighter = 0;  // fast spheres compared with the bound without reach, and how many are smaller

int CheckPose(const FittedCharacter& fc, const RefitRestData& rest, const Pose& pose) {
  const SphereSet& set = fc.set;
  const Refits r = RunAll(set, rest, pose);
  // The same frame under the bound without reach (the formula as it was, in the scalar reference).
  const std::vector<skinspheres::Vec4f> old = ScalarFastRefit(set, rest, pose.world, test::Bound::kWithoutReach);
  for (size_t s = 0; s < set.size(); ++s) {
    g_sum_exact += r.exact[s].w();
    g_sum_fast += r.fast[s].w();
    g_sum_old += old[s].w();
  }
  int failures = 0;
  auto fail = [&](const std::string& what) {
    if (++failures <= 5) ADD_FAILURE() << fc.character.source_file << " " << pose.label << ": " << what;
  };
  auto inside = [&](const skinspheres::Vec4f& sph, const Eigen::Vector3f& p) {
    const double d = (p.cast<double>() - sph.head<3>().cast<double>()).norm();
    return d <= sph.w() * (1.0 + 1e-5);
  };
  // The fast bound carries its own rounding margin (refit_job.h): no tolerance on top of it.
  auto inside_fast = [&](const skinspheres::Vec4f& sph, const Eigen::Vector3f& p) {
    return (p.cast<double>() - sph.head<3>().cast<double>()).norm() <= double(sph.w());
  };
  for (size_t s = 0; s < set.size(); ++s) {
    for (uint32_t k = set.triangle_offsets[s]; k < set.triangle_offsets[s + 1]; ++k) {
      const Eigen::Vector3i& tri = fc.character.triangles[set.triangles[k]];
      for (int c = 0; c < 3; ++c) {
        const Eigen::Vector3f& p = pose.positions[tri[c]];
        if (!inside(r.exact[s], p)) fail("exact sphere " + std::to_string(s) + " misses a vertex");
        if (!inside(r.exact_box[s], p)) fail("exact (box centre) sphere " + std::to_string(s) + " misses a vertex");
        if (!inside_fast(r.fast[s], p)) fail("fast sphere " + std::to_string(s) + " misses a vertex");
      }
    }
    // Oracle: the max distance from the exact centre to the source vertices.
    double dmax = 0.0;
    for (uint32_t k = set.vertex_offsets[s]; k < set.vertex_offsets[s + 1]; ++k) {
      dmax =
          std::max(dmax, (pose.positions[set.vertices[k]].cast<double>() - r.exact[s].head<3>().cast<double>()).norm());
    }
    const double coord = r.exact[s].head<3>().cwiseAbs().maxCoeff();
    if (!(r.exact[s].w() >= dmax * (1 - 1e-6) && r.exact[s].w() <= dmax + 4e-6 * (coord + dmax) + 1e-30)) {
      fail("exact radius " + std::to_string(r.exact[s].w()) + " != max distance " + std::to_string(dmax));
    }
    if (r.fast[s].head<3>() != r.exact[s].head<3>()) fail("fast and exact centres differ");
    // Every source vertex (not only those of owned triangles) inside the fast sphere: what the
    // bound's derivation covers, reach included.
    for (uint32_t k = set.vertex_offsets[s]; k < set.vertex_offsets[s + 1]; ++k) {
      if (!inside_fast(r.fast[s], pose.positions[set.vertices[k]])) {
        fail("fast sphere " + std::to_string(s) + " misses its source vertex " + std::to_string(set.vertices[k]));
      }
    }
    // Never above the bound without reach (min(max, sum) <= max, and the margin grows with r).
    if (old[s].head<3>() != r.fast[s].head<3>() || !(r.fast[s].w() <= old[s].w())) {
      fail("fast sphere " + std::to_string(s) + " radius " + std::to_string(r.fast[s].w()) +
           " above the bound without reach " + std::to_string(old[s].w()));
    }
    ++g_old_spheres;
    g_tighter += r.fast[s].w() < old[s].w();
    // fast >= exact up to the rounding margin (both add ~2e-6 of the coordinates, refit_job.h).
    if (!(r.fast[s].w() >= r.exact[s].w() - 4e-6 * (coord + dmax))) {
      fail("fast radius " + std::to_string(r.fast[s].w()) + " below exact radius " + std::to_string(r.exact[s].w()));
    }
  }
  return failures;
}

void CheckCharacter(const std::string& name, int frames_per_clip, int random_poses) {
  auto fc = test::LoadFitted(name);
  ASSERT_TRUE(fc);
  auto rest = RefitRestData::Create(fc->set);
  ASSERT_TRUE(rest.ok()) << rest.error().message;
  int failures = 0, poses = 0;
  g_sum_exact = g_sum_fast = g_sum_old = 0;
  g_old_spheres = g_tighter = 0;
  EXPECT_EQ(fc->set.influence_reach.size(), fc->set.influence_joints.size()) << "the fitter writes the reach";
  for (const Pose& pose : test::ClipPoses(fc->character, frames_per_clip)) {
    failures += CheckPose(*fc, *rest, pose);
    ++poses;
  }
  std::mt19937 rng(12345);
  for (int i = 0; i < random_poses; ++i) {
    const float scale_probability = (i % 2) ? 0.3f : 0.0f;  // odd poses: non-uniform scales
    failures += CheckPose(*fc, *rest,
                          test::MakePose(fc->character, test::RandomLocal(fc->character, rng, 60.0f, scale_probability),
                                         "random#" + std::to_string(i)));
    ++poses;
  }
  EXPECT_EQ(failures, 0);
  EXPECT_GT(poses, random_poses - 1);
  const double posed_ratio = g_sum_fast / g_sum_exact, old_ratio = g_sum_old / g_sum_exact;
  const double tighter_share = static_cast<double>(g_tighter) / static_cast<double>(g_old_spheres);
  // Tightness figure, for the record: at the rest pose exact radii equal the fitted radii.
  const Pose rest_pose = test::MakePose(fc->character, fc->character.skeleton.rest_local, "rest");
  const Refits r = RunAll(fc->set, *rest, rest_pose);
  double sum_exact = 0, sum_fast = 0, sum_fit = 0;
  for (size_t s = 0; s < fc->set.size(); ++s) {
    sum_exact += r.exact[s].w();
    sum_fast += r.fast[s].w();
    sum_fit += fc->set.radii_rest[s];
    EXPECT_NEAR(r.exact[s].w(), fc->set.radii_rest[s], 1e-4 * (fc->set.radii_rest[s] + fc->set.centers_rest[s].norm()));
  }
  std::printf(
      "%s: %zu spheres, %d poses; rest pose sum of radii exact/fit %.4f fast/fit %.4f; posed fast/exact %.3f "
      "(without reach %.3f; %.0f%% of the fast spheres smaller with it)\n",
      name.c_str(), fc->set.size(), poses, sum_exact / sum_fit, sum_fast / sum_fit, posed_ratio, old_ratio,
      100.0 * tighter_share);
}

TEST(RefitJobTest, BuiltinCharacterIsCoveredInBothModes) { CheckCharacter("builtin", 1000, 100); }

// Pins the fast refit's instruction set for a scope (internal::PinRefitSimd), unpinned after.
class PinnedRefit {
 public:
  explicit PinnedRefit(SimdLevel level) : ok_(internal::PinRefitSimd(level)) {}
  ~PinnedRefit() { internal::PinRefitSimd(SimdLevel::kAuto); }
  PinnedRefit(const PinnedRefit&) = delete;
  PinnedRefit& operator=(const PinnedRefit&) = delete;
  bool ok() const { return ok_; }

 private:
  bool ok_;
};

// Runs check() with the fast refit at each level the build and CPU have (portable always; SSE2 on
// every x86-64; AVX2 when present; what is missing is said), and checks that each pin took.
template <class Check>
void AtEveryRefitLevel(const std::string& what, Check&& check) {
  for (const SimdLevel level : {SimdLevel::kPortable, SimdLevel::kSse2, SimdLevel::kAvx2}) {
    const PinnedRefit pin(level);
    if (!pin.ok()) {
      ASSERT_NE(level, SimdLevel::kPortable);
      std::printf("%s: %s not checked, the CPU lacks it\n", what.c_str(), internal::RefitLevelName(level));
      continue;
    }
    ASSERT_EQ(internal::RefitSimdInUse(), level);
    internal::NoteRefitSimdRun(SimdLevel::kAuto);
    check();
    if (::testing::Test::HasFatalFailure()) {
      ADD_FAILURE() << "at " << internal::RefitLevelName(level);
      return;
    }
    // The copy of that level ran (both give the same bits, so the results alone cannot say).
    ASSERT_EQ(internal::LastRefitSimdRun(), level) << what;
    std::printf("%s: checked at %s\n", what.c_str(), internal::RefitLevelName(level));
  }
}

// count random poses of the character's joints (seeded); every second one with every linear
// coefficient perturbed and far translations, so any affine map, not a skeleton's motion.
std::vector<std::vector<skinspheres::Mat4f>> AnyAffinePoses(const FittedCharacter& fc, uint32_t seed, int count) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> noise(-0.05f, 0.05f), far(-300.0f, 300.0f);
  std::vector<std::vector<skinspheres::Mat4f>> worlds;
  for (int p = 0; p < count; ++p) {
    Pose pose = test::MakePose(fc.character, test::RandomLocal(fc.character, rng, 90.0f, 0.3f), "random");
    if (p % 2 == 1) {
      for (auto& g : pose.world) {
        for (int i = 0; i < 3; ++i)
          for (int j = 0; j < 3; ++j) g(i, j) += noise(rng);
        for (int i = 0; i < 3; ++i) g(i, 3) += far(rng);
      }
    }
    worlds.push_back(std::move(pose.world));
  }
  return worlds;
}

// The SIMD fast refit gives the scalar formula's bits: random poses with non-uniform scale, then
// the same joint matrices with every coefficient perturbed and far translations (any affine map),
// whole set and split ranges, at every instruction set.
void CheckFastBitsAtOneLevel(const std::string& name, int poses);
void CheckFastBits(const std::string& name, int poses) {
  AtEveryRefitLevel(name, [&] { CheckFastBitsAtOneLevel(name, poses); });
}

void CheckFastBitsAtOneLevel(const std::string& name, int poses) {
  auto fc = test::LoadFitted(name);
  ASSERT_TRUE(fc);
  auto rest = RefitRestData::Create(fc->set);
  ASSERT_TRUE(rest.ok());
  size_t compared = 0;
  const std::vector<std::vector<skinspheres::Mat4f>> worlds = AnyAffinePoses(*fc, 11, poses);
  for (int p = 0; p < poses; ++p) {
    const std::vector<skinspheres::Mat4f>& world = worlds[p];
    const auto want = ScalarFastRefit(fc->set, *rest, world, test::Bound::kRestData);
    std::vector<skinspheres::Vec4f> got(fc->set.size()), split(fc->set.size());
    RefitJob job{RefitMode::kFast, &fc->set, &*rest, world, {}, got};
    ASSERT_TRUE(job.Run());
    job.out = split;
    for (size_t b = 0; b < fc->set.size(); b += 5) ASSERT_TRUE(job.RunRange(b, std::min(b + 5, fc->set.size())));
    for (size_t s = 0; s < fc->set.size(); ++s) {
      for (int c = 0; c < 4; ++c) {
        ASSERT_EQ(std::bit_cast<uint32_t>(got[s][c]), std::bit_cast<uint32_t>(want[s][c]))
            << name << " pose " << p << " sphere " << s << " coordinate " << c << ": " << got[s][c] << " vs "
            << want[s][c];
        ASSERT_EQ(std::bit_cast<uint32_t>(split[s][c]), std::bit_cast<uint32_t>(want[s][c])) << name << " sphere " << s;
      }
      ++compared;
    }
  }
  std::printf("%s: %zu fast spheres bit-identical to the scalar formula\n", name.c_str(), compared);
}

TEST(RefitJobTest, FastModeBitIdenticalToScalarFormulaBuiltin) { CheckFastBits("builtin", 200); }

// A set of `joints` joints in a chain, sphere 0 on `influences` of them (every `stride`th, modulo the
// chain), sphere 1 on the last; random affine rest matrices. RandomAffine(scale): identity plus scale x U(-1, 1) per
// linear coefficient, translations U(-3, 3).
struct ManyInfluences {
  SphereSet set;
  std::mt19937 rng{17};
  skinspheres::Mat4f RandomAffine(float scale) {
    std::uniform_real_distribution<float> u(-1.0f, 1.0f);
    skinspheres::Mat4f g = skinspheres::Mat4f::Identity();
    for (int r = 0; r < 3; ++r) {
      for (int c = 0; c < 3; ++c) g(r, c) = (r == c ? 1.0f : 0.0f) + scale * u(rng);
      g(r, 3) = 3.0f * u(rng);
    }
    return g;
  }
  explicit ManyInfluences(int joints, int influences = 20, int stride = 15) {
    set = TwoSpheres();
    set.joint_names.clear();
    set.joint_parents.clear();
    for (int j = 0; j < joints; ++j) {
      std::string name = "j";  // (not "j" + to_string: GCC 12 warns falsely of overlapping memcpy)
      name += std::to_string(j);
      set.joint_names.push_back(name);
      set.joint_parents.push_back(j - 1);
    }
    set.joint_rest_world.clear();
    for (int j = 0; j < joints; ++j) set.joint_rest_world.push_back(RandomAffine(0.2f));
    set.sphere_joint = {0, static_cast<uint16_t>(joints - 1)};
    set.influence_joints.clear();
    set.influence_weights.clear();
    for (int k = 0; k < influences; ++k) {
      set.influence_joints.push_back(static_cast<uint16_t>((k * stride) % (joints - 1)));
      set.influence_weights.push_back(0.1f + 0.05f * static_cast<float>(k));
    }
    set.influence_joints.push_back(static_cast<uint16_t>(joints - 1));
    set.influence_weights.push_back(1.0f);
    set.influence_offsets = {0, static_cast<uint32_t>(influences), static_cast<uint32_t>(influences) + 1};
    // Small reaches (summing to more than 1, as Validate asks), so that the bound's sum term
    // Σ W_j |d_j|, which reads every recomputed point, is the smaller one on some poses.
    const float base = influences >= 20 ? 0.06f : 0.3f;
    for (int k = 0; k < influences; ++k) set.influence_reach.push_back(base + 0.01f * static_cast<float>(k % 3));
    set.influence_reach.push_back(1.0f);
  }
  // Reach groups with blends (docs/REFIT.md#reach-groups, #group-blends): three on sphere 0 (radii
  // 0.7, 0.85 and 1 of its fast radius, reaches growing with the group, blend weights rising with the
  // entry and summing to 1, deviations 0.01 to 0.05), one on sphere 1. The kernels' group loops then
  // run over more entries than they keep moved points for.
  void AddBlendedGroups() {
    const size_t k_count = set.influence_offsets[1];
    set.reach_group_offsets = {0, 3, 4};
    double total = 0.0;
    for (size_t k = 0; k < k_count; ++k) total += static_cast<double>(k + 1);
    for (int g = 0; g < 3; ++g) {
      set.reach_group_radii.push_back(set.radii_fast[0] * (0.7f + 0.15f * static_cast<float>(g)));
      for (size_t k = 0; k < k_count; ++k) {
        set.reach_group_weights.push_back(
            std::min(1.0f, set.influence_reach[k] * (1.0f + 0.25f * static_cast<float>(g))));
        set.reach_group_blend.push_back(static_cast<float>(static_cast<double>(k + 1) / total));
        set.reach_group_deviation.push_back(0.01f + 0.02f * static_cast<float>(g));
      }
    }
    set.reach_group_radii.push_back(set.radii_fast[1]);
    set.reach_group_weights.push_back(1.0f);
    set.reach_group_blend.push_back(1.0f);
    set.reach_group_deviation.push_back(0.0f);
  }  // The groups of AddBlendedGroups: with their blends (kBlended), or without (kGroups: the kernels'
  // copy without blends, the crowd's usual case, with several groups per sphere).
  enum Groups { kOne, kGroups, kBlended };
  void AddGroups(Groups groups) {
    if (groups == kOne) return;
    AddBlendedGroups();
    if (groups == kGroups) set.reach_group_blend.clear(), set.reach_group_deviation.clear();
  }
  static const char* Name(Groups groups) {
    return groups == kOne ? "one group" : groups == kGroups ? "groups" : "blended groups";
  }
};

// The paths the characters do not take: a sphere of more influences than the loop keeps moved
// points for (16), and more joints than a call keeps stretches for on the stack (256). 300 joints
// in a chain, sphere 0 on 20 of them, sphere 1 on the last; random affine joint matrices.
// Then again with reach groups without blends and with them (ManyInfluences::AddGroups), checking
// that the blend term decides some of sphere 0's radii.
TEST(RefitJobTest, FastModeBitIdenticalWithManyInfluencesAndJoints) {
  for (const auto groups : {ManyInfluences::kOne, ManyInfluences::kGroups, ManyInfluences::kBlended}) {
    constexpr int kJoints = 300;
    ManyInfluences many(kJoints);
    many.AddGroups(groups);
    const SphereSet& set = many.set;
    const auto random_affine = [&](float scale) { return many.RandomAffine(scale); };
    ASSERT_FALSE(set.Validate().has_value()) << set.Validate()->message;
    auto rest = RefitRestData::Create(set);
    ASSERT_TRUE(rest.ok()) << rest.error().message;
    SphereSet unblended = set;
    unblended.reach_group_blend.clear();
    unblended.reach_group_deviation.clear();
    auto rest_unblended = RefitRestData::Create(unblended);
    ASSERT_TRUE(rest_unblended.ok()) << rest_unblended.error().message;
    int sum_term_smaller = 0, blend_smaller = 0;
    AtEveryRefitLevel(std::string("20 influences, 300 joints, ") + ManyInfluences::Name(groups), [&] {
      for (int p = 0; p < 50; ++p) {
        std::vector<skinspheres::Mat4f> world;
        for (int j = 0; j < kJoints; ++j) world.push_back(random_affine(0.5f));
        const auto want = ScalarFastRefit(set, *rest, world, test::Bound::kRestData);
        sum_term_smaller += want[0].w() < ScalarFastRefit(set, *rest, world, test::Bound::kWithoutReach)[0].w() ? 1 : 0;
        if (groups == ManyInfluences::kBlended) {
          blend_smaller +=
              want[0].w() < ScalarFastRefit(unblended, *rest_unblended, world, test::Bound::kRestData)[0].w() ? 1 : 0;
        }
        std::vector<skinspheres::Vec4f> got(2);
        ASSERT_TRUE((RefitJob{RefitMode::kFast, &set, &*rest, world, {}, got}.Run()));
        for (size_t s = 0; s < 2; ++s) {
          for (int c = 0; c < 4; ++c) {
            ASSERT_EQ(std::bit_cast<uint32_t>(got[s][c]), std::bit_cast<uint32_t>(want[s][c]))
                << "pose " << p << " sphere " << s;
          }
        }
      }
    });
    // (With the groups' larger reaches and no blends the sum term rarely wins: 16 of 150 poses at
    // three levels, 5 of 50 under qemu's one; there the point is the bits of the copy without blends.)
    if (groups != ManyInfluences::kGroups) {
      EXPECT_GT(sum_term_smaller, 10) << "the sum term decided too few of the big sphere's radii";
    }
    if (groups == ManyInfluences::kBlended) {
      EXPECT_GT(blend_smaller, 10) << "the blend term decided too few of the big sphere's radii";
    }
    std::printf("%s: sum term smaller on %d of the poses checked, blend term on %d\n", ManyInfluences::Name(groups),
                sum_term_smaller, blend_smaller);
  }
}

// The crowd's batch (internal::RefitFastBatch: W instances of one set at once, one per lane, W =
// RefitBatchLanes() at the level pinned) against the scalar formula, lane by lane, bit for bit, in
// both of its outputs. worlds: one joint-matrix array per lane (lanes may share one, and then their
// output); bad: lanes expected to fail (non-finite).
void CheckBatchLanes(SimdLevel level, const SphereSet& set, const RefitRestData& rest,
                     const std::vector<const std::vector<skinspheres::Mat4f>*>& worlds, uint32_t bad,
                     const std::string& what) {
  const size_t width = internal::RefitBatchLanes();
  ASSERT_EQ(worlds.size(), width);
  std::vector<std::vector<skinspheres::Vec4f>> outs(worlds.size(), std::vector<skinspheres::Vec4f>(set.size()));
  const float* world[internal::kRefitBatchLanes];
  float* out[internal::kRefitBatchLanes];
  for (size_t b = 0; b < worlds.size(); ++b) {
    world[b] = reinterpret_cast<const float*>(worlds[b]->data());
    size_t first = b;  // lanes that share a world share the output of the first of them
    while (first > 0 && worlds[first - 1] == worlds[b]) --first;
    out[b] = reinterpret_cast<float*>(outs[first].data());
  }
  internal::NoteRefitSimdRun(SimdLevel::kAuto);
  std::vector<float> soa(4 * width * set.size(), -1.0f);  // the same spheres lanes side by side (crowd query)
  const uint32_t finite = internal::RefitFastBatch(set, rest, world, out, soa.data());
  ASSERT_EQ(internal::LastRefitSimdRun(), level) << what;
  EXPECT_EQ(finite, ((1u << width) - 1) & ~bad) << what;
  for (size_t b = 0; b < worlds.size(); ++b) {
    if ((bad >> b) & 1u) continue;
    size_t first = b;
    while (first > 0 && worlds[first - 1] == worlds[b]) --first;
    const auto want = ScalarFastRefit(set, rest, *worlds[b], test::Bound::kRestData);
    for (size_t s = 0; s < set.size(); ++s) {
      for (int c = 0; c < 4; ++c) {
        ASSERT_EQ(std::bit_cast<uint32_t>(outs[first][s][c]), std::bit_cast<uint32_t>(want[s][c]))
            << what << ": lane " << b << " sphere " << s << " coordinate " << c;
        ASSERT_EQ(std::bit_cast<uint32_t>(soa[4 * width * s + width * c + b]), std::bit_cast<uint32_t>(want[s][c]))
            << what << ": lanes side by side, lane " << b << " sphere " << s << " coordinate " << c;
      }
    }
  }
}

// Every level's batch: AVX-512 (16 lanes), AVX2 (8), SSE2 and portable (4), where the CPU has it.
class CrowdBatchLevel : public ::testing::TestWithParam<SimdLevel> {};

// W poses of the built-in character per batch, random (half of them with every coefficient
// perturbed and far translations, any affine map), then a batch with a NaN in lane W/2 + 1 (it
// alone fails) and one whose lanes from W/4 + 1 on repeat lane W/4 (a crowd's last, partial batch).
TEST_P(CrowdBatchLevel, GivesEachInstanceTheScalarBits) {
  const PinnedRefit pin(GetParam());
  if (!pin.ok()) GTEST_SKIP() << "the CPU lacks " << internal::RefitLevelName(GetParam());
  auto fc = test::LoadFitted("builtin");
  ASSERT_TRUE(fc);
  auto rest = RefitRestData::Create(fc->set);
  ASSERT_TRUE(rest.ok());
  ASSERT_TRUE(internal::RefitBatchUsable());
  const size_t width = internal::RefitBatchLanes();
  const std::vector<std::vector<skinspheres::Mat4f>> poses = AnyAffinePoses(*fc, 23, 16 * 12);
  for (size_t batch = 0; batch < poses.size() / width; ++batch) {
    std::vector<const std::vector<skinspheres::Mat4f>*> lanes;
    for (size_t b = 0; b < width; ++b) lanes.push_back(&poses[width * batch + b]);
    CheckBatchLanes(GetParam(), fc->set, *rest, lanes, 0, "batch " + std::to_string(batch));
  }
  const size_t nan_lane = width / 2 + 1, repeated = width / 4;
  std::vector<skinspheres::Mat4f> nan_pose = poses[nan_lane];
  nan_pose[fc->set.influence_joints[0]](1, 3) = std::numeric_limits<float>::quiet_NaN();
  std::vector<const std::vector<skinspheres::Mat4f>*> lanes;
  for (size_t b = 0; b < width; ++b) lanes.push_back(b == nan_lane ? &nan_pose : &poses[b]);
  CheckBatchLanes(GetParam(), fc->set, *rest, lanes, 1u << nan_lane, "NaN in lane " + std::to_string(nan_lane));
  for (size_t b = repeated + 1; b < width; ++b) lanes[b] = lanes[repeated];
  CheckBatchLanes(GetParam(), fc->set, *rest, lanes, 0, "lanes repeat lane " + std::to_string(repeated));
}

// The batch on a sphere of more influences than it keeps moved points for (20 > 8), and on one of 6
// whose joints all share one slot of its stretch table (every 16th joint: each stretch evicts the
// last, so the second pass computes them again), on a set of 300 joints; each with one group, with
// reach groups without blends (the batch's copy without blends) and with blends.
TEST_P(CrowdBatchLevel, ManyInfluencesAndJoints) {
  const PinnedRefit pin(GetParam());
  if (!pin.ok()) GTEST_SKIP() << "the CPU lacks " << internal::RefitLevelName(GetParam());
  constexpr int kJoints = 300;
  for (const auto& [influences, stride] : {std::pair{20, 15}, std::pair{6, 16}}) {
    for (const auto groups : {ManyInfluences::kOne, ManyInfluences::kGroups, ManyInfluences::kBlended}) {
      ManyInfluences many(kJoints, influences, stride);
      many.AddGroups(groups);
      ASSERT_FALSE(many.set.Validate().has_value()) << many.set.Validate()->message;
      auto rest = RefitRestData::Create(many.set);
      ASSERT_TRUE(rest.ok()) << rest.error().message;
      ASSERT_TRUE(internal::RefitBatchUsable());
      for (int batch = 0; batch < 8; ++batch) {
        std::vector<std::vector<skinspheres::Mat4f>> worlds(internal::RefitBatchLanes());
        std::vector<const std::vector<skinspheres::Mat4f>*> lanes;
        for (auto& w : worlds) {
          for (int j = 0; j < kJoints; ++j) w.push_back(many.RandomAffine(0.5f));
          lanes.push_back(&w);
        }
        CheckBatchLanes(GetParam(), many.set, *rest, lanes, 0,
                        std::to_string(influences) + " influences, 300 joints, " + ManyInfluences::Name(groups) +
                            ", batch " + std::to_string(batch));
      }
    }
  }
}

INSTANTIATE_TEST_SUITE_P(Levels, CrowdBatchLevel, test::AllRefitLevels(), test::RefitLevelName);

class SharedCharacterRefit : public ::testing::TestWithParam<std::string> {};

TEST_P(SharedCharacterRefit, IsCoveredInBothModes) {
  SKINSPHERES_REQUIRE_ASSET(path, GetParam());
  (void)path;
  CheckCharacter(GetParam(), 30, 40);
}

TEST_P(SharedCharacterRefit, FastModeBitIdenticalToScalarFormula) {
  SKINSPHERES_REQUIRE_ASSET(path, GetParam());
  (void)path;
  CheckFastBits(GetParam(), 20);
}

// The first source vertex of sphere s (skinned by the pose, in float) farther from the sphere's
// centre than its radius, in double; UINT32_MAX when none. Grid points are skipped.
uint32_t SourceVertexOutside(const SphereSet& set, const Pose& pose, size_t s, const skinspheres::Vec4f& sphere) {
  for (uint32_t k = set.vertex_offsets[s]; k < set.vertex_offsets[s + 1]; ++k) {
    if (set.vertices[k] >= set.source_vertex_count) continue;
    const Eigen::Vector3f& v = pose.positions[set.vertices[k]];
    if ((v.cast<double>() - sphere.head<3>().cast<double>()).norm() > double(sphere.w())) return set.vertices[k];
  }
  return UINT32_MAX;
}

// The reach groups (docs/REFIT.md#reach-groups) and their blends ("Group blends"): the fitted set
// has both (Xbot no blends); on 30 random poses every fast radius is at most the same set's without the blends, which
// is at most the set's without groups (one group per sphere); the sums are smaller where spheres
// blend joints (printed); every vertex stays inside (IsCoveredInBothModes, and here every source
// vertex of the blended spheres, skinned in float by the pose, is checked in double).
TEST_P(SharedCharacterRefit, ReachGroupsNeverLoosenTheBound) {
  SKINSPHERES_REQUIRE_ASSET(path, GetParam());
  (void)path;
  auto fc = test::LoadFitted(GetParam());
  ASSERT_TRUE(fc);
  ASSERT_EQ(fc->set.reach_group_offsets.size(), fc->set.size() + 1);
  // The fitter stores blends where they pay (sphere_fitter.h, FitSettings::group_blends): on every
  // shared character but Xbot, whose fast radii they would shrink by 0.6% over its eight poses.
  if (GetParam() == "Xbot.glb") {
    EXPECT_TRUE(fc->set.reach_group_blend.empty());
  } else {
    ASSERT_EQ(fc->set.reach_group_blend.size(), fc->set.reach_group_weights.size());
  }
  SphereSet unblended = fc->set;
  unblended.reach_group_blend.clear();
  unblended.reach_group_deviation.clear();
  ASSERT_FALSE(unblended.Validate().has_value());
  SphereSet one_group = fc->set;
  one_group.ClearReachGroups();
  auto blended = RefitRestData::Create(fc->set), grouped = RefitRestData::Create(unblended),
       single = RefitRestData::Create(one_group);
  ASSERT_TRUE(blended.ok() && grouped.ok() && single.ok());
  std::mt19937 rng(4);
  double sum_blended = 0.0, sum_grouped = 0.0, sum_single = 0.0;
  for (int p = 0; p < 30; ++p) {
    const Pose pose = test::MakePose(fc->character, test::RandomLocal(fc->character, rng, 60.0f, 0.3f), "random");
    std::vector<skinspheres::Vec4f> a(fc->set.size()), b(fc->set.size()), c(fc->set.size());
    ASSERT_TRUE((RefitJob{RefitMode::kFast, &fc->set, &*blended, pose.world, {}, a}.Run()));
    ASSERT_TRUE((RefitJob{RefitMode::kFast, &unblended, &*grouped, pose.world, {}, b}.Run()));
    ASSERT_TRUE((RefitJob{RefitMode::kFast, &one_group, &*single, pose.world, {}, c}.Run()));
    for (size_t s = 0; s < a.size(); ++s) {
      ASSERT_LE(a[s].w(), b[s].w()) << "pose " << p << " sphere " << s;
      ASSERT_LE(b[s].w(), c[s].w()) << "pose " << p << " sphere " << s;
      sum_blended += a[s].w(), sum_grouped += b[s].w(), sum_single += c[s].w();
      ASSERT_EQ(SourceVertexOutside(fc->set, pose, s, a[s]), UINT32_MAX) << "sphere " << s << " pose " << p;
    }
  }
  std::printf("%s: fast radii summed over 30 random poses, reach groups / one group = %.3f, with blends %.3f\n",
              GetParam().c_str(), sum_grouped / sum_single, sum_blended / sum_single);
}

// Validate() holds each group to its members: a sphere's groups replaced by one group holding all of
// its source vertices (radius: the largest of their reference radii; reach: the largest weights)
// is accepted; that radius one ulp smaller, or one reach one ulp smaller, is refused by name.
TEST(RefitJobTest, AReachGroupThatMissesAVertexIsRefused) {
  auto fc = test::LoadFitted("builtin");
  ASSERT_TRUE(fc);
  SphereSet set = fc->set;
  auto vertices = FastBoundVerticesFromMesh(set);
  ASSERT_TRUE(vertices.ok()) << vertices.error().message;
  // The first sphere with two influences and two groups or more.
  size_t s = 0;
  while (s < set.size() && (set.influence_offsets[s + 1] - set.influence_offsets[s] < 2 ||
                            set.reach_group_offsets[s + 1] - set.reach_group_offsets[s] < 2)) {
    ++s;
  }
  ASSERT_LT(s, set.size()) << "no sphere blends two joints in two groups";
  const uint32_t k_count = set.influence_offsets[s + 1] - set.influence_offsets[s];
  float radius = 0.0f;
  std::vector<float> reach(k_count, 0.0f);
  for (uint32_t i = set.vertex_offsets[s]; i < set.vertex_offsets[s + 1]; ++i) {
    radius = std::max(radius, vertices->radius[i]);
    for (uint32_t k = 0; k < k_count; ++k) {
      reach[k] = std::max(reach[k],
                          vertices->weights[vertices->weight_offsets[s] + (i - set.vertex_offsets[s]) * k_count + k]);
    }
  }
  // Rebuild the arrays with sphere s's groups replaced by that one group.
  auto with_one_group = [&](float r, const std::vector<float>& w) {
    SphereSet out = set;
    out.ClearReachGroups();  // the blends too: this test is about the radius and the reach
    out.reach_group_offsets = {0};
    size_t base = 0;
    for (size_t t = 0; t < set.size(); ++t) {
      const uint32_t kc = set.influence_offsets[t + 1] - set.influence_offsets[t];
      const uint32_t g0 = set.reach_group_offsets[t], g1 = set.reach_group_offsets[t + 1];
      if (t == s) {
        out.reach_group_radii.push_back(r);
        out.reach_group_weights.insert(out.reach_group_weights.end(), w.begin(), w.end());
      } else {
        out.reach_group_radii.insert(out.reach_group_radii.end(), set.reach_group_radii.begin() + g0,
                                     set.reach_group_radii.begin() + g1);
        out.reach_group_weights.insert(out.reach_group_weights.end(), set.reach_group_weights.begin() + base,
                                       set.reach_group_weights.begin() + base + size_t{g1 - g0} * kc);
      }
      base += size_t{g1 - g0} * kc;
      out.reach_group_offsets.push_back(static_cast<uint32_t>(out.reach_group_radii.size()));
    }
    return out;
  };
  EXPECT_FALSE(with_one_group(radius, reach).Validate().has_value());
  const auto small_radius = with_one_group(std::nextafter(radius, 0.0f), reach).Validate();
  ASSERT_TRUE(small_radius.has_value());
  EXPECT_NE(small_radius->message.find("is in none of its reach groups"), std::string::npos) << small_radius->message;
  for (uint32_t k = 0; k < k_count; ++k) {
    if (reach[k] <= 0.0f) continue;
    std::vector<float> lower = reach;
    lower[k] = std::nextafter(lower[k], 0.0f);
    EXPECT_TRUE(with_one_group(radius, lower).Validate().has_value()) << "reach " << k << " one ulp smaller";
  }
}

// The fitter stores the bind pose as the fast refit's reference only where it bounds tighter
// (docs/REFIT.md#reference-frame). The same set with each reference (no reach groups: they are
// measured in the reference frame) is refitted on 30 random poses: where the fitter stored the bind
// pose, its fast radii sum to less than 99% of the rest pose's; where it did not, the bind pose
// would not have saved 1% (RobotExpressive and Soldier, whose rest poses are not their bind poses,
// have both). Since the fast radius takes each vertex's mean copy distance no shared character
// stores it (ARestPoseAwayFromBindTakesTheBindPoseAsReference covers a set that does). Every vertex stays inside with
// either (IsCoveredInBothModes, and the loop below checks the bind reference's).
TEST_P(SharedCharacterRefit, FastReferenceIsStoredOnlyWhereItBoundsTighter) {
  SKINSPHERES_REQUIRE_ASSET(path, GetParam());
  (void)path;
  auto fc = test::LoadFitted(GetParam());
  ASSERT_TRUE(fc);
  const bool stored = !fc->set.fast_reference_spheres.empty();
  SphereSet rest_set = fc->set;
  rest_set.fast_reference_inverse.clear();
  rest_set.fast_reference_spheres.clear();
  rest_set.ClearReachGroups();
  SphereSet bind_set = rest_set;
  auto built = internal::StoreBindFastReference(&bind_set);
  ASSERT_TRUE(built.ok()) << built.error().message;
  ASSERT_TRUE(*built);
  ASSERT_FALSE(bind_set.Validate().has_value()) << bind_set.Validate()->message;
  auto bind_rest = RefitRestData::Create(bind_set), rest_rest = RefitRestData::Create(rest_set);
  ASSERT_TRUE(bind_rest.ok() && rest_rest.ok());
  std::mt19937 rng(3);
  double sum_bind = 0.0, sum_rest = 0.0;
  for (int p = 0; p < 30; ++p) {
    const Pose pose = test::MakePose(fc->character, test::RandomLocal(fc->character, rng, 60.0f, 0.3f), "random");
    std::vector<skinspheres::Vec4f> a(fc->set.size()), b(fc->set.size());
    ASSERT_TRUE((RefitJob{RefitMode::kFast, &bind_set, &*bind_rest, pose.world, {}, a}.Run()));
    ASSERT_TRUE((RefitJob{RefitMode::kFast, &rest_set, &*rest_rest, pose.world, {}, b}.Run()));
    for (size_t s = 0; s < a.size(); ++s) {
      sum_bind += a[s].w(), sum_rest += b[s].w();
      ASSERT_EQ(SourceVertexOutside(fc->set, pose, s, a[s]), UINT32_MAX) << "sphere " << s << " pose " << p;
    }
  }
  std::printf("%s: fast radii summed over 30 random poses, bind reference / rest reference = %.3f (%s)\n",
              GetParam().c_str(), sum_bind / sum_rest, stored ? "bind stored" : "rest kept");
  if (stored) {
    EXPECT_LT(sum_bind, 0.99 * sum_rest);
  } else {
    EXPECT_GE(sum_bind, 0.99 * sum_rest);
  }
}

INSTANTIATE_TEST_SUITE_P(Assets, SharedCharacterRefit, ::testing::ValuesIn(test::SharedCharacters()),
                         [](const auto& param_info) {
                           std::string n = param_info.param;
                           return n.substr(0, n.find('.'));
                         });

TEST(RefitJobTest, SameOutputForOneAndTwoThreads) {
  auto fc = test::LoadFitted("builtin");
  ASSERT_TRUE(fc);
  auto rest = RefitRestData::Create(fc->set);
  ASSERT_TRUE(rest.ok());
  std::mt19937 rng(7);
  const Pose pose = test::MakePose(fc->character, test::RandomLocal(fc->character, rng, 60.0f, 0.3f), "random");
  for (RefitMode mode : {RefitMode::kExact, RefitMode::kFast}) {
    std::vector<skinspheres::Vec4f> serial(fc->set.size()), one(fc->set.size()), two(fc->set.size());
    RefitJob job{mode, &fc->set, &*rest, pose.world, pose.positions, serial};
    ASSERT_TRUE(job.Run());
    job.out = one;
    test::WithDefaultThreads(1, [&] { EXPECT_TRUE(job.RunParallel(DefaultParallelFor(), 1)); });
    job.out = two;
    test::WithDefaultThreads(2, [&] { EXPECT_TRUE(job.RunParallel(DefaultParallelFor(), 1)); });
    // Split by hand too: any range split gives the same bits.
    std::vector<skinspheres::Vec4f> split(fc->set.size());
    job.out = split;
    for (size_t b = 0; b < fc->set.size(); b += 7) EXPECT_TRUE(job.RunRange(b, std::min(b + 7, fc->set.size())));
    for (size_t s = 0; s < fc->set.size(); ++s) {
      EXPECT_EQ(serial[s], one[s]) << ToString(mode) << " sphere " << s;
      EXPECT_EQ(serial[s], two[s]) << ToString(mode) << " sphere " << s;
      EXPECT_EQ(serial[s], split[s]) << ToString(mode) << " sphere " << s;
    }
  }
}

TEST(RefitJobTest, ValidateRefusesBadJobs) {
  EXPECT_FALSE(RefitJob{}.Validate());
  EXPECT_FALSE(RefitJob{}.Run());
  const SphereSet set = TwoSpheres();
  auto rest = RefitRestData::Create(set);
  ASSERT_TRUE(rest.ok());
  std::vector<skinspheres::Mat4f> world(1, skinspheres::Mat4f::Identity());
  std::vector<Eigen::Vector3f> pos(4, Eigen::Vector3f::Zero());
  std::vector<skinspheres::Vec4f> out(2);
  const RefitJob good_fast{RefitMode::kFast, &set, &*rest, world, {}, out};
  const RefitJob good_exact{RefitMode::kExact, &set, &*rest, world, pos, out};
  EXPECT_TRUE(good_fast.Validate());
  EXPECT_TRUE(good_exact.Validate());
  RefitJob j = good_exact;
  j.rest = nullptr;
  j.joint_world = {};
  EXPECT_TRUE(j.Validate()) << "exact mode without joints needs no rest data";
  j = good_exact;
  j.rest = nullptr;
  EXPECT_FALSE(j.Validate()) << "exact mode with joints needs rest data";
  j = good_fast;
  j.rest = nullptr;
  EXPECT_FALSE(j.Validate());
  j = good_fast;
  j.joint_world = {};
  EXPECT_FALSE(j.Validate()) << "fast mode needs joints";
  j = good_fast;
  j.out = std::span<skinspheres::Vec4f>(out).first(1);
  EXPECT_FALSE(j.Validate()) << "short output";
  j = good_exact;
  j.positions = std::span<const Eigen::Vector3f>(pos).first(3);
  EXPECT_FALSE(j.Validate()) << "short positions";
  j = good_fast;
  j.mode = static_cast<RefitMode>(7);
  EXPECT_FALSE(j.Validate()) << "unknown mode";
  // Rest data of another set.
  SphereSet other = TwoSpheres();
  other.centers_rest.push_back(Eigen::Vector3f::Zero());
  other.radii_rest.push_back(1);
  other.radii_fast.push_back(1);
  other.sphere_part.push_back(0);
  other.sphere_joint.push_back(0);
  other.sphere_level.push_back(2);
  other.vertex_offsets.push_back(6);
  other.triangle_offsets.push_back(2);
  other.influence_offsets = {0, 1, 2, 3};
  other.influence_joints = {0, 0, 0};
  other.influence_weights = {1, 1, 1};
  ASSERT_FALSE(other.Validate().has_value()) << other.Validate()->message;
  j = good_fast;
  j.set = &other;
  std::vector<skinspheres::Vec4f> out3(3);
  j.out = out3;
  EXPECT_FALSE(j.Validate()) << "rest data from another set";
  // Ranges.
  EXPECT_FALSE(good_fast.RunRange(1, 3));
  EXPECT_FALSE(good_fast.RunRange(2, 1));
  EXPECT_TRUE(good_fast.RunRange(1, 2));
  // Bad sets are refused when the rest data is built, naming the file.
  SphereSet bad = TwoSpheres();
  bad.source_file = "broken.json";
  bad.radii_fast.pop_back();
  auto r = RefitRestData::Create(bad);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find("broken.json"), std::string::npos) << r.error().message;
  bad = TwoSpheres();
  bad.source_file = "singular.json";
  bad.joint_rest_world[0] = skinspheres::Mat4f::Zero();
  bad.joint_rest_world[0](3, 3) = 1;
  r = RefitRestData::Create(bad);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find("not invertible"), std::string::npos) << r.error().message;
}

void NonFiniteInputFails();

// Every refusal, at every instruction set of the fast refit (exact mode has one).
TEST(RefitJobTest, NonFiniteInputFailsWithoutCrashing) {
  AtEveryRefitLevel("non-finite input", [] { NonFiniteInputFails(); });
}

void NonFiniteInputFails() {
  const SphereSet set = TwoSpheres();
  auto rest = RefitRestData::Create(set);
  ASSERT_TRUE(rest.ok());
  const float nan = std::numeric_limits<float>::quiet_NaN(), inf = std::numeric_limits<float>::infinity();
  std::vector<skinspheres::Vec4f> out(2);
  for (float bad : {nan, inf}) {
    std::vector<skinspheres::Mat4f> world(1, skinspheres::Mat4f::Identity());
    std::vector<Eigen::Vector3f> pos(4, Eigen::Vector3f::Ones());
    RefitJob fast{RefitMode::kFast, &set, &*rest, world, {}, out};
    RefitJob exact{RefitMode::kExact, &set, &*rest, world, pos, out};
    RefitJob box{RefitMode::kExact, &set, &*rest, {}, pos, out};
    EXPECT_TRUE(fast.Run());
    EXPECT_TRUE(exact.Run());
    EXPECT_TRUE(box.Run());
    world[0](1, 1) = bad;  // linear part only: centre may stay finite, the scale bound may not
    EXPECT_FALSE(fast.Run());
    EXPECT_FALSE(fast.RunParallel(DefaultParallelFor(), 1));
    world[0] = skinspheres::Mat4f::Identity();
    world[0](0, 3) = bad;
    EXPECT_FALSE(fast.Run());
    EXPECT_FALSE(exact.Run());
    world[0] = skinspheres::Mat4f::Identity();
    pos[3].y() = bad;  // a vertex of the second sphere only (vertex 3)
    EXPECT_FALSE(exact.Run());
    EXPECT_FALSE(box.Run());
    EXPECT_TRUE(exact.RunRange(0, 1)) << "the first sphere does not read vertex 3";
    EXPECT_TRUE(fast.Run()) << "fast mode reads no positions";
  }
}

}  // namespace
}  // namespace skinspheres::runtime
