// Broad phase: skinspheres' BroadPhaseJob against Bullet's btDbvtBroadphase, FCL's dynamic AABB
// tree (peer_broad_phases.h: configured as their documentation recommends, float sphere test,
// same exclusions) and the all-pairs loop, on four workloads. One process times every method;
// bench/broad_phase_tables.py makes tables from --benchmark_out (bench/results/ holds the dated
// runs, docs/PERFORMANCE.md quotes them).
//
// Workloads (each iteration is the next frame; frames play forward then backward, so a loop never
// teleports):
//   a_cloud   spheres in a 1.8 x 1.8 x 0.3 box: std::mt19937 seed 3, for each sphere in order
//             x = 1.8U - 0.9, y = 1.8U, z = 0.3U - 0.15, r = 0.02 + 0.06U (U uniform in [0, 1));
//             frame f: x += A sin(0.05f + i), y += A cos(0.05f + i) (offsets from the generated
//             position, so each sphere wiggles within +-A). N = 150, 300, 1000; A = 0.02, 0.3.
//             No exclusions. 128 frames.
//   b_clip    the shared characters' own clips (../shared/assets), fitted with the default
//             settings, exact refit, at 30 and 60 fps, with the fitted exclusions and without any,
//             standing or walking forward at 1.5 body heights per second (the whole clip). A
//             clip whose frames all hold one pose (Xbot's: a T-pose of 0.067 s) is labelled
//             "held pose" (counter held_pose = 1): it moves nothing but the walk, so its rows are
//             reported apart and left out of the clips' ranges.
//   c_scale   the cloud's generator at the density of its N = 300 box, scaled to N = 100 ... 50,000
//             spheres: a slab (x, y grow, z stays 0.3: a crowd's floor) and a cube (all three
//             grow). A = 0.02. 128 frames (32 above 5,000 spheres).
//   d_crowd   1 to 1000 CesiumMan walking in place (clip at 30 fps, exact spheres), character k
//             playing 7k frames ahead, on a square grid 0.8 body heights apart: each alone (one job
//             per character; RunParallel on 1 and 2 threads with per-thread CPU time) and
//             all in one space (one job over every sphere, pairs between characters included).
//             16 frames.
//
// Methods (the last path element of every name):
//   skinspheres[_sse2|_avx2|_avx512]   BroadPhaseJob (sorted list), instruction set auto or forced
//   allpairs                           FindSpherePairsBruteForce, the plain O(n^2) loop (up to 5,000 spheres)
//   bullet_count, bullet_sorted        btDbvtBroadphase: contact count only / sorted contact list
//   fcl_count, fcl_sorted              FCL dynamic AABB tree in float: the same two variants
//   <method>_cold                      (b_clip: skinspheres, bullet_count, fcl_count) the first pass:
//                                      every iteration batch builds the method afresh (untimed: the
//                                      context or the peer's tree over frame 0) and times one pass
//                                      over the clip's frames in order; the Time column is the
//                                      timing thread's CPU time per frame (manual time), so it reads
//                                      beside the warm rows' CPU time
//
// Warm rows (every name without _cold) first play the whole loop once untimed (the check below),
// then time frames from the loop's start; every frame of the loop counts, as a row runs many passes.
//
// Every method is checked before timing, on every frame of the loop, against a reference: the
// all-pairs oracle up to 5,000 spheres, Bullet's sorted list above (checked in turn against FCL
// and ours). A mismatch aborts the process with a message. Counters: contacts and candidates per
// frame (ours: pairs given the exact test; peers: pairs their tree reported), and for ours the
// builds per frame.
#include <benchmark/benchmark.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <functional>
#include <map>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include "peer_broad_phases.h"
#include "skinspheres/lib/body_parts/body_parts.h"
#include "skinspheres/lib/fit/sphere_fitter.h"
#include "skinspheres/lib/io/importer.h"
#include "skinspheres/runtime/api/character.h"
#include "skinspheres/runtime/broad_phase/broad_phase.h"
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
using skinspheres::Vec4f;
using Spheres = std::vector<Vec4f>;

constexpr size_t kOracleMax = 5000;  // spheres: above this the reference is Bullet's sorted list

[[noreturn]] void Abort(const std::string& message) {
  std::fprintf(stderr, "broad_phase_bench: %s\n", message.c_str());
  std::fflush(stderr);
  std::abort();
}

