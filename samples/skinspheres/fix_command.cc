// skinspheres fix CHARACTER [--clips FILE...] [--clip NAME|all] [--max-depth D] [--allow A:B ...]
//   -o OUT.glb [--report R.json] [--spheres S] [--fps F] [--ease S] [--max-rotation DEG] [--jobs N]
//   [--joint-map M] [--source-rest R] [--retarget ...] [fit options]
//
// Each clip (the character's own, or the files' retargeted onto it) sampled at --fps, fixed by a
// ClipFixer (clip_fixer.h), re-checked on the exact contacts, and written with one key per frame:
// the clips that hold (fixed, or clean to begin with) go into OUT.glb under their own names; a clip
// that cannot be fixed within the limits is reported and not written. Clips run in parallel, one
// ClipFixer per worker over one shared Playback.
#include <algorithm>
#include <atomic>
#include <cctype>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <mutex>
#include <thread>

#include "clip_fixer.h"
#include "fix.h"
#include "html_page.h"
#include "ordered_workers.h"
#include "skinspheres/lib/io/glb_exporter.h"
#include "skinspheres/lib/retarget/bake_clip.h"
#include "skinspheres/runtime/format/file_io.h"

namespace skinspheres::tool {
namespace {

struct Fixed {
  size_t clip = 0;
  float max_jerk_ratio = 0.0f;
  float ease_s = 0.0f;  // the easing the kept fix used
  std::optional<FixResult> result;
  std::string error;
  double seconds = 0.0;
};

std::string Percent(double share) {
  char text[32];
  std::snprintf(text, sizeof(text), "%.2f%%", 100.0 * share);
  return text;
}

// The outputs before any work (CheckOutputPaths, commands.h); --html is a folder of pages.
std::optional<std::string> CheckFixOutputs(const FixArgs& a) {
  const std::pair<const char*, std::string> outputs[] = {{"-o", a.output}, {"--report", a.report}};
  if (auto why = tool::CheckOutputPaths(outputs, a.input, a.clip_files.files)) return why;
  if (!a.html.empty() && (SameFile(a.html, a.output) || SameFile(a.html, a.report)))
    return a.html + ": --html names an output file";
  return std::nullopt;
}

std::optional<std::string> Validate(const FixArgs& a) {
  if (!(a.fps > 0.0f) || a.fps > 10000.0f) return "--fps must be in (0, 10000]";
  if (!(a.max_depth > 0.0f) || !(a.max_depth < 1.0f)) return "--max-depth must be a share of the body height in (0, 1)";
  if (!(a.ease_s >= 0.0f) || a.ease_s > 10.0f) return "--ease must be in [0, 10] seconds";
  if (!(a.max_rotation_deg > 0.0f) || a.max_rotation_deg > 180.0f) return "--max-rotation must be in (0, 180] degrees";
  if (!(a.max_jerk_ratio >= 1.0f)) return "--max-jerk-ratio must be at least 1";
  if (a.jobs < 0 || a.jobs > 1024) return "--jobs must be from 0 (one per core) to 1024";
  std::string ext = std::filesystem::path(a.output).extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return char(std::tolower(c)); });
  if (ext != ".glb") return a.output + ": -o takes a .glb file";
  return CheckFixOutputs(a);
}

// --allow A:B by part name, as the set names its parts.
Result<std::vector<std::pair<uint16_t, uint16_t>>> AllowedPairs(const std::vector<std::string>& allow,
                                                                const runtime::SphereSet& set) {
  std::vector<std::pair<uint16_t, uint16_t>> out;
  std::string names;
  for (const auto& part : set.parts) names += (names.empty() ? "" : ", ") + part.name;
  auto find = [&](const std::string& name) -> int {
    for (size_t p = 0; p < set.parts.size(); ++p) {
      if (set.parts[p].name == name) return static_cast<int>(p);
    }
    return -1;
  };
  for (const std::string& pair : allow) {
    const size_t colon = pair.find(':');
    const int a = colon == std::string::npos ? -1 : find(pair.substr(0, colon));
    const int b = colon == std::string::npos ? -1 : find(pair.substr(colon + 1));
    if (a < 0 || b < 0) {
      return MakeError(ErrorCode::kInvalidArgument,
                       "--allow " + pair + ": expected PART_A:PART_B with parts among " + names);
    }
    out.emplace_back(static_cast<uint16_t>(std::min(a, b)), static_cast<uint16_t>(std::max(a, b)));
  }
  return out;
}

