// Runtime speed per character per frame, and for crowds, on the REAL Xbot character.
//
// Set-up (untimed, once per fit): SKINSPHERES_ASSET_DIR/Xbot.glb -> ImportCharacter
// -> SplitBodyParts -> FitSpheres (default FitSettings) -> CharacterAsset. Every benchmark
// SkipWithError()s with a message when the asset is absent or a stage fails. Rows with a `fit`
// argument run on two fits: fit:0 the default FitSettings, fit:1 the same without the tightening
// pass (FitSettings::tighten = false): the tight set against the paper's own spheres; the
// `spheres` counter says how many. The per-character rows run on one thread.
//
// Motion: Xbot's only clip is a held T-pose (0.067 s), so the bench drives the skeleton with a
// deterministic procedural loop of kFrames frames: arms lowered from the T-pose towards the body
// with a swing and an elbow bend (hands reach the torso and the thighs), legs walking with knee
// bend, spine twisting and bending, head nodding, plus a small wobble (fixed seed 42) on every
// other joint. Rotations are given about the body's axes (BodyParts up / left / forward) and
// applied at each joint's own origin, so no joint name is assumed. Poses change every frame and
// contacts happen (see the `contacts` counter). The per-frame inputs (joint-local transforms, and
// for the stages after the pose, G_j(t), skinning matrices and skinned source vertices) are
// precomputed at set-up; each iteration is one new frame of the loop.
//
// Per character per frame (one thread; each row times only its own stage):
//   BM_XbotSampleClip        SamplingJob on Xbot's own clip (65 joints), for reference
//   BM_XbotPose              LocalToModelJob + SkinningMatricesJob (the pose the runtime needs)
//   BM_XbotSkinSources/prepared:0  SkinningJob, CSR influences + subset = the spheres' source vertices
//   BM_XbotSkinSources/prepared:1  the same with PreparedInfluences (the fast layout), SIMD auto
//   BM_XbotRefitExact        CharacterInstance::UpdateExact (RefitJob, exact radii); the frame's
//                            skinned positions are copied (untimed) into one hot buffer first
//   BM_XbotRefitFast/simd:0|1|2  CharacterInstance::UpdateFast (RefitJob, Kavan-Žára radii), the
//                            refit's loop at the CPU's best level, pinned to SSE2, pinned to AVX2
//                            (runtime/src/refit/refit_internal.h; same bits at every level; in a
//                            -DSKINSPHERES_AVX2=ON build both copies are VEX code)
//   BM_XbotQuery/fast:0|1    BroadPhaseJob (sort and sweep) on the exact- or fast-refitted spheres
//   BM_XbotAllPairs/fast:0|1 FindSpherePairsBruteForce on the same spheres (the naive reference)
//   BM_XbotFrameExact        pose + skin sources (prepared) + UpdateExact + FindSpherePairs
//   BM_XbotFrameFast         pose + UpdateFast + FindSpherePairs
//   BM_XbotSetup             no timing: fit time, sphere / vertex counts, mean contacts per frame
// The query rows check, before timing, that sort-and-sweep equals all-pairs on every frame.
//
// Crowd (shared CharacterAsset, one CharacterInstance each, instance k plays the loop 7k frames
// ahead), at 1 and 2 threads:
//   BM_CrowdFast             CrowdUpdateAndFindSpherePairs(kFast): fast refit + query, 1 to 10,000
//                            instances, on a TBB arena of exactly 1 or 2 threads (thread_cpu.h),
//                            with each thread's CPU time in the work next to the wall time. G_j(t)
//                            per instance is precomputed per frame OUTSIDE the timed region.
//                            simd: the refit's level and batch (PinnedRefit: 1 SSE2, 2 AVX2, 4
//                            AVX-512 batches of 4, 8 and 16 instances refitted and queried at once,
//                            3 the AVX-512 batch queried one by one, 5 portable C++, 6 and 7 AVX2
//                            and SSE2 one instance at a time; 0 picks the CPU's best); 1000 and
//                            10,000 instances at every level, and the denser fits 2, 3 and 4 at 1000
//                            instances, one thread, at AVX2, AVX-512 and one at a time.
//   BM_CrowdPose             the separate row for that input: LocalToModelJob per instance under
//                            tbb::parallel_for (what an engine's animation system would do).
//
// Peers (built when CMake finds Bullet and FCL, which defines SKINSPHERES_HAVE_PEERS=1; see
// bench/CMakeLists.txt): BM_XbotPeerBulletDbvt and BM_XbotPeerFclDynamicTree on the same per-frame
// Xbot spheres as BM_XbotQuery, checked equal to all-pairs on every frame before timing.
#include <benchmark/benchmark.h>
#include <tbb/global_control.h>
#include <tbb/parallel_for.h>

#if defined(__GLIBC__)
#include <malloc.h>
#endif

