// skinspheres check CHARACTER [--clips FILE...] [--clip NAME|all] [--max-depth D] [--touch-tolerance T]
//   [--report R.json] [--csv R.csv] [--html DIR] [--spheres S] [--fps F] [--mode exact|fast] [--jobs N]
//   [--joint-map M] [--source-rest R] [--retarget auto|copy|world] [--compare-source] [fit options]
//
// A whole animation library against one character, like a linter: every clip of every file
// (retargeted onto the character), or the character's own clips without --clips, played in
// parallel (one ClipPlayer per worker over one shared Playback). One line per clip, in order, a
// summary, and the exit code: 0 when no clip penetrates deeper than D (a share of the body
// height), 1 when some do, 2 on bad input (a file that cannot be read or retargeted is reported
// on stderr and skipped, the others still run, and the run exits 2).
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdarg>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <mutex>
#include <nlohmann/json.hpp>
#include <thread>

#include "check.h"
#include "clip_files.h"
#include "html_page.h"
#include "ordered_workers.h"
#include "playback.h"
#include "skinspheres/runtime/format/file_io.h"
#include "skinspheres/runtime/format/sphere_set_io.h"
#include "skinspheres/skinning/platform.h"

namespace skinspheres::tool {
namespace {

// One clip to check: its index in the character's clips, the file it came from ("" = the
// character's own) and its name in that file.
struct Entry {
  size_t clip = 0;
  std::string file;
  std::string original;
};

enum class Verdict { kClean, kPenetratingWithinLimit, kOverLimit };

const char* ToString(Verdict v) {
  switch (v) {
    case Verdict::kClean: return "clean";
    case Verdict::kPenetratingWithinLimit: return "penetrating_within_limit";
    case Verdict::kOverLimit: return "penetrating";
  }
  return "?";
}

struct Checked {
  Entry entry;
  std::optional<PlayResult> played;  // empty when it failed
  std::string error;
  std::vector<FrameRecord> frames;  // --html only
  float worst = 0.0f;               // deepest penetration (model units), -1 when none penetrates
  int worst_frame = -1;
  const PartPairSummary* worst_pair = nullptr;
  Verdict verdict = Verdict::kClean;
  // --compare-source: the part pairs that penetrate when the file's own character plays the clip,
  // and those that penetrate here but not there (introduced by retargeting).
  std::optional<std::vector<std::string>> source_penetrating;
  std::vector<std::string> introduced;
};

// stdout, or nothing when the command runs quietly (in-process, for the Python module).
class Say {
 public:
  explicit Say(bool quiet) : quiet_(quiet) {}
  bool quiet() const { return quiet_; }
  void operator()(const char* format, ...) const SKINSPHERES_PRINTF_FORMAT(2, 3) {
    if (quiet_) return;
    va_list args;
    va_start(args, format);
    std::vfprintf(stdout, format, args);
    va_end(args);
  }

