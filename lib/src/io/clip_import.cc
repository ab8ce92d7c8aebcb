// Clips from animation files (clip_import.h): the glTF reader's node tree and clips
// (importer_gltf.cc), or Assimp's scene with FBX pivots folded; the file's own rest pose.
#include "skinspheres/lib/io/clip_import.h"

#include <assimp/config.h>
#include <assimp/postprocess.h>
#include <assimp/scene.h>

#include <algorithm>
#include <assimp/Importer.hpp>
#include <cctype>
#include <cmath>
#include <map>
#include <new>
#include <set>

#include "assimp_nodes.h"
#include "gltf_document.h"
#include "importer_internal.h"

namespace skinspheres::lib {
namespace {

using detail::ImportError;

Result<AnimationFile> ReadGltfAnimations(const std::filesystem::path& file, std::span<const uint8_t> bytes) {
  auto doc = detail::LoadGltf(file, bytes);
  if (!doc.ok()) return doc.error();
  AnimationFile out;
  std::vector<int32_t> node_of_joint;
  if (std::string p = detail::ReadGltfNodeTree(*doc, &out.nodes, &node_of_joint); !p.empty()) {
    return ImportError(ErrorCode::kFormatRejected, file, p);
  }
  std::vector<int32_t> joint_of_node(node_of_joint.size(), -1);
  for (size_t j = 0; j < node_of_joint.size(); ++j)
    joint_of_node[static_cast<size_t>(node_of_joint[j])] = static_cast<int32_t>(j);
  if (std::string p = detail::ReadGltfClips(*doc, joint_of_node, &out.clips); !p.empty()) {
    return ImportError(ErrorCode::kInvalidData, file, p);
  }
  const auto& json = doc->json;
  if (json.contains("meshes") && json["meshes"].is_array()) out.mesh_count = json["meshes"].size();
  if (json.contains("nodes") && json["nodes"].is_array()) {
    for (const auto& n : json["nodes"])
      out.skinned_mesh_count += (n.is_object() && n.contains("mesh") && n.contains("skin")) ? 1 : 0;
  }
  return out;
}

Result<AnimationFile> ReadAssimpAnimations(const std::filesystem::path& file) {
  Assimp::Importer importer;
  // FBX: no "<bone>_$AssimpFbx$_Rotation" helper nodes; channels land on the bones themselves.
  importer.SetPropertyBool(AI_CONFIG_IMPORT_FBX_PRESERVE_PIVOTS, false);
  const aiScene* scene = importer.ReadFile(file.string(), aiProcess_ValidateDataStructure);
  // A scene without meshes is flagged incomplete; that is what an animation file is.
  if (scene == nullptr || scene->mRootNode == nullptr) {
    std::string why = importer.GetErrorString();
    return ImportError(ErrorCode::kFormatRejected, file,
                       "rejected by Assimp: " + (why.empty() ? std::string("no scene") : why));
  }
  auto tree = detail::ReadAssimpNodeTree(*scene, file);
  if (!tree.ok()) return tree.error();
  AnimationFile out;
  for (size_t i = 0; i < tree->nodes.size(); ++i) {
    const aiNode* n = tree->nodes[i];
    out.nodes.joint_names.emplace_back(n->mName.length > 0 ? n->mName.C_Str() : "node_" + std::to_string(i));
    out.nodes.parents.push_back(tree->parent[i]);
    out.nodes.rest_local.push_back(tree->local[i]);
  }
  out.mesh_count = scene->mNumMeshes;
  for (unsigned m = 0; m < scene->mNumMeshes; ++m) out.skinned_mesh_count += scene->mMeshes[m]->HasBones() ? 1 : 0;
  for (unsigned a = 0; a < scene->mNumAnimations; ++a) {
    const aiAnimation* anim = scene->mAnimations[a];
    if (anim->mNumChannels == 0) continue;  // morph or camera animation only (assimp_nodes.h)
    auto header = detail::ReadClipHeader(*anim, a, file);
    if (!header.ok()) return header.error();
    skinning::AnimationClip clip = header->clip;
    std::map<int32_t, size_t> track_of_node;
    for (unsigned ch = 0; ch < anim->mNumChannels; ++ch) {
      const aiNodeAnim* na = anim->mChannels[ch];
      const int32_t node = tree->Find(na->mNodeName);
      if (node < 0) continue;  // a channel on no node moves nothing
      auto [slot, fresh] = track_of_node.emplace(node, clip.tracks.size());
      if (fresh) {
        clip.tracks.emplace_back();
        clip.tracks.back().joint = node;
      }
      if (auto bad = detail::AppendChannelKeys(*na, *header, file, &clip.tracks[slot->second])) return *bad;
    }
    std::sort(clip.tracks.begin(), clip.tracks.end(),
              [](const skinning::JointTrack& x, const skinning::JointTrack& y) { return x.joint < y.joint; });
    out.clips.push_back(std::move(clip));
  }
  return out;
}

}  // namespace

Result<AnimationFile> ReadAnimationFile(const std::filesystem::path& file) {
  auto bytes = detail::ReadFileBytes(file);
  if (!bytes.ok()) return bytes.error();
  try {
    auto read = detail::LooksLikeGltf2(file, *bytes) ? ReadGltfAnimations(file, *bytes) : ReadAssimpAnimations(file);
    if (!read.ok()) return read;
    read->source_file = file.string();
    if (read->nodes.size() == 0 || !read->nodes.Validate()) {
      return ImportError(ErrorCode::kInvalidData, file, "the node tree is empty or not ordered parents-first");
    }
    return read;
  } catch (const detail::NotAnInteger& e) {
    return ImportError(ErrorCode::kFormatRejected, file, std::string("malformed glTF JSON: ") + e.what());
  } catch (const std::bad_alloc&) {
    return ImportError(ErrorCode::kFormatRejected, file, "implausible sizes (out of memory while reading)");
  } catch (const std::exception& e) {
    return ImportError(ErrorCode::kFormatRejected, file, std::string("cannot be read: ") + e.what());
  }
}

Result<std::optional<RawCharacter>> ReadFileRestRig(const AnimationFile& file) {
  if (file.skinned_mesh_count == 0) return std::optional<RawCharacter>();
  auto rig = ImportCharacter(file.source_file);
  if (!rig.ok()) return rig.error();
  return std::optional<RawCharacter>(std::move(*rig));
}

RawCharacter WithoutMesh(RawCharacter c) {
  c.skin = {};
  c.skin.influence_offsets = {0};
  c.positions_rest.clear();
  c.triangles.clear();
  c.meshes.clear();
  return c;
}

std::string DescribeAnimationOnlyFile(const std::filesystem::path& file) {
  const auto read = ReadAnimationFile(file);
  if (!read.ok() || read->mesh_count > 0) return {};
  const size_t n = read->nodes.size(), a = read->clips.size();
  std::string s = "no skinned mesh (" + std::to_string(n) + (n == 1 ? " node, " : " nodes, ") + std::to_string(a) +
                  (a == 1 ? " animation" : " animations") + ", 0 meshes)";
  return s + (a > 0 ? ": an animation-only file; use it with play --clips" : ": nothing to fit");
}

}  // namespace skinspheres::lib