// Frame index of iteration k over f frames played forward then backward.
size_t PingPong(size_t k, size_t f) {
  if (f <= 1) return 0;
  const size_t period = 2 * (f - 1);
  const size_t m = k % period;
  return m < f ? m : period - m;
}

// ------------------------------------------------------------------------------------ scenarios

struct Scenario {
  std::string error;            // non-empty: every row of it is skipped with this message
  std::vector<Spheres> frames;  // the loop
  rt::PairFilter filter;
  std::vector<std::vector<rt::SpherePair>> reference;  // per frame
  // Crowd: the characters alone (spheres of character k at frame f: frames[(f + 7k) % frames]).
  size_t characters = 0;   // 0: not a crowd
  bool held_pose = false;  // every frame holds frame 0's pose (before any walk)
};

// Workload (a)'s generator, box sx x sy x sz (workload (a)'s box is 1.8 x 1.8 x 0.3).
Spheres CloudBase(size_t n, double sx, double sy, double sz) {
  std::mt19937 rng(3);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  Spheres s(n);
  for (size_t i = 0; i < n; ++i) {
    const float x = float(sx) * u(rng) - float(0.5 * sx);
    const float y = float(sy) * u(rng);
    const float z = float(sz) * u(rng) - float(0.5 * sz);
    const float r = 0.02f + 0.06f * u(rng);
    s[i] = Vec4f(x, y, z, r);
  }
  return s;
}

void CloudFrames(Scenario* sc, const Spheres& base, double amplitude, size_t frame_count) {
  sc->frames.assign(frame_count, base);
  for (size_t f = 0; f < frame_count; ++f) {
    for (size_t i = 0; i < base.size(); ++i) {
      const double phase = 0.05 * double(f) + double(i);
      sc->frames[f][i].x() = float(double(base[i].x()) + amplitude * std::sin(phase));
      sc->frames[f][i].y() = float(double(base[i].y()) + amplitude * std::cos(phase));
    }
  }
  sc->filter = rt::PairFilter::Create(base.size(), {}, {}).value();
}

void ComputeReference(Scenario* sc);

// A fitted shared character and one clip's exact spheres at some fps.
struct FittedCharacter {
  std::string error;
  lib::RawCharacter ch;
  lib::BodyParts parts;
  std::shared_ptr<const rt::CharacterAsset> asset;
  float height = 0.0f;
  Eigen::Vector3f forward = Eigen::Vector3f::Zero();
};

const FittedCharacter& Fitted(const std::string& file) {
  static std::map<std::string, std::unique_ptr<FittedCharacter>> cache;
  auto& slot = cache[file];
  if (slot) return *slot;
  slot = std::make_unique<FittedCharacter>();
  FittedCharacter& c = *slot;
  const std::filesystem::path path = std::filesystem::path(SKINSPHERES_ASSET_DIR) / file;
  if (!std::filesystem::exists(path)) {
    c.error = path.string() + ": not found (the shared characters are not installed)";
    return c;
  }
  auto ch = lib::ImportCharacter(path);
  if (!ch.ok()) return c.error = ch.error().message, c;
  c.ch = std::move(*ch);
  auto parts = lib::SplitBodyParts(c.ch);
  if (!parts.ok()) return c.error = parts.error().message, c;
  c.parts = std::move(*parts);
  auto fit = lib::FitSpheres(c.ch, c.parts, lib::FitSettings{});
  if (!fit.ok()) return c.error = fit.error().message, c;
  auto asset = rt::CharacterAsset::Create(std::move(fit->spheres));
  if (!asset.ok()) return c.error = asset.error().message, c;
  c.asset = *asset;
  const rt::SphereSet& set = c.asset->sphere_set();
  const Eigen::Vector3f up = c.parts.humanoid ? c.parts.up : Eigen::Vector3f::UnitY();
  const Eigen::Vector3f left = c.parts.humanoid ? c.parts.left : Eigen::Vector3f::UnitX();
  float lo = INFINITY, hi = -INFINITY;
  for (size_t s = 0; s < set.size(); ++s) {
    lo = std::min(lo, set.centers_rest[s].dot(up) - set.radii_rest[s]);
    hi = std::max(hi, set.centers_rest[s].dot(up) + set.radii_rest[s]);
  }
  c.height = hi - lo;
  c.forward = left.cross(up).normalized();
  return c;
}

