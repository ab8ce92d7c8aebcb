// skinspheres play INPUT [--spheres S.json | fit on the fly] [--clip NAME|INDEX|all] [--clips FILE]...
//   [--fps 30] [--frames N] [--mode exact|fast] [--report R.json] [--dump F.jsonl] [--export-glb V.glb]
//   [--html V.html] [--verify]
#include <unistd.h>

#include <cstdio>
#include <memory>
#include <nlohmann/json.hpp>

#include "clip_files.h"
#include "html_page.h"
#include "playback.h"
#include "skinspheres/lib/glb_exporter.h"
#include "skinspheres/runtime/file_io.h"
#include "skinspheres/runtime/sphere_set_io.h"
#include "skinspheres/skinning/sampling_job.h"

namespace skinspheres::tool {
namespace {

struct PlayArgs {
  std::string input, spheres, clip = "0", mode = "exact", report, dump, export_glb, html;
  std::vector<std::string> clip_files;
  float fps = 30.0f;
  int frames = 0;
  bool verify = false;
  FitOptions fit;
};

int RunPlay(PlayArgs& a) {
  if (a.mode != "exact" && a.mode != "fast") return Fail("--mode must be exact or fast (got " + a.mode + ")");
  if (!(a.fps > 0.0f) || a.fps > 10000.0f) return Fail("--fps must be in (0, 10000]");
  if (auto why = a.fit.Resolve()) return Fail(*why);
  auto loaded = LoadCharacter(a.input, a.fit.parts_file);
  if (!loaded.ok()) return Fail(loaded.error().message);
  std::vector<std::string> notes;
  if (auto why = AddClipFiles(*loaded, a.clip_files, &notes)) return Fail(*why);
  for (const auto& note : notes) std::printf("%s\n", note.c_str());
  std::vector<size_t> clips;
  if (a.clip == "all") {
    for (size_t k = 0; k < loaded->character.clips.size(); ++k) clips.push_back(k);
    if (clips.empty()) return Fail(loaded->character.source_file + ": has no animation clips");
    if (!a.dump.empty() || !a.export_glb.empty() || !a.report.empty()) {
      return Fail("--clip all plays every clip for checking; --dump, --report and --export-glb take one clip");
    }
  } else {
    auto clip = FindClip(loaded->character, a.clip);
    if (!clip.ok()) return Fail(clip.error().message);
    clips.push_back(*clip);
  }
  runtime::SphereSet set;
  double fit_seconds = -1.0;
  if (!a.spheres.empty()) {
    auto read = runtime::LoadSphereSet(a.spheres);
    if (!read.ok()) return Fail(read.error().message);
    set = std::move(read).value();
  } else {
    auto fit = lib::FitSpheres(loaded->character, loaded->parts, a.fit.settings);
    if (!fit.ok()) return Fail(fit.error().message);
    fit_seconds = fit->report.seconds;
    set = std::move(fit->spheres);
  }
  PlayOptions opts;
  opts.fps = a.fps;
  opts.frames = a.frames;
  opts.fast = a.mode == "fast";
  opts.verify = a.verify;
  opts.progress = isatty(STDERR_FILENO);
  opts.keep_spheres = !a.dump.empty() || !a.export_glb.empty() || !a.html.empty();
  // --html: one page with every clip played.
  std::vector<PlayResult> kept;
  auto write_page = [&]() -> int {
    if (a.html.empty()) return 0;
    ViewerPageInput page{&*loaded, &set, fit_seconds, {}, notes};
    for (size_t k = 0; k < kept.size(); ++k) page.clips.push_back(ViewClip{&kept[k], clips[k], a.fps, opts.fast, {}});
    if (auto err = WriteViewerPage(page, a.html)) return Fail(err->message);
    std::printf("wrote %s\n", a.html.c_str());
    return 0;
  };
  if (clips.size() > 1) {
    size_t outside = 0;
    for (size_t k : clips) {
      auto played = PlayClip(*loaded, set, k, opts);
      if (!played.ok()) return Fail(played.error().message);
      PrintPlaySummary(*played, set, a.fps);
      outside += played->triangles_outside;
      if (!a.html.empty()) kept.push_back(std::move(*played));
    }
    if (a.verify) std::printf("verify: %zu triangle-frames outside their sphere over %zu clips\n", outside, clips.size());
    if (const int code = write_page()) return code;
    return outside ? 1 : 0;
  }
  auto played = PlayClip(*loaded, set, clips[0], opts);
  if (!played.ok()) return Fail(played.error().message);
  PrintPlaySummary(*played, set, a.fps);

  // Every write is checked through the close (runtime/file_io.h): a failed one is one line,
  // exit 2, and no "wrote".
  if (!a.dump.empty()) {
    runtime::CheckedFileWriter out(a.dump);
    for (size_t f = 0; f < played->frames.size() && out.ok(); ++f) {
      const auto& fr = played->frames[f];
      nlohmann::json line = {{"frame", f}, {"time", fr.time_s}};
      nlohmann::json spheres = nlohmann::json::array(), pairs = nlohmann::json::array();
      for (const auto& s : fr.spheres) spheres.push_back({s.x(), s.y(), s.z(), s.w()});
      for (const auto& c : fr.contacts) pairs.push_back({c.i, c.j});
      line["spheres"] = std::move(spheres);
      line["pairs"] = std::move(pairs);
      out.Write(line.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace) + '\n');
    }
    if (auto err = out.Close()) return Fail(err->message);
    std::printf("wrote %s\n", a.dump.c_str());
  }
  if (!a.export_glb.empty()) {
    // The spheres' keys go into the played clip's own animation, at the clip times sampled (one
    // pass of the clip: frames past its end, which loop, are left out).
    lib::GlbExtras extras;
    extras.clip_name = played->clip;
    extras.spheres.resize(set.size());
    const float duration = loaded->character.clips[clips[0]].duration_s;
    for (const auto& fr : played->frames) {
      const float t = skinning::LoopTime(fr.time_s, duration);
      if (!extras.frame_times_s.empty() && !(t > extras.frame_times_s.back())) break;
      extras.frame_times_s.push_back(t);
      for (size_t s = 0; s < set.size(); ++s) extras.spheres[s].per_frame_xyzr.push_back(fr.spheres[s]);
    }
    auto written = lib::ExportGlb(loaded->character, a.export_glb, extras);
    if (!written.ok()) return Fail(written.error().message);
    std::printf("wrote %s (character and %zu animated spheres, in clip \"%s\")\n", a.export_glb.c_str(), set.size(),
                played->clip.c_str());
  }
  if (!a.report.empty()) {
    nlohmann::json rep = {{"clip", played->clip}, {"frames", played->frames.size()}, {"mode", a.mode},
                          {"spheres", set.size()}, {"triangles_outside", played->triangles_outside}};
    nlohmann::json per_frame = nlohmann::json::array();
    for (const auto& fr : played->frames) per_frame.push_back(fr.contacts.size());
    rep["pairs_per_frame"] = per_frame;
    if (auto err = runtime::WriteWholeFile(a.report, rep.dump(2, ' ', false, nlohmann::json::error_handler_t::replace) + '\n')) {
      return Fail(err->message);
    }
    std::printf("wrote %s\n", a.report.c_str());
  }
  if (!a.html.empty()) kept.push_back(*played);
  if (const int code = write_page()) return code;
  if (a.verify) {
    std::printf("verify: %zu triangle-frames outside their sphere%s\n", played->triangles_outside,
                played->triangles_outside ? (" (first at frame " + std::to_string(played->first_bad_frame) + ")").c_str() : "");
    if (played->triangles_outside) return 1;
  }
  return 0;
}

}  // namespace

