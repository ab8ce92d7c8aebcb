// The narrow phase (runtime/narrow_phase.h) per character per frame, against FCL on the same
// frames, and beside the other stages of a frame.
//
// Characters: the built-in one and the shared ones (SKINSPHERES_ASSET_DIR; a row whose file is
// absent skips with a message), fitted with the default FitSettings; char 5 and 6 are CesiumMan and
// RobotExpressive fitted with triangle pieces (piece_edge kPieceEdge). Workloads (range `work`):
//   0 "clips":  every clip of the file at 30 fps (at most kMaxFrames frames, evenly spaced);
//   1 "random": kRandomFrames poses with every joint turned by up to 35 degrees about a random
//               axis (seed 7): limbs folded into each other, many contacts, the peer's best case.
// Per frame, precomputed at set-up (untimed): G_j(t), the whole mesh skinned (SkinningJob, CSR),
// the exact and the fast spheres and their broad-phase pairs.
//
// A workload whose frames all hold one pose (Xbot's only clip: a T-pose of 0.067 s, 3 frames) is
// labelled "held pose" (counter held_pose = 1) and belongs in no range over the clips.
//
// Rows (one thread unless said; each iteration is the next frame). BM_Narrow, BM_Stage,
// BM_OursExact and BM_Fcl run whole passes over the workload's frames (KeepRunningBatch): every
// repetition times every frame the same number of times, however slow a frame is (FCL takes up to
// a few hundred ms a frame, so a row of it may be one pass), and a row's time is the mean per frame.
//   BM_Narrow/char/work/mode   the narrow phase alone on the broad phase's pairs:
//     mode 0  exact: mode (a), the frame's skinned positions, exact spheres' pairs;
//     mode 1  fast + lazy: mode (b), fast spheres' pairs, skinning only what it tests (included);
//     mode 2  fast + full skin: skin the whole mesh (prepared, SIMD), then mode (a) on the fast pairs.
//   BM_Stage/char/work/stage   the other stages: 0 skin the whole mesh (prepared), 1 exact refit,
//     2 broad phase on exact spheres, 3 fast refit, 4 broad phase on fast spheres.
//   BM_OursExact/char/work     what FCL is compared to: exact refit + broad phase + narrow phase,
//     from the same skinned positions FCL gets.
//   BM_Fcl/char/work           FCL 0.7 (Debian libfcl-dev): one BVHModel<OBBRSS> per body part,
//     refitted every frame (beginUpdateModel / updateVertex for every vertex / endUpdateModel,
//     refit bottom-up, as FCL's docs recommend for deforming meshes), then collide() on every pair
//     of parts the sphere set does not wholly exclude, all contacts requested (num_max_contacts
//     unbounded). range `fcl`: 0 enable_contact on (FCL computes a contact point and depth per
//     triangle pair, as we compute points), 1 off (the pairs only), 2 the refit alone.
//   BM_ClusterSize/char/work/size  mode (a) with clusters of at most `size` triangles.
//   BM_LazySkin/char/work/way  the skinning of mode (b) alone (see there) against the whole mesh.
//   BM_LazyVsWhole/char/work   modes 1 and 2 paired frame by frame (see there): their ratio under
//     one machine load.
// Checks before timing (set-up; a failure skips the row with the reason): fast + lazy gives the
// same contacts as fast + full skin on every frame, and FCL's intersecting triangle pairs, after
// the contact rules (contact_rules.h: near joints, shared vertex, near at rest; degenerate
// triangles), equal ours between different parts (FCL sees no pair inside one part);
// the counters fcl_same / fcl_only / ours_only say how many pairs agreed over all frames.
#include <benchmark/benchmark.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <map>
#include <memory>
#include <random>
#include <set>
#include <string>
#include <vector>

#include "narrow_phase/internal.h"
#include "skinspheres/lib/body_parts/body_parts.h"
#include "skinspheres/lib/character/builtin_character.h"
#include "skinspheres/lib/fit/sphere_fitter.h"
#include "skinspheres/lib/io/importer.h"
#include "skinspheres/runtime/api/character.h"
#include "skinspheres/runtime/fix/pose_fixer.h"
#include "skinspheres/runtime/narrow_phase/contact_rules.h"
#include "skinspheres/runtime/narrow_phase/narrow_phase.h"
#include "skinspheres/runtime/narrow_phase/triangle_contact.h"
#include "skinspheres/skinning/local_to_model_job.h"
#include "skinspheres/skinning/prepared_influences.h"
#include "skinspheres/skinning/sampling_job.h"
#include "skinspheres/skinning/skinning_job.h"
#include "skinspheres/skinning/skinning_matrices_job.h"

#if SKINSPHERES_HAVE_FCL
#include <fcl/geometry/bvh/BVH_model.h>
#include <fcl/math/bv/OBBRSS.h>
#include <fcl/narrowphase/collision.h>
#include <fcl/narrowphase/collision_object.h>
#endif