// The exact spheres of every frame of `clip` at `fps` (the whole clip), walking or not.
std::string ClipFrames(const FittedCharacter& c, const std::string& clip_name, double fps, bool walk,
                       std::vector<Spheres>* frames, bool* held_pose = nullptr) {
  const sk::AnimationClip* clip = nullptr;
  for (const auto& k : c.ch.clips) {
    if (k.name == clip_name || (clip_name == "0" && &k == &c.ch.clips[0])) clip = &k;
  }
  if (clip == nullptr) return "no clip " + clip_name;
  const rt::SphereSet& set = c.asset->sphere_set();
  const std::vector<uint32_t> sources = rt::SourceVerticesOfPoints(set);
  const sk::SkinnedMesh& skin = c.ch.skin;
  sk::PreparedInfluences prepared;
  std::string why;
  if (!prepared.Build(skin.vertex_count(), skin.influence_offsets, skin.influence_binds, skin.influence_weights,
                      sources, &why)) {
    return why;
  }
  std::vector<sk::Transform> locals(c.ch.skeleton.size());
  std::vector<skinspheres::Mat4f> world(c.ch.skeleton.size()), mats(skin.binds.size());
  std::vector<Eigen::Vector3f> skinned(skin.vertex_count(), Eigen::Vector3f::Zero());
  auto instance = rt::CharacterInstance::Create(c.asset);
  if (!instance.ok()) return instance.error().message;
  const size_t count = size_t(std::floor(double(clip->duration_s) * fps + 1e-3)) + 1;
  frames->assign(count, {});
  float moved = 0.0f;  // the largest distance of a sphere centre from frame 0's, before the walk
  for (size_t f = 0; f < count; ++f) {
    const float t = float(double(f) / fps);
    sk::SamplingJob sampling{clip, &c.ch.skeleton, sk::LoopTime(t, clip->duration_s), locals};
    sk::LocalToModelJob l2m;
    l2m.skeleton = &c.ch.skeleton;
    l2m.input = locals;
    l2m.output = world;
    sk::SkinningMatricesJob m{skin.binds, world, mats};
    sk::SkinningJob job;
    job.joint_matrices = mats;
    job.vertex_count = skin.vertex_count();
    job.in_positions = {reinterpret_cast<const float*>(skin.positions_bind.data()), skin.positions_bind.size() * 3};
    job.out_positions = {reinterpret_cast<float*>(skinned.data()), skinned.size() * 3};
    job.prepared = &prepared;
    if (!sampling.Run() || !l2m.Run() || !m.Run() || !job.Run()) return "posing frame failed";
    if (!instance->UpdateExact(skinned, world).ok()) return instance->status().message;
    Spheres& out = (*frames)[f];
    out.assign(instance->spheres().begin(), instance->spheres().end());
    for (size_t s = 0; s < out.size(); ++s) moved = std::max(moved, (out[s] - (*frames)[0][s]).head<3>().norm());
    if (walk) {
      const Eigen::Vector3f step = c.forward * (1.5f * c.height * t);
      for (Vec4f& s : out) s.head<3>() += step;
    }
  }
  if (held_pose != nullptr) *held_pose = moved <= 1e-4f * c.height;
  return "";
}

// Scenario cache, built on first use.
const Scenario& GetScenario(const std::string& key, const std::function<void(Scenario*)>& make) {
  static std::map<std::string, std::unique_ptr<Scenario>> cache;
  auto& slot = cache[key];
  if (!slot) {
    slot = std::make_unique<Scenario>();
    make(slot.get());
    if (slot->error.empty()) ComputeReference(slot.get());
  }
  return *slot;
}

size_t SphereCount(const Scenario& sc) { return sc.frames.empty() ? 0 : sc.frames[0].size(); }

// ---------------------------------------------------------------------------------- the methods

// One method's per-frame state over a scenario's (one-space) frames.
class Method {
 public:
  virtual ~Method() = default;
  // Runs the frame; returns the contact count (list filled when the method makes one).
  virtual size_t Frame(const Spheres& s, std::vector<rt::SpherePair>* list) = 0;
  virtual bool MakesList() const { return true; }
  virtual double Candidates() const { return 0.0; }
  virtual double Builds() const { return 0.0; }
  virtual double BuildTests() const { return 0.0; }
  virtual double Lookahead() const { return 0.0; }
};

