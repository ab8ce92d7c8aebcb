#include "clip_files.h"

#include <algorithm>
#include <cstdio>
#include <filesystem>

#include "skinspheres/lib/io/clip_import.h"
#include "skinspheres/lib/io/importer.h"
#include "skinspheres/skinning/sampling_job.h"

namespace skinspheres::tool {
namespace {

// A limb whose rest bone directions differ by more than this between the clip's rest pose and the
// character's is named in a warning: an A-pose against a T-pose differs by about 45 degrees, a
// wrong rest frame by up to 180 (119 seen on a Mixamo arm).
constexpr float kSuspectRestDegrees = 60.0f;

std::string Degrees(float d) {
  char text[32];
  std::snprintf(text, sizeof(text), "%.1f\u00b0", static_cast<double>(d));
  return text;
}

// The first few names of a list, then how many more.
std::string Some(const std::vector<std::string>& names, size_t shown = 6) {
  std::string s;
  for (size_t k = 0; k < std::min(shown, names.size()); ++k) s += (k ? ", " : "") + names[k];
  if (names.size() > shown) s += ", ... (+" + std::to_string(names.size() - shown) + ")";
  return s;
}

}  // namespace

std::vector<std::string> DescribeRetarget(const lib::RetargetReport& r, const LoadedCharacter& loaded,
                                          const std::string& file, const std::vector<std::string>& names) {
  std::vector<std::string> notes_out;
  std::vector<std::string>* notes = &notes_out;
  const lib::RawCharacter& ch = loaded.character;
  std::string line =
      "clips from " + file + ": " + Some(names, 12) + " (" + std::to_string(r.mapped.size()) + " joints matched";
  if (r.unmapped_joints > 0) {
    line += ", " + std::to_string(r.unmapped_joints) + " of " + std::to_string(ch.skeleton.size()) +
            " unmapped and kept at rest";
    if (!r.unmapped_deforming.empty()) line += " (" + Some(r.unmapped_deforming) + " move the mesh)";
  }
  if (!r.dropped_nodes.empty())
    line += ", " + std::to_string(r.dropped_nodes.size()) + " animated nodes not in the character";
  if (!r.transferred) {
    line += r.offsets_differ_at.empty() ? ", copied: the same rig" : ", copied as asked (--retarget copy)";
    if (!r.rescaled_joints.empty()) {
      line += ", translations rescaled on " + std::to_string(r.rescaled_joints.size()) + " joints (other units)";
    }
    notes->push_back(line + ")");
    return notes_out;
  }
  notes->push_back(line + ")");
  std::string how =
      "  retargeted in world space: " +
      (r.offsets_differ_at.empty() ? std::string("the same rig, transfer as asked")
                                   : "the rigs differ (bone offsets, first at " + r.offsets_differ_at + ")") +
      "; source rest pose: " + r.rest_from;
  char scale[64];
  std::snprintf(scale, sizeof(scale), "%.4g", static_cast<double>(r.hip_scale));
  if (!r.root_joint.empty()) how += "; root motion on " + r.root_joint + ", scaled " + scale + " (hip heights)";
  if (r.alignment_degrees > 0.05f) how += "; rest poses turned " + Degrees(r.alignment_degrees) + " apart";
  how += "; rest poses differ by up to " + Degrees(r.largest_rest_difference.degrees);
  if (r.rest_directions_matched) how += " (bones laid along the clip's rest directions: --rest-directions match)";
  if (!r.largest_rest_difference.joint.empty()) how += " (" + r.largest_rest_difference.joint + ")";
  if (!r.rest_differences.empty()) {
    how += ", by limb:";
    for (size_t k = 0; k < r.rest_differences.size(); ++k) {
      how += (k ? ", " : " ") + r.rest_differences[k].limb + " " + Degrees(r.rest_differences[k].degrees);
    }
  }
  notes->push_back(how);
  if (const lib::RestDifference* worst = r.rest_differences.empty() ? nullptr : &r.rest_differences.front();
      worst != nullptr && worst->degrees > kSuspectRestDegrees) {
    const bool from_frame = r.rest_from.rfind("frame ", 0) == 0;
    notes->push_back(
        "  warning: the clip's rest pose and the character's differ by " + Degrees(worst->degrees) + " on " +
        worst->limb + " (" + worst->joint + "), more than an A-pose and a T-pose do: " +
        (from_frame ? "that frame is likely not a rest pose; give --source-rest RIG (a skinned file of the clip's "
                      "rig) or the number of a frame where it stands at rest"
                    : "its rest pose is likely not the one it was animated from; give --source-rest RIG (a skinned "
                      "file of the clip's rig), FRAME (a frame where it stands at rest), nodes or identity"));
  }
  return notes_out;
}

namespace {

bool AllDigits(const std::string& s) {
  return !s.empty() && s.size() < 10 &&
         std::all_of(s.begin(), s.end(), [](unsigned char c) { return std::isdigit(c); });
}

}  // namespace

void ClipFileOptions::AddTo(CLI::App& app) {
  app.add_option("--clips", files,
                 "add the clips of animation files (glTF, GLB, FBX, BVH, ...), retargeted onto the character "
                 "(--clips A B or --clips A --clips B; the character's file comes first)")
      ->take_all();
  app.add_option("--joint-map", joint_map,
                 "JSON object {\"clip's joint\": \"character's joint\" or null, ...} for joints names do not match");
  app.add_option("--source-rest", source_rest,
                 "the clips' rest pose when their file has none: RIG (a skinned file of their rig), FRAME (a frame "
                 "number of the clip, at --fps), nodes (the file's node transforms) or identity");
  app.add_option("--retarget", retarget,
                 "auto (copy local rotations when the rigs are the same, else transfer in world space), copy, or "
                 "world")
      ->capture_default_str();
  app.add_option("--rest-directions", rest_directions,
                 "where the rigs' rest poses differ (A-pose against T-pose): keep the character's rest bone "
                 "directions (and the difference), or match the clip's")
      ->capture_default_str();
}

Result<ClipFileContext> ResolveClipFileOptions(const ClipFileOptions& o, float fps) {
  ClipFileContext context;
  if (o.retarget == "auto") {
    context.mode = lib::RetargetMode::kAuto;
  } else if (o.retarget == "copy") {
    context.mode = lib::RetargetMode::kCopy;
  } else if (o.retarget == "world") {
    context.mode = lib::RetargetMode::kWorld;
  } else {
    return MakeError(ErrorCode::kInvalidArgument, "--retarget must be auto, copy or world (got " + o.retarget + ")");
  }
  if (o.rest_directions != "keep" && o.rest_directions != "match") {
    return MakeError(ErrorCode::kInvalidArgument,
                     "--rest-directions must be keep or match (got " + o.rest_directions + ")");
  }
  context.match_rest_directions = o.rest_directions == "match";
  if (!o.joint_map.empty()) {
    auto map = lib::LoadJointMap(o.joint_map);
    if (!map.ok()) return map.error();
    context.joint_map = std::move(*map);
  }
  const std::string& rest = o.source_rest;
  if (rest.empty()) return context;
  if (rest == "nodes" || rest == "identity") {
    context.rest.kind = rest == "nodes" ? lib::SourceRest::Kind::kNodes : lib::SourceRest::Kind::kIdentity;
    context.rest.label = rest == "nodes" ? "the file's node transforms (--source-rest nodes)"
                                         : "identity rotations (--source-rest identity)";
  } else if (AllDigits(rest)) {
    context.rest.kind = lib::SourceRest::Kind::kTime;
    context.rest.time_s = static_cast<float>(std::stoul(rest)) / fps;
    context.rest.fps = fps;
    context.rest.label = "frame " + rest + " of each clip (--source-rest)";
  } else {
    auto rig = lib::ImportCharacter(rest);
    if (!rig.ok()) return MakeError(rig.error().code, "--source-rest: " + rig.error().message);
    context.rest_rig = std::make_shared<const lib::RawCharacter>(std::move(*rig));
    context.rest.kind = lib::SourceRest::Kind::kRig;
    context.rest.rig = context.rest_rig.get();
    context.rest.label = "the bind pose of " + rest + " (--source-rest)";
  }
  return context;
}

Result<std::vector<skinning::AnimationClip>> ReadClipFile(const LoadedCharacter& loaded, const std::string& file,
                                                          const ClipFileContext& context, lib::RetargetReport* report) {
  auto read = lib::ReadAnimationFile(file);
  if (!read.ok()) return read.error();
  lib::RetargetOptions options;
  options.mode = context.mode;
  options.joint_map = context.joint_map ? &*context.joint_map : nullptr;
  options.target_parts = &loaded.parts;
  options.source_rest = context.rest;
  options.match_rest_directions = context.match_rest_directions;
  std::optional<lib::RawCharacter> own;
  if (options.source_rest.kind == lib::SourceRest::Kind::kNone) {
    auto rig = lib::ReadFileRestRig(*read);
    if (!rig.ok()) return rig.error();
    own = std::move(*rig);
    if (own) options.source_rest = {lib::SourceRest::Kind::kRig, &*own, 0.0f, "the file's skin (bind pose)"};
  }
  auto clips = lib::RetargetClips(*read, loaded.character, options, report);
  if (!clips.ok()) return clips.error();
  for (const auto& clip : *clips) {
    std::string why;
    if (!skinning::ValidateClip(clip, loaded.character.skeleton, &why)) {
      return MakeError(ErrorCode::kInvalidData, file + ": clip \"" + clip.name + "\": " + why);
    }
  }
  return clips;
}

std::vector<std::string> AppendClips(LoadedCharacter& loaded, const std::string& file,
                                     std::vector<skinning::AnimationClip> clips) {
  auto& all = loaded.character.clips;
  auto taken = [&](const std::string& name) {
    return std::any_of(all.begin(), all.end(), [&](const auto& c) { return c.name == name; });
  };
  const std::string stem = std::filesystem::path(file).stem().string();
  std::vector<std::string> names;
  for (auto& clip : clips) {
    std::string name = clip.name;
    if (taken(name)) name = stem + "/" + clip.name;
    for (int k = 2; taken(name); ++k) name = stem + "/" + clip.name + "#" + std::to_string(k);
    clip.name = name;
    names.push_back(name);
    all.push_back(std::move(clip));
  }
  return names;
}

std::optional<Error> AddClipFiles(LoadedCharacter& loaded, const ClipFileOptions& options, float fps,
                                  std::vector<std::string>* notes) {
  // The options are checked with or without --clips: a mistyped --retarget is refused, never ignored.
  auto context = ResolveClipFileOptions(options, fps);
  if (!context.ok()) return context.error();
  if (options.files.empty()) return std::nullopt;
  for (const std::string& file : options.files) {
    lib::RetargetReport report;
    auto clips = ReadClipFile(loaded, file, *context, &report);
    if (!clips.ok()) return clips.error();
    const std::vector<std::string> names = AppendClips(loaded, file, std::move(*clips));
    const std::vector<std::string> lines = DescribeRetarget(report, loaded, file, names);
    notes->insert(notes->end(), lines.begin(), lines.end());
  }
  return std::nullopt;
}

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

}  // namespace skinspheres::tool