double JerkRatio(const FixResult& r) { return r.jerk_source > 0.0 ? r.jerk_fixed / r.jerk_source : 1.0; }

// Every chosen clip on `jobs` workers, each with its own ClipFixer; done(k) in order as they finish.
void FixAll(const std::shared_ptr<const Playback>& playback, const FixSettings& settings, float fps, int jobs,
            std::vector<Fixed>* fixed, const std::function<void(size_t)>& done) {
  RunOrdered(
      fixed->size(), jobs, [&] { return ClipFixer::Create(playback); },
      [&](size_t k, Result<ClipFixer>& fixer) {
        Fixed& c = (*fixed)[k];
        const auto start = std::chrono::steady_clock::now();
        auto poses =
            fixer.ok() ? fixer->Sample(playback->loaded().character.clips[c.clip], fps) : Result<Poses>(fixer.error());
        auto result = poses.ok() ? fixer->Fix(*poses, fps, settings) : Result<FixResult>(poses.error());
        // A fix that holds but adds pops is eased over twice, then four times, the time.
        FixSettings wider = settings;
        for (int retry = 0; retry < 2 && result.ok() && result->fixed() && JerkRatio(*result) > c.max_jerk_ratio;
             ++retry) {
          wider.ease_s *= 2.0f;
          auto again = fixer->Fix(*poses, fps, wider);
          if (!again.ok() || (again->fixed() && JerkRatio(*again) < JerkRatio(*result))) {
            result = std::move(again);
            c.ease_s = wider.ease_s;
          }
        }
        if (result.ok()) {
          c.result = std::move(*result);
        } else {
          c.error = result.error().message;
        }
        c.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
      },
      done);
}

// Why a clip that needed fixing is not written: "" when it holds.
std::string Unfixed(const Fixed& c) {
  if (!c.result->fixed()) return "still penetrating";
  if (JerkRatio(*c.result) > c.max_jerk_ratio) return "the fix would add pops (jerk over --max-jerk-ratio)";
  return "";
}

const char* Verdict(const Fixed& c) {
  if (!c.result) return "error";
  if (c.result->before.frames_failing == 0) return "clean";
  return Unfixed(c).empty() ? "fixed" : "unfixed";
}

nlohmann::json MeasuresJson(const FixMeasures& m, const runtime::SphereSet& set, float height) {
  nlohmann::json pairs = nlohmann::json::array();
  for (const auto& [a, b] : m.failing_pairs) pairs.push_back({set.parts[a].name, set.parts[b].name});
  return {{"frames_penetrating", m.frames_failing},
          {"worst_depth", m.worst_depth},
          {"worst_depth_share", m.worst_depth / height},
          {"worst_frame", m.worst_frame},
          {"part_pairs", std::move(pairs)}};
}

nlohmann::json ClipJson(const Fixed& c, const LoadedCharacter& loaded, const runtime::SphereSet& set, float height) {
  nlohmann::json j = {{"name", loaded.character.clips[c.clip].name}, {"verdict", Verdict(c)}, {"seconds", c.seconds}};
  if (!c.result) {
    j["error"] = c.error;
    return j;
  }
  const FixResult& r = *c.result;
  nlohmann::json joints = nlohmann::json::array();
  for (int32_t joint : r.joints_changed)
    joints.push_back(loaded.character.skeleton.joint_names[static_cast<size_t>(joint)]);
  j["frames"] = r.poses.size();
  j["before"] = MeasuresJson(r.before, set, height);
  j["after"] = MeasuresJson(r.after, set, height);
  j["joints_changed"] = std::move(joints);
  j["rotation_change_deg"] = {{"median", r.rotation_median_deg}, {"max", r.rotation_max_deg}};
  j["bone_direction_change_deg"] = {{"median", r.bone_median_deg},
                                    {"p95", r.bone_p95_deg},
                                    {"max", r.bone_max_deg},
                                    {"moved", r.bone_moved},
                                    {"moved_median", r.bone_moved_median_deg},
                                    {"total", r.bone_total}};
  j["jerk"] = {{"source", r.jerk_source}, {"fixed", r.jerk_fixed}, {"ratio", JerkRatio(r)}};
  if (std::string why = Unfixed(c); !why.empty() && r.before.frames_failing > 0) j["unfixed_because"] = why;
  j["solver"] = {
      {"ease_s", c.ease_s}, {"rounds", r.rounds}, {"frame_solves", r.solves}, {"poses_evaluated", r.poses_evaluated}};
  return j;
}