void AddPlayCommand(CLI::App& app, int* exit_code) {
  auto a = std::make_shared<PlayArgs>();
  CLI::App* cmd = app.add_subcommand("play", "play a clip: sample, skin, refit, query every frame");
  cmd->add_option("input", a->input, "character file")->required();
  cmd->add_option("--spheres", a->spheres, "sphere set to use (default: fit on the fly)");
  cmd->add_option("--clip", a->clip, "clip name or index, or all")->capture_default_str();
  cmd->add_option("--fps", a->fps, "frames per second")->capture_default_str();
  cmd->add_option("--frames", a->frames, "number of frames (default: the whole clip)");
  cmd->add_option("--mode", a->mode, "refit mode: exact (skinned source vertices) or fast (joint transforms)")->capture_default_str();
  cmd->add_option("--report", a->report, "write a JSON report");
  cmd->add_option("--dump", a->dump, "write one JSON line per frame: spheres and pairs");
  cmd->add_option("--export-glb", a->export_glb, "write the animated character with its spheres (in the clip's animation) as GLB");
  cmd->add_option("--html", a->html, "write the viewer page: one self-contained HTML file (with --clip all, every clip)");
  cmd->add_option("--clips", a->clip_files,
                  "add the clips of an animation file (glTF, GLB, FBX, ...; joints matched by name); repeatable")
      ->take_all()->allow_extra_args(false);
  cmd->add_flag("--verify", a->verify, "skin every vertex and check every triangle inside its sphere");
  a->fit.AddTo(*cmd);
  cmd->callback([a, exit_code] { *exit_code = RunPlay(*a); });
}

}  // namespace skinspheres::tool