#include <Eigen/Geometry>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include "crowd/crowd_query.h"  // runtime/src: the crowd's query batched or one by one
#include "peer_broad_phases.h"
#include "refit/refit_internal.h"  // runtime/src: pins the fast refit's instruction set for a row
#include "skinspheres/lib/body_parts/body_parts.h"
#include "skinspheres/lib/fit/sphere_fitter.h"
#include "skinspheres/lib/io/importer.h"
#include "skinspheres/runtime/api/character.h"
#include "skinspheres/runtime/broad_phase/broad_phase.h"
#include "skinspheres/runtime/crowd/crowd.h"
#include "skinspheres/skinning/local_to_model_job.h"
#include "skinspheres/skinning/prepared_influences.h"
#include "skinspheres/skinning/sampling_job.h"
#include "skinspheres/skinning/skinning_job.h"
#include "skinspheres/skinning/skinning_matrices_job.h"
#include "thread_cpu.h"

namespace {

namespace lib = skinspheres::lib;
namespace rt = skinspheres::runtime;
namespace sk = skinspheres::skinning;

constexpr int kFrames = 64;  // one loop of the procedural motion (about 2 s at 30 fps)

struct Xbot {
  std::string error;  // non-empty: set-up failed, every benchmark skips with this message
  lib::RawCharacter ch;
  lib::BodyParts parts;
  rt::SphereSet set;
  std::shared_ptr<const rt::CharacterAsset> asset;
  double fit_ms = 0.0;

  std::vector<uint32_t> sources;  // sorted unique source vertices of all spheres
  sk::PreparedInfluences prepared;