// "touch: 121 frames, 24 deeper than 1.00% (worst 2.33% at frame 34) -> 0; 5 joints, ..."
std::string ClipLine(const Fixed& c, const LoadedCharacter& loaded, float height) {
  std::string line = loaded.character.clips[c.clip].name + ": ";
  if (!c.result) return line + "FAILED: " + c.error;
  const FixResult& r = *c.result;
  char text[512];
  std::snprintf(text, sizeof(text), "%zu frames, %d penetrating (worst %s at frame %d) -> %d", r.poses.size(),
                r.before.frames_failing, Percent(r.before.worst_depth / height).c_str(), r.before.worst_frame,
                r.after.frames_failing);
  line += text;
  if (r.before.frames_failing == 0)
    return loaded.character.clips[c.clip].name + ": " + std::to_string(r.poses.size()) +
           " frames, clean (kept as it is)";
  std::snprintf(text, sizeof(text),
                "; %zu joints changed, rotation median %.1f max %.1f deg, bones turned median %.1f p95 %.1f deg, "
                "jerk x%.2f; %.1f s",
                r.joints_changed.size(), double(r.rotation_median_deg), double(r.rotation_max_deg),
                double(r.bone_median_deg), double(r.bone_p95_deg), JerkRatio(r), c.seconds);
  line += text;
  if (!r.fixed()) {
    line += "; NOT FIXED (worst " + Percent(r.after.worst_depth / height) + " at frame " +
            std::to_string(r.after.worst_frame) + "), not written";
  } else if (!Unfixed(c).empty()) {
    line += "; NOT FIXED: " + Unfixed(c) + ", not written";
  }
  return line;
}

nlohmann::json ReportJson(const FixArgs& a, const lib::RawCharacter& ch, float height, bool nothing_written,
                          nlohmann::json clips, nlohmann::json summary) {
  return {{"format", "skinspheres.fix"},
          {"version", 1},
          {"character", ch.source_file.empty() ? "built-in character" : ch.source_file},
          {"body_height", height},
          {"max_depth", a.max_depth},
          {"allow", a.allow},
          {"fps", a.fps},
          {"ease_s", a.ease_s},
          {"max_rotation_deg", a.max_rotation_deg},
          {"max_jerk_ratio", a.max_jerk_ratio},
          {"output", nothing_written ? nlohmann::json(nullptr) : nlohmann::json(a.output)},
          {"clips", std::move(clips)},
          {"summary", std::move(summary)}};
}

// The clips as written (a clean clip as it is, a fixed one keyed per frame, names made unique:
// glTF exporters refuse two animations of one name), the report's entries and the counts.
struct Collected {
  std::vector<skinning::AnimationClip> written;
  nlohmann::json clips = nlohmann::json::array();
  size_t clean = 0, repaired = 0, unfixed = 0, failed = 0;
};
Collected Collect(const std::vector<Fixed>& fixed, const LoadedCharacter& loaded, const runtime::SphereSet& set,
                  float height, float fps, bool quiet) {
  Collected out;
  const lib::RawCharacter& ch = loaded.character;
  for (const Fixed& c : fixed) {
    out.clips.push_back(ClipJson(c, loaded, set, height));
    const std::string verdict = Verdict(c);
    out.clean += verdict == "clean";
    out.repaired += verdict == "fixed";
    out.unfixed += verdict == "unfixed";
    out.failed += verdict == "error";
    if (verdict == "error" && !quiet) Fail(c.error);  // one line on stderr per clip that failed
    if (verdict != "clean" && verdict != "fixed") continue;
    out.written.push_back(verdict == "clean" ? ch.clips[c.clip]
                                             : lib::ClipFromFrames(ch.clips[c.clip].name, c.result->poses, fps));
    auto& written = out.written;
    const std::string base = written.back().name;
    for (int k = 2; std::count_if(written.begin(), written.end() - 1,
                                  [&](const auto& w) { return w.name == written.back().name; }) > 0;
         ++k) {
      written.back().name = base + "#" + std::to_string(k);
    }
  }
  return out;
}