class Ours : public Method {
 public:
  Ours(const Scenario& sc, rt::SimdLevel simd, bool no_cache = false)
      : filter_(&sc.filter), simd_(simd), no_cache_(no_cache) {
    context_.Resize(SphereCount(sc));
  }
  size_t Frame(const Spheres& s, std::vector<rt::SpherePair>* list) override {
    if (no_cache_) context_.Invalidate();
    rt::BroadPhaseJob job{s, filter_, &context_, list};
    job.simd = simd_;
    if (!job.Run()) Abort("BroadPhaseJob refused a frame");
    candidates_ += double(context_.last_candidate_count());
    build_tests_ += double(context_.last_build_tests());
    lookahead_ += context_.last_method() == rt::BroadPhaseMethod::kCached ? 0.0 : double(context_.last_lookahead());
    return list->size();
  }
  double Candidates() const override { return candidates_; }
  double Builds() const override { return double(context_.build_count()); }
  double BuildTests() const override { return build_tests_; }
  double Lookahead() const override { return lookahead_; }

 private:
  const rt::PairFilter* filter_;
  rt::SimdLevel simd_;
  bool no_cache_;
  rt::BroadPhaseContext context_;
  double candidates_ = 0.0, build_tests_ = 0.0, lookahead_ = 0.0;
};

class AllPairs : public Method {
 public:
  explicit AllPairs(const Scenario& sc) : filter_(&sc.filter) {}
  size_t Frame(const Spheres& s, std::vector<rt::SpherePair>* list) override {
    if (!rt::FindSpherePairsBruteForce(s, *filter_, list)) Abort("all-pairs refused a frame");
    return list->size();
  }

 private:
  const rt::PairFilter* filter_;
};

#if SKINSPHERES_HAVE_PEERS
template <class World>
class Peer : public Method {
 public:
  Peer(const Scenario& sc, bool sorted) : world_(sc.frames[0], sc.filter), sorted_(sorted) {}
  size_t Frame(const Spheres& s, std::vector<rt::SpherePair>* list) override {
    const size_t count = world_.Frame(s, sorted_ ? list : nullptr);
    candidates_ += double(world_.last_candidates());
    return count;
  }
  bool MakesList() const override { return sorted_; }
  double Candidates() const override { return candidates_; }

 private:
  World world_;
  bool sorted_;
  double candidates_ = 0.0;
};
#endif

std::unique_ptr<Method> MakeMethod(const std::string& name, const Scenario& sc) {
  if (name == "skinspheres") return std::make_unique<Ours>(sc, rt::SimdLevel::kAuto);
  if (name == "skinspheres_nocache") return std::make_unique<Ours>(sc, rt::SimdLevel::kAuto, true);
  if (name == "skinspheres_nocache_avx2") return std::make_unique<Ours>(sc, rt::SimdLevel::kAvx2, true);
  if (name == "skinspheres_nocache_sse2") return std::make_unique<Ours>(sc, rt::SimdLevel::kSse2, true);
  if (name == "skinspheres_sse2") return std::make_unique<Ours>(sc, rt::SimdLevel::kSse2);
  if (name == "skinspheres_avx2") return std::make_unique<Ours>(sc, rt::SimdLevel::kAvx2);
  if (name == "skinspheres_avx512") return std::make_unique<Ours>(sc, rt::SimdLevel::kAvx512);
  if (name == "allpairs") return std::make_unique<AllPairs>(sc);
#if SKINSPHERES_HAVE_PEERS
  using skinspheres::bench::BulletWorld;
  using skinspheres::bench::FclWorld;
  if (name == "bullet_count") return std::make_unique<Peer<BulletWorld>>(sc, false);
  if (name == "bullet_sorted") return std::make_unique<Peer<BulletWorld>>(sc, true);
  if (name == "fcl_count") return std::make_unique<Peer<FclWorld>>(sc, false);
  if (name == "fcl_sorted") return std::make_unique<Peer<FclWorld>>(sc, true);
#endif
  return nullptr;
}

void ComputeReference(Scenario* sc) {
  const size_t n = SphereCount(*sc);
  std::unique_ptr<Method> ref = n <= kOracleMax ? MakeMethod("allpairs", *sc) : MakeMethod("bullet_sorted", *sc);
  if (!ref) {
    sc->error = "no reference method (Bullet not built) above " + std::to_string(kOracleMax) + " spheres";
    return;
  }
  sc->reference.resize(sc->frames.size());
  for (size_t f = 0; f < sc->frames.size(); ++f) ref->Frame(sc->frames[f], &sc->reference[f]);
}

