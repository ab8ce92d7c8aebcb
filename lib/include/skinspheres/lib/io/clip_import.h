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
// Matching (MatchClips): a file node and a character joint match when their names are equal, or
// else when their MatchKeys are (prefixes such as "mixamorig:", "mixamorig1:", "Armature|" and
// ASCII case ignored). A key shared by two character joints matches neither by key. Every
// joint that moves the character's vertices (a bind entry with weight, or a rigid mesh's joint)
// must have a counterpart in the file; otherwise the error (kNotFound) lists those joints. File
// nodes with tracks but no counterpart are dropped and listed in the report.
// The tracks are copied as local transforms: both files must be the same rig (same rest
// orientations; e.g. a Mixamo character and Mixamo animations). Units may differ: a translation
// track is scaled by |character rest translation| / |file rest translation| of its joint when the
// two differ by more than 0.1% (a rig exported in centimetres drives one in metres).
#pragma once

#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

#include "skinspheres/lib/character/raw_character.h"
#include "skinspheres/runtime/error.h"
#include "skinspheres/skinning/animation_clip.h"
#include "skinspheres/skinning/skeleton.h"

namespace skinspheres::lib {

struct AnimationFile {
  std::string source_file;                     // path as given, for messages
  skinning::Skeleton nodes;                    // every node of the file, parents first
  std::vector<skinning::AnimationClip> clips;  // tracks index `nodes`
  size_t mesh_count = 0;                       // meshes in the file (not read)
  size_t skinned_mesh_count = 0;               // of which skinned
};

Result<AnimationFile> ReadAnimationFile(const std::filesystem::path& file);

// The name as matched: the text after the last ':' or '|', then a leading "mixamorig" (with
// digits and '_' after it, Blender's spelling of "mixamorig:") removed, in ASCII lower case.
// "mixamorig:LeftHand", "Armature|mixamorig1:LeftHand", "mixamorig_LeftHand" -> "lefthand".
std::string MatchKey(std::string_view name);

struct ClipMatchReport {
  size_t matched_joints = 0;                 // character joints that found a file node
  std::vector<std::string> dropped_nodes;    // file nodes with tracks and no character joint
  std::vector<std::string> rescaled_joints;  // joints whose translation tracks were scaled
};

// The file's clips on `character`'s skeleton (see the contract above). Clip names are kept.
Result<std::vector<skinning::AnimationClip>> MatchClips(const AnimationFile& file, const RawCharacter& character,
                                                        ClipMatchReport* report = nullptr);

// The character's skeleton and clips without its mesh: what an animation-only file holds
// (ExportGlb and ExportFbxAscii write it as nodes and animations alone).
RawCharacter WithoutMesh(RawCharacter character);

// One line for a file that reads as animation but holds no mesh to fit, e.g. "no skinned mesh
// (66 nodes, 1 animation, 0 meshes): an animation-only file; use it with play --clips", or an
// empty string when the file is not that (unreadable, or it has meshes).
std::string DescribeAnimationOnlyFile(const std::filesystem::path& file);

}  // namespace skinspheres::lib
