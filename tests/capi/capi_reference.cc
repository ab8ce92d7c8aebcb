// The C++ side of the C API test: fits the built-in character (or a character file), writes its
// sphere set (binary, JSON, fast-only binary) and, for every frame of its "touch" clip (a file's:
// every clip), what an engine would hand the C API (joint world matrices in the engine's own joint
// order, skinned positions) together with the contacts the C++ API (CharacterInstance, set joint
// order) finds in fast and exact mode. A cross build's capi_contacts replays these files on its own
// platform (tests/CMakeLists.txt): the same contacts, byte for byte, on every platform.
//   capi_reference OUT_DIR [MARGIN] [--character FILE]
//     MARGIN: the narrow phase's margin (NarrowPhaseSettings), default 0; with MARGIN > 0 the clip
//     must hold within-margin pairs. FILE: a skinned character (glTF, FBX, ...) instead of the
//     built-in one.
//
// frames.bin (little-endian): u32 joint_count, u32 vertex_count, u32 frame_count; joint_count names
// (u32 length + bytes + padding); then per frame: 16 * joint_count floats, 3 * vertex_count floats, and for
// fast then exact mode a u32 contact count followed by that many 16-byte contacts, then the narrow
// phase's part pairs (u32 count, then 56 bytes each: u16 part_a, part_b, u32 first triangle pair,
// triangle pair count, intersecting count, sphere pair count, f32 depth, min_distance, normal[3],
// center[3], u32 kind) and triangle pairs (u32 count, then 52 bytes each: u32 triangle_a, triangle_b,
// kind, f32 distance, point[3], on_a[3], on_b[3]): the C API's structs, field by field. Names are padded
// with zeros to a multiple of 4 bytes so that every float is 4-byte aligned in a malloc'ed copy.
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <random>
#include <set>
#include <span>
#include <string>
#include <vector>

#include "skinspheres/lib/body_parts/body_parts.h"
#include "skinspheres/lib/character/builtin_character.h"
#include "skinspheres/lib/fit/sphere_fitter.h"
#include "skinspheres/lib/io/importer.h"
#include "skinspheres/runtime/api/character.h"
#include "skinspheres/runtime/format/sphere_set_binary.h"
#include "skinspheres/runtime/format/sphere_set_io.h"
#include "skinspheres/skinning/local_to_model_job.h"
#include "skinspheres/skinning/sampling_job.h"
#include "skinspheres/skinning/skinning_job.h"
#include "skinspheres/skinning/skinning_matrices_job.h"

using namespace skinspheres;

