// skinspheres play INPUT [--spheres S.json | fit on the fly] [--clip NAME|INDEX|all] [--clips FILE]...
//   [--fps 30] [--frames N] [--mode exact|fast] [--margin D] [--sphere-pairs] [--report R.json]
//   [--dump F.jsonl] [--export-glb V.glb] [--html V.html] [--verify]
#include <unistd.h>

#include <cstdio>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>

#include "clip_files.h"
#include "html_page.h"
#include "playback.h"
#include "skinspheres/lib/io/glb_exporter.h"
#include "skinspheres/runtime/format/file_io.h"
#include "skinspheres/runtime/format/sphere_set_io.h"

namespace skinspheres::tool {
namespace {

struct PlayArgs {
  std::string input, spheres, clip = "0", mode = "exact", report, dump, export_glb, html;
  ClipFileOptions clip_files;
  float fps = 30.0f;
  float margin = 0.0f;
  float touch_tolerance = kDefaultTouchTolerance;
  int frames = 0;
  bool verify = false;
  bool sphere_pairs = false;
  FitOptions fit;
};

// One --dump line: the frame, its times, the spheres, the sphere pairs, the contacts by part pair
// (intersecting triangle pairs [t, u], t in the first part; with a margin, "near" [t, u, distance];
// "kind" touching or penetrating), and the world positions of the skin's joints (`skin_joints`,
// skin order), whose names the first line carries.
nlohmann::json DumpLine(const FrameView& fr, const runtime::SphereSet& set, bool margin,
                        const lib::RawCharacter& character, std::span<const int32_t> skin_joints) {
  nlohmann::json line = {{"frame", fr.index}, {"time", fr.time_s}, {"clip_time", fr.clip_time_s}};
  if (fr.index == 0) {
    nlohmann::json names = nlohmann::json::array();
    for (int32_t j : skin_joints) names.push_back(character.skeleton.joint_names[static_cast<size_t>(j)]);
    line["joint_names"] = std::move(names);
  }
  nlohmann::json spheres = nlohmann::json::array(), pairs = nlohmann::json::array(), contacts = nlohmann::json::array();
  for (const auto& s : fr.spheres) spheres.push_back({s.x(), s.y(), s.z(), s.w()});
  for (const auto& c : fr.sphere_pairs) pairs.push_back({c.i, c.j});
  for (const runtime::PartContact& p : fr.contacts->parts) {
    nlohmann::json triangles = nlohmann::json::array(), near = nlohmann::json::array();
    for (uint32_t k = p.first_triangle_pair; k < p.first_triangle_pair + p.triangle_pair_count; ++k) {
      const runtime::TriangleContact& c = fr.contacts->triangle_pairs[k];
      if (c.kind == runtime::TriangleContactKind::kIntersecting) {
        triangles.push_back({c.triangle_a, c.triangle_b});
      } else {
        near.push_back({c.triangle_a, c.triangle_b, c.distance});
      }
    }
    nlohmann::json entry = {{"parts", {set.parts[p.part_a].name, set.parts[p.part_b].name}},
                            {"triangles", std::move(triangles)},
                            {"depth", p.depth},
                            {"kind", runtime::ToString(p.kind)}};
    if (margin) entry["near"] = std::move(near);
    contacts.push_back(std::move(entry));
  }
  line["spheres"] = std::move(spheres);
  line["pairs"] = std::move(pairs);
  line["contacts"] = std::move(contacts);
  nlohmann::json joints = nlohmann::json::array();
  for (int32_t j : skin_joints) {
    const auto p = fr.joint_world[static_cast<size_t>(j)].topRightCorner<3, 1>();
    joints.push_back({p.x(), p.y(), p.z()});
  }
  line["joints"] = std::move(joints);
  return line;
}

int RunPlay(PlayArgs& a) {
  if (a.mode != "exact" && a.mode != "fast") return Fail("--mode must be exact or fast (got " + a.mode + ")");
  if (!(a.fps > 0.0f) || a.fps > 10000.0f) return Fail("--fps must be in (0, 10000]");
  if (!(a.margin >= 0.0f) || !std::isfinite(a.margin)) return Fail("--margin must be a finite distance >= 0");
  if (auto why = CheckTouchTolerance(a.touch_tolerance)) return Fail(*why);
  if (auto why = a.fit.Resolve()) return Fail(*why);
  auto loaded = LoadCharacter(a.input, a.fit.parts_file);
  if (!loaded.ok()) return Fail(loaded.error().message);
  std::vector<std::string> notes;
  if (auto why = AddClipFiles(*loaded, a.clip_files, a.fps, &notes)) return Fail(why->message);
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
    if (AttachMesh(loaded->character, &set)) {
      std::printf("%s: format version 1 (no mesh): the triangle tests use %s's mesh\n", a.spheres.c_str(),
                  loaded->character.source_file.c_str());
    }
    if (set.contact_rules == runtime::ContactRules::kSpherePairs) {
      std::printf("%s: %s\n", a.spheres.c_str(), ContactRulesSummary(set).c_str());
    }
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
  opts.margin = a.margin;
  opts.touch_tolerance = a.touch_tolerance;
  opts.progress = isatty(STDERR_FILENO);
  // Set up once (the set checked against the mesh, the runtime asset), then every clip played by
  // one player.
  auto playback = Playback::Create(*loaded, set, NarrowSettings(opts));
  if (!playback.ok()) return Fail(playback.error().message);
  auto player = ClipPlayer::Create(*playback, opts);
  if (!player.ok()) return Fail(player.error().message);
  // --html: one page with every clip played; its per-frame data is kept for it (RecordFrames).
  std::vector<PlayResult> kept;
  std::vector<std::vector<FrameRecord>> recorded;
  recorded.reserve(clips.size());
  auto write_page = [&]() -> int {
    if (a.html.empty()) return 0;
    ViewerPageInput page{&*loaded, &set, fit_seconds, {}, notes};
    for (size_t k = 0; k < kept.size(); ++k)
      page.clips.push_back(ViewClip{&kept[k], &recorded[k], clips[k], a.fps, opts.fast});
    if (auto err = WriteViewerPage(page, a.html)) return Fail(err->message);
    std::printf("wrote %s\n", a.html.c_str());
    return 0;
  };
  if (a.clip == "all") {
    bool all_verified = true;
    size_t outside = 0, mismatches = 0;
    for (size_t k : clips) {
      FrameSink record;
      if (!a.html.empty()) {
        recorded.emplace_back();
        record = RecordFrames(&recorded.back());
      }
      auto played = player->Play(k, record);
      if (!played.ok()) return Fail(played.error().message);
      PrintPlaySummary(*played, set, a.fps, a.sphere_pairs, a.verify);
      all_verified &= played->verified();
      outside += played->triangles_outside;
      mismatches += played->narrow_mismatches;
      if (!a.html.empty()) kept.push_back(std::move(*played));
    }
    if (a.verify) {
      std::printf(
          "verify: %zu triangle-frames outside their sphere over %zu clips; narrow phase differs from the oracle in "
          "%zu frames\n",
          outside, clips.size(), mismatches);
    }
    if (const int code = write_page()) return code;
    std::printf("memory: peak %ld KiB\n", PeakRssKiB());
    return a.verify && !all_verified ? 1 : 0;
  }

  // Outputs are written frame by frame as the clip plays (nothing per frame is kept in memory,
  // except what --export-glb and --html have to write at the end). Every write is checked through
  // the close (runtime/file_io.h): a failed one is one line, exit 2, and no "wrote".
  std::optional<runtime::CheckedFileWriter> dump, report;
  const std::vector<int32_t> skin_joints = SkinJoints(loaded->character);
  if (!a.dump.empty()) dump.emplace(a.dump);
  if (!a.report.empty()) {
    report.emplace(a.report);
    report->Write("{\"pairs_per_frame\":[");
  }
  // --export-glb: the spheres' keys go into the played clip's own animation, at the clip times
  // sampled (one pass of the clip: frames past its end, which loop, are left out).
  lib::GlbExtras extras;
  bool extras_looped = false;
  if (!a.export_glb.empty()) {
    extras.spheres.resize(set.size());
    extras.clip_name = loaded->character.clips[clips[0]].name;
  }
  if (!a.html.empty()) recorded.emplace_back();
  FrameSink record = a.html.empty() ? FrameSink() : RecordFrames(&recorded.back());
  FrameSink sink = [&](const FrameView& fr) {
    if (record) record(fr);
    if (dump && dump->ok()) {
      dump->Write(DumpLine(fr, set, a.margin > 0.0f, loaded->character, skin_joints)
                      .dump(-1, ' ', false, nlohmann::json::error_handler_t::replace) +
                  '\n');
    }
    if (report) report->Write((fr.index ? "," : "") + std::to_string(fr.sphere_pairs.size()));
    if (!a.export_glb.empty() && !extras_looped) {
      if (!extras.frame_times_s.empty() && !(fr.clip_time_s > extras.frame_times_s.back())) {
        extras_looped = true;
        return;
      }
      extras.frame_times_s.push_back(fr.clip_time_s);
      for (size_t s = 0; s < set.size(); ++s) extras.spheres[s].per_frame_xyzr.push_back(fr.spheres[s]);
    }
  };
  auto played = player->Play(clips[0], sink);
  if (!played.ok()) return Fail(played.error().message);
  PrintPlaySummary(*played, set, a.fps, a.sphere_pairs, a.verify);

  if (dump) {
    if (auto err = dump->Close()) return Fail(err->message);
    std::printf("wrote %s\n", a.dump.c_str());
  }
  if (!a.export_glb.empty()) {
    auto written = lib::ExportGlb(loaded->character, a.export_glb, extras);
    if (!written.ok()) return Fail(written.error().message);
    std::printf("wrote %s (character and %zu animated spheres, in clip \"%s\")\n", a.export_glb.c_str(), set.size(),
                extras.clip_name.c_str());
  }
  if (report) {
    nlohmann::json contacts = nlohmann::json::array();
    for (const PartPairSummary& e : played->contacts) {
      contacts.push_back({{"parts", {set.parts[e.part_a].name, set.parts[e.part_b].name}},
                          {"kind", e.penetrating.frames() > 0 ? "penetrating" : "touching"},
                          {"intersecting", e.intersecting},
                          {"frames", e.frames.frames()},
                          {"first_frame", e.frames.first()},
                          {"last_frame", e.frames.last()},
                          {"penetrating_frames", e.penetrating.frames()},
                          {"most_triangle_pairs", e.most_triangle_pairs},
                          {"max_depth", e.max_depth},
                          {"worst_frame", e.worst_frame}});
    }
    const nlohmann::json rest = {{"clip", played->clip},
                                 {"frames", played->frames},
                                 {"mode", a.mode},
                                 {"margin", a.margin},
                                 {"touch_tolerance", played->touch_tolerance},
                                 {"contact_rules", ContactRulesJson(set)},
                                 {"body_height", played->body_height},
                                 {"spheres", set.size()},
                                 {"triangles_outside", played->triangles_outside},
                                 {"contacts", std::move(contacts)}};
    const std::string tail = rest.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
    report->Write("]," + tail.substr(1) + '\n');  // the summary's members after the streamed array
    if (auto err = report->Close()) return Fail(err->message);
    std::printf("wrote %s\n", a.report.c_str());
  }
  if (!a.html.empty()) kept.push_back(std::move(*played));
  if (const int code = write_page()) return code;
  std::printf("memory: peak %ld KiB\n", PeakRssKiB());
  if (a.verify && !played->verified()) return 1;
  return 0;
}

}  // namespace

void AddPlayCommand(CLI::App& app, int* exit_code) {
  auto a = std::make_shared<PlayArgs>();
  CLI::App* cmd =
      app.add_subcommand("play", "play a clip: sample, skin, refit, find sphere pairs and triangle contacts");
  cmd->add_option("input", a->input, "character file")->required();
  cmd->add_option("--spheres", a->spheres, "sphere set to use (default: fit on the fly)");
  cmd->add_option("--clip", a->clip, "clip name or index, or all")->capture_default_str();
  cmd->add_option("--fps", a->fps, "frames per second")->capture_default_str();
  cmd->add_option("--frames", a->frames,
                  "number of frames (default: the whole clip, its last frame at t = duration sampling the clip's end "
                  "pose; frames past the end loop)");
  cmd->add_option("--mode", a->mode, "refit mode: exact (skinned source vertices) or fast (joint transforms)")
      ->capture_default_str();
  cmd->add_option(
         "--margin", a->margin,
         "also report triangle pairs nearer than this distance (model units; pairs this near at rest excluded)")
      ->capture_default_str();
  AddTouchToleranceOption(*cmd, &a->touch_tolerance);
  cmd->add_flag("--sphere-pairs", a->sphere_pairs, "also list the broad phase's sphere pairs by body-part pair");
  cmd->add_option("--report", a->report, "write a JSON report");
  cmd->add_option("--dump", a->dump, "write one JSON line per frame: spheres, sphere pairs, contacts");
  cmd->add_option("--export-glb", a->export_glb,
                  "write the animated character with its spheres (in the clip's animation) as GLB");
  cmd->add_option("--html", a->html,
                  "write the viewer page: one self-contained HTML file (with --clip all, every clip)");
  a->clip_files.AddTo(*cmd);
  cmd->add_flag("--verify", a->verify,
                "skin every vertex: check every triangle is owned and inside its sphere, and the narrow phase "
                "against the brute-force oracle");
  a->fit.AddTo(*cmd);
  cmd->callback([a, exit_code] { *exit_code = RunPlay(*a); });
}

}  // namespace skinspheres::tool