// Runs every frame of the loop once and aborts unless the method matches the reference.
void CheckAgainstReference(const Scenario& sc, Method& m, const std::string& row) {
  std::vector<rt::SpherePair> out;
  const size_t period = sc.frames.size() <= 1 ? 1 : 2 * (sc.frames.size() - 1);
  for (size_t k = 0; k < period; ++k) {
    const size_t f = PingPong(k, sc.frames.size());
    const size_t count = m.Frame(sc.frames[f], &out);
    const bool same = m.MakesList() ? out == sc.reference[f] : count == sc.reference[f].size();
    if (!same) {
      Abort(row + ": frame " + std::to_string(f) + " differs from the reference (" + std::to_string(count) + " vs " +
            std::to_string(sc.reference[f].size()) + " contacts)");
    }
  }
}

// The body of every one-space row.
void RunRow(benchmark::State& state, const Scenario& sc, const std::string& method, const std::string& row) {
  if (!sc.error.empty()) return state.SkipWithError(sc.error.c_str());
  std::unique_ptr<Method> m = MakeMethod(method, sc);
  if (!m) return state.SkipWithError(("method " + method + " not built").c_str());
  CheckAgainstReference(sc, *m, row);
  const double candidates0 = m->Candidates(), builds0 = m->Builds(), build_tests0 = m->BuildTests(),
               lookahead0 = m->Lookahead();
  std::vector<rt::SpherePair> out;
  out.reserve(2 * sc.reference[0].size() + 64);
  size_t k = 0, contacts = 0;
  for (auto _ : state) {
    contacts += m->Frame(sc.frames[PingPong(k, sc.frames.size())], &out);
    benchmark::DoNotOptimize(out.data());
    ++k;
  }
  const size_t last = PingPong(k - 1, sc.frames.size());
  if (m->MakesList() ? out != sc.reference[last] : false) Abort(row + ": last timed frame differs from the reference");
  const double frames = double(std::max<size_t>(k, 1));
  if (sc.held_pose) state.SetLabel("held pose");
  state.counters["held_pose"] = sc.held_pose ? 1.0 : 0.0;
  state.counters["spheres"] = double(SphereCount(sc));
  state.counters["contacts"] = double(contacts) / frames;
  state.counters["candidates"] = (m->Candidates() - candidates0) / frames;
  state.counters["builds"] = (m->Builds() - builds0) / frames;
  if (m->Builds() > builds0) {
    state.counters["tests_per_build"] = (m->BuildTests() - build_tests0) / (m->Builds() - builds0);
    state.counters["lookahead"] = (m->Lookahead() - lookahead0) / (m->Builds() - builds0);
  }
}

// The body of every _cold row: each batch of iterations is one pass over the frames in order
// (0, 1, ..., F - 1) by a method made afresh outside the timed part, timed on the thread's CPU
// clock, so the figure is the mean per frame of a clip's first pass.
void RunColdRow(benchmark::State& state, const Scenario& sc, const std::string& method) {
  if (!sc.error.empty()) return state.SkipWithError(sc.error.c_str());
  const std::unique_ptr<Method> probe = MakeMethod(method, sc);
  if (!probe) return state.SkipWithError(("method " + method + " not built").c_str());
  const size_t frames = sc.frames.size();
  std::vector<rt::SpherePair> out;
  out.reserve(2 * sc.reference[0].size() + 64);
  size_t contacts = 0, passes = 0;
  double builds = 0.0, candidates = 0.0;
  while (state.KeepRunningBatch(benchmark::IterationCount(frames))) {
    std::unique_ptr<Method> m = MakeMethod(method, sc);
    const double t0 = skinspheres::bench::ThreadCpuSeconds();
    for (size_t f = 0; f < frames; ++f) {
      contacts += m->Frame(sc.frames[f], &out);
      benchmark::DoNotOptimize(out.data());
    }
    state.SetIterationTime(skinspheres::bench::ThreadCpuSeconds() - t0);
    builds += m->Builds();
    candidates += m->Candidates();
    ++passes;
  }
  if (probe->MakesList() && passes > 0 && out != sc.reference[frames - 1]) {
    Abort(method + "_cold: the last frame of the pass differs from the reference");
  }
  if (sc.held_pose) state.SetLabel("held pose");
  state.counters["held_pose"] = sc.held_pose ? 1.0 : 0.0;
  state.counters["spheres"] = double(SphereCount(sc));
  state.counters["contacts"] = double(contacts) / double(std::max<size_t>(passes * frames, 1));
  state.counters["passes"] = double(passes);
  state.counters["builds"] = builds / double(std::max<size_t>(passes * frames, 1));
  state.counters["candidates"] = candidates / double(std::max<size_t>(passes * frames, 1));
}