namespace {

namespace lib = skinspheres::lib;
namespace rt = skinspheres::runtime;
namespace sk = skinspheres::skinning;
using skinspheres::Mat4f;
using skinspheres::Vec4f;

constexpr int kMaxFrames = 240;
constexpr int kRandomFrames = 48;
// 5 and 6 are CesiumMan and RobotExpressive fitted with triangle pieces (FitSettings::piece_edge =
// kPieceEdge, docs/TRIANGLE_PIECES.md): what refit and narrow phase cost when spheres own pieces.
const char* const kNames[] = {"builtin",
                              "CesiumMan.glb",
                              "Soldier.glb",
                              "RobotExpressive.glb",
                              "Xbot.glb",
                              "CesiumMan.glb pieces",
                              "RobotExpressive.glb pieces"};
constexpr int kCharacters = 7;
constexpr float kPieceEdge = 0.03f;

std::span<const float> Floats(const std::vector<Eigen::Vector3f>& v) {
  return {reinterpret_cast<const float*>(v.data()), v.size() * 3};
}
std::span<float> Floats(std::vector<Eigen::Vector3f>& v) { return {reinterpret_cast<float*>(v.data()), v.size() * 3}; }

struct Frame {
  std::vector<Mat4f> joint_world;
  std::vector<Eigen::Vector3f> positions;  // whole mesh, SkinningJob CSR
  std::vector<Vec4f> spheres_exact, spheres_fast;
  std::vector<rt::SpherePair> pairs_exact, pairs_fast;
};

struct Workload {
  std::string error;
  std::vector<Frame> frames;
  double contacts = 0.0;  // triangle pairs per frame (exact mode)
  double fcl_same = 0, fcl_only = 0, ours_only = 0;
  bool checked_fcl = false;
  bool held_pose = false;  // every frame's skinned mesh is frame 0's
};

struct Character {
  std::string error;
  lib::RawCharacter ch;
  rt::SphereSet set;
  std::shared_ptr<const rt::CharacterAsset> asset;
  std::shared_ptr<const rt::CharacterAsset> old_rules;  // the same fit with the rules before (OldRules)
  sk::PreparedInfluences prepared_all;
  Workload work[2];
};

std::vector<sk::Transform> RandomLocals(const lib::RawCharacter& c, std::mt19937& rng) {
  std::uniform_real_distribution<float> u(-1.0f, 1.0f), unit(0.0f, 1.0f);
  std::vector<sk::Transform> local = c.skeleton.rest_local;
  for (auto& t : local) {
    Eigen::Vector3f axis(u(rng), u(rng), u(rng));
    if (axis.norm() < 1e-3f) axis = Eigen::Vector3f::UnitX();
    const float angle = unit(rng) * 35.0f * float(M_PI) / 180.0f;
    t.rotation = (t.rotation * skinspheres::Quatf(Eigen::AngleAxisf(angle, axis.normalized()))).normalized();
  }
  return local;
}

// The fit as a set written before the rules on triangles states its rules (contact_rules.h,
// ContactRules::kSpherePairs): sphere pairs of the same joint, of joints one bone apart in the whole
// skeleton, or overlapping at rest excluded; no sphere tested against itself; rule 3 at the margin.
rt::SphereSet OldRules(rt::SphereSet set) {
  const size_t joints = set.joint_count();
  std::vector<std::vector<int>> hops(joints, std::vector<int>(joints, 1 << 20));
  for (size_t s = 0; s < joints; ++s) {
    hops[s][s] = 0;
    for (bool changed = true; changed;) {  // relax along parent links (joints are few)
      changed = false;
      for (size_t j = 0; j < joints; ++j) {
        const int p = set.joint_parents[j];
        if (p < 0) continue;
        if (hops[s][j] + 1 < hops[s][p]) hops[s][p] = hops[s][j] + 1, changed = true;
        if (hops[s][p] + 1 < hops[s][j]) hops[s][j] = hops[s][p] + 1, changed = true;
      }
    }
  }
  set.contact_rules = rt::ContactRules::kSpherePairs;
  set.contact_hops = 0;
  set.rest_gap = 0.0f;
  set.excluded_pairs.clear();
  for (uint32_t i = 0; i < set.size(); ++i) {
    for (uint32_t j = i + 1; j < set.size(); ++j) {
      const int a = set.sphere_joint[i], b = set.sphere_joint[j];
      const bool overlap = (set.centers_rest[i] - set.centers_rest[j]).norm() < set.radii_rest[i] + set.radii_rest[j];
      if (a == b) {
        set.excluded_pairs.push_back({i, j, rt::ExclusionReason::kSameJoint});
      } else if (hops[a][b] <= 1) {
        set.excluded_pairs.push_back({i, j, rt::ExclusionReason::kAdjacentJoints});
      } else if (overlap) {
        set.excluded_pairs.push_back({i, j, rt::ExclusionReason::kBindOverlap});
      }
    }
  }
  return set;
}

// Poses a frame from joint-local transforms: G_j, the skinned mesh, both refits and their pairs.
bool MakeFrame(const Character& c, const std::vector<sk::Transform>& locals, rt::CharacterInstance& inst, Frame* f) {
  const auto& skin = c.ch.skin;
  f->joint_world.resize(c.ch.skeleton.size());
  sk::LocalToModelJob l2m;
  l2m.skeleton = &c.ch.skeleton;
  l2m.input = locals;
  l2m.output = f->joint_world;
  std::vector<Mat4f> mats(skin.binds.size());
  f->positions.assign(skin.vertex_count(), Eigen::Vector3f::Zero());
  sk::SkinningJob job;
  job.joint_matrices = mats;
  job.vertex_count = skin.vertex_count();
  job.in_positions = Floats(skin.positions_bind);
  job.out_positions = Floats(f->positions);
  job.influence_offsets = skin.influence_offsets;
  job.influence_binds = skin.influence_binds;
  job.influence_weights = skin.influence_weights;
  if (!l2m.Run() || !sk::SkinningMatricesJob{skin.binds, f->joint_world, mats}.Run() || !job.Run()) return false;
  if (!inst.UpdateExact(f->positions, f->joint_world).ok()) return false;
  f->spheres_exact.assign(inst.spheres().begin(), inst.spheres().end());
  const auto pe = inst.FindSpherePairs();
  f->pairs_exact.assign(pe.begin(), pe.end());
  if (!inst.UpdateFast(f->joint_world).ok()) return false;
  f->spheres_fast.assign(inst.spheres().begin(), inst.spheres().end());
  const auto pf = inst.FindSpherePairs();
  f->pairs_fast.assign(pf.begin(), pf.end());
  return true;
}

void Load(Character* c, int index) {
  std::string name = kNames[index];
  const bool pieces = name.ends_with(" pieces");
  if (pieces) name.resize(name.size() - 7);
  if (name == "builtin") {
    c->ch = lib::MakeBuiltinCharacter();
  } else {
    const auto file = std::filesystem::path(SKINSPHERES_ASSET_DIR) / name;
    if (!std::filesystem::exists(file)) {
      c->error = file.string() + ": not found (the shared characters are not installed); skipped";
      return;
    }
    auto ch = lib::ImportCharacter(file);
    if (!ch.ok()) return void(c->error = ch.error().message);
    c->ch = std::move(*ch);
  }
  auto parts = lib::SplitBodyParts(c->ch);
  if (!parts.ok()) return void(c->error = parts.error().message);
  lib::FitSettings settings;
  if (pieces) settings.piece_edge = kPieceEdge;
  auto fit = lib::FitSpheres(c->ch, *parts, settings);
  if (!fit.ok()) return void(c->error = fit.error().message);
  c->set = std::move(fit->spheres);
  if (pieces && !c->set.has_pieces()) return void(c->error = name + ": the fit cut no triangle into pieces");
  auto asset = rt::CharacterAsset::Create(c->set);
  if (!asset.ok()) return void(c->error = asset.error().message);
  c->asset = *asset;
  auto old = rt::CharacterAsset::Create(OldRules(c->set));
  if (!old.ok()) return void(c->error = old.error().message);
  c->old_rules = *old;
  std::string why;
  const auto& skin = c->ch.skin;
  if (!c->prepared_all.Build(skin.vertex_count(), skin.influence_offsets, skin.influence_binds, skin.influence_weights,
                             {}, &why)) {
    return void(c->error = why);
  }
  auto inst = rt::CharacterInstance::Create(c->asset);
  // Clips.
  std::vector<std::pair<size_t, float>> times;
  for (size_t k = 0; k < c->ch.clips.size(); ++k) {
    const int n = int(std::floor(c->ch.clips[k].duration_s * 30.0f + 1e-3f)) + 1;
    for (int f = 0; f < n; ++f) times.push_back({k, float(f) / 30.0f});
  }
  const size_t stride = std::max<size_t>(1, (times.size() + kMaxFrames - 1) / kMaxFrames);
  std::vector<sk::Transform> locals(c->ch.skeleton.size());
  for (size_t k = 0; k < times.size(); k += stride) {
    const auto& clip = c->ch.clips[times[k].first];
    if (!sk::SamplingJob{&clip, &c->ch.skeleton, std::min(times[k].second, clip.duration_s), locals}.Run()) {
      return void(c->error = "sampling failed");
    }
    c->work[0].frames.emplace_back();
    if (!MakeFrame(*c, locals, *inst, &c->work[0].frames.back())) return void(c->error = "posing failed");
  }
  std::mt19937 rng(7);
  for (int k = 0; k < kRandomFrames; ++k) {
    c->work[1].frames.emplace_back();
    if (!MakeFrame(*c, RandomLocals(c->ch, rng), *inst, &c->work[1].frames.back()))
      return void(c->error = "posing failed");
  }
  for (Workload& w : c->work) {
    if (w.frames.empty()) {
      w.error = "no frames";
      continue;
    }
    w.held_pose = std::all_of(w.frames.begin(), w.frames.end(), [&](const Frame& f) {
      for (size_t v = 0; v < f.positions.size(); ++v) {
        if ((f.positions[v] - w.frames[0].positions[v]).norm() > 1e-6f) return false;
      }
      return true;
    });
  }
}

Character* Get(benchmark::State& state, int index, int work) {
  static std::unique_ptr<Character> cache[kCharacters];
  if (!cache[index]) {
    cache[index] = std::make_unique<Character>();
    Load(cache[index].get(), index);
  }
  Character* c = cache[index].get();
  if (!c->error.empty()) {
    state.SkipWithError(c->error.c_str());
    return nullptr;
  }
  if (!c->work[work].error.empty()) {
    state.SkipWithError(c->work[work].error.c_str());
    return nullptr;
  }
  state.SetLabel(std::string(kNames[index]) + (work ? " random" : " clips") +
                 (c->work[work].held_pose ? " (held pose)" : ""));
  state.counters["held_pose"] = c->work[work].held_pose ? 1.0 : 0.0;
  state.counters["frames"] = double(c->work[work].frames.size());
  return c;
}

void Counters(benchmark::State& state, const Character& c, size_t frames, size_t pairs,
              const rt::NarrowPhaseContext::Stats& s, size_t contacts) {
  const double n = frames ? double(frames) : 1.0;
  state.counters["sphere_pairs"] = double(pairs) / n;
  state.counters["triangle_tests"] = double(s.triangle_tests) / n;
  state.counters["cluster_pairs"] = double(s.cluster_pairs) / n;
  state.counters["patch_pairs"] = double(s.patch_pairs) / n;
  state.counters["still"] = double(s.still_patch_pairs) / n;
  state.counters["clusters_bounded"] = double(s.clusters_bounded) / n;
  state.counters["box_tests"] = double(s.box_tests) / n;
  state.counters["culled_triangles"] = double(s.culled_triangles) / n;
  state.counters["contacts"] = double(contacts) / n;
  state.counters["skinned"] = double(s.skinned_vertices) / n;
  state.counters["vertices"] = double(c.ch.vertex_count());
  state.counters["triangles"] = double(c.ch.triangle_count());
}

void AddStats(rt::NarrowPhaseContext::Stats* sum, const rt::NarrowPhaseContext::Stats& s) {
  sum->triangle_tests += s.triangle_tests;
  sum->cluster_pairs += s.cluster_pairs;
  sum->patch_pairs += s.patch_pairs;
  sum->still_patch_pairs += s.still_patch_pairs;
  sum->clusters_bounded += s.clusters_bounded;
  sum->box_tests += s.box_tests;
  sum->culled_triangles += s.culled_triangles;
  sum->skinned_vertices += s.skinned_vertices;
}

// --------------------------------------------------------------------------- our rows

// Skins the whole mesh of a frame the fastest way (prepared influences, SIMD).
struct WholeMeshSkinner {
  const Character& c;
  std::vector<Eigen::Vector3f> skinned;
  std::vector<Mat4f> mats;
  sk::SkinningJob job;
  explicit WholeMeshSkinner(const Character& character)
      : c(character),
        skinned(character.ch.vertex_count(), Eigen::Vector3f::Zero()),
        mats(character.ch.skin.binds.size()) {
    job.joint_matrices = mats;
    job.vertex_count = c.ch.vertex_count();
    job.in_positions = Floats(c.ch.skin.positions_bind);
    job.out_positions = Floats(skinned);
    job.prepared = &c.prepared_all;
  }
  bool Skin(const Frame& f) { return sk::SkinningMatricesJob{c.ch.skin.binds, f.joint_world, mats}.Run() && job.Run(); }
};

// One of BM_Narrow's modes on one frame, with its own context (and, for mode 2, its own
// whole-mesh skinning buffers).
struct NarrowRunner {
  const Character& c;
  const int mode;
  const rt::NarrowPhaseData& data;
  rt::NarrowPhaseContext ctx;
  WholeMeshSkinner whole;
  NarrowRunner(const Character& character, int m)
      : c(character), mode(m), data(*character.asset->narrow_phase()), whole(character) {
    ctx.Resize(data, mode == 1);
  }
  bool Run(const Frame& f, rt::FrameContacts* result) {
    rt::NarrowPhaseJob job;
    job.set = &c.set;
    job.data = &data;
    job.context = &ctx;
    job.out = result;
    if (mode == 0) {
      job.spheres = f.spheres_exact;
      job.pairs = f.pairs_exact;
      job.positions = f.positions;
      job.joint_world = f.joint_world;  // the motion since rest bound (as CharacterInstance passes them)
    } else {
      job.spheres = f.spheres_fast;
      job.pairs = f.pairs_fast;
      job.joint_world = f.joint_world;
      if (mode == 2) {
        if (!whole.Skin(f)) return false;
        job.positions = whole.skinned;
      }
    }
    return job.Run();
  }
  // Fast + lazy == fast + full skin == the frame's own positions, bit for bit, on every frame.
  bool FastModeMatchesFullSkin(const Workload& w, rt::FrameContacts* out, rt::FrameContacts* check) {
    for (const Frame& f : w.frames) {
      rt::NarrowPhaseContext other;
      other.Resize(data, false);
      rt::NarrowPhaseJob job{&c.set, &data, f.spheres_fast, f.pairs_fast, f.positions, {}, &other, check};
      if (!Run(f, out) || !job.Run() || !(*out == *check)) return false;
    }
    return true;
  }
};

void BM_Narrow(benchmark::State& state) {
  const int work = int(state.range(1)), mode = int(state.range(2));
  Character* c = Get(state, int(state.range(0)), work);
  if (!c) return;
  const Workload& w = c->work[work];
  NarrowRunner runner(*c, mode);
  rt::FrameContacts out, check;
  out.Reserve(4096);
  if (mode != 0 && !runner.FastModeMatchesFullSkin(w, &out, &check)) {
    return state.SkipWithError("fast-mode contacts differ between lazy and full skinning");
  }
  size_t frame = 0, pairs = 0, contacts = 0;
  rt::NarrowPhaseContext::Stats stats;
  while (state.KeepRunningBatch(benchmark::IterationCount(w.frames.size()))) {
    for (const Frame& f : w.frames) {
      if (!runner.Run(f, &out)) return state.SkipWithError("narrow phase refused a frame");
      pairs += mode == 0 ? f.pairs_exact.size() : f.pairs_fast.size();
      contacts += out.triangle_pairs.size();
      AddStats(&stats, runner.ctx.last_stats());
      ++frame;
    }
  }
  Counters(state, *c, frame, pairs, stats, contacts);
}
BENCHMARK(BM_Narrow)
    ->ArgsProduct({{0, 1, 2, 3, 4, 5, 6}, {0, 1}, {0, 1, 2}})
    ->ArgNames({"char", "work", "mode"})
    ->Unit(benchmark::kMicrosecond);

// What an engine pays per character and frame for its contacts, under the rules before (rules 0: the
// same fit as a set written before the rules on triangles states them, OldRules) and now (rules 1),
// in the same run: the update and the contacts, through CharacterInstance as an engine calls it.
//   mode 0 exact: UpdateExact(the frame's skinned positions, G_j) + FindContacts(positions);
//   mode 1 fast:  UpdateFast(G_j) + FindContacts() (it skins what it tests).
// The skinning an engine does anyway (exact mode) is not timed. Counters: triangle pairs and sphere
// pairs per frame, and the share of the broad phase's pairs that own a contact.
void BM_Frame(benchmark::State& state) {
  const int work = int(state.range(1)), rules = int(state.range(2)), mode = int(state.range(3));
  Character* c = Get(state, int(state.range(0)), work);
  if (!c) return;
  const Workload& w = c->work[work];
  auto inst = rt::CharacterInstance::Create(rules == 0 ? c->old_rules : c->asset);
  if (!inst.ok()) return state.SkipWithError(inst.error().message.c_str());
  inst->ReserveContacts(4096);
  size_t frames = 0, contacts = 0, pairs = 0;
  auto run = [&](const Frame& f) {
    const bool ok = mode == 0
                        ? inst->UpdateExact(f.positions, f.joint_world).ok() && inst->FindContacts(f.positions).ok()
                        : inst->UpdateFast(f.joint_world).ok() && inst->FindContacts().ok();
    return ok;
  };
  for (const Frame& f : w.frames) {  // warm-up: every buffer at the workload's largest frame
    if (!run(f)) return state.SkipWithError("a frame was refused");
  }
  while (state.KeepRunningBatch(benchmark::IterationCount(w.frames.size()))) {
    for (const Frame& f : w.frames) {
      if (!run(f)) return state.SkipWithError("a frame was refused");
      contacts += inst->contacts().triangle_pairs.size();
      pairs += inst->sphere_pairs().size();
      ++frames;
    }
  }
  state.counters["contacts"] = double(contacts) / double(std::max<size_t>(frames, 1));
  state.counters["sphere_pairs"] = double(pairs) / double(std::max<size_t>(frames, 1));
  state.SetLabel(std::string(kNames[state.range(0)]) + (work ? " random" : " clips") +
                 (rules ? " rules now" : " rules before") + (mode ? " fast" : " exact"));
}
BENCHMARK(BM_Frame)
    ->ArgsProduct({{0, 1, 2, 3, 4, 5, 6}, {0, 1}, {0, 1}, {0, 1}})
    ->ArgNames({"char", "work", "rules", "mode"})
    ->Unit(benchmark::kMicrosecond);

// BM_Narrow's modes 1 and 2 paired: each iteration runs the next frame in both, fast + lazy
// skinning and fast + whole-mesh skin, each call timed on its own (steady clock; two readings,
// ~40 ns, against 1-600 us per call). Both modes see the same frames under the same machine load,
// so a load change between two separate rows cannot decide their ratio. The order flips every
// frame and again on every pass over the frames (frame counts are even), so each frame runs in
// both orders; the ratio is also reported per order, since the whole-mesh skinning streams the
// mesh through the cache and can evict what the lazy run would reuse, an effect alternating does
// not cancel. Both runners make one untimed pass first (warm-up, and lazy == full skin checked),
// and every timed frame's contacts are compared whole between the two, outside the timed calls.
// Counters: lazy_us and whole_us per frame; lazy_over_whole (sum over sum), and the same for the
// frames where lazy ran first (lazy_first) and second (whole_first); lazy_faster, the share of
// frames where lazy took less time; skinned (lazy's vertices per frame) against vertices. The
// row's Time column is both modes together.
void BM_LazyVsWhole(benchmark::State& state) {
  const int work = int(state.range(1));
  Character* c = Get(state, int(state.range(0)), work);
  if (!c) return;
  const Workload& w = c->work[work];
  NarrowRunner lazy(*c, 1), whole(*c, 2);
  rt::FrameContacts out_lazy, out_whole;
  out_lazy.Reserve(4096);
  out_whole.Reserve(4096);
  if (!lazy.FastModeMatchesFullSkin(w, &out_lazy, &out_whole) ||
      !whole.FastModeMatchesFullSkin(w, &out_whole, &out_lazy)) {
    return state.SkipWithError("fast-mode contacts differ between lazy and full skinning");
  }
  using Clock = std::chrono::steady_clock;
  auto timed = [](NarrowRunner& r, const Frame& f, rt::FrameContacts* out, double* seconds) {
    const auto t0 = Clock::now();
    const bool ok = r.Run(f, out);
    *seconds += std::chrono::duration<double>(Clock::now() - t0).count();
    return ok;
  };
  size_t frame = 0, lazy_faster = 0;
  double lazy_s[2] = {0.0, 0.0}, whole_s[2] = {0.0, 0.0};  // [0]: lazy ran first, [1]: second
  rt::NarrowPhaseContext::Stats stats;
  const size_t frames = w.frames.size();
  for (auto _ : state) {
    const Frame& f = w.frames[frame % frames];
    const size_t order = (frame + frame / frames) % 2;
    double l = 0.0, x = 0.0;
    const bool ok = order == 0 ? timed(lazy, f, &out_lazy, &l) && timed(whole, f, &out_whole, &x)
                               : timed(whole, f, &out_whole, &x) && timed(lazy, f, &out_lazy, &l);
    if (!ok) return state.SkipWithError("narrow phase refused a frame");
    if (!(out_lazy == out_whole)) return state.SkipWithError("the two modes' contacts differ");
    lazy_s[order] += l;
    whole_s[order] += x;
    lazy_faster += l < x ? 1 : 0;
    AddStats(&stats, lazy.ctx.last_stats());
    ++frame;
  }
  const double n = frame ? double(frame) : 1.0;
  const auto ratio = [](double a, double b) { return b > 0.0 ? a / b : 0.0; };
  state.counters["lazy_us"] = 1e6 * (lazy_s[0] + lazy_s[1]) / n;
  state.counters["whole_us"] = 1e6 * (whole_s[0] + whole_s[1]) / n;
  state.counters["lazy_over_whole"] = ratio(lazy_s[0] + lazy_s[1], whole_s[0] + whole_s[1]);
  state.counters["lazy_first"] = ratio(lazy_s[0], whole_s[0]);
  state.counters["whole_first"] = ratio(lazy_s[1], whole_s[1]);
  state.counters["lazy_faster"] = double(lazy_faster) / n;
  state.counters["skinned"] = double(stats.skinned_vertices) / n;
  state.counters["vertices"] = double(c->ch.vertex_count());
}
BENCHMARK(BM_LazyVsWhole)
    ->ArgsProduct({{0, 1, 2, 3, 4}, {0, 1}})
    ->ArgNames({"char", "work"})
    ->Unit(benchmark::kMicrosecond);

void BM_Stage(benchmark::State& state) {
  const int work = int(state.range(1)), stage = int(state.range(2));
  Character* c = Get(state, int(state.range(0)), work);
  if (!c) return;
  const Workload& w = c->work[work];
  auto inst = rt::CharacterInstance::Create(c->asset);
  inst->ReserveContacts(8192);
  WholeMeshSkinner whole(*c);
  rt::BroadPhaseContext ctx(c->set.size());
  std::vector<rt::SpherePair> out;
  out.reserve(8192);
  while (state.KeepRunningBatch(benchmark::IterationCount(w.frames.size()))) {
    for (const Frame& f : w.frames) {
      switch (stage) {
        case 0: benchmark::DoNotOptimize(whole.Skin(f)); break;
        case 1: benchmark::DoNotOptimize(inst->UpdateExact(f.positions, f.joint_world).ok()); break;
        case 2:
          benchmark::DoNotOptimize(rt::BroadPhaseJob{f.spheres_exact, &c->asset->filter(), &ctx, &out}.Run());
          break;
        case 3: benchmark::DoNotOptimize(inst->UpdateFast(f.joint_world).ok()); break;
        default:
          benchmark::DoNotOptimize(rt::BroadPhaseJob{f.spheres_fast, &c->asset->filter(), &ctx, &out}.Run());
          break;
      }
      benchmark::ClobberMemory();
    }
  }
  if (stage == 1) {  // the points exact mode bounds: the set's lists, and the rest data's (pieces)
    state.counters["points"] = double(c->set.vertices.size());
    const auto reduced = c->asset->rest().exact_points();
    state.counters["exact_points"] = double(reduced.empty() ? c->set.vertices.size() : reduced.size());
  }
  static const char* const kStages[] = {"skin whole mesh", "refit exact", "query exact", "refit fast", "query fast"};
  state.SetLabel(std::string(kNames[state.range(0)]) + (work ? " random: " : " clips: ") + kStages[stage] +
                 (w.held_pose ? " (held pose)" : ""));
}
BENCHMARK(BM_Stage)
    ->ArgsProduct({{0, 1, 2, 3, 4, 5, 6}, {0, 1}, {0, 1, 2, 3, 4}})
    ->ArgNames({"char", "work", "stage"})
    ->Unit(benchmark::kMicrosecond);

// Exact refit + broad phase + narrow phase from the skinned positions: the work FCL does below.
void BM_OursExact(benchmark::State& state) {
  const int work = int(state.range(1));
  Character* c = Get(state, int(state.range(0)), work);
  if (!c) return;
  const Workload& w = c->work[work];
  auto inst = rt::CharacterInstance::Create(c->asset);
  inst->ReserveContacts(8192);
  size_t frame = 0, contacts = 0;
  while (state.KeepRunningBatch(benchmark::IterationCount(w.frames.size()))) {
    for (const Frame& f : w.frames) {
      if (!inst->UpdateExact(f.positions, f.joint_world).ok() || !inst->FindContacts(f.positions).ok()) {
        return state.SkipWithError("frame failed");
      }
      contacts += inst->contacts().triangle_pairs.size();
      ++frame;
    }
  }
  state.counters["contacts"] = frame ? double(contacts) / double(frame) : 0.0;
}
BENCHMARK(BM_OursExact)
    ->ArgsProduct({{0, 1, 2, 3, 4}, {0, 1}})
    ->ArgNames({"char", "work"})
    ->Unit(benchmark::kMicrosecond);

void BM_ClusterSize(benchmark::State& state) {
  const int work = int(state.range(1));
  Character* c = Get(state, int(state.range(0)), work);
  if (!c) return;
  const Workload& w = c->work[work];
  rt::NarrowPhaseSettings settings;
  settings.cluster_triangles = uint32_t(state.range(2));
  auto data = rt::NarrowPhaseData::Create(c->set, c->asset->filter(), settings);
  if (!data.ok()) return state.SkipWithError(data.error().message.c_str());
  rt::NarrowPhaseContext ctx;
  ctx.Resize(*data, false);
  rt::FrameContacts out;
  out.Reserve(4096);
  size_t frame = 0, pairs = 0, contacts = 0;
  rt::NarrowPhaseContext::Stats stats;
  for (auto _ : state) {
    const Frame& f = w.frames[frame % w.frames.size()];
    rt::NarrowPhaseJob job{&c->set, &*data, f.spheres_exact, f.pairs_exact, f.positions, {}, &ctx, &out};
    if (!job.Run()) return state.SkipWithError("narrow phase refused a frame");
    pairs += f.pairs_exact.size();
    contacts += out.triangle_pairs.size();
    AddStats(&stats, ctx.last_stats());
    ++frame;
  }
  Counters(state, *c, frame, pairs, stats, contacts);
}
BENCHMARK(BM_ClusterSize)
    ->ArgsProduct({{0, 1, 2, 3, 4}, {0, 1}, {4, 8, 16, 32, 64}})
    ->ArgNames({"char", "work", "size"})
    ->Unit(benchmark::kMicrosecond);

// The skinning of mode (b) alone, on each frame's fast pairs (the groups of the spheres in pairs):
//   way 0  the marked runs of the narrow phase's lazy_influences, adjacent runs merged (mode b's path);
//   way 1  one PreparedInfluences per vertex group, each run as its own job (the former layout);
//   way 2  every vertex of the mesh (prepared, SIMD): what fast + whole-mesh skin pays.
// Joint matrices are computed outside the timed part here (every way needs them).
void BM_LazySkin(benchmark::State& state) {
  const int work = int(state.range(1)), way = int(state.range(2));
  Character* c = Get(state, int(state.range(0)), work);
  if (!c) return;
  const Workload& w = c->work[work];
  // The layout, through the narrow phase's friend (runtime/src/narrow_phase/internal.h).
  const rt::NarrowPhaseData::Layout& layout = rt::narrow_phase::Access::Of(*c->asset->narrow_phase());
  const sk::PreparedInfluences& lazy = layout.lazy_influences;
  const auto& skin = c->ch.skin;
  // Per frame: the slot spans to skin (way 0) and the groups (way 1).
  std::vector<std::vector<std::pair<uint32_t, uint32_t>>> spans(w.frames.size());
  std::vector<std::vector<uint32_t>> groups(w.frames.size());
  std::vector<sk::PreparedInfluences> per_group(layout.group_count());
  if (way == 1) {
    for (uint32_t g = 0; g < layout.group_count(); ++g) {
      std::vector<uint32_t> members;
      for (uint32_t r = layout.group_run_offsets[g]; r < layout.group_run_offsets[g + 1]; ++r) {
        const uint32_t run = layout.group_runs[r];
        for (uint32_t slot = layout.run_begin[run]; slot < layout.run_begin[run + 1]; ++slot)
          members.push_back(lazy.vertices()[slot]);
      }
      std::sort(members.begin(), members.end());
      per_group[g].Build(skin.vertex_count(), skin.influence_offsets, skin.influence_binds, skin.influence_weights,
                         members);
    }
  }
  size_t marked_vertices = 0;
  for (size_t k = 0; k < w.frames.size(); ++k) {
    std::vector<char> group_on(layout.group_count(), 0), run_on(layout.run_count(), 0);
    for (const rt::SpherePair& p : w.frames[k].pairs_fast) {
      for (uint32_t s : {p.sphere_i, p.sphere_j}) {
        for (uint32_t q = layout.sphere_group_offsets[s]; q < layout.sphere_group_offsets[s + 1]; ++q)
          group_on[layout.sphere_groups[q]] = 1;
      }
    }
    for (uint32_t g = 0; g < layout.group_count(); ++g) {
      if (!group_on[g]) continue;
      groups[k].push_back(g);
      marked_vertices += layout.group_sizes[g];
      for (uint32_t r = layout.group_run_offsets[g]; r < layout.group_run_offsets[g + 1]; ++r)
        run_on[layout.group_runs[r]] = 1;
    }
    for (uint32_t r = 0; r < layout.run_count(); ++r) {
      if (!run_on[r]) continue;
      if (!spans[k].empty() && spans[k].back().second == layout.run_begin[r]) {
        spans[k].back().second = layout.run_begin[r + 1];
      } else {
        spans[k].emplace_back(layout.run_begin[r], layout.run_begin[r + 1]);
      }
    }
  }
  std::vector<Eigen::Vector3f> out(skin.vertex_count(), Eigen::Vector3f::Zero());
  std::vector<std::vector<Mat4f>> mats(w.frames.size(), std::vector<Mat4f>(skin.binds.size()));
  for (size_t k = 0; k < w.frames.size(); ++k) {
    if (!sk::SkinningMatricesJob{skin.binds, w.frames[k].joint_world, mats[k]}.Run())
      return state.SkipWithError("matrices");
  }
  sk::SkinningJob job;
  job.vertex_count = skin.vertex_count();
  job.in_positions = Floats(skin.positions_bind);
  job.out_positions = Floats(out);
  size_t frame = 0;
  for (auto _ : state) {
    const size_t k = frame % w.frames.size();
    job.joint_matrices = mats[k];
    bool ok = true;
    if (way == 0) {
      job.prepared = &lazy;
      ok &= job.RunRanges(spans[k]);
    } else if (way == 1) {
      for (uint32_t g : groups[k]) {
        job.prepared = &per_group[g];
        ok &= job.Run();
      }
    } else {
      job.prepared = &c->prepared_all;
      ok &= job.Run();
    }
    if (!ok) return state.SkipWithError("skinning refused");
    benchmark::ClobberMemory();
    ++frame;
  }
  state.counters["skinned"] =
      way == 2 ? double(skin.vertex_count()) : double(marked_vertices) / double(w.frames.size());
  state.counters["vertices"] = double(skin.vertex_count());
  size_t span_count = 0;
  for (const auto& s : spans) span_count += s.size();
  state.counters["spans"] = way == 0 ? double(span_count) / double(w.frames.size()) : 0.0;
}
BENCHMARK(BM_LazySkin)
    ->ArgsProduct({{0, 1, 2, 3, 4}, {0, 1}, {0, 1, 2}})
    ->ArgNames({"char", "work", "way"})
    ->Unit(benchmark::kMicrosecond);

#if SKINSPHERES_HAVE_FCL
// --------------------------------------------------------------------------- FCL

using Model = fcl::BVHModel<fcl::OBBRSSd>;

struct FclWorld {
  struct Part {
    std::shared_ptr<Model> model;
    std::unique_ptr<fcl::CollisionObjectd> object;
    std::vector<uint32_t> vertices;   // local vertex -> source vertex
    std::vector<uint32_t> triangles;  // local triangle -> source triangle
  };
  std::vector<Part> parts;
  std::vector<std::pair<int, int>> part_pairs;  // the pairs of parts with a sphere pair the filter allows
  fcl::CollisionRequestd request{1000000, true};
  bool collide = true;  // false: refit only (to see where FCL's time goes)
  fcl::CollisionResultd result;
  std::vector<fcl::Contactd> found;

