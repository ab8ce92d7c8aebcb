// ImportCharacter: a skinned character file -> RawCharacter (rest pose, world space of the file).
//
// What comes out (see raw_character.h for the fields):
//  - one indexed triangle mesh, every mesh of the scene in the rest pose: a skinned vertex at
//    Σ_k w_k · G_j(k) · IBM_k · p_bind with G the node tree's own transforms (no clip applied),
//    a rigid mesh at its node's world transform. The file's units and axes are kept (glTF is
//    +Y up; nothing is rescaled). Where a file's rest pose is not its bind pose, this is still
//    the pose (positions_bind keeps the raw data, positions_rest the character as it stands).
//  - vertex and triangle indices count the file's own vertices and triangles: meshes in file
//    order (glTF: `meshes[]` order; a mesh instanced by several scene nodes is emitted once per
//    node, in node order; a mesh used by no scene node is not part of the character), primitives
//    in file order, one MeshRange per primitive. Nothing is welded, reordered or dropped,
//    degenerate triangles included. Triangle strips and fans become their n-2 triangles in
//    order; point and line primitives are not part of the surface and are skipped entirely
//    (their vertices are not stored, so later primitives' vertices shift down).
//  - per-vertex influences of any count (all JOINTS_n/WEIGHTS_n sets), zero weights dropped,
//    weights normalised to sum 1 (RobotExpressive's hands sum to 1.75 in the file).
//  - the skeleton: every scene node on a path from the scene root to a joint, parents first.
//    Joints are the skins' joints plus, in a skinned file, every rigid mesh's own node (so a
//    rigid part follows the joint it hangs under, and its own animation where it has one:
//    RobotExpressive's Head). A file without any skin is static: one identity joint "root",
//    every mesh rigid on it at its world position.
//  - bind entries: one per (skin, joint); entries with the same joint and an exactly equal IBM
//    are shared across skins; a rigid mesh adds (its node's joint, G_node(rest)^-1) and its
//    positions_bind are the world rest positions.
//  - clips with times in seconds. For .gltf/.glb the file is read by our own glTF 2.0 reader
//    (STEP/LINEAR/CUBICSPLINE kept; Assimp 5.2.5 does not expose the interpolation); other
//    formats go through Assimp (ticks / ticksPerSecond, linear).
//
// Errors: one Error whose message is one line "<file>: <problem>":
//   kFileNotFound (missing), kFileUnreadable (a directory, no permission, I/O failure),
//   kFormatRejected (empty, not a format the readers accept, truncated GLB, bad JSON, a
//   malformed mesh or skin accessor, its sparse block included (sparse accessors are read),
//   glTF features we do not read: Draco/meshopt compression, a node rotation of zero length),
//   kInvalidData (no triangles, NaN/Inf positions or matrices, skin weights summing to zero or
//   negative, joint index out of range (only where its weight is > 0), index out of range; in a
//   clip: a NaN/Inf key value, a rotation key of zero length, and through Assimp a negative or
//   non-finite duration or tick rate).
// Never throws; never crashes on malformed input; no recursion whose depth the file decides, and
// work on the node tree is linear in its size (in our glTF reader; Assimp's readers are Assimp's).
//
// Limits (docs/LIMITS.md): a file beyond one is refused (kFormatRejected, or kInvalidData for
// the counts), naming the limit, before the memory it would need is allocated where the size is
// known up front. Only regular files are read (a FIFO, device, socket or directory is refused
// without reading: kFileUnreadable).
#pragma once

#include <cstdint>
#include <filesystem>
#include <span>

#include "skinspheres/lib/character/raw_character.h"
#include "skinspheres/runtime/error.h"

namespace skinspheres::lib {

// The character file itself, and a .gltf's external buffer files together.
inline constexpr uint64_t kMaxCharacterFileBytes = uint64_t{1} << 30;       // 1 GiB
inline constexpr uint64_t kMaxGltfExternalBufferBytes = uint64_t{1} << 30;  // 1 GiB
// glTF JSON: nesting depth (runtime::kMaxJsonDepth, 128) and values (arrays, objects and the
// separators between values), which bound the parsed document's memory (~100 bytes a value).
inline constexpr uint64_t kMaxGltfJsonValues = uint64_t{1} << 23;  // 8,388,608
// One accessor: count x components values (a 100 MB buffer of bytes must not become 400 MB of floats
// without a check).
inline constexpr uint64_t kMaxAccessorValues = uint64_t{1} << 27;  // 134,217,728
// The character: vertices, triangles, skeleton joints (nodes on a path from a root to a joint),
// and animation keys over every clip and track.
inline constexpr uint64_t kMaxVertices = uint64_t{1} << 24;   // 16,777,216
inline constexpr uint64_t kMaxTriangles = uint64_t{1} << 25;  // 33,554,432
inline constexpr uint64_t kMaxJoints = 4096;
inline constexpr uint64_t kMaxAnimationKeys = uint64_t{1} << 24;  // 16,777,216

struct ImportOptions {
  bool read_clips = true;  // false: skip animations (faster, clips stays empty)
};

Result<RawCharacter> ImportCharacter(const std::filesystem::path& file, const ImportOptions& options = {});

// The same for a glTF 2.0 / GLB file already in memory (a pack file, a fuzzer): our glTF reader
// only (Assimp's readers open their own files). `name` names the file in messages, and external
// buffer uris are looked for beside it.
Result<RawCharacter> ImportGltfBytes(std::span<const uint8_t> bytes, const std::filesystem::path& name,
                                     const ImportOptions& options = {});

}  // namespace skinspheres::lib
