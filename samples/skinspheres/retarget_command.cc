// skinspheres retarget INPUT --clips FILE... [--clip NAME|all] [--fps F] -o OUT.glb
//   [--joint-map M] [--source-rest ...] [--retarget ...] [--rest-directions ...]
// Writes the character (its mesh, skin and joints, as the exporter writes them) with the clips of
// the given files retargeted onto it, as glTF animations: one LINEAR key per frame at --fps for
// every joint, the root's translation included (lib::BakeClip), so any tool plays at that rate
// exactly what `play` and `check` sampled with the same options. The character's own clips are not
// written.
#include <algorithm>
#include <cctype>
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

int RunRetarget(const RetargetArgs& a) {
  auto written = WriteRetargetedClips(a.input, a.clip_files, a.clip, a.fps, a.output);
  if (!written.ok()) return Fail(written.error().message);
  for (const auto& note : written->notes) std::printf("%s\n", note.c_str());
  std::printf("wrote %s: %zu clip%s, %zu frames at %g fps, %zu joints keyed per frame\n", a.output.c_str(),
              written->clips.size(), written->clips.size() == 1 ? "" : "s", written->frames, static_cast<double>(a.fps),
              written->joints);
  for (size_t k = 0; k < written->clips.size(); ++k) {
    std::printf("  %s (%.3f s)\n", written->clips[k].c_str(), static_cast<double>(written->durations[k]));
  }
  return 0;
}

}  // namespace

Result<RetargetWritten> WriteRetargetedClips(const std::string& input, const ClipFileOptions& files,
                                             const std::string& clip, float fps, const std::string& output) {
  if (files.files.empty())
    return MakeError(ErrorCode::kInvalidArgument, "retarget needs --clips: the animation files to retarget");
  if (!(fps > 0.0f) || fps > 10000.0f) return MakeError(ErrorCode::kInvalidArgument, "--fps must be in (0, 10000]");
  std::string ext = std::filesystem::path(output).extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return char(std::tolower(c)); });
  if (ext != ".glb") return MakeError(ErrorCode::kInvalidArgument, output + ": -o takes a .glb file");
  auto loaded = LoadCharacter(input, "");
  if (!loaded.ok()) return loaded.error();
  const size_t own = loaded->character.clips.size();
  RetargetWritten out;
  if (auto why = AddClipFiles(*loaded, files, fps, &out.notes)) return *why;
  auto chosen = SelectClips(loaded->character, own, clip);
  if (!chosen.ok()) return chosen.error();
  lib::RawCharacter& ch = loaded->character;
  std::vector<skinning::AnimationClip> baked;
  for (size_t k : *chosen) {
    auto one = lib::BakeClip(ch.clips[k], ch.skeleton, fps);
    if (!one.ok()) return MakeError(one.error().code, input + ": " + one.error().message);
    out.frames += one->tracks.empty() ? 0 : one->tracks.front().rotation.times_s.size();
    out.clips.push_back(one->name);
    out.durations.push_back(one->duration_s);
    baked.push_back(std::move(*one));
  }
  ch.clips = std::move(baked);
  auto written = lib::ExportGlb(ch, output);
  if (!written.ok()) return written.error();
  out.joints = ch.skeleton.size();
  return out;
}

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
