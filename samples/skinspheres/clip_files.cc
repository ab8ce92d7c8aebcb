#include "clip_files.h"

#include <algorithm>
#include <filesystem>

#include "skinspheres/lib/io/clip_import.h"
#include "skinspheres/skinning/sampling_job.h"

namespace skinspheres::tool {

std::optional<std::string> AddClipFiles(LoadedCharacter& loaded, const std::vector<std::string>& files,
                                        std::vector<std::string>* notes) {
  auto& clips = loaded.character.clips;
  auto taken = [&](const std::string& name) {
    return std::any_of(clips.begin(), clips.end(), [&](const auto& c) { return c.name == name; });
  };
  for (const std::string& file : files) {
    auto read = lib::ReadAnimationFile(file);
    if (!read.ok()) return read.error().message;
    lib::ClipMatchReport report;
    auto matched = lib::MatchClips(*read, loaded.character, &report);
    if (!matched.ok()) return matched.error().message;
    const std::string stem = std::filesystem::path(file).stem().string();
    std::string names;
    for (auto& clip : *matched) {
      std::string why;
      if (!skinning::ValidateClip(clip, loaded.character.skeleton, &why)) return file + ": clip \"" + clip.name + "\": " + why;
      std::string name = clip.name;
      if (taken(name)) name = stem + "/" + clip.name;
      for (int k = 2; taken(name); ++k) name = stem + "/" + clip.name + "#" + std::to_string(k);
      clip.name = name;
      names += (names.empty() ? "" : ", ") + name;
      clips.push_back(std::move(clip));
    }
    std::string note = "clips from " + file + ": " + names + " (" + std::to_string(report.matched_joints) + " joints matched";
    if (!report.dropped_nodes.empty()) note += ", " + std::to_string(report.dropped_nodes.size()) + " animated nodes not in the character";
    if (!report.rescaled_joints.empty()) {
      note += ", translations rescaled on " + std::to_string(report.rescaled_joints.size()) + " joints (other units)";
    }
    notes->push_back(note + ")");
  }
  return std::nullopt;
}

}  // namespace skinspheres::tool
