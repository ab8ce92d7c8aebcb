// skinspheres demo / skinspheres export-builtin OUT.glb
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
    // Contacts of a hand: a sphere whose dominant joint is a hand (or a finger under it).
    auto is_hand = [&](uint32_t s) {
      const std::string& j = set.joint_names[set.sphere_joint[s]];
      return j.find("Hand") != std::string::npos;
    };
    const int torso = [&] {
      for (size_t k = 0; k < set.parts.size(); ++k) if (set.parts[k].name == "torso") return static_cast<int>(k);
      return -1;
    }();
    const int head = [&] {
      for (size_t k = 0; k < set.parts.size(); ++k) if (set.parts[k].name == "head") return static_cast<int>(k);
      return -1;
    }();
    for (size_t c = 0; c < loaded->character.clips.size(); ++c) {
      PlayOptions play;
      play.verify = true;
      auto played = PlayClip(*loaded, set, c, play);
      if (!played.ok()) {
        *exit_code = Fail(played.error().message);
        return;
      }
      std::printf("\n");
      PrintPlaySummary(*played, set, play.fps);
      for (const auto& [target, label] : {std::pair{torso, "chest"}, std::pair{head, "head"}}) {
        std::vector<int> frames;
        for (size_t f = 0; f < played->frames.size(); ++f) {
          for (const auto& k : played->frames[f].contacts) {
            if ((is_hand(k.i) && k.part_j == target) || (is_hand(k.j) && k.part_i == target)) {
              frames.push_back(static_cast<int>(f));
              break;
            }
          }
        }
        if (frames.empty()) {
          std::printf("  hands on the %s: never\n", label);
        } else {
          std::printf("  hands on the %s: %zu frames, first %d (t=%.2f s), last %d (t=%.2f s)\n", label, frames.size(),
                      frames.front(), played->frames[frames.front()].time_s, frames.back(), played->frames[frames.back()].time_s);
        }
      }
      std::printf("  verify: %zu triangle-frames outside their sphere\n", played->triangles_outside);
      if (played->triangles_outside) {
        *exit_code = 1;
        return;
      }
    }
    *exit_code = 0;
  });
}

}  // namespace skinspheres::tool
