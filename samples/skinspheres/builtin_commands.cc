// skinspheres demo / skinspheres export-builtin OUT.glb
#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <memory>

#include "playback.h"
#include "skinspheres/lib/builtin_character.h"
#include "skinspheres/lib/glb_exporter.h"

namespace skinspheres::tool {

void AddExportBuiltinCommand(CLI::App& app, int* exit_code) {
  auto out = std::make_shared<std::string>();
  CLI::App* cmd = app.add_subcommand("export-builtin", "write the built-in character (mesh, skin, clips) as GLB");
  cmd->add_option("output", *out, "GLB file to write")->required();
  cmd->callback([out, exit_code] {
    const lib::RawCharacter ch = lib::MakeBuiltinCharacter();
    auto written = lib::ExportGlb(ch, *out);
    if (!written.ok()) {
      *exit_code = Fail(written.error().message);
      return;
    }
    std::printf("wrote %s: %zu vertices, %zu triangles, %zu joints, %zu clips\n", out->c_str(), ch.vertex_count(),
                ch.triangle_count(), ch.skeleton.size(), ch.clips.size());
    *exit_code = 0;
  });
}

void AddDemoCommand(CLI::App& app, int* exit_code) {
  auto opts = std::make_shared<FitOptions>();
  CLI::App* cmd = app.add_subcommand("demo", "fit the built-in character and play its clips");
  opts->AddTo(*cmd);
  cmd->callback([opts, exit_code] {
    if (auto why = opts->Resolve()) {
      *exit_code = Fail(*why);
      return;
    }
    auto loaded = LoadCharacter("", opts->parts_file);
    if (!loaded.ok()) {
      *exit_code = Fail(loaded.error().message);
      return;
    }
    auto fit = lib::FitSpheres(loaded->character, loaded->parts, opts->settings);
    if (!fit.ok()) {
      *exit_code = Fail(fit.error().message);
      return;
    }
    std::printf("built-in character: %zu vertices, %zu triangles, %zu joints, clips:", loaded->character.vertex_count(),
                loaded->character.triangle_count(), loaded->character.skeleton.size());
    for (const auto& c : loaded->character.clips) std::printf(" %s (%.2f s)", c.name.c_str(), c.duration_s);
    std::printf("\n");
    PrintFitSummary(*fit, loaded->import_seconds);
    const runtime::SphereSet& set = fit->spheres;
    // A hand touches when a contact's arm-side triangle belongs to a sphere whose dominant joint is
    // a hand (or a finger under it): real triangle contacts, not overlapping spheres.
    std::vector<uint32_t> owner(set.source_triangle_count, UINT32_MAX);
    for (uint32_t s = 0; s < set.size(); ++s) {
      for (uint32_t k = set.triangle_offsets[s]; k < set.triangle_offsets[s + 1]; ++k) owner[set.triangles[k]] = s;
    }
    auto is_hand = [&](uint32_t triangle) {
      const uint32_t s = owner[triangle];
      return s != UINT32_MAX && set.joint_names[set.sphere_joint[s]].find("Hand") != std::string::npos;
    };
    auto part_named = [&](const char* name) {
      for (size_t k = 0; k < set.parts.size(); ++k) {
        if (set.parts[k].name == name) return static_cast<int>(k);
      }
      return -1;
    };
    const int torso = part_named("torso"), head = part_named("head");
    bool all_verified = true;
    for (size_t c = 0; c < loaded->character.clips.size(); ++c) {
      struct Touches {
        size_t frames = 0;
        int first = -1, last = -1;
        float first_t = 0.0f, last_t = 0.0f;
        float depth = 0.0f;
      } on[2];  // chest, head
      PlayOptions play;
      play.verify = true;
      FrameSink sink = [&](const FrameView& fr) {
        for (int target = 0; target < 2; ++target) {
          const int part = target == 0 ? torso : head;
          bool touching = false;
          float depth = 0.0f;
          for (const runtime::PartContact& p : fr.contacts->parts) {
            if (p.part_a != part && p.part_b != part) continue;
            for (uint32_t k = p.first_triangle_pair; k < p.first_triangle_pair + p.triangle_pair_count; ++k) {
              const runtime::TrianglePairContact& tp = fr.contacts->triangle_pairs[k];
              const uint32_t other = p.part_a == part ? tp.u : tp.t;
              if (tp.kind == runtime::TriangleContactKind::kIntersecting && is_hand(other)) {
                touching = true;
                depth = std::max(depth, p.depth);
              }
            }
          }
          if (!touching) continue;
          Touches& t = on[target];
          if (t.frames++ == 0) t.first = fr.index, t.first_t = fr.clip_time_s;
          t.last = fr.index;
          t.last_t = fr.clip_time_s;
          t.depth = std::max(t.depth, depth);
        }
      };
      auto played = PlayClip(*loaded, set, c, play, sink);
      if (!played.ok()) {
        *exit_code = Fail(played.error().message);
        return;
      }
      std::printf("\n");
      PrintPlaySummary(*played, set, play.fps, /*sphere_pairs=*/false, /*verify=*/true);
      for (int target = 0; target < 2; ++target) {
        const char* label = target == 0 ? "chest" : "head";
        const Touches& t = on[target];
        if (t.frames == 0) {
          std::printf("  hands on the %s: never\n", label);
        } else {
          std::printf("  hands on the %s: %zu frames, first %d (t=%.2f s), last %d (t=%.2f s), up to %.3g deep\n", label,
                      t.frames, t.first, t.first_t, t.last, t.last_t, t.depth);
        }
      }
      all_verified &= played->verified();
    }
    if (!all_verified) {
      *exit_code = 1;
      return;
    }
    *exit_code = 0;
  });
}

}  // namespace skinspheres::tool
