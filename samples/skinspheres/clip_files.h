// `play --clips FILE` (repeatable): clips from animation files (glTF, GLB or any format Assimp
// reads), matched to the character's joints by name (lib/clip_import.h), appended to its clips.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "commands.h"

namespace skinspheres::tool {

// Appends every clip of every file to loaded->character.clips, in order. A clip whose name is
// already taken is renamed "<file stem>/<name>" (then "<file stem>/<name>#2", ...). One line per
// file goes to `notes` (what was added, joints matched, animated nodes dropped, tracks rescaled).
// Returns the first error as one line naming the file and the problem.
std::optional<std::string> AddClipFiles(LoadedCharacter& loaded, const std::vector<std::string>& files,
                                        std::vector<std::string>* notes);

}  // namespace skinspheres::tool
