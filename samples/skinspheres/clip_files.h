// Clips from other files (`play --clips FILE...`, `check --clips FILE...`): animation files (glTF,
// GLB or any format Assimp reads) retargeted onto the character (lib/retarget/retarget.h) and
// appended to its clips, with the options that steer the retarget.
#pragma once

#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "commands.h"
#include "skinspheres/lib/retarget/retarget.h"

namespace skinspheres::tool {

// --clips, --joint-map, --source-rest, --retarget.
struct ClipFileOptions {
  std::vector<std::string> files;
  std::string joint_map;
  std::string source_rest;  // RIG (a file), FRAME (a number), "nodes" or "identity"
  std::string retarget = "auto";
  std::string rest_directions = "keep";
  void AddTo(CLI::App& app);
};

// The options resolved once for a run: the map read, the rest rig imported, the mode parsed.
struct ClipFileContext {
  std::optional<lib::JointMap> joint_map;
  std::shared_ptr<const lib::RawCharacter> rest_rig;  // --source-rest RIG
  lib::SourceRest rest;                               // from --source-rest (kNone: the file's own, if any)
  lib::RetargetMode mode = lib::RetargetMode::kAuto;
  bool match_rest_directions = false;
};
// An error message (one line, naming the file or the option) when an option is refused.
Result<ClipFileContext> ResolveClipFileOptions(const ClipFileOptions& options, float fps);

// One file's clips on loaded.character (names as in the file, each checked with ValidateClip),
// and what was done to them.
Result<std::vector<skinning::AnimationClip>> ReadClipFile(const LoadedCharacter& loaded, const std::string& file,
                                                          const ClipFileContext& context, lib::RetargetReport* report);

// What was done to one file's clips (`names` as added), in one or two lines: joints mapped and
// unmapped, copied or retargeted, the rest pose used, the rest-pose differences by limb.
std::vector<std::string> DescribeRetarget(const lib::RetargetReport& report, const LoadedCharacter& loaded,
                                          const std::string& file, const std::vector<std::string>& names);

// Appends the clips of `clips` to loaded->character.clips. A clip whose name is already taken is
// renamed "<file stem>/<name>" (then "<file stem>/<name>#2", ...). Returns the names given.
std::vector<std::string> AppendClips(LoadedCharacter& loaded, const std::string& file,
                                     std::vector<skinning::AnimationClip> clips);

// Every file's clips, in order (ReadClipFile, then AppendClips); the first error, its message one
// line naming the file and the problem (its code: a missing file, a bad option, bad data). The
// options are resolved (ResolveClipFileOptions) even when there are no files.
std::optional<Error> AddClipFiles(LoadedCharacter& loaded, const ClipFileOptions& options, float fps,
                                  std::vector<std::string>* notes);

// The clips from index `first` on that `clip` names: all of them, or those whose name is `clip` or
// ends in "/clip" (as AppendClips renames a file's clips), or else the one at that index among
// them. Error kNotFound listing the names when none is.
Result<std::vector<size_t>> SelectClips(const lib::RawCharacter& ch, size_t first, const std::string& clip);

}  // namespace skinspheres::tool
