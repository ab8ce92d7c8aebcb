// Private to the importer: pieces shared by the glTF reader (importer_gltf.cc) and the Assimp
// reader (importer_assimp.cc). Not installed; include only from lib/src/io/.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <filesystem>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "skinspheres/lib/io/importer.h"

namespace skinspheres::lib::detail {

// "<file>: <problem>" on one line (newlines in `problem` become spaces).
Error ImportError(ErrorCode code, const std::filesystem::path& file, const std::string& problem);

// The whole file; errors as ImportCharacter's (missing, not a regular file, larger than
// kMaxCharacterFileBytes, unreadable, empty): runtime::ReadRegularFile.
Result<std::vector<uint8_t>> ReadFileBytes(const std::filesystem::path& file);

struct Influence {
  uint32_t bind = 0;    // index into SkinnedMesh::binds
  float weight = 0.0f;  // as read; normalised by AppendVertex
};

// Index of the bind entry (joint, ibm) in skin.binds, adding it when no entry has the same joint
// and an exactly equal matrix. -1 when the uint16_t influence index space (65536) is exhausted.
int32_t FindOrAddBind(skinning::SkinnedMesh& skin, int32_t joint, const Mat4f& ibm);

// Appends one vertex to skin: merges repeated binds, drops zero weights, normalises the rest to
// sum 1. Returns a problem text (weights negative, non-finite or summing to zero) or nullopt.
std::optional<std::string> AppendVertex(skinning::SkinnedMesh& skin, const Eigen::Vector3f& p_bind,
                                        std::vector<Influence>& influences);

// Final pass shared by all readers: positions_rest = Σ w · (G · IBM) · p_bind from the skeleton's
// rest pose, then the checks every character must pass (a valid skeleton, finite rest
// positions, at least one triangle, indices in range).
std::optional<Error> FinishCharacter(RawCharacter& character, const std::filesystem::path& file);

// The readers. `bytes` is the whole file (already read and non-empty).
Result<RawCharacter> ImportGltf(const std::filesystem::path& file, std::span<const uint8_t> bytes,
                                const ImportOptions& options);
Result<RawCharacter> ImportWithAssimp(const std::filesystem::path& file, std::span<const uint8_t> bytes,
                                      const ImportOptions& options);

// True when the bytes look like glTF 2.0 (GLB magic, or JSON with asset.version "2.x").
bool LooksLikeGltf2(const std::filesystem::path& file, std::span<const uint8_t> bytes);

// The glTF reader's node tree and clips, for the animation-file reader (clip_import.cc).
// ReadGltfNodeTree: every node of the document as a skeleton, parents first (the default
// scene's roots first, then any other root), names as in the file ("node_<i>" when unnamed);
// node_of_joint[j] is joint j's glTF node index. ReadGltfClips: every animation, tracks on
// joint_of_node[node] (channels on nodes mapped to -1 dropped), STEP/LINEAR/CUBICSPLINE kept.
// Both return the problem (without the file name) or an empty string.
struct GltfDocument;
std::string ReadGltfNodeTree(const GltfDocument& doc, skinning::Skeleton* nodes, std::vector<int32_t>* node_of_joint);
std::string ReadGltfClips(const GltfDocument& doc, const std::vector<int32_t>& joint_of_node,
                          std::vector<skinning::AnimationClip>* clips);

}  // namespace skinspheres::lib::detail