  FclWorld(const Character& c) {
    const rt::SphereSet& set = c.set;
    parts.resize(set.parts.size());
    std::vector<int> local(set.source_vertex_count, -1);
    for (size_t p = 0; p < parts.size(); ++p) {
      Part& part = parts[p];
      std::fill(local.begin(), local.end(), -1);
      std::vector<fcl::Vector3d> points;
      std::vector<fcl::Triangle> tris;
      for (size_t s = 0; s < set.size(); ++s) {
        if (set.sphere_part[s] != p) continue;
        for (uint32_t k = set.triangle_offsets[s]; k < set.triangle_offsets[s + 1]; ++k) {
          const uint32_t t = set.triangles[k];
          size_t idx[3];
          for (int v = 0; v < 3; ++v) {
            const uint32_t src = set.triangle_vertices[3 * size_t{t} + v];
            if (local[src] < 0) {
              local[src] = int(part.vertices.size());
              part.vertices.push_back(src);
              points.push_back(c.asset->narrow_phase()->rest_positions()[src].cast<double>());
            }
            idx[v] = size_t(local[src]);
          }
          tris.emplace_back(idx[0], idx[1], idx[2]);
          part.triangles.push_back(t);
        }
      }
      part.model = std::make_shared<Model>();
      part.model->beginModel(int(tris.size()), int(points.size()));
      part.model->addSubModel(points, tris);
      part.model->endModel();
      part.object = std::make_unique<fcl::CollisionObjectd>(part.model);
    }
    const rt::PairFilter& filter = c.asset->filter();
    for (size_t p = 0; p < parts.size(); ++p) {
      for (size_t q = p + 1; q < parts.size(); ++q) {
        bool allowed = false;
        for (uint32_t i = 0; i < set.size() && !allowed; ++i) {
          for (uint32_t j = 0; j < set.size() && !allowed; ++j) {
            allowed = set.sphere_part[i] == p && set.sphere_part[j] == q && !filter.excluded(i, j);
          }
        }
        if (allowed && !parts[p].triangles.empty() && !parts[q].triangles.empty())
          part_pairs.push_back({int(p), int(q)});
      }
    }
  }