  // Per frame (kFrames): joint-local TRS, G_j(t), skinning matrices, skinned positions (source
  // vertices filled, others zero), refitted spheres of each mode, all-pairs contact counts.
  std::vector<std::vector<sk::Transform>> locals;
  std::vector<std::vector<skinspheres::Mat4f>> joint_world;
  std::vector<std::vector<skinspheres::Mat4f>> bind_matrices;
  std::vector<std::vector<Eigen::Vector3f>> skinned;
  std::vector<std::vector<skinspheres::Vec4f>> spheres_exact, spheres_fast;
  double contacts_exact = 0.0, contacts_fast = 0.0;  // mean per frame
};

std::span<const float> Floats(const std::vector<Eigen::Vector3f>& v) {
  return {reinterpret_cast<const float*>(v.data()), v.size() * 3};
}
std::span<float> Floats(std::vector<Eigen::Vector3f>& v) { return {reinterpret_cast<float*>(v.data()), v.size() * 3}; }

// The procedural pose of frame f: rest locals with world-axis rotations applied at the joints.
void MakeLocals(const Xbot& x, const std::vector<skinspheres::Mat4f>& rest_world, int f,
                std::vector<sk::Transform>* out) {
  const sk::Skeleton& skel = x.ch.skeleton;
  const size_t n = skel.size();
  *out = skel.rest_local;
  const float phi = 2.0f * float(M_PI) * float(f) / float(kFrames);
  const Eigen::Vector3f up = x.parts.up, left = x.parts.left, forward = left.cross(up).normalized();
  // Per joint, the world-space rotation to apply at the joint (identity = rest).
  std::vector<skinspheres::Quatf> world(n, skinspheres::Quatf::Identity());
  auto aa = [](float angle, const Eigen::Vector3f& axis) { return skinspheres::Quatf(Eigen::AngleAxisf(angle, axis)); };
  // Every joint: a small wobble with a seeded amplitude, axis and phase (same for every frame).
  std::mt19937 rng(42);
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  for (size_t j = 0; j < n; ++j) {
    const Eigen::Vector3f axis = Eigen::Vector3f(u(rng), u(rng), u(rng)).normalized();
    const float amp = 0.05f * (1.0f + u(rng)) * 0.5f, phase = float(M_PI) * u(rng);
    world[j] = aa(amp * std::sin(phi + phase), axis);
  }
  for (const lib::BodyPart& part : x.parts.parts) {
    const auto& c = part.chain;
    const bool is_left = part.kind == lib::PartKind::kArmLeft || part.kind == lib::PartKind::kLegLeft;
    const float sgn = is_left ? -1.0f : 1.0f;
    const float side_phase = is_left ? 0.0f : float(M_PI);
    switch (part.kind) {
      case lib::PartKind::kArmLeft:
      case lib::PartKind::kArmRight:
        if (c.size() >= 3) {
          // Upper arm (chain[1], after the clavicle): lowered from the T-pose about forward, then
          // swung forward and back about left. Forearm: elbow bend bringing the hand to the front.
          const float down = 1.2f + 0.25f * std::sin(phi + side_phase);
          const float swing = 0.45f * std::sin(phi + side_phase);
          world[c[1]] = aa(swing, left) * aa(sgn * down, forward);
          const float elbow = 0.9f + 0.7f * std::sin(2.0f * phi + side_phase);
          world[c[2]] = aa(sgn * elbow, up);
        }
        break;
      case lib::PartKind::kLegLeft:
      case lib::PartKind::kLegRight:
        if (c.size() >= 2) {
          const float s = std::sin(phi + side_phase);
          world[c[0]] = aa(-0.5f * s, left) * aa(-0.04f * sgn, forward);  // hip swing, slight abduction
          world[c[1]] = aa(0.35f * (1.0f - s), left);                     // knee bend (shin backwards)
        }
        break;
      case lib::PartKind::kTorso:
        for (size_t k = 1; k < c.size(); ++k) {
          world[c[k]] = aa(0.08f * std::sin(phi), up) * aa(0.06f * (1.0f + std::sin(2.0f * phi)), left);
        }
        break;
      case lib::PartKind::kHead:
        if (!c.empty()) world[c[0]] = aa(0.15f * std::sin(2.0f * phi), left);
        break;
      default: break;
    }
  }
  // A world rotation about the joint's own origin becomes a local one by conjugating with the
  // rotation of G_j(rest) (uniform scale assumed; Xbot's armature scale is uniform).
  for (size_t j = 0; j < n; ++j) {
    const Eigen::Matrix3f rw = Eigen::Affine3f(rest_world[j]).rotation();
    const skinspheres::Quatf qr(rw);
    const skinspheres::Quatf local_delta = qr.conjugate() * world[j] * qr;
    (*out)[j].rotation = ((*out)[j].rotation * local_delta).normalized();
  }
}

void Fail(Xbot* x, std::string message) { x->error = std::move(message); }

// Fit variants: 0 = default FitSettings (tightening on: centre search, hand-over, splitting up
// to max_spheres); 1 = FitSettings::tighten = false, the paper's spheres after ownership and
// refinement only: fewer, looser spheres; 2 and 3 = split on towards 160 and 256 spheres (no
// standoff target, split_gain 0.99), 4 = towards 512 (split_gain 0.999), denser sets for the
// crowd's rows (4: past the 256 spheres up to which the crowd's query lists every pair). The `spheres` counter of
// every row says how many.
// Fills *x, or sets x->error and returns at the first failure.
void Load(Xbot* x, int variant) {
  const std::filesystem::path file = std::filesystem::path(SKINSPHERES_ASSET_DIR) / "Xbot.glb";
  if (!std::filesystem::exists(file)) {
    x->error = file.string() + ": not found (the shared test characters are not installed); Xbot benchmarks skipped";
    return;
  }
  auto ch = lib::ImportCharacter(file);
  if (!ch.ok()) return Fail(x, ch.error().message);
  x->ch = std::move(*ch);
  auto parts = lib::SplitBodyParts(x->ch);
  if (!parts.ok()) return Fail(x, parts.error().message);
  x->parts = std::move(*parts);
  if (!x->parts.humanoid) return Fail(x, file.string() + ": not split as a humanoid; the motion needs limbs");
  const auto t0 = std::chrono::steady_clock::now();
  lib::FitSettings settings;
  if (variant == 1) settings.tighten = false;
  if (variant >= 2) {  // denser sets, to see how the crowd's batched query scales with the sphere count
    settings.target_standoff = 0.0f;
    settings.split_gain = variant == 4 ? 0.999f : 0.99f;
    settings.max_spheres = variant == 2 ? 160 : variant == 3 ? 256 : 512;
    settings.split_rounds = 1;  // the sets docs/PERFORMANCE.md measured (one greedy round, before 2026-12-06)
  }
  auto fit = lib::FitSpheres(x->ch, x->parts, settings);
  x->fit_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  if (!fit.ok()) return Fail(x, fit.error().message);
  x->set = std::move(fit->spheres);
  auto asset = rt::CharacterAsset::Create(x->set);
  if (!asset.ok()) return Fail(x, asset.error().message);
  x->asset = *asset;

  x->sources = rt::SourceVerticesOfPoints(x->set);
  const sk::SkinnedMesh& skin = x->ch.skin;
  std::string why;
  if (!x->prepared.Build(skin.vertex_count(), skin.influence_offsets, skin.influence_binds, skin.influence_weights,
                         x->sources, &why)) {
    return Fail(x, "PreparedInfluences::Build: " + why);
  }

  // The frames.
  const size_t joints = x->ch.skeleton.size();
  std::vector<skinspheres::Mat4f> rest_world(joints);
  x->ch.skeleton.RestWorld(rest_world);
  auto instance = rt::CharacterInstance::Create(x->asset);
  if (!instance.ok()) return Fail(x, instance.error().message);
  x->locals.resize(kFrames);
  x->joint_world.assign(kFrames, std::vector<skinspheres::Mat4f>(joints));
  x->bind_matrices.assign(kFrames, std::vector<skinspheres::Mat4f>(skin.binds.size()));
  x->skinned.assign(kFrames, std::vector<Eigen::Vector3f>(skin.vertex_count(), Eigen::Vector3f::Zero()));
  x->spheres_exact.resize(kFrames);
  x->spheres_fast.resize(kFrames);
  std::vector<rt::SpherePair> contacts;
  size_t total_exact = 0, total_fast = 0;
  for (int f = 0; f < kFrames; ++f) {
    MakeLocals(*x, rest_world, f, &x->locals[f]);
    sk::LocalToModelJob l2m;
    l2m.skeleton = &x->ch.skeleton;
    l2m.input = x->locals[f];
    l2m.output = x->joint_world[f];
    sk::SkinningMatricesJob mats{skin.binds, x->joint_world[f], x->bind_matrices[f]};
    sk::SkinningJob job;
    job.joint_matrices = x->bind_matrices[f];
    job.vertex_count = skin.vertex_count();
    job.in_positions = Floats(skin.positions_bind);
    job.out_positions = Floats(x->skinned[f]);
    job.prepared = &x->prepared;
    if (!l2m.Run() || !mats.Run() || !job.Run()) return Fail(x, "posing or skinning frame failed");
    if (!instance->UpdateExact(x->skinned[f], x->joint_world[f]).ok()) return Fail(x, instance->status().message);
    x->spheres_exact[f].assign(instance->spheres().begin(), instance->spheres().end());
    if (!rt::FindSpherePairsBruteForce(x->spheres_exact[f], x->asset->filter(), &contacts))
      return Fail(x, "all-pairs failed");
    total_exact += contacts.size();
    if (!instance->UpdateFast(x->joint_world[f]).ok()) return Fail(x, instance->status().message);
    x->spheres_fast[f].assign(instance->spheres().begin(), instance->spheres().end());
    if (!rt::FindSpherePairsBruteForce(x->spheres_fast[f], x->asset->filter(), &contacts))
      return Fail(x, "all-pairs failed");
    total_fast += contacts.size();
  }
  x->contacts_exact = double(total_exact) / kFrames;
  x->contacts_fast = double(total_fast) / kFrames;
}

std::unique_ptr<Xbot> LoadXbot(int variant) {
  auto x = std::make_unique<Xbot>();
  Load(x.get(), variant);
  return x;
}

// variant: see "Fit variants" above. Loaded once per variant, on first use.
const Xbot* GetXbot(benchmark::State& state, int variant = 0) {
  static std::unique_ptr<Xbot> cache[5];
  std::unique_ptr<Xbot>& xbot = cache[variant];
  if (!xbot) xbot = LoadXbot(variant);
  if (!xbot->error.empty()) {
    state.SkipWithError(xbot->error.c_str());
    return nullptr;
  }
  return xbot.get();
}

void SphereCounters(benchmark::State& state, const Xbot& x) {
  state.counters["spheres"] = double(x.set.size());
  state.counters["source_vertices"] = double(x.sources.size());
}

// ------------------------------------------------------------------- per character per frame

void BM_XbotSampleClip(benchmark::State& state) {
  const Xbot* x = GetXbot(state);
  if (!x) return;
  if (x->ch.clips.empty()) return state.SkipWithError("Xbot has no clip");
  const sk::AnimationClip& clip = x->ch.clips[0];
  std::vector<sk::Transform> locals(x->ch.skeleton.size());
  size_t frame = 0;
  for (auto _ : state) {
    const float t = sk::LoopTime(float(frame) / 30.0f, clip.duration_s);
    benchmark::DoNotOptimize(sk::SamplingJob{&clip, &x->ch.skeleton, t, locals}.Run());
    benchmark::ClobberMemory();
    ++frame;
  }
  state.counters["joints"] = double(x->ch.skeleton.size());
  state.counters["tracks"] = double(clip.tracks.size());
}
BENCHMARK(BM_XbotSampleClip)->Unit(benchmark::kMicrosecond);

void BM_XbotPose(benchmark::State& state) {
  const Xbot* x = GetXbot(state);
  if (!x) return;
  std::vector<skinspheres::Mat4f> world(x->ch.skeleton.size()), mats(x->ch.skin.binds.size());
  size_t frame = 0;
  for (auto _ : state) {
    sk::LocalToModelJob l2m;
    l2m.skeleton = &x->ch.skeleton;
    l2m.input = x->locals[frame % kFrames];
    l2m.output = world;
    const bool ok = l2m.Run() && sk::SkinningMatricesJob{x->ch.skin.binds, world, mats}.Run();
    benchmark::DoNotOptimize(ok);
    benchmark::ClobberMemory();
    ++frame;
  }
  state.counters["joints"] = double(x->ch.skeleton.size());
  state.counters["binds"] = double(x->ch.skin.binds.size());
}
BENCHMARK(BM_XbotPose)->Unit(benchmark::kMicrosecond);

// range(0): 0 CSR + subset, 1 prepared.
void BM_XbotSkinSources(benchmark::State& state) {
  const Xbot* x = GetXbot(state);
  if (!x) return;
  const sk::SkinnedMesh& skin = x->ch.skin;
  std::vector<Eigen::Vector3f> out(skin.vertex_count(), Eigen::Vector3f::Zero());
  sk::SkinningJob job;
  job.vertex_count = skin.vertex_count();
  job.in_positions = Floats(skin.positions_bind);
  job.out_positions = Floats(out);
  if (state.range(0)) {
    job.prepared = &x->prepared;
  } else {
    job.influence_offsets = skin.influence_offsets;
    job.influence_binds = skin.influence_binds;
    job.influence_weights = skin.influence_weights;
    job.subset = x->sources;
  }
  size_t frame = 0;
  for (auto _ : state) {
    job.joint_matrices = x->bind_matrices[frame % kFrames];
    benchmark::DoNotOptimize(job.Run());
    benchmark::ClobberMemory();
    ++frame;
  }
  state.SetLabel(std::string(state.range(0) ? "prepared " : "csr ") +
                 sk::ToString(sk::ResolveSimdLevel(sk::SimdLevel::kAuto)));
  SphereCounters(state, *x);
  state.counters["mesh_vertices"] = double(skin.vertex_count());
  state.SetItemsProcessed(int64_t(state.iterations()) * int64_t(job.WorkSize()));
}
BENCHMARK(BM_XbotSkinSources)->Arg(0)->Arg(1)->ArgName("prepared")->Unit(benchmark::kMicrosecond);

void BM_XbotRefitExact(benchmark::State& state) {
  const Xbot* x = GetXbot(state, int(state.range(0)));
  if (!x) return;
  auto instance = rt::CharacterInstance::Create(x->asset);
  // The refit runs right after skinning, so its input is in cache: each frame's positions are
  // copied (untimed) into one buffer rather than read cold from 64 frames' worth (~22 MB).
  std::vector<Eigen::Vector3f> hot(x->skinned[0].size());
  size_t frame = 0;
  for (auto _ : state) {
    const int f = int(frame % kFrames);
    state.PauseTiming();
    std::copy(x->skinned[f].begin(), x->skinned[f].end(), hot.begin());
    state.ResumeTiming();
    benchmark::DoNotOptimize(instance->UpdateExact(hot, x->joint_world[f]).ok());
    benchmark::ClobberMemory();
    ++frame;
  }
  SphereCounters(state, *x);
}
BENCHMARK(BM_XbotRefitExact)->Arg(0)->Arg(1)->ArgName("fit")->Unit(benchmark::kMicrosecond);

// The fast refit's instruction set for a row, unpinned again when the row ends; the row is skipped
// when the CPU lacks it. One instance alone refits at SSE2, AVX2 (also at AVX-512) or portable; the
// crowd calls batch instances of one asset, one per lane, and query the batch at once:
//   0 the CPU's best; 1 SSE2 (4 lanes); 2 AVX2 (8 lanes); 3 AVX-512 (16 lanes) refitted at once and
//   then queried one by one; 4 AVX-512 refitted and queried at once; 5 portable C++ (4 lanes);
//   6 AVX2 and 7 SSE2 one instance at a time (no batch: the per-instance loop the batch is measured
//   against).
class PinnedRefit {
 public:
  PinnedRefit(benchmark::State& state, int64_t level) {
    using rt::SimdLevel;
    constexpr SimdLevel kLevels[] = {SimdLevel::kAuto,   SimdLevel::kSse2,     SimdLevel::kAvx2, SimdLevel::kAvx512,
                                     SimdLevel::kAvx512, SimdLevel::kPortable, SimdLevel::kAvx2, SimdLevel::kSse2};
    ok_ = rt::internal::PinRefitSimd(kLevels[level]);
    rt::internal::SetCrowdQueryBatched(level != 3);
    rt::internal::SetCrowdBatched(level < 6);
    if (!ok_) {
      state.SkipWithError("the CPU lacks this instruction set");
    } else {
      const std::string batch = level >= 6   ? ", one at a time"
                                : level == 3 ? ", batch of 16, query one by one"
                                             : ", batch of " + std::to_string(rt::internal::RefitBatchLanes());
      state.SetLabel(std::string(rt::internal::RefitLevelName(rt::internal::RefitSimdInUse())) + batch);
    }
  }
  ~PinnedRefit() {
    rt::internal::PinRefitSimd(rt::SimdLevel::kAuto);
    rt::internal::SetCrowdQueryBatched(true);
    rt::internal::SetCrowdBatched(true);
  }
  PinnedRefit(const PinnedRefit&) = delete;
  PinnedRefit& operator=(const PinnedRefit&) = delete;
  bool ok() const { return ok_; }

