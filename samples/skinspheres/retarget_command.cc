// skinspheres retarget INPUT --clips FILE... [--clip NAME|all] [--fps F] -o OUT.glb
//   [--joint-map M] [--source-rest ...] [--retarget ...] [--rest-directions ...]
// Writes the character (its mesh, skin and joints, as the exporter writes them) with the clips of
// the given files retargeted onto it, as glTF animations: one LINEAR key per frame at --fps for
// every joint, the root's translation included (lib::BakeClip), so any tool plays at that rate
// exactly what `play` and `check` sampled with the same options. The character's own clips are not
// written.
#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "clip_files.h"
#include "commands.h"
#include "skinspheres/lib/io/glb_exporter.h"
#include "skinspheres/lib/retarget/bake_clip.h"

namespace skinspheres::tool {
namespace {

struct RetargetArgs {
  std::string input, output, clip = "all";
  float fps = 30.0f;
  ClipFileOptions clip_files;
};

// The added clips `clip` names: all of them, or those whose name is `clip` or ends in "/clip" (as
// play and check name a file's clips), or the one at that index among them.
Result<std::vector<size_t>> SelectClips(const lib::RawCharacter& ch, size_t own, const std::string& clip) {
  std::vector<size_t> out;
  for (size_t k = own; k < ch.clips.size(); ++k) {
    const std::string& name = ch.clips[k].name;
    if (clip == "all" || name == clip || (name.size() > clip.size() && name.ends_with("/" + clip))) out.push_back(k);
  }
  const bool index = !clip.empty() && clip.size() < 10 && clip.find_first_not_of("0123456789") == std::string::npos;
  if (out.empty() && index && std::stoul(clip) < ch.clips.size() - own) out.push_back(own + std::stoul(clip));
  if (out.empty()) {
    std::string names;
    for (size_t k = own; k < ch.clips.size(); ++k) names += (names.empty() ? "" : ", ") + ch.clips[k].name;
    return MakeError(ErrorCode::kNotFound, "--clip " + clip + ": no such clip among " + names);
  }
  return out;
}

int RunRetarget(const RetargetArgs& a) {
  if (a.clip_files.files.empty()) return Fail("retarget needs --clips: the animation files to retarget");
  if (!(a.fps > 0.0f) || a.fps > 10000.0f) return Fail("--fps must be in (0, 10000]");
  std::string ext = std::filesystem::path(a.output).extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return char(std::tolower(c)); });
  if (ext != ".glb") return Fail(a.output + ": -o takes a .glb file");
  auto loaded = LoadCharacter(a.input, "");
  if (!loaded.ok()) return Fail(loaded.error().message);
  const size_t own = loaded->character.clips.size();
  std::vector<std::string> notes;
  if (auto why = AddClipFiles(*loaded, a.clip_files, a.fps, &notes)) return Fail(why->message);
  for (const auto& note : notes) std::printf("%s\n", note.c_str());
  auto chosen = SelectClips(loaded->character, own, a.clip);
  if (!chosen.ok()) return Fail(chosen.error().message);
  lib::RawCharacter& ch = loaded->character;
  std::vector<skinning::AnimationClip> baked;
  size_t keys = 0;
  for (size_t k : *chosen) {
    auto clip = lib::BakeClip(ch.clips[k], ch.skeleton, a.fps);
    if (!clip.ok()) return Fail(a.input + ": " + clip.error().message);
    keys += clip->tracks.empty() ? 0 : clip->tracks.front().rotation.times_s.size();
    baked.push_back(std::move(*clip));
  }
  ch.clips = std::move(baked);
  auto written = lib::ExportGlb(ch, a.output);
  if (!written.ok()) return Fail(written.error().message);
  std::printf("wrote %s: %zu clip%s, %zu frames at %g fps, %zu joints keyed per frame\n", a.output.c_str(),
              ch.clips.size(), ch.clips.size() == 1 ? "" : "s", keys, static_cast<double>(a.fps), ch.skeleton.size());
  for (const auto& clip : ch.clips)
    std::printf("  %s (%.3f s)\n", clip.name.c_str(), static_cast<double>(clip.duration_s));
  return 0;
}

}  // namespace

void AddRetargetCommand(CLI::App& app, int* exit_code) {
  auto a = std::make_shared<RetargetArgs>();
  CLI::App* cmd = app.add_subcommand(
      "retarget",
      "write the character with clips of other files retargeted onto it, as glTF animations keyed per frame");
  cmd->add_option("input", a->input, "character file (glTF/GLB, FBX, ...)")->required();
  cmd->add_option("-o,--output", a->output, "output .glb: the character and the retargeted clips")->required();
  cmd->add_option("--clip", a->clip, "which of the files' clips: all, a name, or an index among them")
      ->capture_default_str();
  cmd->add_option("--fps", a->fps, "frames per second of the keys (as play and check sample)")->capture_default_str();
  a->clip_files.AddTo(*cmd);
  cmd->callback([a, exit_code] { *exit_code = RunRetarget(*a); });
}

}  // namespace skinspheres::tool
