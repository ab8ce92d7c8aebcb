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
  for (const auto& c : fr.sphere_pairs) pairs.push_back({c.sphere_i, c.sphere_j});
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

// The flags' values, checked: 0, else Fail's exit code for the first problem.
int CheckPlayArgs(PlayArgs& a) {
  if (a.mode != "exact" && a.mode != "fast") return Fail("--mode must be exact or fast (got " + a.mode + ")");
  if (!(a.fps > 0.0f) || a.fps > 10000.0f) return Fail("--fps must be in (0, 10000]");
  if (!(a.margin >= 0.0f) || !std::isfinite(a.margin)) return Fail("--margin must be a finite distance >= 0");
  if (auto why = CheckTouchTolerance(a.touch_tolerance)) return Fail(*why);
  if (auto why = a.fit.Resolve()) return Fail(*why);
  return 0;
}

// The clips to play: every clip (--clip all, which takes no per-clip output file), or the one named.
int ChooseClips(const PlayArgs& a, const lib::RawCharacter& character, std::vector<size_t>* clips) {
  if (a.clip == "all") {
    for (size_t k = 0; k < character.clips.size(); ++k) clips->push_back(k);
    if (clips->empty()) return Fail(character.source_file + ": has no animation clips");
    if (!a.dump.empty() || !a.export_glb.empty() || !a.report.empty()) {
      return Fail("--clip all plays every clip for checking; --dump, --report and --export-glb take one clip");
    }
  } else {
    auto clip = FindClip(character, a.clip);
    if (!clip.ok()) return Fail(clip.error().message);
    clips->push_back(*clip);
  }
  return 0;
}

// The sphere set: read from --spheres (a version 1 set takes the character's mesh), else fitted
// now (*fit_seconds its time; -1 for a set read).
int LoadOrFitSpheres(const PlayArgs& a, const LoadedCharacter& loaded, runtime::SphereSet* set, double* fit_seconds) {
  *fit_seconds = -1.0;
  if (a.spheres.empty()) {
    auto fit = lib::FitSpheres(loaded.character, loaded.parts, a.fit.settings);
    if (!fit.ok()) return Fail(fit.error().message);
    *fit_seconds = fit->report.seconds;
    *set = std::move(fit->spheres);
    return 0;
  }
  auto read = runtime::LoadSphereSet(a.spheres);
  if (!read.ok()) return Fail(read.error().message);
  *set = std::move(read).value();
  if (AttachMesh(loaded.character, set)) {
    std::printf("%s: format version 1 (no mesh): the triangle tests use %s's mesh\n", a.spheres.c_str(),
                loaded.character.source_file.c_str());
  }
  if (set->contact_rules == runtime::ContactRules::kSpherePairs) {
    std::printf("%s: %s\n", a.spheres.c_str(), ContactRulesSummary(*set).c_str());
  }
  return 0;
}

PlayOptions MakePlayOptions(const PlayArgs& a) {
  PlayOptions opts;
  opts.fps = a.fps;
  opts.frames = a.frames;
  opts.fast = a.mode == "fast";
  opts.verify = a.verify;
  opts.margin = a.margin;
  opts.touch_tolerance = a.touch_tolerance;
  opts.progress = isatty(STDERR_FILENO);
  return opts;
}

// What every clip plays with: the flags, the character and its set, the player, and --html's page
// (one page with every clip played; its per-frame data is kept for it, RecordFrames).
struct PlaySession {
  const PlayArgs& a;
  const LoadedCharacter& loaded;
  const runtime::SphereSet& set;
  const std::vector<size_t>& clips;
  ClipPlayer& player;
  double fit_seconds;
  const std::vector<std::string>& notes;
  std::vector<PlayResult> kept;
  std::vector<std::vector<FrameRecord>> recorded;