// --------------------------------------------------------------------------------- registration

std::vector<std::string> OurMethods(bool all_levels) {
  std::vector<std::string> m = {"skinspheres"};
  if (all_levels) {
    for (auto level : {rt::SimdLevel::kSse2, rt::SimdLevel::kAvx2, rt::SimdLevel::kAvx512}) {
      if (rt::SimdLevelSupported(level)) m.push_back(std::string("skinspheres_") + rt::ToString(level));
    }
  }
  return m;
}

const std::vector<std::string> kPeers = {"bullet_count", "bullet_sorted", "fcl_count", "fcl_sorted"};

void Register(const std::string& row, std::function<const Scenario&()> scenario, const std::string& method,
              benchmark::TimeUnit unit = benchmark::kMicrosecond) {
  benchmark::RegisterBenchmark(row.c_str(), [=](benchmark::State& state) {
    RunRow(state, scenario(), method, row);
  })->Unit(unit);
}

void RegisterCloud() {
  for (double amplitude : {0.02, 0.3}) {
    for (size_t n : {150, 300, 1000}) {
      char key[96];
      std::snprintf(key, sizeof key, "a_cloud/amp:%g/n:%zu", amplitude, n);
      const std::string k = key;
      auto scenario = [k, n, amplitude]() -> const Scenario& {
        return GetScenario(k, [&](Scenario* sc) { CloudFrames(sc, CloudBase(n, 1.8, 1.8, 0.3), amplitude, 128); });
      };
      std::vector<std::string> methods = OurMethods(true);
      for (const char* m : {"skinspheres_nocache", "skinspheres_nocache_avx2", "skinspheres_nocache_sse2"})
        methods.push_back(m);
      methods.push_back("allpairs");
      methods.insert(methods.end(), kPeers.begin(), kPeers.end());
      for (const auto& m : methods) Register(k + "/" + m, scenario, m);
    }
  }
}

struct ClipSpec {
  const char* file;
  const char* clip;
};
const ClipSpec kClips[] = {{"CesiumMan.glb", "0"},
                           {"Soldier.glb", "Run"},
                           {"RobotExpressive.glb", "Dance"},
                           {"RobotExpressive.glb", "Running"},
                           {"Xbot.glb", "0"}};

void RegisterClips() {
  for (const ClipSpec& spec : kClips) {
    for (int fps : {30, 60}) {
      for (bool exclusions : {true, false}) {
        for (bool walk : {false, true}) {
          std::string name = std::string(spec.file).substr(0, std::string(spec.file).find('.'));
          const std::string k = "b_clip/" + name + ":" + (spec.clip[0] == '0' ? "clip0" : spec.clip) +
                                "/fps:" + std::to_string(fps) + "/excl:" + (exclusions ? "1" : "0") +
                                "/walk:" + (walk ? "1" : "0");
          auto scenario = [k, spec, fps, exclusions, walk]() -> const Scenario& {
            return GetScenario(k, [&](Scenario* sc) {
              const FittedCharacter& c = Fitted(spec.file);
              if (!c.error.empty()) return void(sc->error = c.error);
              const std::string err = ClipFrames(c, spec.clip, fps, walk, &sc->frames, &sc->held_pose);
              if (!err.empty()) return void(sc->error = std::string(spec.file) + ": " + err);
              const rt::PairFilter& fitted = c.asset->filter();
              sc->filter = exclusions ? fitted : rt::PairFilter::Create(fitted.size(), fitted.parts(), {}).value();
            });
          };
          std::vector<std::string> methods = {"skinspheres", "skinspheres_sse2", "allpairs"};
          methods.insert(methods.end(), kPeers.begin(), kPeers.end());
          for (const auto& m : methods) Register(k + "/" + m, scenario, m);
          for (const std::string m : {"skinspheres", "bullet_count", "fcl_count"}) {
            benchmark::RegisterBenchmark((k + "/" + m + "_cold").c_str(),
                                         [=](benchmark::State& state) { RunColdRow(state, scenario(), m); })
                ->Unit(benchmark::kMicrosecond)
                ->UseManualTime();
          }
        }
      }
    }
  }
}