// --html DIR: per clip that needed fixing, a viewer page holding the clip as it was and as fixed
// ("NAME (fixed)"), each played with its contacts and timeline, one selected at a time.
std::optional<Error> WriteBeforeAfterPages(const std::vector<Fixed>& fixed, const LoadedCharacter& loaded,
                                           const runtime::SphereSet& set, const FixArgs& a,
                                           const std::function<void(const std::string&)>& say) {
  std::error_code ec;
  std::filesystem::create_directories(a.html, ec);
  if (ec) return MakeError(ErrorCode::kFileUnreadable, a.html + ": cannot create the folder (" + ec.message() + ")");
  for (const Fixed& c : fixed) {
    if (!c.result || c.result->before.frames_failing == 0) continue;
    LoadedCharacter page_character = loaded;
    const skinning::AnimationClip& original = loaded.character.clips[c.clip];
    page_character.character.clips = {original,
                                      lib::ClipFromFrames(original.name + " (fixed)", c.result->poses, a.fps)};
    std::vector<PlayResult> played(2);
    std::vector<std::vector<FrameRecord>> frames(2);
    PlayOptions options;
    options.fps = a.fps;
    ViewerPageInput page{&page_character, &set, -1.0, {}, {"before and after skinspheres fix"}, nullptr};
    for (size_t k = 0; k < 2; ++k) {
      auto result = PlayClip(page_character, set, k, options, RecordFrames(&frames[k]));
      if (!result.ok()) return result.error();
      played[k] = std::move(*result);
      page.clips.push_back(ViewClip{&played[k], &frames[k], k, a.fps, false});
    }
    std::string stem = original.name;
    for (char& ch : stem) {
      if (!std::isalnum(static_cast<unsigned char>(ch)) && ch != '-' && ch != '.') ch = '_';
    }
    const std::string path = (std::filesystem::path(a.html) / (stem + ".html")).string();
    if (auto err = WriteViewerPage(page, path)) return err;
    say("wrote " + path);
  }
  return std::nullopt;
}

FixOutcome RunFixCommand(FixArgs& a, bool quiet) {
  FixOutcome out;
  auto say = [quiet](const std::string& line) {
    if (!quiet) std::printf("%s\n", line.c_str()), std::fflush(stdout);
  };
  auto fail = [&](const std::string& message, ErrorCode code = ErrorCode::kInvalidArgument) {
    out.report = nullptr;  // a failed run has no report: the Python module raises
    out.error = runtime::OneLine(message);
    out.error_code = code;
    out.exit_code = quiet ? kExitBadInput : Fail(message);
    return out;
  };
  if (auto why = Validate(a)) return fail(*why);
  if (auto why = a.fit.Resolve()) return fail(*why);
  const auto start = std::chrono::steady_clock::now();
  auto loaded = LoadCharacter(a.input, a.fit.parts_file);
  if (!loaded.ok()) return fail(loaded.error().message, loaded.error().code);
  if (loaded->character.triangle_count() == 0)
    return fail(loaded->character.Name() + ": no mesh: nothing for the clips to penetrate");
  const size_t own = loaded->character.clips.size();
  std::vector<std::string> notes;
  if (auto why = AddClipFiles(*loaded, a.clip_files, a.fps, &notes)) return fail(why->message, why->code);
  for (const std::string& note : notes) say(note);
  auto chosen = SelectClips(loaded->character, a.clip_files.files.empty() ? 0 : own, a.clip);
  if (!chosen.ok()) return fail(loaded->character.Name() + ": " + chosen.error().message, chosen.error().code);
  double fit_seconds = -1.0;
  auto set = SphereSetFor(*loaded, a.spheres, a.fit.settings, &fit_seconds);
  if (!set.ok()) return fail(set.error().message, set.error().code);
  auto allow = AllowedPairs(a.allow, *set);
  if (!allow.ok()) return fail(allow.error().message);
  PlayOptions options;
  auto playback = Playback::Create(*loaded, *set, NarrowSettings(options));
  if (!playback.ok()) return fail(playback.error().message, playback.error().code);
  const float height = (*playback)->body_height();
  FixSettings settings;
  settings.max_depth = a.max_depth * height;
  settings.ease_s = a.ease_s;
  settings.max_rotation_deg = a.max_rotation_deg;
  settings.allow = std::move(*allow);

  std::vector<Fixed> fixed(chosen->size());
  for (size_t k = 0; k < fixed.size(); ++k)
    fixed[k].clip = (*chosen)[k], fixed[k].max_jerk_ratio = a.max_jerk_ratio, fixed[k].ease_s = a.ease_s;
  const int hardware = static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
  const int jobs = std::max(1, std::min<int>(a.jobs > 0 ? a.jobs : hardware, static_cast<int>(fixed.size())));
  say("fixing " + std::to_string(fixed.size()) + " clips on " + (*playback)->file() + ": penetration deeper than " +
      Percent(a.max_depth) + " of height is removed");
  FixAll(*playback, settings, a.fps, jobs, &fixed, [&](size_t k) { say("  " + ClipLine(fixed[k], *loaded, height)); });

  lib::RawCharacter& ch = loaded->character;
  Collected got = Collect(fixed, *loaded, *set, height, a.fps, quiet);
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  out.report = ReportJson(a, ch, height, got.written.empty(), std::move(got.clips),
                          {{"clips", fixed.size()},
                           {"clean", got.clean},
                           {"fixed", got.repaired},
                           {"unfixed", got.unfixed},
                           {"failed", got.failed},
                           {"seconds", seconds}});
  if (!a.html.empty()) {
    if (auto err = WriteBeforeAfterPages(fixed, *loaded, *set, a, say)) return fail(err->message, err->code);
  }
  if (!got.written.empty()) {
    ch.clips = std::move(got.written);
    auto exported = lib::ExportGlb(ch, a.output);
    if (!exported.ok()) return fail(exported.error().message, exported.error().code);
    say("wrote " + a.output + ": " + std::to_string(ch.clips.size()) + " clips");
  }
  if (!a.report.empty()) {
    const std::string text = out.report.dump(1, ' ', false, nlohmann::json::error_handler_t::replace) + "\n";
    if (auto err = runtime::WriteWholeFile(a.report, text)) return fail(err->message);
    say("wrote " + a.report);
  }
  char summary[256];
  std::snprintf(summary, sizeof(summary), "fixed %zu clips in %.1f s: %zu fixed, %zu clean, %zu could not be fixed%s",
                fixed.size(), seconds, got.repaired, got.clean, got.unfixed,
                got.failed ? (", " + std::to_string(got.failed) + " failed").c_str() : "");
  say(summary);
  out.exit_code = got.failed ? kExitBadInput : got.unfixed ? 1 : 0;
  return out;
}

}  // namespace