namespace {

int Fail(const std::string& what) {
  std::fprintf(stderr, "capi_reference: %s\n", what.c_str());
  return 1;
}

void Put(FILE* f, const void* data, size_t bytes) { std::fwrite(data, 1, bytes, f); }
void Put32(FILE* f, uint32_t v) { Put(f, &v, 4); }

// The engine's joints: the skin's, in reverse order, plus one the set does not know (-1). A skeleton
// whose names repeat (RobotExpressive) cannot be mapped by name: its engine passes the set's own
// list, in order.
std::vector<int32_t> EngineJoints(const lib::RawCharacter& ch, const runtime::SphereSet& set, std::string* error) {
  std::set<int32_t> skin;
  for (const skinning::BindEntry& b : ch.skin.binds) skin.insert(b.joint);
  std::vector<int32_t> engine_joint(skin.rbegin(), skin.rend());
  engine_joint.push_back(-1);
  const std::set<std::string> distinct(ch.skeleton.joint_names.begin(), ch.skeleton.joint_names.end());
  if (distinct.size() != ch.skeleton.joint_names.size() || set.joint_names != ch.skeleton.joint_names) {
    if (set.joint_names != ch.skeleton.joint_names) *error = "the set's joints are not the skeleton's";
    engine_joint.clear();
    for (size_t j = 0; j < ch.skeleton.size(); ++j) engine_joint.push_back(static_cast<int32_t>(j));
  }
  return engine_joint;
}

// The frames to write: each a clip and its time, or (clip null) a random pose. The built-in
// character's "touch" (hands on the chest, then the head), or every clip of a file at 15 fps; a
// file's character also gets random poses (every joint turned up to 50 degrees, seeded), so that a
// character whose clips hold no contact (Xbot's is a held T-pose) still gives the replay something
// to compare.
struct FramePlan {
  std::vector<std::pair<const skinning::AnimationClip*, float>> times;
  std::vector<std::vector<skinning::Transform>> random_locals;  // the last random_locals.size() frames
  size_t clips = 0;
  std::string first_clip;
};

FramePlan PlanFrames(const lib::RawCharacter& ch, bool from_file) {
  FramePlan plan;
  std::vector<const skinning::AnimationClip*> clips;
  if (!from_file) {
    clips.push_back(&ch.clips.back());
  } else {
    for (const skinning::AnimationClip& c : ch.clips) clips.push_back(&c);
  }
  const float fps = 15.0f;
  for (const skinning::AnimationClip* c : clips) {
    const uint32_t n = static_cast<uint32_t>(c->duration_s * fps) + 1;
    for (uint32_t k = 0; k < n; ++k) plan.times.emplace_back(c, std::min(c->duration_s, static_cast<float>(k) / fps));
  }
  plan.clips = clips.size();
  plan.first_clip = clips.empty() ? "" : clips.front()->name;
  std::mt19937 rng(20261204);
  for (uint32_t k = 0; from_file && k < 24; ++k) {
    std::uniform_real_distribution<float> u(-1.0f, 1.0f), unit(0.0f, 1.0f);
    std::vector<skinning::Transform> local = ch.skeleton.rest_local;
    for (skinning::Transform& tr : local) {
      Eigen::Vector3f axis(u(rng), u(rng), u(rng));
      if (axis.norm() < 1e-3f) axis = Eigen::Vector3f::UnitX();
      const float angle = unit(rng) * 50.0f * 3.14159265f / 180.0f;
      tr.rotation = (tr.rotation * Quatf(Eigen::AngleAxisf(angle, axis.normalized()))).normalized();
    }
    plan.random_locals.push_back(std::move(local));
    plan.times.emplace_back(nullptr, 0.0f);
  }
  return plan;
}

// One mode of one frame: the sphere pairs, then the narrow phase behind them (fast mode skins
// what it tests from the joint matrices, exact mode takes the skinned positions), written as the
// header says. Empty, or what failed.
std::string WriteMode(FILE* f, runtime::CharacterInstance& instance, runtime::RefitMode mode,
                      std::span<const Mat4f> world, std::span<const Eigen::Vector3f> skinned, size_t* pairs_total,
                      size_t* triangle_total, size_t* within_margin) {
  const runtime::FrameStatus st = instance.Update(mode, world, skinned);
  if (!st.ok()) return std::string("update: ") + st.message;
  const auto pairs = instance.FindSpherePairs();
  Put32(f, static_cast<uint32_t>(pairs.size()));
  Put(f, pairs.data(), pairs.size() * sizeof(runtime::SpherePair));
  *pairs_total += pairs.size();
  const runtime::FrameStatus nst =
      mode == runtime::RefitMode::kFast ? instance.FindContacts() : instance.FindContacts(skinned);
  if (!nst.ok()) return std::string("find contacts: ") + nst.message;
  const runtime::FrameContacts& found = instance.contacts();
  Put32(f, static_cast<uint32_t>(found.parts.size()));
  for (const runtime::PartContact& p : found.parts) {
    Put(f, &p.part_a, 2);
    Put(f, &p.part_b, 2);
    Put32(f, p.first_triangle_pair);
    Put32(f, p.triangle_pair_count);
    Put32(f, p.intersecting_count);
    Put32(f, p.sphere_pair_count);
    Put(f, &p.depth, 4);
    Put(f, &p.min_distance, 4);
    Put(f, p.normal, 12);
    Put(f, p.center, 12);
    Put32(f, static_cast<uint32_t>(p.kind));
  }
  Put32(f, static_cast<uint32_t>(found.triangle_pairs.size()));
  for (const runtime::TriangleContact& t : found.triangle_pairs) {
    Put32(f, t.triangle_a);
    Put32(f, t.triangle_b);
    Put32(f, static_cast<uint32_t>(t.kind));
    Put(f, &t.distance, 4);
    Put(f, t.point, 12);
    Put(f, t.on_a, 12);
    Put(f, t.on_b, 12);
    *within_margin += t.kind == runtime::TriangleContactKind::kWithinMargin;
  }
  *triangle_total += found.triangle_pairs.size();
  return {};
}

}  // namespace