 private:
  bool ok_ = false;
};

// range(0): fit variant; range(1): refit instruction set (PinnedRefit).
void BM_XbotRefitFast(benchmark::State& state) {
  const Xbot* x = GetXbot(state, int(state.range(0)));
  if (!x) return;
  const PinnedRefit pin(state, state.range(1));
  if (!pin.ok()) return;
  auto instance = rt::CharacterInstance::Create(x->asset);
  size_t frame = 0;
  for (auto _ : state) {
    benchmark::DoNotOptimize(instance->UpdateFast(x->joint_world[frame % kFrames]).ok());
    benchmark::ClobberMemory();
    ++frame;
  }
  SphereCounters(state, *x);
  state.counters["influences"] = double(x->set.influence_joints.size());
}
BENCHMARK(BM_XbotRefitFast)->ArgsProduct({{0, 1}, {0, 1, 2}})->ArgNames({"fit", "simd"})->Unit(benchmark::kMicrosecond);

// range(0): fit variant; range(1): 0 exact spheres, 1 fast spheres.
void BM_XbotQuery(benchmark::State& state) {
  const Xbot* x = GetXbot(state, int(state.range(0)));
  if (!x) return;
  const auto& frames = state.range(1) ? x->spheres_fast : x->spheres_exact;
  const rt::PairFilter& filter = x->asset->filter();
  rt::BroadPhaseContext ctx(x->set.size());
  std::vector<rt::SpherePair> out, oracle;
  out.reserve(8 * x->set.size());
  for (int f = 0; f < kFrames; ++f) {
    rt::FindSpherePairsBruteForce(frames[f], filter, &oracle);
    if (!rt::BroadPhaseJob{frames[f], &filter, &ctx, &out}.Run() || out != oracle) {
      return state.SkipWithError("sort and sweep differs from all-pairs on Xbot");
    }
  }
  size_t frame = 0, contacts = 0, candidates = 0;
  const uint64_t builds0 = ctx.build_count();
  for (auto _ : state) {
    rt::BroadPhaseJob{frames[frame % kFrames], &filter, &ctx, &out}.Run();
    contacts += out.size();
    candidates += ctx.last_candidate_count();
    benchmark::DoNotOptimize(out.data());
    ++frame;
  }
  state.SetLabel(state.range(1) ? "fast spheres" : "exact spheres");
  SphereCounters(state, *x);
  state.counters["contacts"] = frame ? double(contacts) / double(frame) : 0.0;
  state.counters["candidates"] = frame ? double(candidates) / double(frame) : 0.0;
  state.counters["builds"] = frame ? double(ctx.build_count() - builds0) / double(frame) : 0.0;
  state.counters["excluded_pairs"] = double(filter.excluded_pair_count());
}
BENCHMARK(BM_XbotQuery)->ArgsProduct({{0, 1}, {0, 1}})->ArgNames({"fit", "fast"})->Unit(benchmark::kMicrosecond);

void BM_XbotAllPairs(benchmark::State& state) {
  const Xbot* x = GetXbot(state, int(state.range(0)));
  if (!x) return;
  const auto& frames = state.range(1) ? x->spheres_fast : x->spheres_exact;
  std::vector<rt::SpherePair> out;
  out.reserve(8 * x->set.size());
  size_t frame = 0, contacts = 0;
  for (auto _ : state) {
    rt::FindSpherePairsBruteForce(frames[frame % kFrames], x->asset->filter(), &out);
    contacts += out.size();
    benchmark::DoNotOptimize(out.data());
    ++frame;
  }
  state.SetLabel(state.range(1) ? "fast spheres" : "exact spheres");
  SphereCounters(state, *x);
  state.counters["contacts"] = frame ? double(contacts) / double(frame) : 0.0;
}
BENCHMARK(BM_XbotAllPairs)->ArgsProduct({{0, 1}, {0, 1}})->ArgNames({"fit", "fast"})->Unit(benchmark::kMicrosecond);

// The whole frame of one character, exact mode: pose, skin the source vertices, refit, query.
void BM_XbotFrameExact(benchmark::State& state) {
  const Xbot* x = GetXbot(state, int(state.range(0)));
  if (!x) return;
  const sk::SkinnedMesh& skin = x->ch.skin;
  auto instance = rt::CharacterInstance::Create(x->asset);
  instance->ReserveContacts(8 * x->set.size());
  std::vector<skinspheres::Mat4f> world(x->ch.skeleton.size()), mats(skin.binds.size());
  std::vector<Eigen::Vector3f> skinned(skin.vertex_count(), Eigen::Vector3f::Zero());
  sk::SkinningJob job;
  job.joint_matrices = mats;
  job.vertex_count = skin.vertex_count();
  job.in_positions = Floats(skin.positions_bind);
  job.out_positions = Floats(skinned);
  job.prepared = &x->prepared;
  size_t frame = 0, contacts = 0;
  for (auto _ : state) {
    sk::LocalToModelJob l2m;
    l2m.skeleton = &x->ch.skeleton;
    l2m.input = x->locals[frame % kFrames];
    l2m.output = world;
    const bool ok = l2m.Run() && sk::SkinningMatricesJob{skin.binds, world, mats}.Run() && job.Run() &&
                    instance->UpdateExact(skinned, world).ok();
    if (!ok) return state.SkipWithError("frame failed");
    contacts += instance->FindSpherePairs().size();
    ++frame;
  }
  SphereCounters(state, *x);
  state.counters["contacts"] = frame ? double(contacts) / double(frame) : 0.0;
}
BENCHMARK(BM_XbotFrameExact)->Arg(0)->Arg(1)->ArgName("fit")->Unit(benchmark::kMicrosecond);

// The whole frame of one character, fast mode: pose, refit from G_j(t), query.
void BM_XbotFrameFast(benchmark::State& state) {
  const Xbot* x = GetXbot(state, int(state.range(0)));
  if (!x) return;
  auto instance = rt::CharacterInstance::Create(x->asset);
  instance->ReserveContacts(8 * x->set.size());
  std::vector<skinspheres::Mat4f> world(x->ch.skeleton.size());
  size_t frame = 0, contacts = 0;
  for (auto _ : state) {
    sk::LocalToModelJob l2m;
    l2m.skeleton = &x->ch.skeleton;
    l2m.input = x->locals[frame % kFrames];
    l2m.output = world;
    if (!l2m.Run() || !instance->UpdateFast(world).ok()) return state.SkipWithError("frame failed");
    contacts += instance->FindSpherePairs().size();
    ++frame;
  }
  SphereCounters(state, *x);
  state.counters["contacts"] = frame ? double(contacts) / double(frame) : 0.0;
}
BENCHMARK(BM_XbotFrameFast)->Arg(0)->Arg(1)->ArgName("fit")->Unit(benchmark::kMicrosecond);

// ---------------------------------------------------------------------------------- crowds

// Bytes of heap in use (glibc's mallinfo2; 0 elsewhere): the crowd rows' bytes per instance.
size_t HeapInUse() {
#if defined(__GLIBC__) && (__GLIBC__ > 2 || (__GLIBC__ == 2 && __GLIBC_MINOR__ >= 33))
  return mallinfo2().uordblks;
#else
  return 0;
#endif
}

constexpr size_t kPhaseShift = 7;  // instance k plays the loop 7k frames ahead

// range(0) fit variant, range(1) instances, range(2) threads, range(3) refit instruction set (PinnedRefit). Fast-mode
// refit + query for every instance; G_j(t) of each instance precomputed (per frame, outside the timed region).
void BM_CrowdFast(benchmark::State& state) {
  const Xbot* x = GetXbot(state, int(state.range(0)));
  if (!x) return;
  const PinnedRefit pin(state, state.range(3));
  if (!pin.ok()) return;
  const size_t count = size_t(state.range(1));
  skinspheres::bench::TimedParallelFor pf(int(state.range(2)));
  std::vector<rt::CharacterInstance> instances;
  std::vector<rt::CharacterInstance*> pointers;
  instances.reserve(count);
  const size_t heap_before = HeapInUse();
  for (size_t k = 0; k < count; ++k) {
    // No ReserveContacts: it also sizes the narrow phase's scratch (about 570 KB for Xbot), which a
    // broad-phase-only crowd never uses (10,000 instances: 5.3 GB of RSS with it, 0.47 GB without;
    // ReserveSpherePairs is the call for such a crowd). Create's room (4 contacts per sphere)
    // holds the ~22 contacts of a frame.
    instances.push_back(rt::CharacterInstance::Create(x->asset).value());
  }
  const size_t heap_created = HeapInUse() - heap_before;
  for (auto& i : instances) pointers.push_back(&i);
  // inputs[f][k]: instance k's input at loop frame f.
  std::vector<std::vector<rt::CharacterFrameInput>> inputs(kFrames, std::vector<rt::CharacterFrameInput>(count));
  for (int f = 0; f < kFrames; ++f)
    for (size_t k = 0; k < count; ++k) inputs[f][k].joint_world = x->joint_world[(f + kPhaseShift * k) % kFrames];
  // One warm-up frame (caches, contact lists), then per-thread CPU time of the timed frames only.
  const size_t heap_before_frame = HeapInUse();
  if (!rt::CrowdUpdateAndFindSpherePairs(pointers, inputs[0], rt::RefitMode::kFast, pf.get()).ok()) {
    return state.SkipWithError("crowd update failed");
  }
  // The instances' heap: what Create took, and what the first frame added (each instance's own
  // buffers grown, the threads' batch buffers: a few KB in all).
  state.counters["heap_bytes_per_instance"] =
      double(heap_created + (HeapInUse() - heap_before_frame)) / double(std::max<size_t>(count, 1));
  pf.Reset();
  size_t frame = 1;
  for (auto _ : state) {
    if (!rt::CrowdUpdateAndFindSpherePairs(pointers, inputs[frame % kFrames], rt::RefitMode::kFast, pf.get()).ok()) {
      return state.SkipWithError("crowd update failed");
    }
    ++frame;
  }
  size_t contacts = 0;
  for (const auto& i : instances) contacts += i.sphere_pairs().size();
  state.counters["contacts_last_frame"] = double(contacts);
  state.counters["spheres_total"] = double(count * x->set.size());
  state.SetItemsProcessed(int64_t(state.iterations()) * int64_t(count));  // characters per second
  pf.Report(state);
}
BENCHMARK(BM_CrowdFast)
    ->ArgsProduct({{0, 1}, {1, 10, 100, 1000, 10000}, {1, 2}, {0}})
    ->ArgsProduct({{0}, {1000, 10000}, {1, 2}, {1, 2, 3, 4, 5, 6, 7}})  // every level, batched and one at a time
    ->ArgsProduct({{2, 3, 4}, {1000}, {1}, {2, 4, 6}})                  // denser sets: the cost against the contacts
    ->ArgNames({"fit", "instances", "threads", "simd"})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

// The crowd's pose input as its own row: LocalToModelJob for every instance (phase-shifted).
void BM_CrowdPose(benchmark::State& state) {
  const Xbot* x = GetXbot(state);
  if (!x) return;
  const size_t count = size_t(state.range(0));
  tbb::global_control limit(tbb::global_control::max_allowed_parallelism, size_t(state.range(1)));
  std::vector<std::vector<skinspheres::Mat4f>> world(count, std::vector<skinspheres::Mat4f>(x->ch.skeleton.size()));
  size_t frame = 0;
  for (auto _ : state) {
    tbb::parallel_for(tbb::blocked_range<size_t>(0, count, 8), [&](const tbb::blocked_range<size_t>& r) {
      for (size_t k = r.begin(); k < r.end(); ++k) {
        sk::LocalToModelJob l2m;
        l2m.skeleton = &x->ch.skeleton;
        l2m.input = x->locals[(frame + kPhaseShift * k) % kFrames];
        l2m.output = world[k];
        l2m.Run();
      }
    });
    benchmark::ClobberMemory();
    ++frame;
  }
  state.SetItemsProcessed(int64_t(state.iterations()) * int64_t(count));
}
BENCHMARK(BM_CrowdPose)
    ->ArgsProduct({{1000}, {1, 2}})
    ->ArgNames({"instances", "threads"})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

// Prints the set-up facts once, before the table (fit time, sphere count, contacts per frame).
void BM_XbotSetup(benchmark::State& state) {
  const Xbot* x = GetXbot(state, int(state.range(0)));
  if (!x) return;
  for (auto _ : state) benchmark::DoNotOptimize(x);
  state.counters["fit_ms"] = x->fit_ms;
  state.counters["spheres"] = double(x->set.size());
  state.counters["vertices"] = double(x->ch.vertex_count());
  state.counters["source_vertices"] = double(x->sources.size());
  state.counters["vertex_entries"] = double(x->set.vertices.size());  // what the exact refit reads
  state.counters["contacts_exact"] = x->contacts_exact;
  state.counters["contacts_fast"] = x->contacts_fast;
  state.counters["excluded_pairs"] = double(x->asset->filter().excluded_pair_count());
}
BENCHMARK(BM_XbotSetup)->Arg(0)->Arg(1)->ArgName("fit")->Iterations(1);

#if SKINSPHERES_HAVE_PEERS
// ------------------------------------------------------------ peers on the same Xbot spheres
// Bullet and FCL (peer_broad_phases.h) on the same per-frame spheres; before timing, every
// frame's result must equal FindSpherePairsBruteForce, else the row is skipped with an error.
using skinspheres::bench::BulletWorld;
using skinspheres::bench::FclWorld;

// range(0) fit variant, range(1) 0 exact / 1 fast spheres.
template <class World>
void PeerBenchmark(benchmark::State& state, const char* name) {
  const Xbot* x = GetXbot(state, int(state.range(0)));
  if (!x) return;
  const auto& frames = state.range(1) ? x->spheres_fast : x->spheres_exact;
  const rt::PairFilter& filter = x->asset->filter();
  World world(frames[0], filter);
  std::vector<rt::SpherePair> out, oracle;
  out.reserve(8 * x->set.size());
  for (int f = 0; f < kFrames; ++f) {
    world.Frame(frames[f], &out);
    rt::FindSpherePairsBruteForce(frames[f], filter, &oracle);
    if (out != oracle) return state.SkipWithError((std::string(name) + " differs from all-pairs on Xbot").c_str());
  }
  size_t frame = 0, contacts = 0;
  for (auto _ : state) {
    world.Frame(frames[frame % kFrames], &out);
    contacts += out.size();
    ++frame;
  }
  state.SetLabel(state.range(1) ? "fast spheres" : "exact spheres");
  SphereCounters(state, *x);
  state.counters["contacts"] = frame ? double(contacts) / double(frame) : 0.0;
}
void BM_XbotPeerBulletDbvt(benchmark::State& state) { PeerBenchmark<BulletWorld>(state, "Bullet"); }
void BM_XbotPeerFclDynamicTree(benchmark::State& state) { PeerBenchmark<FclWorld>(state, "FCL"); }
BENCHMARK(BM_XbotPeerBulletDbvt)
    ->ArgsProduct({{0, 1}, {0, 1}})
    ->ArgNames({"fit", "fast"})
    ->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_XbotPeerFclDynamicTree)
    ->ArgsProduct({{0, 1}, {0, 1}})
    ->ArgNames({"fit", "fast"})
    ->Unit(benchmark::kMicrosecond);
#endif  // SKINSPHERES_HAVE_PEERS

}  // namespace

BENCHMARK_MAIN();