FixOutcome RunFix(FixArgs& a, bool quiet) { return RunFixCommand(a, quiet); }

void AddFixCommand(CLI::App& app, int* exit_code) {
  auto a = std::make_shared<FixArgs>();
  CLI::App* cmd = app.add_subcommand(
      "fix",
      "change clips as little as possible so that no part pair penetrates deeper than --max-depth, smoothly, and "
      "write them as glTF (exit 0 all hold, 1 some could not be fixed, 2 bad input)");
  cmd->add_option("input", a->input, "character file")->required();
  cmd->add_option("-o,--output", a->output, "output .glb: the character and the clips that hold")->required();
  a->clip_files.AddTo(*cmd);
  cmd->add_option("--clip", a->clip, "which clips: all, a name, or an index among them")->capture_default_str();
  cmd->add_option("--max-depth", a->max_depth, "no part pair may penetrate deeper than this share of the body height")
      ->capture_default_str();
  cmd->add_option("--allow", a->allow, "PART_A:PART_B: an intended contact, left alone (repeatable)");
  cmd->add_option("--report", a->report, "write a JSON report (per clip: before and after, joints, degrees, jerk)");
  cmd->add_option("--html", a->html,
                  "write a viewer page per clip that needed fixing into this folder: the clip before and after");
  cmd->add_option("--spheres", a->spheres, "sphere set to use (default: fit on the fly)");
  cmd->add_option("--fps", a->fps, "frames per second: the frames checked, fixed and keyed")->capture_default_str();
  cmd->add_option("--ease", a->ease_s, "seconds over which corrections ease in and out")->capture_default_str();
  cmd->add_option("--max-rotation", a->max_rotation_deg, "largest change of one joint's rotation, degrees")
      ->capture_default_str();
  cmd->add_option("--max-jerk-ratio", a->max_jerk_ratio,
                  "a fix may raise the moved joints' RMS jerk at most this many times, else the clip is not written")
      ->capture_default_str();
  cmd->add_option("--jobs", a->jobs, "clips fixed at once (0: one per core)")->capture_default_str();
  a->fit.AddTo(*cmd);
  cmd->callback([a, exit_code] { *exit_code = RunFix(*a, false).exit_code; });
}

}  // namespace skinspheres::tool
