// hello_world: the whole embedding of skinspheres in an engine, in one file.
//
// Offline (your asset pipeline, links skinspheres::lib): fit a character, save its sphere set.
// At run time (your engine, links skinspheres::runtime only): load the set, create one shared
// asset and an instance per character, and every frame hand over joint world transforms,
// update, read the overlapping sphere pairs (broad phase) and the surfaces that really touch
// (narrow phase: triangle pairs by body-part pair, with a penetration depth).
#include <cstdio>
#include <filesystem>
#include <vector>

#include "skinspheres/lib/body_parts/body_parts.h"
#include "skinspheres/lib/character/builtin_character.h"
#include "skinspheres/lib/fit/sphere_fitter.h"
#include "skinspheres/runtime/api/character.h"
#include "skinspheres/runtime/format/sphere_set_io.h"
#include "skinspheres/skinning/local_to_model_job.h"
#include "skinspheres/skinning/sampling_job.h"

int main() {
  using namespace skinspheres;
  // --- Offline: fit and save (normally `skinspheres fit Character.glb -o character.spheres.json`).
  const lib::RawCharacter character = lib::MakeBuiltinCharacter();
  auto parts = lib::SplitBodyParts(character);
  if (!parts.ok()) return std::fprintf(stderr, "%s\n", parts.error().message.c_str()), 2;
  auto fit = lib::FitSpheres(character, *parts, lib::FitSettings{});
  if (!fit.ok()) return std::fprintf(stderr, "%s\n", fit.error().message.c_str()), 2;
  const auto path = std::filesystem::temp_directory_path() / "hello_world.spheres.json";
  if (auto err = runtime::SaveSphereSet(fit->spheres, path))
    return std::fprintf(stderr, "%s\n", err->message.c_str()), 2;

  // --- Run time: load once, share the asset between instances.
  auto set = runtime::LoadSphereSet(path);
  if (!set.ok()) return std::fprintf(stderr, "%s\n", set.error().message.c_str()), 2;
  // The narrow phase's tables (the contact rules on the mesh's triangles) are built here, once.
  auto asset = runtime::CharacterAsset::Create(std::move(set).value(), runtime::NarrowPhaseSettings{});
  if (!asset.ok()) return std::fprintf(stderr, "%s\n", asset.error().message.c_str()), 2;
  auto instance = runtime::CharacterInstance::Create(*asset);
  if (!instance.ok()) return std::fprintf(stderr, "%s\n", instance.error().message.c_str()), 2;

  // Your animation system gives joint world transforms; here the built-in "touch" clip does.
  const skinning::AnimationClip& clip = character.clips.back();
  std::vector<skinning::Transform> locals(character.skeleton.size());
  std::vector<skinspheres::Mat4f> joint_world(character.skeleton.size());
  for (int frame = 0; frame <= 40; frame += 4) {
    const float t = frame / 10.0f;
    skinning::SamplingJob{&clip, &character.skeleton, t, locals}.Run();
    skinning::LocalToModelJob l2m;
    l2m.skeleton = &character.skeleton;
    l2m.input = locals;
    l2m.output = joint_world;
    l2m.Run();
    // Fast mode: no vertex skinning, spheres from the joints alone (conservative bound).
    if (auto status = instance->UpdateFast(joint_world); !status.ok()) {
      std::fprintf(stderr, "frame %d: %s\n", frame, status.message);
      continue;
    }
    const auto sphere_pairs = instance->FindSpherePairs();
    // The triangles behind those pairs: fast mode skins only the vertices it tests, from the same
    // joint matrices (pass your skinned buffer instead when you skin on the CPU).
    if (auto status = instance->FindContacts(); !status.ok()) {
      std::fprintf(stderr, "frame %d: %s\n", frame, status.message);
      continue;
    }
    const auto& s = (*asset)->sphere_set();
    const runtime::FrameContacts& contacts = instance->contacts();
    std::printf("t=%.1f s: %zu sphere pairs, %zu touching part pairs", t, sphere_pairs.size(), contacts.parts.size());
    for (const runtime::PartContact& p : contacts.parts) {
      std::printf("  [%s - %s: %u triangle pairs, depth %.3f]", s.parts[p.part_a].name.c_str(),
                  s.parts[p.part_b].name.c_str(), p.triangle_pair_count, p.depth);
    }
    std::printf("\n");
  }
  return 0;
}