void RegisterScale() {
  for (const char* shape : {"slab", "cube"}) {
    for (size_t n : {100, 300, 1000, 3000, 10000, 30000, 50000}) {
      const std::string k = std::string("c_scale/") + shape + "/n:" + std::to_string(n);
      const bool slab = shape[0] == 's';
      auto scenario = [k, n, slab]() -> const Scenario& {
        return GetScenario(k, [&](Scenario* sc) {
          const double grow = double(n) / 300.0;
          const double s2 = std::sqrt(grow), s3 = std::cbrt(grow);
          const Spheres base =
              slab ? CloudBase(n, 1.8 * s2, 1.8 * s2, 0.3) : CloudBase(n, 1.8 * s3, 1.8 * s3, 0.3 * s3);
          CloudFrames(sc, base, 0.02, n > 5000 ? 32 : 128);
        });
      };
      std::vector<std::string> methods = {"skinspheres", "bullet_count", "fcl_count"};
      if (n <= 3000) methods.push_back("allpairs");
      for (const auto& m : methods)
        Register(k + "/" + m, scenario, m, n >= 10000 ? benchmark::kMillisecond : benchmark::kMicrosecond);
    }
  }
}

// ------------------------------------------------------------------------------------ crowds (d)

constexpr size_t kCrowdFrames = 16;
constexpr size_t kPhase = 7;

// CesiumMan's walk in place at 30 fps (first kCrowdFrames frames), its filter, its height.
struct CrowdCharacter {
  std::string error;
  std::vector<Spheres> frames;
  const rt::PairFilter* filter = nullptr;
  float height = 0.0f;
  Eigen::Vector3f forward, left;
};

const CrowdCharacter& GetCrowdCharacter() {
  static std::unique_ptr<CrowdCharacter> cc;
  if (cc) return *cc;
  cc = std::make_unique<CrowdCharacter>();
  const FittedCharacter& c = Fitted("CesiumMan.glb");
  if (!c.error.empty()) return cc->error = c.error, *cc;
  std::vector<Spheres> all;
  const std::string err = ClipFrames(c, "0", 30.0, false, &all);
  if (!err.empty()) return cc->error = err, *cc;
  all.resize(std::min(all.size(), kCrowdFrames));
  cc->frames = std::move(all);
  cc->filter = &c.asset->filter();
  cc->height = c.height;
  cc->forward = c.forward;
  cc->left = c.parts.humanoid ? c.parts.left : Eigen::Vector3f::UnitX();
  return *cc;
}

// All characters in one space: frame f holds every character's spheres, character k at its grid
// place, 7k frames ahead.
void CrowdSpace(Scenario* sc, size_t characters) {
  const CrowdCharacter& cc = GetCrowdCharacter();
  if (!cc.error.empty()) return void(sc->error = cc.error);
  const size_t per = cc.frames[0].size(), f_count = cc.frames.size();
  const size_t side = size_t(std::ceil(std::sqrt(double(characters))));
  const float spacing = 0.8f * cc.height;
  sc->frames.assign(f_count, Spheres(characters * per));
  for (size_t f = 0; f < f_count; ++f) {
    for (size_t k = 0; k < characters; ++k) {
      const Eigen::Vector3f place = cc.left * (spacing * float(k % side)) + cc.forward * (spacing * float(k / side));
      const Spheres& src = cc.frames[(f + kPhase * k) % f_count];
      for (size_t s = 0; s < per; ++s) {
        Vec4f v = src[s];
        v.head<3>() += place;
        sc->frames[f][k * per + s] = v;
      }
    }
  }
  std::vector<const rt::PairFilter*> members(characters, cc.filter);
  auto combined = rt::PairFilter::Combine(members, {true, true});
  if (!combined.ok()) return void(sc->error = combined.error().message);
  sc->filter = std::move(*combined);
  sc->characters = characters;
}

