// Private to the glTF reader: the stages ImportGltf (importer_gltf.cc) runs, one file each.
//   importer_gltf_nodes.cc       the node tree (TRS/matrix, parents, cycles) and its preorder
//   importer_gltf_skins.cc       the scene, its mesh instances, the skeleton and the skins' binds
//   importer_gltf_meshes.cc      the geometry: primitives, influences, triangles
//   importer_gltf_animations.cc  the animations: samplers into clips
// Not installed; include only from lib/src/io/.
#pragma once

#include <cstdint>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "gltf_document.h"
#include "importer_internal.h"

namespace skinspheres::lib::detail {

struct GltfNode {
  std::string name;
  int32_t parent = -1;
  std::vector<int32_t> children;
  skinning::Transform local;
  int64_t mesh = -1;
  int64_t skin = -1;
  bool has_matrix = false;
};

struct GltfMeshInstance {
  int64_t mesh;
  int32_t node;
};

// The file being read and its errors: "<file>: <problem>" with the code ImportGltf reports.
struct GltfReadContext {
  const GltfDocument& doc;
  const std::filesystem::path& file;
  Error Invalid(const std::string& problem) const { return ImportError(ErrorCode::kInvalidData, file, problem); }
  Error Rejected(const std::string& problem) const { return ImportError(ErrorCode::kFormatRejected, file, problem); }
};

// --- The node tree (importer_gltf_nodes.cc) ---

// A node rotation or rotation key that float arithmetic can normalise (the sampler and the skeleton
// normalise in float): unchanged when its float squared norm lies within [1e-30, 1e30] (every file
// written with unit quaternions, to the bit), else normalised in double, whose range holds the
// square of every finite float (a float squared norm over/underflows past ~1.8e19 and below ~1e-19
// per component, and normalized() then gives zeros or no rotation at all); nullopt when its length
// is zero.
std::optional<Quatf> UsableRotation(const Quatf& q);
// j[key] when it is an array, else an empty array.
const nlohmann::json& ArrayOrEmpty(const nlohmann::json& j, const char* key);
// "node <n>", with " '<name>'" when the node has a name.
std::string NodeLabel(const std::vector<GltfNode>& nodes, int32_t n);
// Every node of `j`, checked (one of matrix or TRS, finite, a tree without cycles). Returns the
// problem, empty on success.
std::string ReadNodes(const nlohmann::json& j, std::vector<GltfNode>* nodes);
// Preorder over the node forest: the scene's roots first (in scene order), then every other
// root in index order, so parents always come before children.
std::vector<int32_t> PreorderNodes(const std::vector<GltfNode>& nodes, const std::vector<int32_t>& scene_roots);

// --- The scene, the skeleton and the skins (importer_gltf_skins.cc) ---

// What the geometry needs of the scene: its mesh instances (mesh order, then node order), the
// node -> joint map, the rest world transforms, and the bind entries of each used skin
// (skin_bind[s][k] for skin s's k-th joint).
struct GltfScene {
  std::vector<GltfNode> nodes;
  std::vector<int32_t> preorder;
  std::vector<GltfMeshInstance> instances;
  bool skinned_file = false;  // some instance is skinned: every rigid mesh's node becomes a joint
  std::vector<int32_t> joint_of_node;
  std::vector<Mat4f> joint_world;  // rest, per joint
  std::vector<Mat4f> node_world;   // rest, per node (rigid meshes of a static file)
  std::vector<std::vector<int32_t>> skin_bind;
};

// The scene's instances, the skeleton into c->skeleton and the skins' binds into c->skin: the
// node tree must be in scene->nodes. A skinned file's skeleton is the skin joints, every rigid
// mesh's own node and all their ancestors, in preorder; a static file has one identity joint.
std::optional<Error> ReadSceneAndSkeleton(const GltfReadContext& ctx, GltfScene* scene, RawCharacter* c);

// --- The geometry (importer_gltf_meshes.cc) ---

// Every primitive of every mesh instance, in order, appended to c (vertices, influences,
// triangles, one MeshRange each); points and lines are skipped.
std::optional<Error> ReadMeshes(const GltfReadContext& ctx, const GltfScene& scene, RawCharacter* c);

// --- The animations (importer_gltf_animations.cc) ---

// Every animation of the document as a clip, tracks on joint_of_node[node]. Returns the problem,
// empty on success.
std::string ReadClips(const GltfDocument& doc, const std::vector<GltfNode>& nodes,
                      const std::vector<int32_t>& joint_of_node, std::vector<skinning::AnimationClip>* clips);

}  // namespace skinspheres::lib::detail