int main(int argc, char** argv) {
  std::vector<std::string> args(argv + 1, argv + argc);
  std::string character_file;
  if (args.size() >= 2 && args[args.size() - 2] == "--character") {
    character_file = args.back();
    args.resize(args.size() - 2);
  }
  if (args.empty() || args.size() > 2) return Fail("usage: capi_reference OUT_DIR [MARGIN] [--character FILE]");
  const std::filesystem::path dir = args[0];
  runtime::NarrowPhaseSettings narrow;
  if (args.size() == 2) narrow.margin = std::strtof(args[1].c_str(), nullptr);
  std::filesystem::create_directories(dir);
  lib::RawCharacter ch;
  if (character_file.empty()) {
    ch = lib::MakeBuiltinCharacter();
  } else {
    auto imported = lib::ImportCharacter(character_file);
    if (!imported.ok()) return Fail(imported.error().message);
    ch = std::move(imported).value();
  }
  auto parts = lib::SplitBodyParts(ch);
  if (!parts.ok()) return Fail(parts.error().message);
  auto fit = lib::FitSpheres(ch, *parts, lib::FitSettings{});
  if (!fit.ok()) return Fail(fit.error().message);
  const runtime::SphereSet& set = fit->spheres;
  if (auto err = runtime::SaveSphereSet(set, dir / "set.ssb")) return Fail(err->message);
  if (auto err = runtime::SaveSphereSet(set, dir / "set.json")) return Fail(err->message);
  if (auto err = runtime::SaveSphereSet(set, dir / "set_fast.ssb", runtime::SphereSetFileFormat::kBinaryFastOnly)) {
    return Fail(err->message);
  }

  std::string joints_error;
  const std::vector<int32_t> engine_joint = EngineJoints(ch, set, &joints_error);
  if (!joints_error.empty()) return Fail(joints_error);
  std::vector<std::string> names;
  for (int32_t j : engine_joint) names.push_back(j < 0 ? "IK_target" : ch.skeleton.joint_names[static_cast<size_t>(j)]);

  auto asset = runtime::CharacterAsset::Create(set, narrow);
  if (!asset.ok()) return Fail(asset.error().message);
  auto instance = runtime::CharacterInstance::Create(*asset);
  if (!instance.ok()) return Fail(instance.error().message);

  const FramePlan plan = PlanFrames(ch, !character_file.empty());
  if (plan.times.empty()) return Fail(character_file + ": no clip");
  const uint32_t frames = static_cast<uint32_t>(plan.times.size());
  const uint32_t random_poses = static_cast<uint32_t>(plan.random_locals.size());
  const size_t joints = ch.skeleton.size(), vertices = ch.vertex_count();
  FILE* f = std::fopen((dir / "frames.bin").c_str(), "wb");
  if (!f) return Fail("cannot write frames.bin");
  Put32(f, static_cast<uint32_t>(names.size()));
  Put32(f, static_cast<uint32_t>(vertices));
  Put32(f, frames);
  for (const std::string& n : names) {
    Put32(f, static_cast<uint32_t>(n.size()));
    Put(f, n.data(), n.size());
    const char zeros[4] = {};
    Put(f, zeros, (4 - n.size() % 4) % 4);  // the floats that follow stay 4-byte aligned
  }
  std::vector<skinning::Transform> locals(joints);
  std::vector<Mat4f> world(joints), skin_matrices(ch.skin.binds.size());
  std::vector<Mat4f> engine_world(names.size(), Mat4f::Identity());
  std::vector<float> positions(3 * vertices);
  size_t total = 0, triangle_total = 0, within_margin = 0;
  for (uint32_t k = 0; k < frames; ++k) {
    const bool random = plan.times[k].first == nullptr;
    if (random) locals = plan.random_locals[k - (frames - random_poses)];
    skinning::SamplingJob sampling{plan.times[k].first, &ch.skeleton, plan.times[k].second, locals};
    skinning::LocalToModelJob l2m;
    l2m.skeleton = &ch.skeleton;
    l2m.input = locals;
    l2m.output = world;
    skinning::SkinningMatricesJob matrices{ch.skin.binds, world, skin_matrices};
    skinning::SkinningJob skinning;
    skinning.joint_matrices = skin_matrices;
    skinning.vertex_count = vertices;
    skinning.in_positions = {ch.skin.positions_bind.data()->data(), 3 * vertices};
    skinning.out_positions = positions;
    skinning.influence_offsets = ch.skin.influence_offsets;
    skinning.influence_binds = ch.skin.influence_binds;
    skinning.influence_weights = ch.skin.influence_weights;
    if ((!random && !sampling.Run()) || !l2m.Run() || !matrices.Run() || !skinning.Run()) {
      return Fail("posing the character failed");
    }
    for (size_t e = 0; e < engine_joint.size(); ++e) {
      if (engine_joint[e] >= 0) engine_world[e] = world[static_cast<size_t>(engine_joint[e])];
    }
    Put(f, engine_world.data()->data(), engine_world.size() * sizeof(Mat4f));
    Put(f, positions.data(), positions.size() * sizeof(float));
    const std::span<const Eigen::Vector3f> skinned(reinterpret_cast<const Eigen::Vector3f*>(positions.data()),
                                                   vertices);
    for (runtime::RefitMode mode : {runtime::RefitMode::kFast, runtime::RefitMode::kExact}) {
      const std::string err = WriteMode(f, *instance, mode, world, skinned, &total, &triangle_total, &within_margin);
      if (!err.empty()) return Fail(err);
    }
  }
  std::fclose(f);
  std::printf(
      "wrote %u frames of %zu clip(s) (first: \"%s\") and %u random poses, %zu sphere pairs and %zu triangle "
      "contacts in all (%zu "
      "within the margin %g), %zu engine joints\n",
      frames, plan.clips, plan.first_clip.c_str(), random_poses, total, triangle_total, within_margin, narrow.margin,
      names.size());
  if (total == 0 || triangle_total == 0) return Fail("no sphere or no triangle contacts: the test would prove nothing");
  if (narrow.margin > 0 && within_margin == 0) return Fail("no within-margin triangle pairs: the margin is not tested");
  return 0;
}