  // Refit every part to the positions, collide every allowed part pair; calls fn(t, u) per pair.
  template <class Fn>
  void Frame(const std::vector<Eigen::Vector3f>& pos, Fn&& fn) {
    for (Part& part : parts) {
      part.model->beginUpdateModel();
      for (uint32_t v : part.vertices) part.model->updateVertex(pos[v].cast<double>());
      part.model->endUpdateModel(true, true);
      part.object->computeAABB();
    }
    if (!collide) return;
    for (const auto& [p, q] : part_pairs) {
      result.clear();
      fcl::collide(parts[p].object.get(), parts[q].object.get(), request, result);
      found.clear();
      result.getContacts(found);
      for (const fcl::Contactd& contact : found) {
        const bool first = contact.o1 == parts[p].model.get();
        const uint32_t t = parts[first ? p : q].triangles[size_t(contact.b1)];
        const uint32_t u = parts[first ? q : p].triangles[size_t(contact.b2)];
        fn(t, u);
      }
    }
  }
};

// Compares FCL's pairs with ours on every frame (after our rules), once per workload.
void CheckFcl(Character* c, Workload* w, FclWorld* world) {
  if (w->checked_fcl) return;
  w->checked_fcl = true;
  // Whole triangles only: with pieces (docs/TRIANGLE_PIECES.md) the exclusions apply per piece, and
  // the sets fitted here have none.
  if (c->set.has_pieces()) return;
  const rt::NarrowPhaseData& data = *c->asset->narrow_phase();
  const rt::PairFilter& filter = c->asset->filter();
  std::vector<uint32_t> owner(c->set.source_triangle_count, UINT32_MAX);
  for (uint32_t s = 0; s < c->set.size(); ++s) {
    for (uint32_t k = c->set.triangle_offsets[s]; k < c->set.triangle_offsets[s + 1]; ++k)
      owner[c->set.triangles[k]] = s;
  }
  auto degenerate = [&](const std::vector<Eigen::Vector3f>& pos, uint32_t t) {
    const uint32_t* v = &c->set.triangle_vertices[3 * size_t{t}];
    return rt::TriangleIsDegenerate(pos[v[0]], pos[v[1]], pos[v[2]]);
  };
  // Rule 2 as the set states it: on the triangles' joints (rules on triangles), else on the
  // spheres that own them (the filter's excluded pairs, as sets before the rules on triangles).
  const bool on_triangles = c->set.contact_rules == rt::ContactRules::kTriangles;
  const std::vector<uint16_t> joint = on_triangles ? rt::TriangleJoints(c->set) : std::vector<uint16_t>{};
  const rt::NearJoints near = on_triangles ? rt::NearJoints(c->set, c->set.contact_hops) : rt::NearJoints{};
  auto rule2 = [&](uint32_t t, uint32_t u) {
    return on_triangles ? near(joint[t], joint[u]) : filter.excluded(owner[t], owner[u]);
  };
  auto inst = rt::CharacterInstance::Create(c->asset);
  for (const Frame& f : w->frames) {
    std::set<std::pair<uint32_t, uint32_t>> fcl_pairs, ours;
    world->Frame(f.positions, [&](uint32_t t, uint32_t u) {
      if (rule2(t, u) || data.ShareVertex(t, u) || data.RestExcluded(t, u) || degenerate(f.positions, t) ||
          degenerate(f.positions, u)) {
        return;
      }
      fcl_pairs.insert(std::minmax(t, u));
    });
    inst->UpdateExact(f.positions, f.joint_world);
    inst->FindContacts(f.positions);
    const rt::FrameContacts& fc = inst->contacts();
    for (const rt::PartContact& p : fc.parts) {
      if (p.part_a == p.part_b) continue;
      for (uint32_t k = p.first_triangle_pair; k < p.first_triangle_pair + p.triangle_pair_count; ++k) {
        const auto& tp = fc.triangle_pairs[k];
        if (tp.kind == rt::TriangleContactKind::kIntersecting) ours.insert(std::minmax(tp.triangle_a, tp.triangle_b));
      }
    }
    for (const auto& key : fcl_pairs) (ours.count(key) ? w->fcl_same : w->fcl_only) += 1;
    for (const auto& key : ours) w->ours_only += fcl_pairs.count(key) ? 0 : 1;
  }
}

// range(2): 0 all contacts with contact points (enable_contact), 1 all contacts without points
// (primitive pairs only: the least work that still finds every pair), 2 the refit alone.
void BM_Fcl(benchmark::State& state) {
  const int work = int(state.range(1)), variant = int(state.range(2));
  Character* c = Get(state, int(state.range(0)), work);
  if (!c) return;
  Workload& w = c->work[work];
  FclWorld world(*c);
  CheckFcl(c, &w, &world);
  world.request.enable_contact = variant == 0;
  world.collide = variant != 2;
  static const char* const kVariants[] = {": contact points", ": pairs only", ": refit only"};
  state.SetLabel(std::string(kNames[state.range(0)]) + (work ? " random" : " clips") + kVariants[variant] +
                 (w.held_pose ? " (held pose)" : ""));
  size_t frame = 0, contacts = 0;
  while (state.KeepRunningBatch(benchmark::IterationCount(w.frames.size()))) {
    for (const Frame& f : w.frames) {
      world.Frame(f.positions, [&](uint32_t, uint32_t) { ++contacts; });
      ++frame;
    }
  }
  const double frames = double(w.frames.size());
  state.counters["contacts_raw"] = frame ? double(contacts) / double(frame) : 0.0;
  state.counters["fcl_same"] = w.fcl_same / frames;
  state.counters["fcl_only"] = w.fcl_only / frames;
  state.counters["ours_only"] = w.ours_only / frames;
  state.counters["part_pairs"] = double(world.part_pairs.size());
}
BENCHMARK(BM_Fcl)
    ->ArgsProduct({{0, 1, 2, 3, 4}, {0, 1}, {0, 1, 2}})
    ->ArgNames({"char", "work", "fcl"})
    ->Unit(benchmark::kMicrosecond);
#endif  // SKINSPHERES_HAVE_FCL

// runtime::PoseFixer on the penetrating poses of the character's own clips (every frame at 30 fps
// where a part pair penetrates deeper than the touch tolerance, 48 at most): the cost of one Fix
// call, the way an engine would correct a generated pose. Counters: steps per call, the share of
// poses that hold after, poses.
void BM_FixPose(benchmark::State& state) {
  Character* c = Get(state, int(state.range(0)), 0);
  if (!c) return;
  if (c->set.joint_names != c->ch.skeleton.joint_names) return state.SkipWithError("set joints != skeleton");
  auto fixer = rt::PoseFixer::Create(c->asset);
  if (!fixer.ok()) return state.SkipWithError(fixer.error().message.c_str());
  std::vector<std::vector<sk::Transform>> poses;
  std::vector<sk::Transform> locals(c->ch.skeleton.size());
  for (const auto& clip : c->ch.clips) {
    for (int f = 0; poses.size() < 48 && f / 30.0f <= clip.duration_s; ++f) {
      if (!sk::SamplingJob{&clip, &c->ch.skeleton, f / 30.0f, locals}.Run()) continue;
      std::vector<sk::Transform> copy = locals;
      auto probe = fixer->Fix(copy, {});
      if (probe.ok() && probe->deepest_before > c->asset->narrow_phase()->touch_tolerance()) poses.push_back(locals);
    }
  }
  if (poses.empty()) return state.SkipWithError("no clip frame penetrates");
  size_t calls = 0, steps = 0, holds = 0;
  std::vector<sk::Transform> work;
  while (state.KeepRunningBatch(benchmark::IterationCount(poses.size()))) {
    for (const auto& pose : poses) {
      state.PauseTiming();
      work = pose;
      state.ResumeTiming();
      auto r = fixer->Fix(work, {});
      if (!r.ok()) return state.SkipWithError(r.error().message.c_str());
      ++calls;
      steps += size_t(r->steps);
      holds += r->holds;
    }
  }
  state.counters["steps"] = double(steps) / double(std::max<size_t>(calls, 1));
  state.counters["holds"] = double(holds) / double(std::max<size_t>(calls, 1));
  state.counters["poses"] = double(poses.size());
  state.SetLabel(std::string(kNames[state.range(0)]) + " own clips, penetrating frames");
}
BENCHMARK(BM_FixPose)->DenseRange(0, 4)->ArgName("char")->Unit(benchmark::kMicrosecond);

}  // namespace

BENCHMARK_MAIN();
