// Clips from other files: animators keep one character file and many animation-only files (a
// Mixamo "without skin" download reads as a node tree and one animation, no mesh). This reads
// such a file (or any file with animations, mesh or not) and re-expresses its clips on a
// character's skeleton, matching joints by name.
//
// Reading (ReadAnimationFile): .gltf/.glb through the project's glTF reader (STEP, LINEAR and
// CUBICSPLINE kept), every other format through Assimp (linear keys, ticks / ticksPerSecond; FBX
// pivot helper nodes folded into their bone, so channels land on the bones themselves). Meshes
// are counted, never read. Errors are one line "<file>: <problem>" (kFileNotFound,
// kFileUnreadable, kFormatRejected, kInvalidData), as ImportCharacter's.
//
// Retargeting onto a character is lib/retarget/retarget.h (RetargetClips): an AnimationFile is
// its SourceRig. ReadFileRestRig gives the file's own rest pose when it has one (a skin).
#pragma once

#include <filesystem>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "skinspheres/lib/character/raw_character.h"
#include "skinspheres/lib/retarget/retarget.h"
#include "skinspheres/runtime/error.h"
#include "skinspheres/skinning/animation_clip.h"
#include "skinspheres/skinning/skeleton.h"

namespace skinspheres::lib {

// The file's node tree and clips (SourceRig), and what else it holds.
struct AnimationFile : SourceRig {
  size_t mesh_count = 0;          // meshes in the file (not read)
  size_t skinned_mesh_count = 0;  // of which skinned
};

Result<AnimationFile> ReadAnimationFile(const std::filesystem::path& file);

// The file's own rest pose: the file read as a character (ImportCharacter: its skin's inverse
// bind matrices, FBX's bind pose through Assimp) when it holds a skinned mesh, for
// SourceRest::Kind::kRig; nullopt when it holds none. Errors are ImportCharacter's.
Result<std::optional<RawCharacter>> ReadFileRestRig(const AnimationFile& file);

// The character's skeleton and clips without its mesh: what an animation-only file holds
// (ExportGlb and ExportFbxAscii write it as nodes and animations alone).
RawCharacter WithoutMesh(RawCharacter character);

// One line for a file that reads as animation but holds no mesh to fit, e.g. "no skinned mesh
// (66 nodes, 1 animation, 0 meshes): an animation-only file; use it with play --clips", or an
// empty string when the file is not that (unreadable, or it has meshes).
std::string DescribeAnimationOnlyFile(const std::filesystem::path& file);

}  // namespace skinspheres::lib