// Each alone: one job per character, RunParallel on `threads` threads (per-thread CPU
// counters), checked against the per-character oracle first.
void CrowdAloneOurs(benchmark::State& state, size_t characters, int threads) {
  const CrowdCharacter& cc = GetCrowdCharacter();
  if (!cc.error.empty()) return state.SkipWithError(cc.error.c_str());
  const size_t per = cc.frames[0].size(), f_count = cc.frames.size();
  std::vector<std::vector<rt::SpherePair>> reference(f_count);
  for (size_t f = 0; f < f_count; ++f) rt::FindSpherePairsBruteForce(cc.frames[f], *cc.filter, &reference[f]);
  std::vector<rt::BroadPhaseContext> contexts(characters);
  std::vector<std::vector<rt::SpherePair>> outs(characters);
  std::vector<rt::BroadPhaseJob> jobs(characters);
  for (size_t k = 0; k < characters; ++k) {
    contexts[k].Resize(per);
    outs[k].reserve(4 * per);
    jobs[k] = {cc.frames[0], cc.filter, &contexts[k], &outs[k]};
  }
  skinspheres::bench::TimedParallelFor pf(threads);
  const auto frame = [&](size_t f) {
    for (size_t k = 0; k < characters; ++k) jobs[k].spheres = cc.frames[(f + kPhase * k) % f_count];
    if (!rt::RunParallel(jobs, pf.get())) Abort("crowd job failed");
  };
  for (size_t f = 0; f < 2 * f_count; ++f) {
    frame(f);
    for (size_t k = 0; k < characters; ++k) {
      if (outs[k] != reference[(f + kPhase * k) % f_count])
        Abort("d_crowd alone: character " + std::to_string(k) + " differs");
    }
  }
  pf.Reset();
  size_t f = 0;
  for (auto _ : state) frame(f++);
  pf.Report(state);
  state.counters["spheres"] = double(characters * per);
  state.counters["threads"] = threads;
}

#if SKINSPHERES_HAVE_PEERS
// Each alone with a peer: one world per character, one after the other (count only).
template <class World>
void CrowdAlonePeer(benchmark::State& state, size_t characters) {
  const CrowdCharacter& cc = GetCrowdCharacter();
  if (!cc.error.empty()) return state.SkipWithError(cc.error.c_str());
  const size_t f_count = cc.frames.size();
  std::vector<std::unique_ptr<World>> worlds;
  for (size_t k = 0; k < characters; ++k) worlds.push_back(std::make_unique<World>(cc.frames[0], *cc.filter));
  std::vector<rt::SpherePair> reference;
  size_t f = 0;
  const auto frame = [&](bool check) {
    size_t total = 0;
    for (size_t k = 0; k < characters; ++k) {
      const Spheres& s = cc.frames[(f + kPhase * k) % f_count];
      const size_t count = worlds[k]->Frame(s, nullptr);
      if (check) {
        rt::FindSpherePairsBruteForce(s, *cc.filter, &reference);
        if (count != reference.size()) Abort("d_crowd alone: a peer differs from the oracle");
      }
      total += count;
    }
    ++f;
    return total;
  };
  for (size_t w = 0; w < 2 * f_count; ++w) frame(true);
  for (auto _ : state) benchmark::DoNotOptimize(frame(false));
  state.counters["spheres"] = double(characters * cc.frames[0].size());
}
#endif

void RegisterCrowds() {
  for (size_t characters : {1, 10, 100, 1000}) {
    const std::string alone = "d_crowd/alone/chars:" + std::to_string(characters);
    for (int threads : {1, 2}) {
      benchmark::RegisterBenchmark((alone + "/skinspheres_threads:" + std::to_string(threads)).c_str(),
                                   [=](benchmark::State& s) { CrowdAloneOurs(s, characters, threads); })
          ->Unit(benchmark::kMillisecond)
          ->UseRealTime();
    }
#if SKINSPHERES_HAVE_PEERS
    benchmark::RegisterBenchmark((alone + "/bullet_count").c_str(), [=](benchmark::State& s) {
      CrowdAlonePeer<skinspheres::bench::BulletWorld>(s, characters);
    })->Unit(benchmark::kMillisecond);
    benchmark::RegisterBenchmark((alone + "/fcl_count").c_str(), [=](benchmark::State& s) {
      CrowdAlonePeer<skinspheres::bench::FclWorld>(s, characters);
    })->Unit(benchmark::kMillisecond);
#endif
    const std::string k = "d_crowd/space/chars:" + std::to_string(characters);
    auto scenario = [k, characters]() -> const Scenario& {
      return GetScenario(k, [&](Scenario* sc) { CrowdSpace(sc, characters); });
    };
    std::vector<std::string> methods = {"skinspheres", "bullet_count", "fcl_count"};
    if (characters <= 10) methods.push_back("allpairs");
    for (const auto& m : methods) Register(k + "/" + m, scenario, m, benchmark::kMillisecond);
  }
}

}  // namespace

int main(int argc, char** argv) {
  RegisterCloud();
  RegisterClips();
  RegisterScale();
  RegisterCrowds();
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