 private:
  bool quiet_;
};

std::string PartName(const runtime::SphereSet& set, uint16_t p) {
  return p < set.parts.size() ? set.parts[p].name : "part " + std::to_string(p);
}
std::string PairName(const runtime::SphereSet& set, const PartPairSummary& e) {
  return PartName(set, e.part_a) + " - " + PartName(set, e.part_b);
}
std::string Percent(double share) {
  char text[32];
  std::snprintf(text, sizeof(text), "%.2f%%", 100.0 * share);
  return text;
}

void Judge(Checked& c, float max_depth_share) {
  if (!c.played) return;
  c.worst = -1.0f;
  for (const PartPairSummary& e : c.played->contacts) {
    if (e.penetrating.frames() == 0 || e.max_depth <= c.worst) continue;
    c.worst = e.max_depth;
    c.worst_frame = e.worst_frame;
    c.worst_pair = &e;
  }
  const float height = c.played->body_height > 0.0f ? c.played->body_height : 1.0f;
  c.verdict = c.worst < 0.0f                       ? Verdict::kClean
              : c.worst > max_depth_share * height ? Verdict::kOverLimit
                                                   : Verdict::kPenetratingWithinLimit;
}

// "touch [anim.glb]: 121 frames, PENETRATES deeper than 1.00%: torso - arm_r 2.33% at frame 34, ...; touching: ..."
std::string ClipLine(const Checked& c, const LoadedCharacter& loaded, const runtime::SphereSet& set, float max_depth) {
  const std::string name = loaded.character.clips[c.entry.clip].name;
  std::string line = name + (c.entry.file.empty() ? "" : " [" + c.entry.file + "]") + ": ";
  if (!c.played) return line + "FAILED: " + c.error;
  const PlayResult& r = *c.played;
  const float height = r.body_height > 0.0f ? r.body_height : 1.0f;
  line += std::to_string(r.frames) + (r.frames == 1 ? " frame, " : " frames, ");
  std::vector<const PartPairSummary*> penetrating, touching;
  for (const PartPairSummary& e : r.contacts) (e.penetrating.frames() ? penetrating : touching).push_back(&e);
  std::stable_sort(penetrating.begin(), penetrating.end(),
                   [](const PartPairSummary* x, const PartPairSummary* y) { return x->max_depth > y->max_depth; });
  if (penetrating.empty()) {
    line += "no penetration";
  } else {
    line += c.verdict == Verdict::kOverLimit ? "PENETRATES deeper than " + Percent(max_depth) + " of height:"
                                             : "penetrates less than " + Percent(max_depth) + " of height:";
    for (size_t k = 0; k < penetrating.size(); ++k) {
      const PartPairSummary& e = *penetrating[k];
      line += (k ? ", " : " ") + PairName(set, e) + " " + Percent(e.max_depth / height) + " at frame " +
              std::to_string(e.worst_frame) + " (" + std::to_string(e.penetrating.frames()) +
              (e.penetrating.frames() == 1 ? " frame)" : " frames)");
    }
  }
  if (!touching.empty()) {
    line += "; touching:";
    for (size_t k = 0; k < touching.size(); ++k) line += (k ? ", " : " ") + PairName(set, *touching[k]);
  }
  return line;
}

// Plays every entry on `jobs` workers, each with its own ClipPlayer over the shared Playback; calls
// `done(k)` for the entries in order as soon as each and every one before it is finished.
void PlayAll(const std::shared_ptr<const Playback>& playback, const PlayOptions& options, bool record, int jobs,
             std::vector<Checked>* checked, const std::function<void(size_t)>& done) {
  RunOrdered(
      checked->size(), jobs, [&] { return ClipPlayer::Create(playback, options); },
      [&](size_t k, Result<ClipPlayer>& player) {
        Checked& c = (*checked)[k];
        if (!player.ok()) {
          c.error = player.error().message;
          return;
        }
        auto played = player->Play(c.entry.clip, record ? RecordFrames(&c.frames) : FrameSink());
        if (played.ok()) {
          c.played = std::move(*played);
        } else {
          c.error = played.error().message;
          c.frames.clear();
        }
      },
      done);
}

nlohmann::json PairJson(const PartPairSummary& e, const runtime::SphereSet& set, float height) {
  return {{"parts", {PartName(set, e.part_a), PartName(set, e.part_b)}},
          {"kind", e.penetrating.frames() ? "penetrating" : "touching"},
          {"frames", e.frames.frames()},
          {"penetrating_frames", e.penetrating.frames()},
          {"first_frame", e.frames.first()},
          {"last_frame", e.frames.last()},
          {"max_depth", e.max_depth},
          {"max_depth_share", height > 0.0f ? e.max_depth / height : 0.0f},
          {"worst_frame", e.worst_frame}};
}

nlohmann::json ReportJson(const std::vector<Checked>& checked,
                          const std::vector<std::pair<std::string, std::string>>& bad, const LoadedCharacter& loaded,
                          const runtime::SphereSet& set, const CheckArgs& a, double seconds, float height) {
  nlohmann::json clips = nlohmann::json::array();
  size_t over = 0, within = 0, clean = 0, failed = 0;
  for (const Checked& c : checked) {
    nlohmann::json j = {{"name", loaded.character.clips[c.entry.clip].name}, {"file", c.entry.file}};
    if (!c.played) {
      ++failed;
      j["verdict"] = "error";
      j["error"] = c.error;
      clips.push_back(std::move(j));
      continue;
    }
    over += c.verdict == Verdict::kOverLimit;
    within += c.verdict == Verdict::kPenetratingWithinLimit;
    clean += c.verdict == Verdict::kClean;
    nlohmann::json pairs = nlohmann::json::array();
    for (const PartPairSummary& e : c.played->contacts) pairs.push_back(PairJson(e, set, height));
    j["frames"] = c.played->frames;
    j["verdict"] = ToString(c.verdict);
    j["worst_depth"] = c.worst > 0.0f ? c.worst : 0.0f;
    j["worst_depth_share"] = c.worst > 0.0f && height > 0.0f ? c.worst / height : 0.0f;
    j["worst_frame"] = c.worst_frame;
    j["worst_parts"] = c.worst_pair
                           ? nlohmann::json{PartName(set, c.worst_pair->part_a), PartName(set, c.worst_pair->part_b)}
                           : nlohmann::json(nullptr);
    j["part_pairs"] = std::move(pairs);
    if (c.source_penetrating) {
      j["compare_source"] = {{"source_penetrating", *c.source_penetrating}, {"introduced", c.introduced}};
    }
    clips.push_back(std::move(j));
  }
  nlohmann::json errors = nlohmann::json::array();
  for (const auto& [file, message] : bad) errors.push_back({{"file", file}, {"message", message}});
  return {{"format", "skinspheres.check"},
          {"version", 1},
          {"character", loaded.character.source_file.empty() ? "built-in character" : loaded.character.source_file},
          {"body_height", height},
          {"max_depth", a.max_depth},
          {"touch_tolerance", a.touch_tolerance},
          {"contact_rules", ContactRulesJson(set)},
          {"fps", a.fps},
          {"mode", a.mode},
          {"clips", std::move(clips)},
          {"errors", std::move(errors)},
          {"summary",
           {{"clips", checked.size()},
            {"over_limit", over},
            {"penetrating_within_limit", within},
            {"clean", clean},
            {"failed", failed},
            {"unreadable_files", bad.size()},
            {"seconds", seconds}}}};
}

// RFC 4180: a field with a comma, quote or line break is quoted, quotes doubled.
std::string Csv(const std::string& field) {
  if (field.find_first_of(",\"\r\n") == std::string::npos) return field;
  std::string out = "\"";
  for (char ch : field) out += ch == '"' ? std::string("\"\"") : std::string(1, ch);
  return out + "\"";
}

std::string ReportCsv(const nlohmann::json& report) {
  std::string out =
      "file,clip,frames,verdict,part_a,part_b,kind,contact_frames,penetrating_frames,first_frame,last_frame,max_depth,"
      "max_depth_share,worst_frame,message\n";
  auto num = [](const nlohmann::json& v) { return v.dump(); };
  for (const auto& c : report["clips"]) {
    const std::string head = Csv(c["file"].get<std::string>()) + "," + Csv(c["name"].get<std::string>()) + "," +
                             (c.contains("frames") ? num(c["frames"]) : "") + "," + c["verdict"].get<std::string>() +
                             ",";
    if (!c.contains("part_pairs") || c["part_pairs"].empty()) {
      out += head + ",,,,,,,,,," + (c.contains("error") ? Csv(c["error"].get<std::string>()) : "") + "\n";
      continue;
    }
    for (const auto& p : c["part_pairs"]) {
      out += head + Csv(p["parts"][0].get<std::string>()) + "," + Csv(p["parts"][1].get<std::string>()) + "," +
             p["kind"].get<std::string>() + "," + num(p["frames"]) + "," + num(p["penetrating_frames"]) + "," +
             num(p["first_frame"]) + "," + num(p["last_frame"]) + "," + num(p["max_depth"]) + "," +
             num(p["max_depth_share"]) + "," + num(p["worst_frame"]) + ",\n";
    }
  }
  for (const auto& e : report["errors"]) {
    out += Csv(e["file"].get<std::string>()) + ",,,error,,,,,,,,,,," + Csv(e["message"].get<std::string>()) + "\n";
  }
  return out;
}

// The clips to check: the files' (retargeted, appended to the character's clips; a file that
// fails is reported and skipped), else the character's own; only those named --clip.
std::vector<Entry> CollectClips(LoadedCharacter& loaded, const CheckArgs& a, const ClipFileContext& context,
                                std::vector<std::pair<std::string, std::string>>* bad, const Say& say) {
  std::vector<Entry> entries;
  auto wanted = [&](const std::string& original, const std::string& added) {
    return a.clip == "all" || a.clip == original || a.clip == added;
  };
  if (a.clip_files.files.empty()) {
    for (size_t k = 0; k < loaded.character.clips.size(); ++k) {
      const std::string& name = loaded.character.clips[k].name;
      if (wanted(name, name)) entries.push_back({k, "", name});
    }
    return entries;
  }
  for (const std::string& file : a.clip_files.files) {
    lib::RetargetReport report;
    auto clips = ReadClipFile(loaded, file, context, &report);
    if (!clips.ok()) {
      if (!say.quiet()) Fail(clips.error().message);  // one line on stderr; the others still run
      bad->emplace_back(file, runtime::OneLine(clips.error().message));
      continue;
    }
    std::vector<std::string> originals;
    for (const auto& clip : *clips) originals.push_back(clip.name);
    const size_t first = loaded.character.clips.size();
    const std::vector<std::string> names = AppendClips(loaded, file, std::move(*clips));
    for (const std::string& note : DescribeRetarget(report, loaded, file, names)) say("%s\n", note.c_str());
    for (size_t k = 0; k < names.size(); ++k) {
      if (wanted(originals[k], names[k])) entries.push_back({first + k, file, originals[k]});
    }
  }
  return entries;
}

// One page per file, named for its stem ("_2", "_3", ... where stems repeat), holding the
// character with that file's clips only.
std::optional<std::string> WritePages(const std::vector<Checked>& checked, const LoadedCharacter& loaded,
                                      const runtime::SphereSet& set, const CheckArgs& a, double fit_seconds,
                                      const Say& say) {
  std::error_code ec;
  std::filesystem::create_directories(a.html, ec);
  if (ec) return a.html + ": cannot create the folder (" + ec.message() + ")";
  std::vector<std::string> files, stems;
  for (const Checked& c : checked) {
    if (std::find(files.begin(), files.end(), c.entry.file) == files.end()) files.push_back(c.entry.file);
  }
  for (const std::string& file : files) {
    const std::string own = loaded.character.source_file.empty() ? "builtin" : loaded.character.source_file;
    std::string stem = std::filesystem::path(file.empty() ? own : file).stem().string();
    for (int k = 2; std::find(stems.begin(), stems.end(), stem) != stems.end(); ++k) {
      stem = std::filesystem::path(file.empty() ? own : file).stem().string() + "_" + std::to_string(k);
    }
    stems.push_back(stem);
    LoadedCharacter page_character = loaded;
    page_character.character.clips.clear();
    ViewerPageInput page{&page_character, &set, fit_seconds, {}, {"clips checked by skinspheres check"}, nullptr};
    for (const Checked& c : checked) {
      if (c.entry.file != file || !c.played) continue;
      page.clips.push_back(
          ViewClip{&*c.played, &c.frames, page_character.character.clips.size(), a.fps, a.mode == "fast"});
      page_character.character.clips.push_back(loaded.character.clips[c.entry.clip]);
    }
    if (page.clips.empty()) continue;
    const std::string path = (std::filesystem::path(a.html) / (stem + ".html")).string();
    if (auto err = WriteViewerPage(page, path)) return err->message;
    say("wrote %s\n", path.c_str());
  }
  return std::nullopt;
}

// The penetrating part pairs of a played clip, by name.
std::vector<std::string> PenetratingPairs(const PlayResult& r, const runtime::SphereSet& set) {
  std::vector<std::string> names;
  for (const PartPairSummary& e : r.contacts) {
    if (e.penetrating.frames()) names.push_back(PairName(set, e));
  }
  return names;
}

// --compare-source: each file that holds a skinned character of its own is fitted and plays its
// own clips; a clip's part pairs that penetrate on the target but not there were introduced by
// retargeting. Prints what it finds; a file without a character (or one that fails to fit) is
// said so in a line, and is no error of the run.
void CompareWithSources(std::vector<Checked>& checked, const runtime::SphereSet& set, const CheckArgs& a,
                        const PlayOptions& options, int jobs, const Say& say) {
  std::vector<std::string> files;
  for (const Checked& c : checked) {
    if (!c.entry.file.empty() && c.played && std::find(files.begin(), files.end(), c.entry.file) == files.end())
      files.push_back(c.entry.file);
  }
  if (files.empty()) return;
  say("compared with the characters the clips' files hold (--compare-source):\n");
  for (const std::string& file : files) {
    auto source = LoadCharacter(file, "");
    if (!source.ok()) {
      say("  %s: nothing to compare with (%s)\n", file.c_str(), runtime::OneLine(source.error().message).c_str());
      continue;
    }
    auto fit = lib::FitSpheres(source->character, source->parts, a.fit.settings);
    auto playback = fit.ok() ? Playback::Create(*source, fit->spheres, NarrowSettings(options))
                             : Result<std::shared_ptr<const Playback>>(fit.error());
    if (!playback.ok()) {
      say("  %s: nothing to compare with (%s)\n", file.c_str(), runtime::OneLine(playback.error().message).c_str());
      continue;
    }
    std::vector<Checked> own;
    std::vector<Checked*> targets;
    for (Checked& c : checked) {
      if (c.entry.file != file || !c.played) continue;
      for (size_t k = 0; k < source->character.clips.size(); ++k) {
        if (source->character.clips[k].name != c.entry.original) continue;
        own.push_back({});
        own.back().entry = {k, file, c.entry.original};
        targets.push_back(&c);
        break;
      }
    }
    PlayAll(*playback, options, false, std::max(1, std::min<int>(jobs, static_cast<int>(own.size()))), &own,
            [](size_t) {});
    for (size_t k = 0; k < own.size(); ++k) {
      Checked& c = *targets[k];
      if (!own[k].played) {
        say("  %s [%s]: its own character cannot play it (%s)\n", c.entry.original.c_str(), file.c_str(),
            own[k].error.c_str());
        continue;
      }
      c.source_penetrating = PenetratingPairs(*own[k].played, fit->spheres);
      std::string line;
      for (const std::string& pair : PenetratingPairs(*c.played, set)) {
        if (std::find(c.source_penetrating->begin(), c.source_penetrating->end(), pair) != c.source_penetrating->end())
          continue;
        c.introduced.push_back(pair);
        line += (line.empty() ? "" : ", ") + pair;
      }
      std::string there;
      for (const std::string& pair : *c.source_penetrating) there += (there.empty() ? "" : ", ") + pair;
      say("  %s [%s]: %s; penetrating on its own character: %s\n", c.entry.original.c_str(), file.c_str(),
          line.empty() ? "nothing introduced by retargeting" : ("introduced by retargeting: " + line).c_str(),
          there.empty() ? "none" : there.c_str());
    }
  }
}

std::optional<std::string> Validate(const CheckArgs& a) {
  if (a.mode != "exact" && a.mode != "fast") return "--mode must be exact or fast (got " + a.mode + ")";
  if (!(a.fps > 0.0f) || a.fps > 10000.0f) return "--fps must be in (0, 10000]";
  if (!(a.max_depth > 0.0f) || !(a.max_depth < 1.0f)) return "--max-depth must be a share of the body height in (0, 1)";
  if (auto why = CheckTouchTolerance(a.touch_tolerance)) return why;
  if (a.jobs < 0 || a.jobs > 1024) return "--jobs must be from 0 (one per core) to 1024";
  return std::nullopt;
}

// The command; quiet: nothing printed, the failure in outcome.error.
CheckOutcome RunCheckCommand(CheckArgs& a, bool quiet) {
  CheckOutcome out;
  const Say say(quiet);
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
  auto context = ResolveClipFileOptions(a.clip_files, a.fps);
  if (!context.ok()) return fail(context.error().message, context.error().code);
  std::vector<std::pair<std::string, std::string>> bad;
  const std::vector<Entry> entries = CollectClips(*loaded, a, *context, &bad, say);
  if (entries.empty()) {
    if (!bad.empty()) {  // each file that failed has had its line
      out.exit_code = kExitBadInput;
      out.error = bad.front().second;
      out.error_code = ErrorCode::kInvalidData;
      return out;
    }
    return fail((a.input.empty() ? std::string("built-in character") : a.input) + ": no clip to check" +
                (a.clip == "all" ? std::string() : " named \"" + a.clip + "\""));
  }
  double fit_seconds = -1.0;
  auto set = SphereSetFor(*loaded, a.spheres, a.fit.settings, &fit_seconds);
  if (!set.ok()) return fail(set.error().message, set.error().code);
  PlayOptions options;
  options.fps = a.fps;
  options.fast = a.mode == "fast";
  options.touch_tolerance = a.touch_tolerance;
  auto playback = Playback::Create(*loaded, *set, NarrowSettings(options));
  if (!playback.ok()) return fail(playback.error().message, playback.error().code);
  const float height = (*playback)->body_height();
  if (set->contact_rules == runtime::ContactRules::kSpherePairs) {
    say("%s: %s\n", a.spheres.c_str(), ContactRulesSummary(*set).c_str());
  }

  std::vector<Checked> checked(entries.size());
  for (size_t k = 0; k < entries.size(); ++k) checked[k].entry = entries[k];
  const int hardware = static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
  const int jobs = std::min<int>(a.jobs > 0 ? a.jobs : hardware, static_cast<int>(entries.size()));
  const bool bar = !quiet && isatty(STDERR_FILENO) != 0;
  say("checking %zu clips on %s (%d workers): penetration deeper than %s of height (%.4g) fails, "
      "intersections up to %s touch\n",
      entries.size(), (*playback)->file().c_str(), jobs, Percent(a.max_depth).c_str(), a.max_depth * height,
      Percent(a.touch_tolerance).c_str());
  std::fflush(stdout);
  if (bar) std::fprintf(stderr, "[%s] 0/%zu clips", std::string(30, '.').c_str(), checked.size());
  PlayAll(*playback, options, !a.html.empty(), jobs, &checked, [&](size_t k) {
    Judge(checked[k], a.max_depth);
    if (bar) std::fprintf(stderr, "\r\033[K");
    say("  %s\n", ClipLine(checked[k], *loaded, *set, a.max_depth).c_str());
    std::fflush(stdout);
    if (bar) {
      const size_t n = k + 1, width = 30, filled = width * n / checked.size();
      std::fprintf(stderr, "[%s%s] %zu/%zu clips", std::string(filled, '#').c_str(),
                   std::string(width - filled, '.').c_str(), n, checked.size());
      if (n == checked.size()) std::fprintf(stderr, "\r\033[K");
    }
  });
  if (a.compare_source) CompareWithSources(checked, *set, a, options, jobs, say);
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  out.report = ReportJson(checked, bad, *loaded, *set, a, seconds, height);
  const nlohmann::json& report = out.report;
  const auto& sum = report["summary"];
  say("checked %zu clips in %.1f s: %zu penetrate deeper than %s of height, %zu penetrate less, %zu do not "
      "penetrate%s%s\n",
      checked.size(), seconds, sum["over_limit"].get<size_t>(), Percent(a.max_depth).c_str(),
      sum["penetrating_within_limit"].get<size_t>(), sum["clean"].get<size_t>(),
      sum["failed"].get<size_t>() ? ("; " + std::to_string(sum["failed"].get<size_t>()) + " failed").c_str() : "",
      bad.empty()
          ? ""
          : ("; " + std::to_string(bad.size()) +
             (bad.size() == 1 ? " file could not be read or retargeted" : " files could not be read or retargeted"))
                .c_str());
  const std::string json_text = report.dump(1, ' ', false, nlohmann::json::error_handler_t::replace) + "\n";
  for (const auto& [path, text] : {std::pair{a.report, json_text}, std::pair{a.csv, ReportCsv(report)}}) {
    if (path.empty()) continue;
    if (auto err = runtime::WriteWholeFile(path, text)) return fail(err->message);
    say("wrote %s\n", path.c_str());
  }
  if (!a.html.empty()) {
    if (auto err = WritePages(checked, *loaded, *set, a, fit_seconds, say)) return fail(*err);
  }
  out.exit_code = !bad.empty() || sum["failed"].get<size_t>() > 0 ? kExitBadInput
                  : sum["over_limit"].get<size_t>() > 0           ? 1
                                                                  : 0;
  return out;
}

}  // namespace

CheckOutcome RunCheck(CheckArgs& a, bool quiet) { return RunCheckCommand(a, quiet); }

void AddCheckCommand(CLI::App& app, int* exit_code) {
  auto a = std::make_shared<CheckArgs>();
  CLI::App* cmd = app.add_subcommand(
      "check",
      "check an animation library: which clips make the character penetrate itself (exit 0 none deeper than "
      "--max-depth, 1 some, 2 bad input)");
  cmd->add_option("input", a->input, "character file")->required();
  a->clip_files.AddTo(*cmd);
  cmd->add_option("--clip", a->clip, "check only the clips of this name (as in their file, or as added), or all")
      ->capture_default_str();
  cmd->add_option("--max-depth", a->max_depth,
                  "a clip fails when a part pair penetrates deeper than this share of the body height")
      ->capture_default_str();
  AddTouchToleranceOption(*cmd, &a->touch_tolerance);
  cmd->add_option("--report", a->report, "write a JSON report (every clip, its part pairs, the files that failed)");
  cmd->add_option("--csv", a->csv, "write a CSV report (one row per clip and part pair)");
  cmd->add_option("--html", a->html, "write one viewer page per file into this folder");
  cmd->add_option("--spheres", a->spheres, "sphere set to use (default: fit on the fly)");
  cmd->add_option("--fps", a->fps, "frames per second (the last frame, at t = duration, samples the clip's end pose)")
      ->capture_default_str();
  cmd->add_option("--mode", a->mode, "refit mode: exact or fast")->capture_default_str();
  cmd->add_flag("--compare-source", a->compare_source,
                "fit the character each clip's file holds (when it has one), play the clip on it too, and list the "
                "part pairs that penetrate here but not there (introduced by retargeting)");
  cmd->add_option("--jobs", a->jobs, "clips played at once (0: one per core)")->capture_default_str();
  a->fit.AddTo(*cmd);
  cmd->callback([a, exit_code] { *exit_code = RunCheck(*a, false).exit_code; });
}

}  // namespace skinspheres::tool