  // The sink that records the next clip's frames for the page (none without --html).
  FrameSink Record() {
    if (a.html.empty()) return FrameSink();
    recorded.emplace_back();
    return RecordFrames(&recorded.back());
  }
  void Keep(PlayResult&& played) {
    if (!a.html.empty()) kept.push_back(std::move(played));
  }
  int WritePage() const {
    if (a.html.empty()) return 0;
    ViewerPageInput page{&loaded, &set, fit_seconds, {}, notes, nullptr};
    for (size_t k = 0; k < kept.size(); ++k)
      page.clips.push_back(ViewClip{&kept[k], &recorded[k], clips[k], a.fps, a.mode == "fast"});
    if (auto err = WriteViewerPage(page, a.html)) return Fail(err->message);
    std::printf("wrote %s\n", a.html.c_str());
    return 0;
  }
};

// --clip all: every clip played and summarised, then the totals of --verify.
int PlayAllClips(PlaySession& s) {
  const PlayArgs& a = s.a;
  bool all_verified = true;
  size_t outside = 0, mismatches = 0;
  for (size_t k : s.clips) {
    auto played = s.player.Play(k, s.Record());
    if (!played.ok()) return Fail(played.error().message);
    PrintPlaySummary(*played, s.set, a.fps, a.sphere_pairs, a.verify);
    all_verified &= played->verified();
    outside += played->triangles_outside;
    mismatches += played->narrow_mismatches;
    s.Keep(std::move(*played));
  }
  if (a.verify) {
    std::printf(
        "verify: %zu triangle-frames outside their sphere over %zu clips; narrow phase differs from the oracle in "
        "%zu frames\n",
        outside, s.clips.size(), mismatches);
  }
  if (const int code = s.WritePage()) return code;
  std::printf("memory: peak %ld KiB\n", PeakRssKiB());
  return a.verify && !all_verified ? 1 : 0;
}

// The outputs of one clip, written frame by frame as it plays (nothing per frame is kept in memory,
// except what --export-glb and --html have to write at the end). Every write is checked through
// the close (runtime/file_io.h): a failed one is one line, exit 2, and no "wrote".
class ClipOutputs {
 public:
  ClipOutputs(const PlayArgs& a, const LoadedCharacter& loaded, const runtime::SphereSet& set, size_t clip)
      : a_(a), loaded_(loaded), set_(set), skin_joints_(SkinJoints(loaded.character)) {
    if (!a.dump.empty()) dump_.emplace(a.dump);
    if (!a.report.empty()) {
      report_.emplace(a.report);
      report_->Write("{\"pairs_per_frame\":[");
    }
    // --export-glb: the spheres' keys go into the played clip's own animation, at the clip times
    // sampled (one pass of the clip: frames past its end, which loop, are left out).
    if (!a.export_glb.empty()) {
      extras_.spheres.resize(set.size());
      extras_.clip_name = loaded.character.clips[clip].name;
    }
  }

  void Frame(const FrameView& fr) {
    if (dump_ && dump_->ok()) {
      dump_->Write(DumpLine(fr, set_, a_.margin > 0.0f, loaded_.character, skin_joints_)
                       .dump(-1, ' ', false, nlohmann::json::error_handler_t::replace) +
                   '\n');
    }
    if (report_) report_->Write((fr.index ? "," : "") + std::to_string(fr.sphere_pairs.size()));
    if (!a_.export_glb.empty() && !extras_looped_) {
      if (!extras_.frame_times_s.empty() && !(fr.clip_time_s > extras_.frame_times_s.back())) {
        extras_looped_ = true;
        return;
      }
      extras_.frame_times_s.push_back(fr.clip_time_s);
      for (size_t s = 0; s < set_.size(); ++s) extras_.spheres[s].per_frame_xyzr.push_back(fr.spheres[s]);
    }
  }

