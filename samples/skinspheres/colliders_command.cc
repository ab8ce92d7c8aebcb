#include <algorithm>
#include <cctype>
#include <chrono>
#include <cstdio>
#include <filesystem>

#include "colliders.h"
#include "html_page.h"
#include "playback.h"
#include "skinspheres/lib/retarget/bake_clip.h"
#include "skinspheres/runtime/error.h"
#include "skinspheres/runtime/format/file_io.h"
#include "skinspheres/skinning/local_to_model_job.h"
#include "skinspheres/skinning/sampling_job.h"

namespace skinspheres::tool {

namespace {

constexpr ColliderFormat kFormats[] = {
    {"vrm1", true, true, false, ".vrm/.glb"}, {"vrm0", true, false, false, ".vrm/.glb"},
    {"godot", true, true, false, ".tscn"},    {"unity", true, true, true, ".cs"},
    {"usd", true, true, true, ".usda"},       {"json", true, true, true, ".json"},
};

std::optional<std::string> Validate(const CollidersArgs& a, const ColliderFormat** format) {
  *format = FindColliderFormat(a.format);
  if (!*format) return "--format: '" + a.format + "' is not one of vrm1, vrm0, godot, unity, usd, json";
  if (a.budget < 1 || a.budget > 1024)
    return "--budget: must be between 1 and 1024 (got " + std::to_string(a.budget) + ")";
  if (a.shapes != "auto" && a.shapes != "spheres" && a.shapes != "capsules" && a.shapes != "both")
    return "--shapes: '" + a.shapes + "' is not one of spheres, capsules, both";
  if (!(*format)->capsules && (a.shapes == "capsules" || a.shapes == "both"))
    return "--shapes " + a.shapes + ": --format " + a.format + " holds spheres only";
  if (!(a.fps > 0.0f && a.fps <= 1000.0f)) return "--fps: must be in (0, 1000]";
  if (!(a.tolerance >= 0.0f && a.tolerance <= 0.5f)) return "--tolerance: must be a share of the height in [0, 0.5]";
  if (a.fit_poses < 1) return "--fit-poses: must be at least 1";
  if (!a.output.empty()) {
    std::string ext = std::filesystem::path(a.output).extension().string();
    for (char& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    const std::string allowed = (*format)->extension;
    bool ok = false;
    for (size_t at = 0; at < allowed.size();) {
      const size_t end = std::min(allowed.find('/', at), allowed.size());
      ok = ok || ext == allowed.substr(at, end - at);
      at = end + 1;
    }
    if (!ok) return a.output + ": -o: --format " + a.format + " writes a " + allowed + " file";
  }
  const std::pair<const char*, std::string> outputs[] = {{"-o", a.output}, {"--report", a.report}, {"--html", a.html}};
  return CheckOutputPaths(outputs, a.input, a.clip_files.files);
}

nlohmann::json Summary(const lib::ColliderCoverage& c) {
  const float h = c.height > 0.0f ? c.height : 1.0f;
  return {{"min_covered", c.min_covered},
          {"mean_covered", c.mean_covered},
          {"poke_p95_share", c.poke_p95 / h},
          {"mean_standoff_share", c.mean_standoff / h},
          {"max_standoff_share", c.max_standoff / h},
          {"mean_surface_gap_share", c.mean_surface_gap / h},
          {"max_surface_gap_share", c.max_surface_gap / h}};
}

std::string Pct(float share) {
  char b[32];
  std::snprintf(b, sizeof(b), "%.2f%%", 100.0 * share);
  return b;
}

std::string SummaryLine(const char* what, size_t count, const lib::ColliderCoverage& c) {
  const float h = c.height > 0.0f ? c.height : 1.0f;
  return std::string(what) + ": " + std::to_string(count) + " shapes, covered " + Pct(c.min_covered) +
         " (worst pose), " + Pct(c.mean_covered) + " (mean); body outside by " + Pct(c.poke_p95 / h) +
         " of height at p95; standoff " + Pct(c.mean_standoff / h) + " mean, " + Pct(c.max_standoff / h) +
         " worst pose; surface gap " + Pct(c.mean_surface_gap / h);
}

// The poses measured: the rest pose, then every frame of the chosen clips at fps.
Result<std::vector<std::vector<skinning::Transform>>> Poses(const lib::RawCharacter& ch,
                                                            const std::vector<size_t>& clips, float fps,
                                                            std::vector<std::string>* names) {
  std::vector<std::vector<skinning::Transform>> out{ch.skeleton.rest_local};
  for (size_t c : clips) {
    auto frames = lib::SampleFrames(ch.clips[c], ch.skeleton, fps);
    if (!frames.ok())
      return MakeError(frames.error().code, ch.Name() + ": clip '" + ch.clips[c].name + "': " + frames.error().message);
    if (out.size() + frames->size() > 200000)
      return MakeError(ErrorCode::kInvalidArgument, ch.Name() + ": more than 200000 frames: lower --fps");
    for (auto& f : *frames) out.push_back(std::move(f));
    names->push_back(ch.clips[c].name);
  }
  return out;
}

nlohmann::json ShapesJson(const CollidersOutcome& o, const lib::ColliderCoverage& cov) {
  nlohmann::json shapes = nlohmann::json::array();
  const float h = cov.height > 0.0f ? cov.height : 1.0f;
  for (size_t s = 0; s < o.colliders.size(); ++s) {
    const auto& c = o.colliders[s];
    shapes.push_back({{"joint", o.joint_names[c.joint]},
                      {"part", c.part},
                      {"type", c.is_sphere() ? "sphere" : "capsule"},
                      {"radius_share", c.head_radius / h},
                      {"tail_radius_share", c.tail_radius / h},
                      {"covered", cov.shapes[s].covered},
                      {"poke_p95_share", cov.shapes[s].poke_p95 / h},
                      {"standoff_share", cov.shapes[s].standoff / h},
                      {"surface_gap_share", cov.shapes[s].surface_gap / h}});
  }
  return shapes;
}

lib::ColliderSettings SettingsFor(const CollidersArgs& a, const ColliderFormat& format, const std::string& shapes) {
  lib::ColliderSettings settings;
  settings.budget = a.budget;
  settings.tolerance_share = a.tolerance;
  settings.max_fit_poses = a.fit_poses;
  settings.tapered = format.tapered;
  settings.shapes = shapes == "spheres"    ? lib::ColliderShapes::kSpheres
                    : shapes == "capsules" ? lib::ColliderShapes::kCapsules
                                           : lib::ColliderShapes::kBoth;
  return settings;
}

// Per joint, its body part's name ("other" for a joint in none).
std::vector<std::string> JointParts(const LoadedCharacter& loaded) {
  std::vector<std::string> out(loaded.character.skeleton.size());
  for (size_t j = 0; j < out.size(); ++j) {
    const int32_t p = loaded.parts.joint_part.size() > j ? loaded.parts.joint_part[j] : -1;
    out[j] = p >= 0 ? loaded.parts.parts[static_cast<size_t>(p)].name : "other";
  }
  return out;
}

// The shapes' heads and tails in world space (6 floats each) at one local pose.
std::vector<float> PlacedShapes(const lib::RawCharacter& ch, std::span<const skinning::Transform> local,
                                const std::vector<lib::Collider>& colliders) {
  std::vector<Mat4f> world(ch.skeleton.size());
  skinning::LocalToModelJob l2m;
  l2m.skeleton = &ch.skeleton;
  l2m.input = local;
  l2m.output = world;
  l2m.Run();
  std::vector<float> out;
  for (const auto& c : colliders) {
    const lib::PlacedCollider p = lib::PlaceCollider(c, world[c.joint]);
    out.insert(out.end(), {p.head.x(), p.head.y(), p.head.z(), p.tail.x(), p.tail.y(), p.tail.z()});
  }
  return out;
}

// --html: the viewer page playing the chosen clips (a sphere set fitted for it) with the colliders
// drawn on the moving character, placed at each frame's clip time.
std::optional<Error> WriteColliderPage(const LoadedCharacter& loaded, const std::vector<size_t>& clips,
                                       const CollidersOutcome& o, const lib::ColliderCoverage& coverage,
                                       const CollidersArgs& a) {
  double fit_seconds = -1.0;
  auto set = SphereSetFor(loaded, "", lib::FitSettings{}, &fit_seconds);
  if (!set.ok()) return set.error();
  const lib::RawCharacter& ch = loaded.character;
  nlohmann::json shapes = nlohmann::json::array();
  for (size_t s = 0; s < o.colliders.size(); ++s) {
    const auto& c = o.colliders[s];
    shapes.push_back({{"joint", o.joint_names[c.joint]},
                      {"part", c.part},
                      {"head_radius", c.head_radius},
                      {"tail_radius", c.tail_radius},
                      {"length", (c.tail - c.head).norm()},
                      {"covered", coverage.shapes[s].covered},
                      {"standoff", coverage.shapes[s].standoff}});
  }
  std::vector<PlayResult> played(clips.size());
  std::vector<std::vector<FrameRecord>> frames(clips.size());
  PlayOptions options;
  options.fps = a.fps;
  ViewerPageInput page{&loaded, &*set, fit_seconds, {}, {"colliders by skinspheres colliders"}, nullptr};
  nlohmann::json per_clip = nlohmann::json::array();
  std::vector<skinning::Transform> local(ch.skeleton.size());
  for (size_t k = 0; k < clips.size(); ++k) {
    auto result = PlayClip(loaded, *set, clips[k], options, RecordFrames(&frames[k]));
    if (!result.ok()) return result.error();
    played[k] = std::move(*result);
    page.clips.push_back(ViewClip{&played[k], &frames[k], clips[k], a.fps, false});
    nlohmann::json at = nlohmann::json::array();
    for (const FrameRecord& f : frames[k]) {
      skinning::SamplingJob sample{&ch.clips[clips[k]], &ch.skeleton, f.clip_time_s, local};
      sample.Run();
      at.push_back(PlacedShapes(ch, local, o.colliders));
    }
    per_clip.push_back(std::move(at));
  }
  page.colliders = {{"shapes", std::move(shapes)},
                    {"rest", PlacedShapes(ch, ch.skeleton.rest_local, o.colliders)},
                    {"clips", std::move(per_clip)}};
  return WriteViewerPage(page, a.html);
}

}  // namespace

const ColliderFormat* FindColliderFormat(const std::string& name) {
  for (const auto& f : kFormats) {
    if (name == f.name) return &f;
  }
  return nullptr;
}

CollidersOutcome RunColliders(CollidersArgs& a, bool quiet) {
  CollidersOutcome out;
  auto say = [quiet](const std::string& line) {
    if (!quiet) std::printf("%s\n", line.c_str()), std::fflush(stdout);
  };
  auto fail = [&](const std::string& message, ErrorCode code = ErrorCode::kInvalidArgument) {
    out.report = nullptr;
    out.error = runtime::OneLine(message);
    out.error_code = code;
    out.exit_code = quiet ? kExitBadInput : Fail(message);
    return out;
  };
  const ColliderFormat* format = nullptr;
  if (auto why = Validate(a, &format)) return fail(*why);
  const auto start = std::chrono::steady_clock::now();
  auto loaded = LoadCharacter(a.input, a.parts_file);
  if (!loaded.ok()) return fail(loaded.error().message, loaded.error().code);
  lib::RawCharacter& ch = loaded->character;
  if (ch.triangle_count() == 0) return fail(ch.Name() + ": no mesh: nothing to cover");
  if (ch.skin.vertex_count() != ch.vertex_count())
    return fail(ch.Name() + ": no skin: colliders attach to the joints that move the mesh, and nothing moves it");
  const size_t own = ch.clips.size();
  std::vector<std::string> notes;
  if (auto why = AddClipFiles(*loaded, a.clip_files, a.fps, &notes)) return fail(why->message, why->code);
  for (const std::string& note : notes) say(note);
  std::vector<size_t> chosen;
  if (ch.clips.size() > (a.clip_files.files.empty() ? 0 : own)) {
    auto picked = SelectClips(ch, a.clip_files.files.empty() ? 0 : own, a.clip);
    if (!picked.ok()) return fail(ch.Name() + ": " + picked.error().message, picked.error().code);
    chosen = std::move(*picked);
  }
  std::vector<std::string> clip_names;
  auto poses = Poses(ch, chosen, a.fps, &clip_names);
  if (!poses.ok()) return fail(poses.error().message, poses.error().code);

  const std::string shapes = a.shapes == "auto" ? (format->capsules ? "both" : "spheres") : a.shapes;
  const lib::ColliderSettings settings = SettingsFor(a, *format, shapes);
  const std::vector<std::string> joint_part = JointParts(*loaded);
  // Fitted on the rest pose and frames of the clips; measured on every frame.
  auto fit = lib::FitColliders(ch, std::span(*poses).subspan(1), joint_part, settings);
  if (!fit.ok()) return fail(ch.Name() + ": " + fit.error().message, fit.error().code);
  auto coverage = lib::EvaluateColliders(ch, *poses, fit->colliders, a.tolerance);
  if (!coverage.ok()) return fail(ch.Name() + ": " + coverage.error().message, coverage.error().code);
  out.colliders = fit->colliders;
  out.joint_names = ch.skeleton.joint_names;
  out.joint_rest_world.resize(ch.skeleton.size());
  ch.skeleton.RestWorld(out.joint_rest_world);

  nlohmann::json report = {
      {"format", "skinspheres.colliders"},
      {"version", 1},
      {"character", ch.Name()},
      {"height", coverage->height},
      {"budget", a.budget},
      {"shapes", shapes},
      {"written_as", a.format},
      {"tolerance_share", a.tolerance},
      {"poses", {{"fitted", fit->fit_poses}, {"measured", poses->size()}, {"fps", a.fps}, {"clips", clip_names}}},
      {"summary", Summary(*coverage)},
      {"colliders", ShapesJson(out, *coverage)}};
  say(SummaryLine("colliders", out.colliders.size(), *coverage) + " (" + std::to_string(poses->size()) + " poses)");
  if (a.compare) {
    nlohmann::json baseline;
    for (bool covering : {true, false}) {
      const auto bones = lib::PerBoneCapsules(ch, static_cast<int>(out.colliders.size()), covering);
      auto cov = lib::EvaluateColliders(ch, *poses, bones, a.tolerance);
      if (!cov.ok()) return fail(ch.Name() + ": " + cov.error().message, cov.error().code);
      baseline[covering ? "per_bone_covering" : "per_bone_median"] = Summary(*cov);
      baseline[covering ? "per_bone_covering" : "per_bone_median"]["count"] = bones.size();
      say(SummaryLine(covering ? "per-bone capsules (covering)" : "per-bone capsules (median)", bones.size(), *cov));
    }
    report["baseline"] = std::move(baseline);
  }
  report["seconds"] = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  out.report = report;
  if (!a.output.empty()) {
    ColliderOutput o{&ch, out.colliders, out.joint_rest_world, out.report};
    if (auto err = WriteColliders(a.format, o, a.output)) return fail(*err, ErrorCode::kFileUnreadable);
    say("wrote " + a.output + " (" + a.format + ")");
  }
  if (!a.report.empty()) {
    const std::string text = out.report.dump(1, ' ', false, nlohmann::json::error_handler_t::replace) + "\n";
    if (auto err = runtime::WriteWholeFile(a.report, text)) return fail(err->message, err->code);
    say("wrote " + a.report);
  }
  if (!a.html.empty()) {
    if (auto err = WriteColliderPage(*loaded, chosen, out, *coverage, a)) return fail(err->message, err->code);
    say("wrote " + a.html);
  }
  return out;
}

void AddCollidersCommand(CLI::App& app, int* exit_code) {
  auto a = std::make_shared<CollidersArgs>();
  CLI::App* cmd = app.add_subcommand(
      "colliders",
      "fit a few spheres and capsules on joints that cover the body over its clips, for cloth and spring bones, "
      "and write them for an engine (exit 0 written, 2 bad input)");
  cmd->add_option("input", a->input, "character file")->required();
  cmd->add_option("-o,--output", a->output, "output file (see --format)")->required();
  cmd->add_option("--format", a->format,
                  "vrm1 | vrm0 (glTF with VRM spring-bone colliders), godot (.tscn), unity (.cs), usd (.usda), json")
      ->capture_default_str();
  cmd->add_option("--budget", a->budget, "the most shapes written")->capture_default_str();
  cmd->add_option("--shapes", a->shapes,
                  "spheres | capsules | both (auto: both, or spheres where the format has no capsule)")
      ->capture_default_str();
  a->clip_files.AddTo(*cmd);
  cmd->add_option("--clip", a->clip, "which clips give the poses: all, a name, or an index among them")
      ->capture_default_str();
  cmd->add_option("--fps", a->fps, "frames per second at which the clips are measured")->capture_default_str();
  cmd->add_option("--tolerance", a->tolerance, "a vertex is covered inside or within this share of the body height")
      ->capture_default_str();
  cmd->add_option("--fit-poses", a->fit_poses, "at most this many poses (evenly chosen) shape the fit")
      ->capture_default_str();
  cmd->add_option("--report", a->report, "write a JSON report: per shape its joint and coverage, and the totals");
  cmd->add_option("--html", a->html, "write the viewer page: the clips played with the colliders on the character");
  cmd->add_flag("--compare", a->compare, "also measure per-bone capsules at the same count (the usual generator)");
  cmd->add_option("--parts", a->parts_file, "joint -> body part overrides (JSON)");
  cmd->callback([a, exit_code] { *exit_code = RunColliders(*a, false).exit_code; });
}

}  // namespace skinspheres::tool
