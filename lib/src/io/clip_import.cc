// Clips from animation files (clip_import.h): the glTF reader's node tree and clips
// (importer_gltf.cc), or Assimp's scene with FBX pivots folded; then name matching onto a
// character's skeleton.
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

// The character joints that move vertices: bind entries with a weight, rigid meshes' joints.
std::vector<char> DeformingJoints(const RawCharacter& c) {
  std::vector<char> deforming(c.skeleton.size(), 0);
  for (size_t k = 0; k < c.skin.influence_binds.size(); ++k) {
    if (c.skin.influence_weights[k] <= 0.0f || c.skin.influence_binds[k] >= c.skin.binds.size()) continue;
    const int32_t j = c.skin.binds[c.skin.influence_binds[k]].joint;
    if (j >= 0 && static_cast<size_t>(j) < deforming.size()) deforming[static_cast<size_t>(j)] = 1;
  }
  for (const auto& m : c.meshes) {
    if (!m.skinned && m.rigid_joint >= 0 && static_cast<size_t>(m.rigid_joint) < deforming.size()) {
      deforming[static_cast<size_t>(m.rigid_joint)] = 1;
    }
  }
  return deforming;
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

std::string MatchKey(std::string_view name) {
  const size_t cut = name.find_last_of(":|");
  if (cut != std::string_view::npos) name.remove_prefix(cut + 1);
  std::string key(name);
  std::transform(key.begin(), key.end(), key.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  constexpr std::string_view kMixamo = "mixamorig";
  if (key.size() > kMixamo.size() && key.compare(0, kMixamo.size(), kMixamo) == 0) {
    size_t k = kMixamo.size();
    while (k < key.size() && std::isdigit(static_cast<unsigned char>(key[k]))) ++k;
    if (k < key.size() && key[k] == '_') ++k;
    if (k < key.size()) key.erase(0, k);
  }
  return key;
}

Result<std::vector<skinning::AnimationClip>> MatchClips(const AnimationFile& file, const RawCharacter& character,
                                                        ClipMatchReport* report) {
  const skinning::Skeleton& target = character.skeleton;
  const skinning::Skeleton& source = file.nodes;
  const std::string who = character.source_file.empty() ? "the built-in character" : character.source_file;
  if (file.clips.empty()) return MakeError(ErrorCode::kNotFound, file.source_file + ": has no animations");

  // File node -> character joint: equal names first, then equal keys where one file node and
  // one character joint share the key.
  std::vector<int32_t> joint_of(source.size(), -1);
  std::vector<int32_t> node_of(target.size(), -1);
  for (size_t n = 0; n < source.size(); ++n) {
    const int32_t j = target.Find(source.joint_names[n]);
    if (j >= 0 && node_of[static_cast<size_t>(j)] < 0) {
      joint_of[n] = j;
      node_of[static_cast<size_t>(j)] = static_cast<int32_t>(n);
    }
  }
  std::map<std::string, std::vector<int32_t>> joints_by_key, nodes_by_key;
  for (size_t j = 0; j < target.size(); ++j)
    joints_by_key[MatchKey(target.joint_names[j])].push_back(static_cast<int32_t>(j));
  for (size_t n = 0; n < source.size(); ++n) {
    if (joint_of[n] < 0) nodes_by_key[MatchKey(source.joint_names[n])].push_back(static_cast<int32_t>(n));
  }
  for (const auto& [key, nodes] : nodes_by_key) {
    const auto it = joints_by_key.find(key);
    if (key.empty() || nodes.size() != 1 || it == joints_by_key.end() || it->second.size() != 1) continue;
    const int32_t j = it->second.front();
    if (node_of[static_cast<size_t>(j)] >= 0) continue;
    joint_of[static_cast<size_t>(nodes.front())] = j;
    node_of[static_cast<size_t>(j)] = nodes.front();
  }

  const std::vector<char> deforming = DeformingJoints(character);
  std::string missing;
  size_t missing_count = 0, deforming_count = 0;
  for (size_t j = 0; j < target.size(); ++j) {
    if (!deforming[j]) continue;
    ++deforming_count;
    if (node_of[j] >= 0) continue;
    missing += (missing_count++ ? ", " : "") + target.joint_names[j];
  }
  if (missing_count) {
    return MakeError(ErrorCode::kNotFound, file.source_file + ": " + std::to_string(missing_count) + " of the " +
                                               std::to_string(deforming_count) + " joints that move " + who +
                                               " have no counterpart in this file (names compared without " +
                                               "prefixes such as \"mixamorig:\" and without case): " + missing);
  }

  ClipMatchReport local;
  ClipMatchReport& rep = report ? *report : local;
  rep = ClipMatchReport{};
  for (size_t j = 0; j < target.size(); ++j) rep.matched_joints += node_of[j] >= 0 ? 1 : 0;
  // Per matched joint, the factor its translation tracks are scaled by (units of the two files).
  std::vector<float> translation_scale(target.size(), 1.0f);
  for (size_t j = 0; j < target.size(); ++j) {
    if (node_of[j] < 0) continue;
    const float from = source.rest_local[static_cast<size_t>(node_of[j])].translation.norm();
    const float to = target.rest_local[j].translation.norm();
    if (from > 0.0f && to > 0.0f && std::isfinite(to / from) && std::abs(to / from - 1.0f) > 1e-3f)
      translation_scale[j] = to / from;
  }
  std::set<std::string> dropped, rescaled;
  std::vector<skinning::AnimationClip> clips;
  for (const auto& in : file.clips) {
    skinning::AnimationClip clip;
    clip.name = in.name;
    clip.duration_s = in.duration_s;
    for (const auto& tr : in.tracks) {
      const size_t node = static_cast<size_t>(tr.joint);
      if (tr.joint < 0 || node >= source.size()) continue;
      const int32_t j = joint_of[node];
      if (j < 0) {
        if (!tr.translation.empty() || !tr.rotation.empty() || !tr.scale.empty())
          dropped.insert(source.joint_names[node]);
        continue;
      }
      skinning::JointTrack out = tr;
      out.joint = j;
      if (translation_scale[static_cast<size_t>(j)] != 1.0f && !out.translation.empty()) {
        for (auto& v : out.translation.values) v *= translation_scale[static_cast<size_t>(j)];
        rescaled.insert(target.joint_names[static_cast<size_t>(j)]);
      }
      clip.tracks.push_back(std::move(out));
    }
    std::sort(clip.tracks.begin(), clip.tracks.end(),
              [](const skinning::JointTrack& x, const skinning::JointTrack& y) { return x.joint < y.joint; });
    clips.push_back(std::move(clip));
  }
  rep.dropped_nodes.assign(dropped.begin(), dropped.end());
  rep.rescaled_joints.assign(rescaled.begin(), rescaled.end());
  return clips;
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