  // After the clip: --dump closed, --export-glb and --report written. 0, else Fail's exit code.
  int Finish(const PlayResult& played) {
    if (dump_) {
      if (auto err = dump_->Close()) return Fail(err->message);
      std::printf("wrote %s\n", a_.dump.c_str());
    }
    if (!a_.export_glb.empty()) {
      auto written = lib::ExportGlb(loaded_.character, a_.export_glb, extras_);
      if (!written.ok()) return Fail(written.error().message);
      std::printf("wrote %s (character and %zu animated spheres, in clip \"%s\")\n", a_.export_glb.c_str(), set_.size(),
                  extras_.clip_name.c_str());
    }
    if (report_) {
      const std::string tail = ReportSummary(played).dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
      report_->Write("]," + tail.substr(1) + '\n');  // the summary's members after the streamed array
      if (auto err = report_->Close()) return Fail(err->message);
      std::printf("wrote %s\n", a_.report.c_str());
    }
    return 0;
  }

 private:
  // --report's members after the per-frame pair counts: the clip, the settings, the contacts by part pair.
  nlohmann::json ReportSummary(const PlayResult& played) const {
    nlohmann::json contacts = nlohmann::json::array();
    for (const PartPairSummary& e : played.contacts) {
      contacts.push_back({{"parts", {set_.parts[e.part_a].name, set_.parts[e.part_b].name}},
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
    return {{"clip", played.clip},
            {"frames", played.frames},
            {"mode", a_.mode},
            {"margin", a_.margin},
            {"touch_tolerance", played.touch_tolerance},
            {"contact_rules", ContactRulesJson(set_)},
            {"body_height", played.body_height},
            {"spheres", set_.size()},
            {"triangles_outside", played.triangles_outside},
            {"contacts", std::move(contacts)}};
  }

  const PlayArgs& a_;
  const LoadedCharacter& loaded_;
  const runtime::SphereSet& set_;
  const std::vector<int32_t> skin_joints_;
  std::optional<runtime::CheckedFileWriter> dump_, report_;
  lib::GlbExtras extras_;
  bool extras_looped_ = false;
};

// One clip, with its outputs (--dump, --report, --export-glb, --html).
int PlayOneClip(PlaySession& s) {
  const PlayArgs& a = s.a;
  ClipOutputs outputs(a, s.loaded, s.set, s.clips[0]);
  const FrameSink record = s.Record();
  const FrameSink sink = [&](const FrameView& fr) {
    if (record) record(fr);
    outputs.Frame(fr);
  };
  auto played = s.player.Play(s.clips[0], sink);
  if (!played.ok()) return Fail(played.error().message);
  PrintPlaySummary(*played, s.set, a.fps, a.sphere_pairs, a.verify);
  if (const int code = outputs.Finish(*played)) return code;
  const bool verified = played->verified();
  s.Keep(std::move(*played));
  if (const int code = s.WritePage()) return code;
  std::printf("memory: peak %ld KiB\n", PeakRssKiB());
  if (a.verify && !verified) return 1;
  return 0;
}

int RunPlay(PlayArgs& a) {
  if (const int code = CheckPlayArgs(a)) return code;
  auto loaded = LoadCharacter(a.input, a.fit.parts_file);
  if (!loaded.ok()) return Fail(loaded.error().message);
  std::vector<std::string> notes;
  if (auto why = AddClipFiles(*loaded, a.clip_files, a.fps, &notes)) return Fail(why->message);
  for (const auto& note : notes) std::printf("%s\n", note.c_str());
  std::vector<size_t> clips;
  if (const int code = ChooseClips(a, loaded->character, &clips)) return code;
  runtime::SphereSet set;
  double fit_seconds = -1.0;
  if (const int code = LoadOrFitSpheres(a, *loaded, &set, &fit_seconds)) return code;
  const PlayOptions opts = MakePlayOptions(a);
  // Set up once (the set checked against the mesh, the runtime asset), then every clip played by
  // one player.
  auto playback = Playback::Create(*loaded, set, NarrowSettings(opts));
  if (!playback.ok()) return Fail(playback.error().message);
  auto player = ClipPlayer::Create(*playback, opts);
  if (!player.ok()) return Fail(player.error().message);
  PlaySession session{a, *loaded, set, clips, *player, fit_seconds, notes, {}, {}};
  session.recorded.reserve(clips.size());  // RecordFrames keeps a pointer to its element
  return a.clip == "all" ? PlayAllClips(session) : PlayOneClip(session);
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
